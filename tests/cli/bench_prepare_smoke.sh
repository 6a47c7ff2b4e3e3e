#!/bin/sh
# bench_prepare_smoke.sh TESSERA: `tessera bench prepare` on a small mesh prints a row per
# thread count with every stage, ours beside Embree's build (where this build has Embree),
# and then a cache miss followed by hits through a real in-process server.
tessera="$1"
out=$("$tessera" bench prepare --triangles 3000 --threads 1,2 --reps 1 --gltf '' --cache-triangles 3000 --cache-jobs 3 2>&1)
status=$?
if [ "$status" -ne 0 ]; then echo "exit $status: $out"; exit 1; fi
rows=$(printf '%s\n' "$out" | grep -cE '^\| displaced_sphere 3000 \| [0-9]+ \| [12] \|( [0-9.]+ \|){5} \*\*[0-9.]+\*\* \|')
if [ "$rows" -ne 2 ]; then echo "expected a row for 1 and 2 threads, got $rows: $out"; exit 1; fi
if ! printf '%s\n' "$out" | grep -qE '^\| 1 \| miss \|'; then echo "the first job should miss the scene cache: $out"; exit 1; fi
hits=$(printf '%s\n' "$out" | grep -cE '^\| [23] \| hit \|')
if [ "$hits" -ne 2 ]; then echo "jobs 2 and 3 should hit the scene cache: $out"; exit 1; fi
echo "ok"
