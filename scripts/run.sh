#!/usr/bin/env bash
# The README's first command: install what is missing, build, and start the render server on
# its embedded defaults (http://127.0.0.1:8080, data in ./data, our scenes/ plus the shared
# CS184 scenes when they are beside the repository). Stop it with Ctrl-C (SIGTERM-safe: jobs
# are kept and resumed on the next start).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh release
args=()
[ -d ../shared/scenes/cs184 ] && args+=(--scenes ../shared/scenes/cs184)
exec ./build/release/cli/tessera serve "${args[@]}" "$@"
