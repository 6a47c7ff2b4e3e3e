#!/usr/bin/env bash
# Two builds of tessera side by side on the denoiser's cost: at each size, renders the CS184
# diffuse Cornell box at 4 spp with the denoiser, alternating the binaries REPS times, and prints
# the median of each one's last-pass "denoising took" and its seconds per megapixel.
# Alternating whole runs keeps the host's drift out of the comparison between builds.
#   scripts/ab_denoise_cost.sh REPS BIN_A BIN_B
#   e.g. scripts/ab_denoise_cost.sh 3 /tmp/before/tessera build/release/cli/tessera
# SIZES (default "320x240 640x480 1280x960 1920x1440"); the scene comes from
# TESSERA_SHARED_SCENES (default ../shared/scenes); EXTRA adds render flags to both (e.g.
# "-b 0.05 -d 2", a thin lens: the seen light's filter then runs over the lamp's halo).
set -euo pipefail
if [ $# -ne 3 ]; then
  sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
reps=$1 a=$2 b=$3
case "$reps" in '' | *[!0-9]* | 0) echo "REPS must be a positive whole number, not '$reps'" >&2; exit 2 ;; esac
root=$(cd "$(dirname "$0")/.." && pwd)
scene="${TESSERA_SHARED_SCENES:-$root/../shared/scenes}/cs184/sky/CBspheres_lambertian.dae"
[ -f "$scene" ] || { echo "no scene at $scene" >&2; exit 2; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| size | A (s) | B (s) | B, s per megapixel |"
echo "|---|---:|---:|---:|"
for size in ${SIZES:-320x240 640x480 1280x960 1920x1440}; do
  w=${size%x*} h=${size#*x}
  times=$(for r in $(seq "$reps"); do
    for bin in A B; do
      exe=$a; [ $bin = B ] && exe=$b
      "$exe" render "$scene" -r "$w" "$h" -s 4 -m 1 -t 2 --denoise true --guided-sampling false ${EXTRA:-} -f "$out/i.exr" \
        >"$out/log" 2>&1 || { echo "$exe failed at $size:" >&2; tail -5 "$out/log" >&2; exit 1; }
      t=$(grep -oE 'denoising took [0-9.]+' "$out/log" | grep -oE '[0-9.]+$' || true)
      [ -n "$t" ] || { echo "$exe printed no denoising time at $size" >&2; exit 1; }
      echo "$bin $t"
    done
  done)
  printf '%s\n' "$times" | sort -k1,1 -k2,2n | awk -v size="$size" -v w="$w" -v h="$h" '
    function median(k) { return (all[k, int((n[k] + 1) / 2)] + all[k, int(n[k] / 2) + 1]) / 2 }
    { n[$1]++; all[$1, n[$1]] = $2 }
    END { ma = median("A"); mb = median("B")
          printf "| %s | %.3f | %.3f | %.2f |\n", size, ma, mb, mb / (w * h / 1e6) }'
done
