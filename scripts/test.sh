#!/usr/bin/env bash
# The README's second command: install what is missing, build, and run every test: all of them
# in a Release build; the unit suites again under ASan+UBSan (clang), whose build also carries
# each loader's and the request handler's libFuzzer target, run for a bounded time on the
# broken-file corpus.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each stage's time is printed when it ends (also when it fails), and the whole run's at the end.
stage_name="setup"
stage_start=$SECONDS
stage_end() { echo "== $stage_name took $((SECONDS - stage_start)) s (the run so far: $SECONDS s)"; }
stage() {
  stage_end
  stage_name="$1"
  stage_start=$SECONDS
  echo "== $1"
}
trap stage_end EXIT
echo "== setup"
bash scripts/setup.sh
fuzz_seconds="${TESSERA_FUZZ_SECONDS:-60}"

stage "release build and tests"
bash scripts/build.sh release
ctest --test-dir build/release --output-on-failure -j 2

stage "ASan+UBSan build and unit tests"
# The unit suites and the fuzzers only: the command line's own tests run in the Release build.
bash scripts/build.sh asan engine_tests api_tests server_tests stability_tests fuzz_collada fuzz_gltf fuzz_requests
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build/asan --output-on-failure -j 2 -L '^(engine|api|server|stability)$' -LE slow --no-tests=error

stage "fuzzers (${fuzz_seconds}s each, side by side)"
# Each loader on its broken files, and the real server's request handling on whole requests
# (tests/corpus/http); a crash, a sanitizer report or a connection that never ends fails.
fuzz() {
  local target="$1" seeds="tests/corpus/$1"
  [ "$target" = requests ] && seeds=tests/corpus/http
  mkdir -p "build/asan/corpus-$target"
  # A finding prints its stack and input, and the input is kept in build/asan/ to replay:
  # ./build/asan/tests/fuzz/fuzz_$target build/asan/crash-...
  ./build/asan/tests/fuzz/fuzz_$target -max_total_time="$fuzz_seconds" -timeout=60 -rss_limit_mb=2048 -max_len=65536 \
    -artifact_prefix=build/asan/ "build/asan/corpus-$target" "$seeds" > "build/asan/fuzz-$target.log" 2>&1
}
pids=()
for target in collada gltf requests; do
  fuzz "$target" &
  pids+=($!)
done
failed=0
for i in 0 1 2; do
  target=$(echo collada gltf requests | cut -d' ' -f$((i + 1)))
  log="build/asan/fuzz-$target.log"
  if wait "${pids[$i]}"; then
    tail -n 1 "$log"
  else
    grep -v '^#[0-9]' "$log" | tail -n 60
    echo "fuzz_$target found a failure (its whole log: $log)" >&2
    failed=1
  fi
done
[ "$failed" = 0 ] || exit 1
echo "all tests passed"
