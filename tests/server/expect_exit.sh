#!/bin/sh
# expect_exit.sh STATUS PATTERN COMMAND...: the command must exit with STATUS (not crash) and
# print a one-line reason on stderr that matches PATTERN.
expected="$1"; pattern="$2"; shift 2
err=$("$@" 2>&1 >/dev/null)
status=$?
if [ "$status" -ne "$expected" ]; then
  echo "expected exit $expected, got $status: $err"; exit 1
fi
if ! printf '%s\n' "$err" | grep -q -- "$pattern"; then
  echo "stderr does not match '$pattern': $err"; exit 1
fi
if [ "$(printf '%s\n' "$err" | grep -c .)" -gt 3 ]; then
  echo "the reason should be short: $err"; exit 1
fi
echo "ok: exit $status: $err"
