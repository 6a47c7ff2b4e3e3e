#!/bin/sh
# bench_denoise_smoke.sh TESSERA: `tessera bench denoise` on the built-in lamp room, tiny: a row per
# count, and with --candidates each candidate's error and its variance by its halves; --seed is
# the renders' (the header says so), and the references' own seed is refused; --until-reached stops
# the renders at the first that reaches the undenoised baseline's error.
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
out=$("$tessera" bench denoise -r 64 48 --ref-spp 512 --max-spp 256 --scene lamp --until-reached 2>&1)
status=$?
if [ "$status" -ne 0 ]; then echo "--until-reached: exit $status: $out"; exit 1; fi
if ! printf '%s\n' "$out" | grep -q 'error of 256 undenoised spp'; then echo "--until-reached: no baseline line: $out"; exit 1; fi
last=$(printf '%s\n' "$out" | grep -oE '^\| [0-9]+ \| [0-9.]+ \|' | tail -1 | awk '{print $2}')
reached=$(printf '%s\n' "$out" | grep -oE 'reached denoised by [0-9]+ spp' | awk '{print $4}')
if [ -n "$reached" ]; then
  if [ "$last" != "$reached" ]; then echo "--until-reached: reached at $reached spp but rendered to $last: $out"; exit 1; fi
  if [ "$reached" -lt 256 ] && ! printf '%s\n' "$out" | grep -q 'not rendered, --until-reached'; then
    echo "--until-reached: the counts not rendered should be said: $out"; exit 1
  fi
elif [ "$last" != 256 ]; then echo "--until-reached: nothing reached, yet the renders stopped at $last: $out"; exit 1; fi
if ! printf '%s\n' "$out" | grep -q 'over the rows rendered'; then echo "--until-reached: the verdict should say it covers the rows rendered: $out"; exit 1; fi
refused=$("$tessera" bench denoise --seed 7 2>&1)
status=$?
if [ "$status" -ne 2 ]; then echo "--seed 7 should exit 2, got $status: $refused"; exit 1; fi
if ! printf '%s\n' "$refused" | grep -q "7 is the references' seed"; then echo "--seed 7 should say why: $refused"; exit 1; fi
echo "ok"
