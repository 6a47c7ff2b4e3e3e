#!/bin/sh
# bench_rays_smoke.sh TESSERA CS184_DIR: `tessera bench rays` measures CBbunny's shadow rays with
# our BVH and Embree and prints both rows (1 thread and all) with a ratio, the two agreeing
# on the hits. Skips (77) with the reason where the CS184 scenes or Embree are absent.
tessera="$1"; cs184="$2"
if [ ! -f "$cs184/sky/CBbunny.dae" ]; then echo "skipped: the CS184 scenes are absent ($cs184)"; exit 77; fi
out=$("$tessera" bench rays --cs184 "$cs184" --scene CBbunny --rays shadow --seconds 0.02 2>&1)
status=$?
if [ "$status" -eq 2 ] && printf '%s\n' "$out" | grep -q "no Embree"; then echo "skipped: this build has no Embree"; exit 77; fi
if [ "$status" -ne 0 ]; then echo "exit $status: $out"; exit 1; fi
rows=$(printf '%s\n' "$out" | grep -cE '^\| CBbunny \| shadow \(any hit\) \| [0-9]+ \| [0-9.]+ / [0-9.]+ \| [0-9]+ \| [0-9.]+ \| [0-9.]+ \| [0-9.]+× \|')
if [ "$rows" -ne 2 ]; then echo "expected two throughput rows for CBbunny, got $rows: $out"; exit 1; fi
# Both BVHs must agree on the hits: "same", or counts within 0.1% of the rays (Embree's default
# test is not watertight, so rays through shared edges may differ).
bad=$(printf '%s\n' "$out" | grep -E '^\| CBbunny \| shadow' | grep -v '| same |$' |
  sed -E 's/^\| [^|]*\| [^|]*\| ([0-9]+) \|.*\| ours ([0-9]+), Embree ([0-9]+) \|$/\1 \2 \3/' |
  awk 'NF != 3 { print; next } { d = $2 - $3; if (d < 0) d = -d; if (d > $1 / 1000) print }')
if [ -n "$bad" ]; then echo "our BVH and Embree disagree on the hits: $bad"; exit 1; fi
echo "ok"
