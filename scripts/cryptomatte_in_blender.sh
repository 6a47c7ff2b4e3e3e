#!/usr/bin/env bash
# Our Cryptomatte read by another decoder: Blender's compositor (its Cryptomatte node, the image
# as source, the layer found from our EXR header) pulls each object's matte out of a Tessera
# render, and its area is set beside the share of the image's first samples that hit that object
# (the object_id pass). A check by hand, not a test: it needs Debian's blender (3.4, `sudo
# apt-get install blender`), which nothing else in the project does.
#
#   bash scripts/cryptomatte_in_blender.sh             # builtin:cornell_spheres, 800x600 (its whole view), 16 spp
#   SCENE=... WIDTH=... HEIGHT=... SPP=... OUT=dir bash scripts/cryptomatte_in_blender.sh
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
tessera=${TESSERA:-$here/build/release/cli/tessera}
scene=${SCENE:-builtin:cornell_spheres}
width=${WIDTH:-800} height=${HEIGHT:-600} spp=${SPP:-16}
out=${OUT:-$(mktemp -d)}
command -v blender >/dev/null || { echo "blender is not installed (sudo apt-get install blender)"; exit 2; }
[ -x "$tessera" ] || { echo "no $tessera: build first (bash scripts/build.sh release)"; exit 2; }
mkdir -p "$out"
"$tessera" render "$scene" -r "$width" "$height" -s "$spp" -m 1 --passes crypto_object,object_id -f "$out/render.exr" >/dev/null
cat > "$out/mattes.py" <<'PY'
import json, os, sys, bpy
out = os.environ["CRYPTO_OUT"]
img = bpy.data.images.load(os.path.join(out, "render_passes.exr"))
sc = bpy.context.scene
sc.render.resolution_x, sc.render.resolution_y = int(os.environ["CRYPTO_W"]), int(os.environ["CRYPTO_H"])
sc.render.resolution_percentage = 100
sc.view_settings.view_transform = "Standard"
sc.render.image_settings.file_format = "OPEN_EXR"
sc.render.use_compositing = True
sc.camera = None
sc.use_nodes = True
nt = sc.node_tree
for n in list(nt.nodes):
    nt.nodes.remove(n)
cm = nt.nodes.new("CompositorNodeCryptomatteV2")
cm.source = "IMAGE"
cm.image = img
comp = nt.nodes.new("CompositorNodeComposite")
nt.links.new(cm.outputs["Matte"], comp.inputs["Image"])
names = json.loads(os.environ["CRYPTO_NAMES"])
print("layer found in the header:", cm.layer_name)
for name in names:
    cm.matte_id = name
    sc.render.filepath = os.path.join(out, "matte_" + name.replace(" ", "_") + ".exr")
    bpy.ops.render.render(write_still=True)
PY
# The object names from the render's own manifest.
manifest=$(oiiotool --info -v "$out/render_passes.exr" | sed -n 's/.*cryptomatte\/[0-9a-f]*\/manifest: "\(.*\)"$/\1/p' | sed 's/\\"/"/g')
names=$(python3 -c 'import json,sys; print(json.dumps(sorted(json.loads(sys.argv[1]))))' "$manifest")
CRYPTO_W="$width" CRYPTO_H="$height" CRYPTO_OUT="$out" CRYPTO_NAMES="$names" blender -b --factory-startup -P "$out/mattes.py" 2>&1 | grep -E "layer found" || true
# Each matte's mean from Blender beside the same matte decoded here by the specification (the
# coverage of every rank whose id is the name's, from the manifest), over the image.
python3 - "$out" "$names" "$scene" "$manifest" <<'PY'
import json, struct, subprocess, sys
out, names, scene, manifest = sys.argv[1], json.loads(sys.argv[2]), sys.argv[3], json.loads(sys.argv[4])
def mean_of(path):
    r = subprocess.run(["oiiotool", "--stats", path], capture_output=True, text=True).stdout
    return float([l for l in r.splitlines() if "Stats Avg" in l][0].split()[2])
# Each rank's id and coverage exactly (oiiotool's text dump rounds the tiny ids to zero): the
# layers rewritten uncompressed, then read scanline by scanline (OpenEXR stores a line's
# channels one after another, sorted by name).
names_ch = sorted(f"CryptoObject0{i}.{c}" for i in range(3) for c in "RGBA")
raw = out + "/crypto_raw.exr"
subprocess.run(["oiiotool", out + "/render_passes.exr", "--ch", ",".join(names_ch), "-d", "float", "--compression", "none", "-o", raw], check=True)
data = open(raw, "rb").read()
at, attrs = 8, {}
while data[at] != 0:
    name_end = data.index(b"\0", at); type_end = data.index(b"\0", name_end + 1)
    size = struct.unpack_from("<i", data, type_end + 1)[0]
    attrs[data[at:name_end].decode()] = data[type_end + 5:type_end + 5 + size]
    at = type_end + 5 + size
x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"])
w, h = x1 - x0 + 1, y1 - y0 + 1
offsets = struct.unpack_from(f"<{h}Q", data, at + 1)
plane = {c: [] for c in names_ch}
for off in offsets:
    line = struct.unpack_from(f"<{w * len(names_ch)}f", data, off + 8)
    for k, c in enumerate(names_ch):
        plane[c].extend(line[k * w:(k + 1) * w])
ranks = [(plane[f"CryptoObject0{k // 2}.{'RB'[k % 2]}"], plane[f"CryptoObject0{k // 2}.{'GA'[k % 2]}"]) for k in range(6)]
n = w * h
print(f"{scene}, {n} pixels: each object's matte, Blender's Cryptomatte node against the specification's decoding")
print("| object | id | Blender | decoded here |")
print("|---|---|---:|---:|")
worst = 0.0
for name in names:
    want = struct.unpack(">f", bytes.fromhex(manifest[name]))[0]
    ours = sum(sum(c for i, c in zip(ids, cov) if i == want) for ids, cov in ranks) / n
    theirs = mean_of(f"{out}/matte_{name.replace(' ', '_')}.exr")
    worst = max(worst, abs(theirs - ours))
    print(f"| {name} | {manifest[name]} | {theirs:.5f} | {ours:.5f} |")
print(f"largest difference: {worst:.2g}")
PY
