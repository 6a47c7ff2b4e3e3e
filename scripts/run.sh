#!/usr/bin/env bash
# The README's first command: install what is missing, build, and run the main job — a demo
# render of the built-in Cornell box with two spheres (out/cornell_spheres.png and .exr).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh release
mkdir -p out
./build/release/server/tessera render -s 64 -l 4 -m 5 -r 480 360 -f out/cornell_spheres.png builtin:cornell_spheres
./build/release/server/tessera render -s 64 -l 4 -m 5 -r 480 360 -f out/cornell_spheres.exr builtin:cornell_spheres
