#!/usr/bin/env bash
# contract.sh TESSERA: the OpenAPI description checked by outside tools. Spectral lints
# api/openapi.yaml (no errors allowed), then ajv validates the answers of a real server, started
# here on a free loopback port with a bearer token, against the description's schemas
# (validate_responses.mjs). The tools come from npm (package-lock.json), installed by
# scripts/setup.sh (they run on Debian 12's Node 18: package.json's overrides hold jsep, which
# Spectral's JSONPath needs, at 1.4.0, as 1.6 asks for Node 20); without them this skips (77),
# or fails where TESSERA_REQUIRE_CONTRACT=1 (CI).
set -euo pipefail
bin=$1
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
if [ ! -x "$here/node_modules/.bin/spectral" ] || ! command -v node > /dev/null; then
  if [ "${TESSERA_REQUIRE_CONTRACT:-0}" = 1 ]; then
    echo "FAIL: the contract tools are not installed (bash scripts/setup.sh installs them)"; exit 1
  fi
  echo "SKIP: the contract tools are not installed: bash scripts/setup.sh"; exit 77
fi

tmp=$(mktemp -d)
data=$tmp/data
log=$tmp/server.log
source "$root/tests/server/server_lib.sh"
trap '[ -n "$pid" ] && kill "$pid" 2> /dev/null; wait; rm -rf "$tmp"' EXIT

echo "== Spectral (spectral:oas)"
"$here/node_modules/.bin/spectral" lint --ruleset "$here/.spectral.yaml" --fail-severity error "$root/api/openapi.yaml"

echo "== real responses against the schemas"
mkdir -p "$tmp/scenes"
# A scene file that is broken where it lies: a job naming it is accepted and fails saying where.
printf '{"asset": {"version": "2.0"}, "meshes": [' > "$tmp/scenes/broken.gltf"
token=$(od -An -N24 -tx1 /dev/urandom | tr -d ' \n')
TESSERA_TOKENS=$token start --scenes "$tmp/scenes" --max-body 512 --max-upload 65536 --max-queued 3 --max-jobs 1
node "$here/validate_responses.mjs" "$root/api/openapi.yaml" "http://127.0.0.1:$port" "$token" broken || fail "answers that the description does not allow"
if grep -q -- "$token" "$log"; then fail "the token appears in the server's log"; fi
kill "$pid"
wait "$pid" || fail "the server did not stop cleanly on SIGTERM"
pid=""
echo "contract: ok"
