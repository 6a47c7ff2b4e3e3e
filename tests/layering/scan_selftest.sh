#!/bin/sh
# scan_selftest.sh SOURCE_DIR: include_scan.sh must fail, naming the line, on a tree where
# engine/ includes an api/ header.
d=$(mktemp -d)
trap 'rm -rf "$d"' EXIT
mkdir -p "$d/engine" "$d/api" "$d/server" "$d/cli"
printf '#pragma once\n#include "api/job.h"\n' > "$d/engine/bad.h"
out=$("$1/tests/layering/include_scan.sh" "$d")
status=$?
[ $status -ne 0 ] || { echo "the scan passed a tree with an upward include: $out"; exit 1; }
printf '%s\n' "$out" | grep -q 'engine/bad.h:2: engine/ may include only engine' || { echo "unexpected report: $out"; exit 1; }
echo "ok: $out"
