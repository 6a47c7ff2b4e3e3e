#!/usr/bin/env bash
# web_test.sh TESSERA: the web page in a real browser. The binary is started here on a free
# loopback port with a bearer token and a temporary data directory; page_test.mjs drives
# Debian's Chromium (headless) through playwright-core from npm (tests/web/package-lock.json),
# which uses the system browser and downloads none. Skips (77) where Chromium or the npm
# package is missing, fails there when TESSERA_REQUIRE_BROWSER=1 (CI). Screenshots go to
# $TESSERA_SCREENSHOTS when set (docs/figures/web_*.png are made so).
set -euo pipefail
bin=$1
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
trap '[ -n "$pid" ] && kill "$pid" 2> /dev/null; wait; rm -rf "$tmp"' EXIT

token=$(od -An -N24 -tx1 /dev/urandom | tr -d ' \n')
# One job at a time (a second one waits, to be canceled), and a pixel bound a form value can
# pass the page's own checks and still break (the server's problem names the field).
TESSERA_TOKENS=$token start --max-jobs 1 --max-pixels 50000
shots=${TESSERA_SCREENSHOTS:-$tmp/shots}
mkdir -p "$shots"
HOME=$tmp node "$here/page_test.mjs" "http://127.0.0.1:$port" "$token" "$browser" "$shots" || fail "the page test failed"
kill "$pid"
wait "$pid" || fail "the server did not stop cleanly on SIGTERM"
pid=""
echo "web page: ok"
