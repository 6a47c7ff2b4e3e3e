#!/bin/sh
# Passes and the denoised image from the CLI: the multilayer EXR opens in OpenImageIO's own tool
# with the channel names compositors read, Cryptomatte's header attributes among them. $1: the tessera binary; $2: a scratch folder.
set -eu
tessera="$1"
dir="$2"
rm -rf "$dir" && mkdir -p "$dir"
out=$("$tessera" render -s 4 -m 2 -r 40 30 --passes albedo,normal,depth,diffuse_direct,crypto_object,crypto_material --denoise true -f "$dir/x.exr" builtin:cornell_spheres)
echo "$out" | grep -q 'denoised: .*x_denoised.exr (estimated relMSE' || { echo "no denoised line in: $out"; exit 1; }
test -f "$dir/x_denoised.exr"
info=$(oiiotool --info -v "$dir/x_passes.exr")
channels=$(echo "$info" | grep 'channel list:' | sed 's/.*channel list://' | tr -d ' ' | tr ',' '\n')
for c in R G B samples albedo.R albedo.G albedo.B N.X N.Y N.Z Z diffuse_direct.R diffuse_direct.G diffuse_direct.B \
         CryptoObject00.R CryptoObject00.G CryptoObject00.B CryptoObject00.A CryptoObject02.A CryptoMaterial01.R; do
  echo "$channels" | grep -qx "$c" || { echo "channel $c missing from: $channels"; exit 1; }
done
echo "passes: $(echo "$channels" | wc -l) channels"
# Cryptomatte's header, one key per layer: name, hash, conversion and a manifest naming the box's
# floor and its white material by their ids.
for layer in CryptoObject CryptoMaterial; do
  key=$(echo "$info" | grep -E "cryptomatte/[0-9a-f]{7}/name: \"$layer\"" | sed 's|.*cryptomatte/\([0-9a-f]*\)/name.*|\1|')
  test -n "$key" || { echo "no cryptomatte name attribute for $layer in: $info"; exit 1; }
  echo "$info" | grep -q "cryptomatte/$key/hash: \"MurmurHash3_32\"" || { echo "$layer: no hash attribute"; exit 1; }
  echo "$info" | grep -q "cryptomatte/$key/conversion: \"uint32_to_float32\"" || { echo "$layer: no conversion attribute"; exit 1; }
  echo "$info" | grep "cryptomatte/$key/manifest:" | grep -Eq '"(floor|white)\\?":\\?"[0-9a-f]{8}' || { echo "$layer: no manifest"; echo "$info" | grep manifest; exit 1; }
done
echo "cryptomatte: $(echo "$info" | grep -c 'cryptomatte/') header attributes"
