#!/usr/bin/env bash
# The README's second command: install what is missing, build, and run every test — the unit
# tests in a Release build and again under ASan+UBSan, then each loader's libFuzzer target for
# a bounded time on the broken-file corpus.
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

stage "ASan+UBSan build and tests"
bash scripts/build.sh asan
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build/asan --output-on-failure -j 2 -LE slow

stage "fuzzers (${fuzz_seconds}s each)"
bash scripts/build.sh fuzz
# Each loader on its broken files, and the real server's request handling on whole requests
# (tests/corpus/http); a crash, a sanitizer report or a connection that never ends fails.
for target in collada gltf requests; do
  seeds="tests/corpus/$target"
  [ "$target" = requests ] && seeds=tests/corpus/http
  mkdir -p "build/fuzz/corpus-$target"
  log="build/fuzz/fuzz-$target.log"
  # A finding prints its stack and input, and the input is kept in build/fuzz/ to replay:
  # ./build/fuzz/tests/fuzz/fuzz_$target build/fuzz/crash-...
  if ! ./build/fuzz/tests/fuzz/fuzz_$target -max_total_time="$fuzz_seconds" -timeout=60 -rss_limit_mb=2048 -max_len=65536 \
    -artifact_prefix=build/fuzz/ "build/fuzz/corpus-$target" "$seeds" > "$log" 2>&1; then
    grep -v '^#[0-9]' "$log" | tail -n 60
    echo "fuzz_$target found a failure (its whole log: $log)" >&2
    exit 1
  fi
  tail -n 1 "$log"
done
echo "all tests passed"
