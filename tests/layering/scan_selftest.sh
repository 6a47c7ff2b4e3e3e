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
# A room that includes one above it (the store, the farm's render node).
rm "$d/engine/bad.h"
mkdir -p "$d/server/store" "$d/server/farm"
printf '#pragma once\n#include "server/store/job_store.h"\n#include "server/farm/render_node.h"\n' > "$d/server/store/bad.h"
out2=$("$1/tests/layering/include_scan.sh" "$d")
[ $? -ne 0 ] || { echo "the scan passed a room including one above it: $out2"; exit 1; }
printf '%s\n' "$out2" | grep -q 'server/store/bad.h:3: server/store/ may include only' || { echo "unexpected report: $out2"; exit 1; }
printf '%s\n' "$out2" | grep -q 'bad.h:2' && { echo "a room's own include was reported: $out2"; exit 1; }
echo "ok: $out"
echo "ok: $out2"
