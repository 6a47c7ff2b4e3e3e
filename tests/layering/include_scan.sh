#!/usr/bin/env bash
# include_scan.sh SOURCE_DIR: every #include "..." of a layer names its own folder or a layer
# below it (engine < api < server < cli), and none climbs out with "../". The include roots
# (CMakeLists.txt, tessera_include_root) make a violation fail to compile; this scan says which
# line broke the rule, for every file, including headers no target compiles alone.
# Inside server/, the rooms point down too: store < queue < farm, and http sees store and queue
# (the queue's interface) but not the farm; files at server/'s top are shared by every room and
# include no room.
set -euo pipefail
src="${1:?usage: include_scan.sh SOURCE_DIR}"
cd "$src"
declare -A allowed=(
  [engine]="engine"
  [api]="engine api"
  [server]="engine api server"
  [cli]="engine api server cli"
)
bad=0
for layer in engine api server cli; do
  while IFS= read -r hit; do
    file=${hit%%:*}; rest=${hit#*:}; line=${rest%%:*}
    inc=$(printf '%s' "$rest" | sed -n 's/.*#include *"\([^"]*\)".*/\1/p')
    top=${inc%%/*}
    ok=0
    if [[ "$inc" != *..* && "$inc" == */* ]]; then
      for a in ${allowed[$layer]}; do [ "$top" = "$a" ] && ok=1; done
    fi
    if [ $ok -eq 0 ]; then
      echo "$file:$line: $layer/ may include only ${allowed[$layer]// /, } (got \"$inc\")"
      bad=1
    fi
  done < <(grep -rn --include='*.h' --include='*.cpp' --include='*.in' '^[[:space:]]*#[[:space:]]*include[[:space:]]*"' "$layer" || true)
done
declare -A rooms=(
  [store]="store"
  [queue]="store queue"
  [farm]="store queue farm"
  [http]="store queue http"
)
for room in store queue farm http; do
  [ -d "server/$room" ] || continue
  while IFS= read -r hit; do
    file=${hit%%:*}; rest=${hit#*:}; line=${rest%%:*}
    inc=$(printf '%s' "$rest" | sed -n 's/.*#include *"server\/\([^"]*\)".*/\1/p')
    [[ "$inc" == */* ]] || continue  # a shared file at server/'s top
    target=${inc%%/*}
    ok=0
    for a in ${rooms[$room]}; do [ "$target" = "$a" ] && ok=1; done
    if [ $ok -eq 0 ]; then
      echo "$file:$line: server/$room/ may include only server/{${rooms[$room]// /,}}/ (got \"server/$inc\")"
      bad=1
    fi
  done < <(grep -rn --include='*.h' --include='*.cpp' --include='*.in' '^[[:space:]]*#[[:space:]]*include[[:space:]]*"server/' "server/$room" || true)
done
while IFS= read -r hit; do
  file=${hit%%:*}; rest=${hit#*:}; line=${rest%%:*}
  echo "$file:$line: a shared file at server/'s top includes no room"
  bad=1
done < <(grep -n '^[[:space:]]*#[[:space:]]*include[[:space:]]*"server/[^"/]*/' server/*.h server/*.cpp 2>/dev/null || true)
[ $bad -eq 0 ] && echo "layering: every include of engine/, api/, server/ and cli/ points down, and so do server/'s rooms"
exit $bad
