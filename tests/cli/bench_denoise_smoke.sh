#!/bin/sh
# bench_denoise_smoke.sh TESSERA: `tessera bench denoise` on the built-in lamp room, tiny: a row per
# count, and with --candidates each candidate's error and its variance by its halves; --seed is
# the renders' (the header says so), and the references' own seed is refused; --until-reached stops
# the renders at the first that reaches the undenoised baseline's error; --regions splits the error
# by region, --exr writes every image measured; a --scene naming none is refused, and a run whose
# scenes are all absent gives no verdict.
tessera="$1"
out=$("$tessera" bench denoise -r 32 24 --ref-spp 64 --max-spp 8 --scene lamp --candidates --seed 3 2>&1)
status=$?
if [ "$status" -ne 0 ]; then echo "exit $status: $out"; exit 1; fi
if ! printf '%s\n' "$out" | grep -q 'renders seed 3,'; then echo "the header should name seed 3: $out"; exit 1; fi
rows=$(printf '%s\n' "$out" | grep -cE '^\| (4|8) \| [0-9.]+ \|')
if [ "$rows" -ne 2 ]; then echo "expected rows at 4 and 8 spp, got $rows: $out"; exit 1; fi
lines=$(printf '%s\n' "$out" | grep -c '^  candidates:')
if [ "$lines" -ne 2 ]; then echo "expected 2 candidates lines, got $lines: $out"; exit 1; fi
# Every candidate (noisy and the three filters) prints a variance; the noisy one's is above zero.
per_line=$(printf '%s\n' "$out" | grep '^  candidates:' | head -1 | grep -o 'variance by its halves [0-9.e+-]*' | wc -l)
if [ "$per_line" -ne 4 ]; then echo "expected 4 variances on a line, got $per_line: $out"; exit 1; fi
noisy=$(printf '%s\n' "$out" | grep '^  candidates: noisy' | head -1 | grep -o 'variance by its halves [0-9.e+-]*' | head -1 | awk '{print $5}')
if ! awk -v v="$noisy" 'BEGIN { exit !(v + 0 > 0) }'; then echo "the noisy image's variance should be above zero: $noisy"; exit 1; fi
# --until-reached: the baseline's line names --max-spp, and the renders stop at the row that
# reaches its error (that row is the last printed; the counts after it are said not rendered).
exr=$(mktemp -d)
trap 'rm -rf "$exr"' EXIT
out=$("$tessera" bench denoise -r 64 48 --ref-spp 512 --max-spp 256 --scene lamp --until-reached --regions --exr "$exr" 2>&1)
status=$?
if [ "$status" -ne 0 ]; then echo "--until-reached: exit $status: $out"; exit 1; fi
if ! printf '%s\n' "$out" | grep -q 'error of 256 undenoised spp'; then echo "--until-reached: no baseline line: $out"; exit 1; fi
last=$(printf '%s\n' "$out" | grep -oE '^\| [0-9]+ \| [0-9]+\.[0-9]+ \|' | tail -1 | awk '{print $2}')
reached=$(printf '%s\n' "$out" | grep -oE 'reached denoised by [0-9]+ spp' | awk '{print $4}')
if [ -n "$reached" ]; then
  if [ "$last" != "$reached" ]; then echo "--until-reached: reached at $reached spp but rendered to $last: $out"; exit 1; fi
  if [ "$reached" -lt 256 ] && ! printf '%s\n' "$out" | grep -q 'not rendered, --until-reached'; then
    echo "--until-reached: the counts not rendered should be said: $out"; exit 1
  fi
