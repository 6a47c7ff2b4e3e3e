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
# Scene preparation writes hundreds of megabytes of fresh memory; in transparent huge pages
# it faults a fraction as often (docs/benchmarks.md, "Scene preparation": a 1M-triangle glTF
# loads in 34 ms instead of 139). The engine asks for them for its own arrays; this asks
# glibc's malloc to, for the rest (the loaders').
export GLIBC_TUNABLES="${GLIBC_TUNABLES:-glibc.malloc.hugetlb=1}"
exec ./build/release/cli/tessera serve "${args[@]}" "$@"
