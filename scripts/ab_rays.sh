#!/usr/bin/env bash
# Two (or more) builds of tessera side by side on one row of `tessera bench rays`: runs the
# binaries in turn, REPS times, and prints each one's one-thread ours/Embree ratios and their
# mean. Alternating whole runs keeps the host's drift out of the comparison between builds.
#   scripts/ab_rays.sh SCENE camera|incoherent|shadow REPS BIN_A BIN_B [...]
#   e.g. scripts/ab_rays.sh building shadow 4 /tmp/before/tessera build/release/cli/tessera
# SECONDS_PER_ROW (default 0.5) is passed as --seconds.
set -euo pipefail
if [ $# -lt 5 ]; then
  sed -n '2,7p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
scene=$1 kind=$2 reps=$3
shift 3
for r in $(seq "$reps"); do
  for bin in "$@"; do
    ratio=$("$bin" bench rays --scene "$scene" --rays "$kind" --seconds "${SECONDS_PER_ROW:-0.5}" 2>/dev/null |
      awk -F'|' -v s=" $scene " '$2 == s && ($3 ~ /closest|any/) && $6 + 0 == 1 { gsub(/[× ]/, "", $9); print $9 }')
    echo "$bin ${ratio:-?}"
  done
done | awk '{ s[$1] += $2; n[$1]++; v[$1] = v[$1] " " $2 }
  END { for (b in s) printf "%s: mean %.3f (%s )\n", b, s[b] / n[b], v[b] }'