elif [ "$last" != 256 ]; then echo "--until-reached: nothing reached, yet the renders stopped at $last: $out"; exit 1; fi
if ! printf '%s\n' "$out" | grep -q 'over the rows rendered'; then echo "--until-reached: the verdict should say it covers the rows rendered: $out"; exit 1; fi
# --regions: four regions and the pixels that saw nothing (the void around the box) partition the image,
# the reference's own error in each above zero, and a row for the baseline and each count rendered.
head=$(printf '%s\n' "$out" | grep '^by region')
shares=$(printf '%s\n' "$head" | grep -oE '[0-9.]+% of the pixels' | awk '{s += $1; n++} END {print n, s}')
case "$shares" in 5\ 99.9*|5\ 100*) ;; *) echo "--regions: expected 4 regions and the void covering the image, got '$shares': $out"; exit 1;; esac
own=$(printf '%s\n' "$head" | grep -oE "the reference's own [0-9.e+-]+" | awk '$4 + 0 <= 0' | wc -l)
if [ "$own" -ne 0 ]; then echo "--regions: the reference's own error should be above zero in every region: $head"; exit 1; fi
if ! printf '%s\n' "$out" | grep -qE '^\| plain 256 \| 256 \|'; then echo "--regions: no row for the baseline: $out"; exit 1; fi
region_rows=$(printf '%s\n' "$out" | grep -cE '^\| [0-9]+ \| [0-9]+ \| [0-9.e+-]+ \| [0-9.e+-]+ \| [0-9]+ \|')
rows=$(printf '%s\n' "$out" | grep -cE '^\| [0-9]+ \| [0-9]+\.[0-9]+ \|')
if [ "$region_rows" -ne "$rows" ]; then echo "--regions: $region_rows region rows for $rows counts: $out"; exit 1; fi
# --exr: the reference with its passes and its own error, and every image measured.
for f in lamp_room_reference lamp_room_plain_256spp lamp_room_4spp lamp_room_4spp_denoised "lamp_room_${last}spp_denoised"; do
  [ -s "$exr/$f.exr" ] || { echo "--exr: no $f.exr in: $(ls "$exr")"; exit 1; }
done
if command -v oiiotool >/dev/null; then
  info=$(oiiotool --info -v "$exr/lamp_room_reference.exr")
  for c in albedo.R N.X Z emission.R environment.R variance.R; do
    printf '%s\n' "$info" | grep -q "$c" || { echo "--exr: the reference lacks $c: $info"; exit 1; }
  done
  # Its own error holds values, not a layer of zeros under the right names (scaled: oiiotool
  # prints six decimals).
  max=$(oiiotool "$exr/lamp_room_reference.exr" --ch variance.R,variance.G,variance.B --mulc 1e6 --printinfo:stats=1 | sed -n 's/.*Stats Max: *//p')
  if ! printf '%s\n' "$max" | awk '{ exit !($1 > 0 && $2 > 0 && $3 > 0) }'; then echo "--exr: the reference's own error is zero everywhere: $max"; exit 1; fi
fi
refused=$("$tessera" bench denoise --seed 7 2>&1)
status=$?
if [ "$status" -ne 2 ]; then echo "--seed 7 should exit 2, got $status: $refused"; exit 1; fi
if ! printf '%s\n' "$refused" | grep -q "7 is the references' seed"; then echo "--seed 7 should say why: $refused"; exit 1; fi
# A --scene that names no scene is refused with the scenes' labels, not measured as nothing.
unknown=$("$tessera" bench denoise -r 16 16 --ref-spp 16 --max-spp 4 --scene nosuchscene 2>&1)
status=$?
if [ "$status" -ne 2 ]; then echo "--scene nosuchscene should exit 2, got $status: $unknown"; exit 1; fi
if ! printf '%s\n' "$unknown" | grep -q "no scene's label contains it.*lamp room"; then echo "--scene nosuchscene should list the scenes: $unknown"; exit 1; fi
# Scenes whose files are absent give no verdict.
empty=$(mktemp -d)
absent=$("$tessera" bench denoise -r 16 16 --ref-spp 16 --max-spp 4 --scene Duck --gltf-pbr "$empty" 2>&1)
status=$?
rmdir "$empty"
if [ "$status" -ne 1 ]; then echo "an absent scene alone should exit 1, got $status: $absent"; exit 1; fi
if printf '%s\n' "$absent" | grep -q "denoised below noisy wherever it denoised"; then echo "no verdict without a scene measured: $absent"; exit 1; fi
echo "ok"
