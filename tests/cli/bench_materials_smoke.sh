#!/bin/sh
# bench_materials_smoke.sh TESSERA CS184_DIR: `tessera bench materials` prints the energy table
# (every white BSDF at most 1, the glass split exactly 1) and, where the CS184 scenes are, a row
# per material scene.
tessera="$1"
cs184="$2"
out=$("$tessera" bench materials --samples 20000 --spp 1 --width 16 --height 12 -t 1 --cs184 "$cs184" 2>&1)
status=$?
if [ "$status" -ne 0 ]; then echo "exit $status: $out"; exit 1; fi
rows=$(printf '%s\n' "$out" | grep -cE '^\| (Beckmann|glTF) [^|]+ \| [0-9.]+ \|( [0-9.]+ \|){5}$')
if [ "$rows" -ne 20 ]; then echo "expected 20 energy rows, got $rows: $out"; exit 1; fi
# Ours keep at most what arrives (the sampled estimate within 2%); glTF's sample formula does not.
over=$(printf '%s\n' "$out" | grep -E '^\| (Beckmann|glTF metal|glTF dielectric, white \(ours\))' |
       awk -F'|' '{for (i = 4; i <= 8; ++i) if ($i + 0 > 1.02) print}')
if [ -n "$over" ]; then echo "a BSDF reflects more than arrives: $over"; exit 1; fi
if ! printf '%s\n' "$out" | grep -qE '^Glass .* 85°: 1\.0000'; then echo "glass should keep exactly 1: $out"; exit 1; fi
if [ -d "$cs184" ]; then
  scenes=$(printf '%s\n' "$out" | grep -cE '^\| CB[a-z_]+ \| [^|]+ \| [0-9.]+ \| [0-9.]+ \| [0-9.]+ \| [0-9]+ \|$')
  if [ "$scenes" -ne 8 ]; then echo "expected 8 scene rows, got $scenes: $out"; exit 1; fi
fi
echo "ok"
