#!/usr/bin/env bash
# e2e_curl.sh /path/to/tessera: drives the real server with curl, as docker/README.md's
# walk-through does. Starts `tessera serve` on a free loopback port with a fresh data folder
# and the project scenes, then: health, readiness, the OpenAPI document, submit, poll, fetch
# PNG/EXR/rate map/report, bad requests (400 problem+json naming the field, 404), list,
# cancel, delete results, metrics, and exit within 10 s of SIGTERM. Needs only bash, curl,
# coreutils, grep and sed (python3, if present, also checks that the report is valid JSON).
# Exits non-zero with a reason on the first failure; the server is always stopped.
set -euo pipefail

if [ $# -ne 1 ]; then
  echo "usage: $0 /path/to/tessera" >&2
  exit 2
fi
bin=$1
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)

fail() { echo "e2e: FAIL: $*" >&2; exit 1; }
step() { echo "e2e: $*"; }

[ -x "$bin" ] || fail "not an executable file: $bin"
command -v curl >/dev/null || fail "curl is required"

work=$(mktemp -d)
data=$(mktemp -d)
log="$work/server.log"
body="$work/body"
headers="$work/headers"
pid=""

stop_server() {  # SIGTERM, then SIGKILL after 5 s
  [ -n "$pid" ] || return 0
  if kill -0 "$pid" 2>/dev/null; then
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null || true
  fi
  wait "$pid" 2>/dev/null || true
  pid=""
}
cleanup() {
  local status=$?
  stop_server
  if [ "$status" -ne 0 ] && [ -s "$log" ]; then
    echo "--- server log (last 40 lines)" >&2
    tail -n 40 "$log" >&2
  fi
  rm -rf "$work" "$data"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# request METHOD PATH [JSON_BODY]: sets $code; the body goes to $body, the headers to $headers.
request() {
  last="$1 $2"
  local args=(-sS --noproxy '*' --max-time 30 -X "$1" -o "$body" -D "$headers" -w '%{http_code}')
  if [ $# -ge 3 ]; then args+=(-H 'Content-Type: application/json' --data-binary "$3"); fi
  code=$(curl "${args[@]}" "$base$2") || fail "$last: curl failed"
}
expect_code() {
  [ "$code" = "$1" ] || fail "$last: expected HTTP $1, got $code: $(head -c 400 "$body")"
}
header() {  # the value of response header $1 (case-insensitive name)
  sed -n "s/^$1:[[:space:]]*//Ip" "$headers" | tr -d '\r' | tail -n 1
}
expect_type() {
  local type
  type=$(header Content-Type)
  case $type in
    "$1"|"$1;"*) ;;
    *) fail "$last: expected Content-Type $1, got '$type'" ;;
  esac
}
expect_magic() {  # expect_magic HEX: the body starts with these bytes
  local n=$(( ${#1} / 2 )) got
  got=$(head -c "$n" "$body" | od -An -tx1 | tr -d ' \n')
  [ "$got" = "$1" ] || fail "$last: body starts with $got, expected $1"
}
json_state() {
  grep -o '"state"[[:space:]]*:[[:space:]]*"[a-z]*"' "$body" | head -n 1 | sed 's/.*"\([a-z]*\)"$/\1/'
}
# wait_state ID STATE SECONDS: polls GET /v1/jobs/ID; fails on any other final state.
wait_state() {
  local id=$1 want=$2 deadline=$((SECONDS + $3)) state
  while :; do
    request GET "/v1/jobs/$id"
    expect_code 200
    state=$(json_state)
    [ "$state" = "$want" ] && return 0
    case $state in
      succeeded|failed|canceled) fail "job $id ended $state, expected $want: $(head -c 400 "$body")" ;;
    esac
    [ "$SECONDS" -lt "$deadline" ] || fail "job $id still '$state' after $3 s (expected $want)"
    sleep 0.2
  done
}

# --- start the server on a free port and read the port from its log
step "starting $bin serve"
"$bin" serve --host 127.0.0.1 --port 0 --data-dir "$data" --scenes "$repo/scenes" >"$log" 2>&1 &
pid=$!
port=""
for _ in $(seq 100); do
  port=$(sed -n 's|.*listening on http://127\.0\.0\.1:\([0-9][0-9]*\).*|\1|p' "$log" | head -n 1)
  [ -n "$port" ] && break
  kill -0 "$pid" 2>/dev/null || fail "the server exited before listening"
  sleep 0.1
done
[ -n "$port" ] || fail "no 'listening on http://127.0.0.1:PORT' line in the log within 10 s"
base="http://127.0.0.1:$port"
step "server at $base"

# --- health
request GET /healthz
expect_code 200
grep -q '"ok"' "$body" || fail "$last: body lacks \"ok\": $(cat "$body")"
request GET /readyz
expect_code 200
request GET /v1/openapi.yaml
expect_code 200; expect_type application/yaml
grep -q '^openapi: 3' "$body" || fail "$last: not an OpenAPI document"

# --- submit a job and poll it
request POST /v1/jobs '{"scene":"cornell_box","width":64,"height":48,"spp":4,"max_depth":2}'
expect_code 202
location=$(header Location)
id=${location##*/}
printf '%s\n' "$id" | grep -Eq '^[0-9a-f]{16}$' || fail "$last: bad Location header '$location'"
[ "$location" = "/v1/jobs/$id" ] || [ "$location" = "$base/v1/jobs/$id" ] || fail "$last: bad Location header '$location'"
step "job $id submitted"
wait_state "$id" succeeded 60
step "job $id succeeded"

# --- results
request GET "/v1/jobs/$id/image.png"
expect_code 200; expect_type image/png; expect_magic 89504e470d0a1a0a
request GET "/v1/jobs/$id/image.exr"
expect_code 200; expect_type image/x-exr; expect_magic 762f3101
request GET "/v1/jobs/$id/rate.png"
expect_code 200; expect_type image/png; expect_magic 89504e470d0a1a0a
request GET "/v1/jobs/$id/report.json"
expect_code 200; expect_type application/json
if command -v python3 >/dev/null; then
  python3 -c 'import json,sys; json.load(sys.stdin)' <"$body" || fail "$last: not valid JSON"
fi
grep -q '"timings"' "$body" || fail "$last: no \"timings\" in the report"
step "PNG, EXR, rate map and report fetched"

# --- bad requests
request POST /v1/jobs '{"scene": "cornell_box", "spp": '
expect_code 400; expect_type application/problem+json
request POST /v1/jobs '{"scene":"cornell_box","spp":"many"}'
expect_code 400; expect_type application/problem+json
grep -q '/spp' "$body" || fail "$last: the problem does not name /spp: $(cat "$body")"
request GET /v1/jobs/ffffffffffffffff
expect_code 404; expect_type application/problem+json
step "malformed body, mistyped field and unknown job rejected"

# --- list
request GET '/v1/jobs?state=succeeded&limit=10'
expect_code 200; expect_type application/json
grep -q "\"$id\"" "$body" || fail "$last: job $id not listed: $(head -c 400 "$body")"

# --- cancel a long job
request POST /v1/jobs '{"scene":"cornell_box","width":640,"height":480,"spp":4096,"max_depth":5}'
expect_code 202
long=$(header Location); long=${long##*/}
request DELETE "/v1/jobs/$long"
expect_code 200
wait_state "$long" canceled 30
request DELETE "/v1/jobs/$long"
expect_code 200
request GET "/v1/jobs/$long/image.png"
expect_code 410; expect_type application/problem+json
step "job $long canceled"

# --- delete the first job's results
request DELETE "/v1/jobs/$id/results"
expect_code 204
request GET "/v1/jobs/$id/image.png"
expect_code 410
step "results of $id deleted"

# --- metrics
request GET /metrics
expect_code 200
grep -q '^tessera_jobs' "$body" || fail "$last: no tessera_jobs metric"

# --- graceful shutdown
step "SIGTERM"
kill -TERM "$pid"
for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
kill -0 "$pid" 2>/dev/null && fail "the server is still running 10 s after SIGTERM"
rc=0
wait "$pid" || rc=$?
pid=""
step "server exited with status $rc"
echo "e2e: all checks passed"
