# Sourced by the server scripts: start the real binary on a free loopback port and talk to it.
# The caller sets bin (the tessera binary), data (its data directory) and log (a file), and
# reads pid and port after `start`.
pid=""
port=""
fail() { echo "FAIL: $*"; echo "--- server log"; tail -n 40 "$log"; exit 1; }
start() {  # extra serve flags...
  : > "$log"
  "$bin" serve --host 127.0.0.1 --port 0 --data-dir "$data" --threads 2 "$@" > "$log" 2>&1 &
  pid=$!
  port=""
  for _ in $(seq 1 100); do
    port=$(grep -o 'listening on http://127.0.0.1:[0-9]*' "$log" | grep -o '[0-9]*$' || true)
    [ -n "$port" ] && return 0
    sleep 0.1
  done
  fail "server did not start"
}
api() { curl -s --noproxy '*' "$@"; }
field() { sed -n "s/.*\"$1\":\"\{0,1\}\([^,\"}]*\).*/\1/p" | head -n 1; }
state_of() { api "http://127.0.0.1:$port/v1/jobs/$1" | field state; }
wait_state() {  # id state...
  local id=$1 s=""; shift
  for _ in $(seq 1 600); do
    s=$(state_of "$id")
    for want in "$@"; do [ "$s" = "$want" ] && return 0; done
    sleep 0.1
  done
  fail "job $id stuck in '$s' (wanted $*)"
}
