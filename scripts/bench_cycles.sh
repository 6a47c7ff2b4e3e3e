#!/usr/bin/env bash
# Tessera against Blender Cycles on the same glTF scene, at equal error: for each Cycles sample
# count, Cycles' time and relative MSE, and the time Tessera takes to reach that error. A
# benchmark, not a test: it needs Debian's blender (3.4) and numpy (`sudo apt-get install blender
# python3-numpy`), which nothing else in the project does, and it is not run in CI.
#
#   bash scripts/bench_cycles.sh            # cornell_box.gltf, 320x240, depth 5, 2 threads
#   SCENE=... WIDTH=... HEIGHT=... DEPTH=... THREADS=... CYCLES_SPP="16 64 256 1024" \
#   REF_SPP=4096 OUT=dir bash scripts/bench_cycles.sh
#
# Each renderer's error is measured against its own converged render (REF_SPP samples), so a
# small difference between the two renderers' images does not count as noise; the two
# references' relative MSE against each other is printed too (how far they agree). Tessera's
# time is its render_seconds (sampling only, as the EXR's metadata records it); Cycles' is the
# wall time of a render after a first one has synchronised the scene and built its BVH
# (persistent data), so both leave out loading and building. Cycles runs twice: with its
# defaults (Russian roulette on) and with roulette off (min_light_bounces = max_bounces), as
# Tessera's default has none.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
T=${TESSERA:-$root/build/release/cli/tessera}
SCENE=${SCENE:-$root/scenes/cornell_box.gltf}
WIDTH=${WIDTH:-320}
HEIGHT=${HEIGHT:-240}
DEPTH=${DEPTH:-5}
THREADS=${THREADS:-2}
CYCLES_SPP=${CYCLES_SPP:-16 64 256 1024}
REF_SPP=${REF_SPP:-4096}
OUT=${OUT:-$(mktemp -d)}
if ! command -v blender > /dev/null || ! blender -b --factory-startup --python-exit-code 1 --python-expr "import numpy" > /dev/null 2>&1; then
  echo "bench_cycles: needs Debian's blender and numpy (sudo apt-get install blender python3-numpy); a benchmark-only dependency" >&2
  exit 1
fi
[ -x "$T" ] || { echo "bench_cycles: build Tessera first (bash scripts/build.sh release)" >&2; exit 1; }
mkdir -p "$OUT"
here="$root/scripts/cycles"
# Blender's own output is long; its script's lines are kept, and a failing script fails the bench.
blender_run() {
  if ! blender -b --factory-startup --python-exit-code 1 --python "$@" > "$OUT/blender.out" 2>&1; then
    tail -n 20 "$OUT/blender.out" >&2
    echo "bench_cycles: blender failed (whole output in $OUT/blender.out)" >&2
    exit 1
  fi
  grep -E '^(cycles_render|REL_MSE_JSON)' "$OUT/blender.out" || true
}

echo "== Cycles, defaults (roulette on), and its reference ($REF_SPP spp)"
# shellcheck disable=SC2086
blender_run "$here/cycles_render.py" -- "$SCENE" "$OUT/cycles_on" "$WIDTH" "$HEIGHT" "$DEPTH" "$THREADS" on $CYCLES_SPP "$REF_SPP"
echo "== Cycles, roulette off"
# shellcheck disable=SC2086
blender_run "$here/cycles_render.py" -- "$SCENE" "$OUT/cycles_off" "$WIDTH" "$HEIGHT" "$DEPTH" "$THREADS" off $CYCLES_SPP

echo "== Tessera: 1 to 2048 spp, and its reference ($REF_SPP spp)"
ours=()
for s in 1 2 4 8 16 32 64 128 256 512 1024 2048 "$REF_SPP"; do
  "$T" render -s "$s" -m "$DEPTH" -r "$WIDTH" "$HEIGHT" -t "$THREADS" -f "$OUT/tessera_$s.exr" "$SCENE" > /dev/null
  ours+=("$OUT/tessera_$s.exr")
