# Sourced by the farm scripts: a real redis-server (Debian's) on a random loopback port with its
# own directory, real `tessera serve --redis` API nodes and `tessera worker` render nodes, and a
# one-process `tessera serve` for reference images. The caller sets bin and work (a temporary
# directory) and traps `farm_cleanup`.
redis_port=""
redis_pid=""
declare -A node_pid=()   # name → pid
declare -A node_port=()  # API nodes: name → HTTP port
visibility_ms=${visibility_ms:-1500}

fail() {
  echo "FAIL: $*"
  for f in "$work"/*.log; do [ -f "$f" ] && { echo "--- $f"; tail -n 25 "$f"; }; done
  exit 1
}
api() { curl -s --noproxy '*' --max-time 10 "$@"; }
field() { sed -n "s/.*\"$1\":\"\{0,1\}\([^,\"}]*\).*/\1/p" | head -n 1; }

need_redis() {
  if ! command -v redis-server > /dev/null; then
    [ "${TESSERA_REQUIRE_REDIS:-0}" = 1 ] && { echo "FAIL: redis-server is not installed (TESSERA_REQUIRE_REDIS=1)"; exit 1; }
    echo "SKIP: redis-server is not installed (apt-get install redis-server); the farm is not tested"
    exit 77
  fi
}

# AOF with fsync every second: the durability docs/scaling.md documents.
start_redis() {
  mkdir -p "$work/redis"
  for _ in $(seq 1 20); do
    [ -z "$redis_port" ] && redis_port=$((20000 + RANDOM % 40000))
    redis-server --port "$redis_port" --bind 127.0.0.1 --dir "$work/redis" --appendonly yes --appendfsync everysec \
      --save "" --daemonize no --logfile "$work/redis.log" &
    redis_pid=$!
    for _ in $(seq 1 100); do
      redis-cli -p "$redis_port" ping 2> /dev/null | grep -q PONG && return 0
      kill -0 "$redis_pid" 2> /dev/null || break
      sleep 0.05
    done
    kill -9 "$redis_pid" 2> /dev/null
    redis_port=""
  done
  fail "redis-server did not start"
}
redis_url() { echo "redis://127.0.0.1:$redis_port/0"; }

start_api() {  # name [serve flags...]
  local name=$1; shift
  : > "$work/$name.log"
  "$bin" serve --host 127.0.0.1 --port 0 --data-dir "$work/data" --redis "$(redis_url)" --node-name "$name" \
    --visibility-ms "$visibility_ms" "$@" > "$work/$name.log" 2>&1 &
  node_pid[$name]=$!
  for _ in $(seq 1 100); do
    node_port[$name]=$(grep -o 'listening on http://127.0.0.1:[0-9]*' "$work/$name.log" | grep -o '[0-9]*$' || true)
    [ -n "${node_port[$name]}" ] && return 0
    sleep 0.1
  done
  fail "API node $name did not start"
}
start_worker() {  # name [worker flags...]
  local name=$1; shift
  "$bin" worker --redis "$(redis_url)" --data-dir "$work/data" --node-name "$name" --visibility-ms "$visibility_ms" \
    --threads 1 "$@" >> "$work/$name.log" 2>&1 &
  node_pid[$name]=$!
}
kill_node() {  # name [signal]
  kill "-${2:-9}" "${node_pid[$1]}" 2> /dev/null
  [ "${2:-9}" = 9 ] && wait "${node_pid[$1]}" 2> /dev/null
  return 0
}
# Stops a render node (SIGSTOP) at a moment it holds a task: stopped first, then its own
# pending tasks counted in Redis, resumed and tried again if it held none. A node stopped or
# killed between two batches (waiting for the next pass, say) leaves nothing to take over.
# The node renders on one thread (start_worker's default), so its one consumer is NAME/0; each
# pending entry names it on a line of its own.
stop_while_holding() {  # name
  local pending=0
  for _ in $(seq 1 400); do
    kill_node "$1" STOP
    pending=$(redis-cli -p "$redis_port" XPENDING tessera:tasks:0 nodes - + 10 "$1/0" | grep -cx "$1/0" || true)
    [ "${pending:-0}" -gt 0 ] && return 0
    kill_node "$1" CONT
    sleep 0.02
  done
  fail "$1 never held a task"
}
farm_cleanup() {
  for p in "${node_pid[@]}"; do kill -CONT "$p" 2> /dev/null; kill -9 "$p" 2> /dev/null; done
  [ -f "$work/single.pid" ] && kill -9 "$(cat "$work/single.pid")" 2> /dev/null
  [ -n "$redis_pid" ] && kill -9 "$redis_pid" 2> /dev/null
  wait 2> /dev/null
  rm -rf "$work"
}

url() { echo "http://127.0.0.1:${node_port[$1]}"; }  # an API node's base URL
submit() {  # node json → id
  api -X POST -H 'Content-Type: application/json' -d "$2" "$(url "$1")/v1/jobs" | field id
}
state_on() { api "$(url "$1")/v1/jobs/$2" | field state; }
wait_state_on() {  # node id seconds state...
  local node=$1 id=$2 secs=$3 s=""; shift 3
  for _ in $(seq 1 $((secs * 10))); do
    s=$(state_on "$node" "$id")
    for want in "$@"; do [ "$s" = "$want" ] && return 0; done
    sleep 0.1
  done
  fail "job $id stuck in '$s' (wanted $*) on $node"
}
tiles_done_on() { api "$(url "$1")/v1/jobs/$2" | sed -n 's/.*"tiles_done":\([0-9]*\).*/\1/p' | head -n 1; }

# One-process reference images: the same job on `tessera serve` with SQLite. reference runs in
# a command substitution (a subshell), so the server's pid and port live in files: the next
# call reuses the server and farm_cleanup stops it.
reference() {  # json → path of the image.exr
  local ref_port=""
  [ -f "$work/single.port" ] && ref_port=$(cat "$work/single.port")
  if [ -z "$ref_port" ]; then
    "$bin" serve --host 127.0.0.1 --port 0 --data-dir "$work/single" --threads 2 > "$work/single.log" 2>&1 &
    echo $! > "$work/single.pid"
    for _ in $(seq 1 100); do
      ref_port=$(grep -o 'listening on http://127.0.0.1:[0-9]*' "$work/single.log" | grep -o '[0-9]*$' || true)
      [ -n "$ref_port" ] && break
      sleep 0.1
    done
    echo "$ref_port" > "$work/single.port"
  fi
  local id s=""
  id=$(api -X POST -H 'Content-Type: application/json' -d "$1" "http://127.0.0.1:$ref_port/v1/jobs" | field id)
  for _ in $(seq 1 1200); do
    s=$(api "http://127.0.0.1:$ref_port/v1/jobs/$id" | field state)
    [ "$s" = succeeded ] && { echo "$work/single/jobs/$id/image.exr"; return 0; }
    sleep 0.1
  done
  fail "reference render $id stuck in '$s'"
}
# The farm's image, downloaded through an API node, equals the reference bit for bit.
same_image() {  # node id reference.exr
  api -o "$work/$2.exr" "$(url "$1")/v1/jobs/$2/image.exr"
  idiff -a -fail 0 -warn 0 "$3" "$work/$2.exr" > "$work/idiff.txt" 2>&1 || { cat "$work/idiff.txt"; fail "job $2: the image differs from one process's"; }
}
