#!/usr/bin/env bash
# Two builds of tessera on the same renders, one of each pass schedule, compared bit for bit
# (pixels and sample counts, OpenImageIO's idiff): passes of doubling spp with the error
# estimate, adaptive sampling, a target error, a scene without lights (the default sky) and an
# environment map. For restructurings that must change no image.
#   scripts/ab_images.sh BIN_A BIN_B [OUT_DIR]
#   e.g. scripts/ab_images.sh /tmp/before/build/release/cli/tessera build/release/cli/tessera
# The shared scenes come from TESSERA_SHARED_SCENES (default ../shared/scenes).
set -euo pipefail
if [ $# -lt 2 ]; then
  sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
root=$(cd "$(dirname "$0")/.." && pwd)
shared="${TESSERA_SHARED_SCENES:-$root/../shared/scenes}"
out="${3:-$(mktemp -d)}"
mkdir -p "$out"
render_all() {
  local bin=$1 dir=$2
  mkdir -p "$dir"
  echo '{"width":120,"height":90,"spp":32,"max_depth":3,"target_error":0.0001}' > "$dir/target_error.json"
  "$bin" render -t 2 -r 160 120 -s 16 -m 5 -f "$dir/spheres.exr" "$shared/cs184/sky/CBspheres_lambertian.dae"
  "$bin" render -t 2 -r 160 120 -s 64 -m 4 -a 8 0.05 -f "$dir/adaptive.exr" "$root/scenes/cornell_box.gltf"
  "$bin" render -t 2 -r 120 90 -s 8 -m 3 -f "$dir/default_sky.exr" "$shared/gltf-pbr/MetalRoughSpheresNoTextures.gltf"
  "$bin" render -t 2 --job "$dir/target_error.json" -f "$dir/target_error.exr" "$root/scenes/cornell_spheres.gltf"
  "$bin" render -t 2 -r 120 90 -s 16 -m 4 -e "$root/scenes/sky.exr" -f "$dir/environment.exr" "$shared/gltf-pbr/Duck.gltf"
}
render_all "$1" "$out/a" > "$out/a.log" 2>&1 || { cat "$out/a.log"; exit 1; }
render_all "$2" "$out/b" > "$out/b.log" 2>&1 || { cat "$out/b.log"; exit 1; }
status=0
for f in spheres adaptive default_sky target_error environment; do
  if idiff -fail 0 -warn 0 "$out/a/$f.exr" "$out/b/$f.exr" > "$out/$f.idiff" 2>&1; then echo "$f: identical"
  else echo "$f: DIFFERENT ($(tail -n 1 "$out/$f.idiff"))"; status=1; fi
done
exit $status
