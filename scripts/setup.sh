#!/usr/bin/env bash
# Installs what Tessera needs to build and test, from Debian 12's packages only.
# Idempotent: packages already present are left alone. Runs as root or through sudo.
# `setup.sh --build`: only what building needs (the container image's build stage): no Node,
# no contract tools.
set -euo pipefail
build_only=0
[ "${1:-}" = "--build" ] && build_only=1

packages=(
  # toolchain; ccache: a clean clone or the image's build stage compiles only the sources that
  # changed since a build of this machine (CMakeLists.txt uses it where it is installed)
  build-essential cmake git pkg-config ninja-build ccache
  # the design card; libstb-dev: the stb_image that tinygltf is written for, which decodes glTF's
  # PNG and JPEG textures in memory (engine/io/texture_decode.cpp)
  libcpp-httplib-dev nlohmann-json3-dev libglm-dev libtinygltf-dev libstb-dev
  libopenimageio-dev openimageio-tools libspdlog-dev libfmt-dev libgtest-dev libgmock-dev
  # COLLADA is XML (pugixml); Google Benchmark for the micro benchmarks
  libpugixml-dev libbenchmark-dev
  # the command line (subcommands, help, environment variables) is CLI11, fed from api/'s job
  # field table; yaml-cpp reads api/openapi.yaml in the test that holds it to that table
  libcli11-dev libyaml-cpp-dev
  # the server's durable job records (one process), and a render farm's queue: Redis 7 and
  # its C client hiredis; the farm tests start a real redis-server
  libsqlite3-dev redis-server libhiredis-dev
  # notifications are signed with HMAC-SHA256 (OpenSSL's libcrypto)
  libssl-dev
  # Intel Embree 3, the reference our BVH is measured against (bvh "embree")
  libembree-dev
  # libFuzzer comes with clang's runtime
  clang libclang-rt-14-dev
  # the end-to-end scripts
  curl
  # the container test (tests/container): podman with runc, CNI networking with container names
  # resolved (compose), debootstrap for the debian:12 base image, podman-compose
  podman runc containernetworking-plugins golang-github-containernetworking-plugin-dnsname iptables
  debootstrap podman-compose
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done

# The contract tests' outside tools (Spectral, ajv) run on Node, and npm fetches them. Debian's
# nodejs and npm, unless a node and npm are already there (another build of Node ships its own
# npm, which Debian's npm package would conflict with).
if [ "$build_only" = 0 ]; then
  command -v node > /dev/null || missing+=(nodejs)
  command -v npm > /dev/null || missing+=(npm)
  # The web page's test drives Debian's Chromium (tests/web).
  dpkg-query -W -f='${Status}' chromium 2>/dev/null | grep -q 'install ok installed' || missing+=(chromium)
fi
# A shot's preview video (preview.mp4, H.264) is encoded by Debian's ffmpeg: an encoder is not
# ours to write. Without it a shot is rendered all the same and its report says the preview was
# left out. Also with --build: the container image's run stage takes it from the build stage.
dpkg-query -W -f='${Status}' ffmpeg 2>/dev/null | grep -q 'install ok installed' || missing+=(ffmpeg)

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
else
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "setup: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
    sudo="sudo"
  fi
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The test tools from npm at the versions each package-lock.json pins, into node_modules beside
# it (not committed); again only when the lock file changed: the contract tools (Spectral,
# ajv) and the browser driver (playwright-core, which uses Debian's Chromium and downloads none).
root="$(cd "$(dirname "$0")/.." && pwd)"
if [ "$build_only" = 0 ]; then
  for tools in "$root/tests/contract" "$root/tests/web"; do
    if [ ! -f "$tools/node_modules/.package-lock.json" ] || [ "$tools/package-lock.json" -nt "$tools/node_modules/.package-lock.json" ]; then
      echo "setup: installing test tools (npm ci in ${tools#$root/})"
      (cd "$tools" && npm ci --no-audit --no-fund --loglevel=error)
    fi
  done
fi
echo "setup: done"
