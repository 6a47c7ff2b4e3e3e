#!/usr/bin/env bash
# Configures and builds one CMake preset (release by default: build/release/server/tessera).
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-release}"
jobs="${TESSERA_BUILD_JOBS:-$(nproc)}"
if [ ! -f "build/$preset/CMakeCache.txt" ]; then
  cmake --preset "$preset" >/dev/null
fi
cmake --build --preset "$preset" -j "$jobs"