done

echo "== errors"
cyc=()
for s in $CYCLES_SPP; do cyc+=("$OUT/cycles_on/cycles_$s.exr" "$OUT/cycles_off/cycles_$s.exr"); done
blender_run "$here/rel_mse.py" -- "$OUT/cycles_on/cycles_$REF_SPP.exr" "${cyc[@]}" "$OUT/tessera_$REF_SPP.exr" > "$OUT/cycles_err.txt"
blender_run "$here/rel_mse.py" -- "$OUT/tessera_$REF_SPP.exr" "${ours[@]}" > "$OUT/tessera_err.txt"
for s in 1 2 4 8 16 32 64 128 256 512 1024 2048; do
  printf '%s %s\n' "$s" "$(iinfo -v "$OUT/tessera_$s.exr" | sed -n 's/.*tessera:render_seconds: "\(.*\)"/\1/p')"
done > "$OUT/tessera_times.txt"

python3 - "$OUT" "$REF_SPP" "$WIDTH" "$HEIGHT" "$DEPTH" "$THREADS" "$SCENE" $CYCLES_SPP <<'EOF'
import json, math, sys
out, ref_spp, w, h, depth, threads, scene = sys.argv[1:8]
cycles_spp = [int(s) for s in sys.argv[8:]]
load = lambda f: json.loads(open(f"{out}/{f}").read().split("REL_MSE_JSON ", 1)[1])
cerr, terr = load("cycles_err.txt"), load("tessera_err.txt")
times = {int(s): float(t) for s, t in (l.split() for l in open(f"{out}/tessera_times.txt"))}
ours = sorted((times[s], terr["images"][f"{out}/tessera_{s}.exr"]["rel_mse"], s) for s in times)

def time_to(err):
    """Tessera's time to reach `err`: log-log interpolation between the runs either side."""
    prev = None
    for t, e, s in ours:
        if e <= err:
            if prev is None:
                return t, f"<= {s} spp"
            (t0, e0, s0) = prev
            f = math.log(err / e0) / math.log(e / e0)
            return math.exp(math.log(t0) + f * (math.log(t) - math.log(t0))), f"{s0}-{s} spp"
        prev = (t, e, s)
    return None, "not reached"

version = json.load(open(f"{out}/cycles_on/cycles_times.json"))["version"]
agree = cerr["images"][f"{out}/tessera_{ref_spp}.exr"]
print(f"\nScene {scene}, {w}x{h}, Tessera max_depth {depth} (Cycles max_bounces {int(depth) - 1}), {threads} threads, "
      f"Blender {version}; references {ref_spp} spp each; the two references' relative MSE against each other: "
      f"{agree['rel_mse']:.2e} (means {agree['mean']:.5f} Tessera, {cerr['reference_mean']:.5f} Cycles)\n")
print("| Cycles | spp | time (s) | relMSE | Tessera time to that relMSE (s) | Tessera / Cycles time |")
print("|---|---:|---:|---:|---:|---:|")
for variant in ("on", "off"):
    ct = json.load(open(f"{out}/cycles_{variant}/cycles_times.json"))["seconds"]
    for s in cycles_spp:
        e = cerr["images"][f"{out}/cycles_{variant}/cycles_{s}.exr"]["rel_mse"]
        t, where = time_to(e)
        c = ct[str(s)]
        label = "defaults" if variant == "on" else "roulette off"
        print(f"| {label} | {s} | {c:.3f} | {e:.3e} | {'%.3f' % t if t else '-'} ({where}) | {'%.2f' % (t / c) if t else '-'} |")
print("\nTessera alone (relMSE against its own reference):\n\n| spp | time (s) | relMSE | relMSE x spp |\n|---:|---:|---:|---:|")
for t, e, s in ours:
    print(f"| {s} | {t:.3f} | {e:.3e} | {e * s:.3f} |")
EOF
echo "(images and raw figures in $OUT)"
