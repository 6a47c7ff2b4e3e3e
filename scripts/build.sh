#!/usr/bin/env bash
# Configures and builds one CMake preset (release by default: build/release/cli/tessera).
# `build.sh PRESET TARGET...` builds only those targets (the container image: tessera).
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-release}"
shift || true
targets=()
[ $# -gt 0 ] && targets=(--target "$@")
jobs="${TESSERA_BUILD_JOBS:-$(nproc)}"
# ccache (where installed) names paths relative to the clone, so a clone elsewhere (CI's) finds
# what this one compiled; the sanitizer build's debug info then names the first clone's folder.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}" CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-1}"
# TESSERA_NATIVE=OFF builds for any x86-64 (the container image); the default tunes for this CPU.
# The asan preset builds with clang (its objects serve the fuzzers too): a build/asan made with
# GCC before is configured afresh.
if [ "$preset" = asan ] && [ -f build/asan/CMakeCache.txt ] && ! grep -q '^CMAKE_CXX_COMPILER:[A-Z]*=.*clang' build/asan/CMakeCache.txt; then
  rm -rf build/asan
fi
if [ ! -f "build/$preset/CMakeCache.txt" ]; then
  cmake --preset "$preset" -DTESSERA_NATIVE="${TESSERA_NATIVE:-ON}" >/dev/null
fi
cmake --build --preset "$preset" -j "$jobs" "${targets[@]}"
