#!/bin/sh
# compile_probe.sh BUILD_DIR TARGET HEADER: building TARGET (a file of a lower layer that
# includes HEADER of a higher one) must fail because HEADER is not on that layer's include path.
build="$1"; target="$2"; header="$3"
out=$(cmake --build "$build" --target "$target" 2>&1)
if [ $? -eq 0 ]; then
  echo "$target compiled: the layer's include root lets it reach $header"; exit 1
fi
if ! printf '%s\n' "$out" | grep -q "$header: No such file"; then
  echo "$target failed for another reason:"; printf '%s\n' "$out" | tail -n 20; exit 1
fi
echo "ok: $target cannot include $header"
