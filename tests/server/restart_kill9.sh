#!/usr/bin/env bash
# restart_kill9.sh TESSERA: start the real server, accept jobs, SIGKILL it mid-render, start it
# again on the same data directory, and find every job: the one that was running is queued
# again (and runs), the queued ones still run, the finished one is still downloadable.
set -u
bin="$1"
data=$(mktemp -d)
log=$(mktemp)
cleanup() { [ -n "$pid" ] && kill -9 "$pid" 2>/dev/null; rm -rf "$data" "$log"; }
trap cleanup EXIT
. "$(dirname "$0")/server_lib.sh"
submit() { api -X POST -H 'Content-Type: application/json' -d "$1" "http://127.0.0.1:$port/v1/jobs" | field id; }

start
done_id=$(submit '{"scene":"cornell_box","width":32,"height":24,"spp":2}')
wait_state "$done_id" succeeded
long=$(submit '{"scene":"builtin:cornell_spheres","width":400,"height":300,"spp":4096,"max_depth":5,"tile_size":16}')
wait_state "$long" running
q1=$(submit '{"scene":"cornell_box","width":32,"height":24,"spp":2,"priority":1}')
q2=$(submit '{"scene":"cornell_box","width":32,"height":24,"spp":2}')
[ -n "$q1" ] && [ -n "$q2" ] || fail "submissions were not accepted"
sleep 0.3
kill -9 "$pid"; wait "$pid" 2>/dev/null; pid=""
echo "killed the server with SIGKILL while job $long was running"

start
for id in "$done_id" "$long" "$q1" "$q2"; do
  s=$(state_of "$id")
  [ -n "$s" ] || fail "job $id was lost across the restart"
  echo "after restart: $id $s"
done
[ "$(state_of "$done_id")" = succeeded ] || fail "finished job changed state"
code=$(api -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port/v1/jobs/$done_id/image.png")
[ "$code" = 200 ] || fail "finished result not downloadable after restart ($code)"
s=$(state_of "$long")
[ "$s" = queued ] || [ "$s" = running ] || fail "interrupted job is '$s', expected queued or running"
attempts=$(api "http://127.0.0.1:$port/v1/jobs/$long" | field attempts)
# Let the re-queued long job show it runs again, then cancel it so the queued ones follow.
wait_state "$long" running
api -X DELETE "http://127.0.0.1:$port/v1/jobs/$long" > /dev/null
wait_state "$long" canceled
wait_state "$q1" succeeded
wait_state "$q2" succeeded
kill -TERM "$pid"
for _ in $(seq 1 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
kill -0 "$pid" 2>/dev/null && fail "server did not stop on SIGTERM"
pid=""
echo "ok: every job survived SIGKILL (the interrupted one had attempts=$attempts before running again)"
