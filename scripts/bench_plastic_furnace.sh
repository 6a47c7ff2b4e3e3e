#!/usr/bin/env bash
# How much light a white glTF plastic reflects in Tessera and in Blender Cycles: a sphere of
# base colour 1, metallic 0, at roughness 0.05, 0.3 and 0.6, under a uniform white environment
# of radiance 1 and nothing else. The sphere is convex, so each pixel reads its material's
# directional albedo at that pixel's angle; the table gives the mean over the sphere's disk.
# Tessera's glTF layering reflects at most what arrives (docs/materials.md); Cycles 3.4's
# Principled BSDF, as Blender's glTF importer sets it up, adds its specular layer on top of the
# full diffuse. A benchmark, not a test: needs Debian's blender and numpy, like bench_cycles.sh.
#
#   bash scripts/bench_plastic_furnace.sh      # 128x128, 256 spp, 2 threads
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
T=${TESSERA:-$root/build/release/cli/tessera}
OUT=${OUT:-$(mktemp -d)}
SPP=${SPP:-256}
SIZE=${SIZE:-128}
command -v blender > /dev/null || { echo "bench_plastic_furnace: needs Debian's blender (sudo apt-get install blender python3-numpy)" >&2; exit 1; }
mkdir -p "$OUT"
oiiotool --create 16x8 3 --fill:color=1,1,1 0,0,16,8 -d float -o "$OUT/white.exr"
python3 - "$OUT" <<'PY'
import base64, json, math, struct, sys
out = sys.argv[1]
nu, nv = 96, 48
pos, idx = [], []
for j in range(nv + 1):
    th = math.pi * j / nv
    for i in range(nu + 1):
        ph = 2 * math.pi * i / nu
        pos.append((math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)))
for j in range(nv):
    for i in range(nu):
        a = j * (nu + 1) + i
        b = a + nu + 1
        idx += [a, a + 1, b, a + 1, b + 1, b]  # counter-clockwise seen from outside
pb = b"".join(struct.pack("<3f", *p) for p in pos)  # on the unit sphere, positions are normals
ib = b"".join(struct.pack("<I", i) for i in idx)
buf = pb + pb + ib
for rough in (0.05, 0.3, 0.6):
    g = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
         "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 4.5]}],
         "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.01}}],
         "materials": [{"name": "white_plastic", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": rough}}],
         "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
         "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
         "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pb)}, {"buffer": 0, "byteOffset": len(pb), "byteLength": len(pb)},
                         {"buffer": 0, "byteOffset": 2 * len(pb), "byteLength": len(ib)}],
         "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3", "min": [-1, -1, -1], "max": [1, 1, 1]},
                       {"bufferView": 1, "componentType": 5126, "count": len(pos), "type": "VEC3"},
                       {"bufferView": 2, "componentType": 5125, "count": len(idx), "type": "SCALAR"}]}
    json.dump(g, open(f"{out}/plastic_{rough}.gltf", "w"))
PY
images=()
for r in 0.05 0.3 0.6; do
  "$T" render -s "$SPP" -m 2 -r "$SIZE" "$SIZE" -t 2 -e "$OUT/white.exr" -f "$OUT/tessera_$r.exr" "$OUT/plastic_$r.gltf" > /dev/null
  CYCLES_MATERIALS=gltf CYCLES_ENVIRONMENT="$OUT/white.exr" blender -b --factory-startup --python-exit-code 1 \
    --python "$root/scripts/cycles/cycles_render.py" -- "$OUT/plastic_$r.gltf" "$OUT/cycles_$r" "$SIZE" "$SIZE" 2 2 off "$SPP" > "$OUT/blender.out" 2>&1
  images+=("$OUT/tessera_$r.exr" "$OUT/cycles_$r/cycles_$SPP.exr")
done
# The sphere covers 0.89 of the half-height; its inner 0.85 is averaged (no edge pixels).
blender -b --factory-startup --python-exit-code 1 --python "$root/scripts/cycles/disk_mean.py" -- 0.85 "${images[@]}" 2>/dev/null |
  sed -n 's/^DISK_MEAN_JSON //p' | python3 -c '
import json, sys
m = json.load(sys.stdin)
print("| roughness | Tessera | Cycles 3.4 Principled | Cycles / Tessera |\n|---:|---:|---:|---:|")
for r in ("0.05", "0.3", "0.6"):
    t = [v for k, v in m.items() if k.endswith(f"tessera_{r}.exr")][0]
    c = [v for k, v in m.items() if f"cycles_{r}/" in k][0]
    print(f"| {r} | {sum(t) / 3:.4f} | {sum(c) / 3:.4f} | {sum(c) / sum(t):.3f} |")'
echo "(images in $OUT)"
