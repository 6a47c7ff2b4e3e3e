#!/bin/sh
# bench_server_smoke.sh TESSERA: `tessera bench server` with every phase cut short prints its
# tables, the live updates' among them: an event latency row per kind of event with every job
# seen, and the paired runs with and without keeping each pass.
tessera="$1"
out=$("$tessera" bench server --clients 2 --seconds 0.3 --slow-clients 2 --crowd 4 --crowd-pause-ms 100 \
  --cache-triangles 3000 --cache-jobs 2 --event-jobs 3 2>&1)
status=$?
if [ "$status" -ne 0 ]; then echo "exit $status: $out"; exit 1; fi
for row in '| GET /v1/jobs/{id} |' '| POST /v1/jobs |' '| GET /healthz |' '| 1 | miss |' '| 2 | hit |'; do
  printf '%s\n' "$out" | grep -qF "$row" || { echo "no row '$row': $out"; exit 1; }
done
events=$(printf '%s\n' "$out" | grep -cE '^\| (created \(from sending the POST\)|state running|state succeeded) \| 3 \| [0-9.]+ \| [0-9.]+ \|$')
if [ "$events" -ne 3 ]; then echo "expected three event rows of 3 events each, got $events: $out"; exit 1; fi
printf '%s\n' "$out" | grep -qE 'Keeping each pass.s image .*: [0-9]+ passes\), .* \(ratio [0-9.]+;' || { echo "no paired runs: $out"; exit 1; }
echo "ok"
