#!/bin/sh
# Passes and the denoised image from the CLI: the multilayer EXR opens in OpenImageIO's own tool
# with the channel names compositors read. $1: the tessera binary; $2: a scratch folder.
set -eu
tessera="$1"
dir="$2"
rm -rf "$dir" && mkdir -p "$dir"
out=$("$tessera" render -s 4 -m 2 -r 40 30 --passes albedo,normal,depth,diffuse_direct --denoise true -f "$dir/x.exr" builtin:cornell_spheres)
echo "$out" | grep -q 'denoised: .*x_denoised.exr (estimated relMSE' || { echo "no denoised line in: $out"; exit 1; }
test -f "$dir/x_denoised.exr"
channels=$(oiiotool --info -v "$dir/x_passes.exr" | grep 'channel list:' | sed 's/.*channel list://' | tr -d ' ' | tr ',' '\n')
for c in R G B samples albedo.R albedo.G albedo.B N.X N.Y N.Z Z diffuse_direct.R diffuse_direct.G diffuse_direct.B; do
  echo "$channels" | grep -qx "$c" || { echo "channel $c missing from: $channels"; exit 1; }
done
echo "passes: $(echo "$channels" | wc -l) channels"
