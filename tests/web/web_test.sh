#!/usr/bin/env bash
# web_test.sh TESSERA [farm]: the web page in a real browser. The binary is started here on a free
# loopback port with a bearer token and a temporary data directory; page_test.mjs drives
# Debian's Chromium (headless) through playwright-core from npm (tests/web/package-lock.json),
# which uses the system browser and downloads none (1.61, the last release whose engines accept
# Debian 12's Node 18; 1.62 and later need Node 20). Skips (77) where Chromium or the npm
# package is missing, fails there when TESSERA_REQUIRE_BROWSER=1 (CI). Screenshots go to
# $TESSERA_SCREENSHOTS when set (docs/figures/web_*.png are made so). With `farm`, the page is
# served by an API node of a render farm (a real redis-server, `serve --redis --render`): the
# same walk through the page, without pass images (a farm's passes are no one process's).
set -euo pipefail
bin=$1
mode=${2:-one}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
browser=${TESSERA_CHROMIUM:-/usr/bin/chromium}
if [ ! -x "$browser" ] || [ ! -d "$here/node_modules/playwright-core" ] || ! command -v node > /dev/null; then
  if [ "${TESSERA_REQUIRE_BROWSER:-0}" = 1 ]; then
    echo "FAIL: Chromium or playwright-core is not installed (bash scripts/setup.sh installs them)"; exit 1
  fi
  echo "SKIP: Chromium or playwright-core is not installed: bash scripts/setup.sh"; exit 77
fi

tmp=$(mktemp -d)
data=$tmp/data
log=$tmp/server.log
source "$root/tests/server/server_lib.sh"
redis_pid=""
trap '[ -n "$pid" ] && kill "$pid" 2> /dev/null; [ -n "$redis_pid" ] && kill -9 "$redis_pid" 2> /dev/null; wait; rm -rf "$tmp"' EXIT
farm=()
if [ "$mode" = farm ]; then
  if ! command -v redis-server > /dev/null; then
    [ "${TESSERA_REQUIRE_REDIS:-0}" = 1 ] && { echo "FAIL: redis-server is not installed"; exit 1; }
    echo "SKIP: redis-server is not installed"; exit 77
  fi
  for _ in $(seq 1 20); do
    redis_port=$((20000 + RANDOM % 40000))
    mkdir -p "$tmp/redis"
    redis-server --port "$redis_port" --bind 127.0.0.1 --dir "$tmp/redis" --save "" --appendonly no > "$tmp/redis.log" 2>&1 &
    redis_pid=$!
    for _ in $(seq 1 100); do redis-cli -p "$redis_port" ping 2> /dev/null | grep -q PONG && break 2; sleep 0.05; done
    kill -9 "$redis_pid" 2> /dev/null; redis_pid=""
  done
  [ -n "$redis_pid" ] || fail "redis-server did not start"
  farm=(--redis "redis://127.0.0.1:$redis_port/0" --render)
fi

token=$(od -An -N24 -tx1 /dev/urandom | tr -d ' \n')
# One job at a time (a second one waits, to be canceled), and a pixel bound a form value can
# pass the page's own checks and still break (the server's problem names the field).
TESSERA_TOKENS=$token start --max-jobs 1 --max-pixels 50000 "${farm[@]}"
shots=${TESSERA_SCREENSHOTS:-$tmp/shots}
mkdir -p "$shots"
HOME=$tmp node "$here/page_test.mjs" "http://127.0.0.1:$port" "$token" "$browser" "$shots" "$mode" || fail "the page test failed"
kill "$pid"
wait "$pid" || fail "the server did not stop cleanly on SIGTERM"
pid=""
echo "web page ($mode): ok"
