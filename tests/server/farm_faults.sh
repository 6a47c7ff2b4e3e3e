#!/usr/bin/env bash
# farm_faults.sh TESSERA SCENARIO: a render farm of real processes (redis-server, API nodes,
# render nodes) under one fault, and the image compared bit for bit with one process's.
#   kill_render_node  kill -9 of a render node mid-tile: its task is claimed by the other node
#   kill_api_node     kill -9 of the API node that accepted the job: another API node serves it
#   sigstop_node      a render node stopped past the visibility timeout, then resumed: its late
#                     result changes nothing
#   redis_restart     kill -9 of Redis after the AOF's fsync window, restarted from its AOF mid-job
#   cancel_priority   a high-priority job overtakes a running low one; cancel stops a running job
#   poison_task       a task whose nodes keep dying fails its job with the reason, instead of looping
#   blocklist         a node that fails every task (its --max-triangles refuses the scene) is
#                     blocklisted for the job; the other finishes it, the same image; the node is
#                     counted in /v1/nodes and /metrics
#   tags              a job that requires tags no live node has waits, saying so; a node started
#                     with them takes it, and only it renders the job
#   random_kills      3 nodes (API + render each), 50 jobs, random kill -9 and restarts: every job
#                     accounted for, every image identical to one process's
#   environment       a job with an environment map: published through Redis, the same image
#   no_lights         a scene without lights: the default sky on the farm's nodes, the same image
#   events            GET /v1/events on an API node that did not take the job: its life as events
#                     (what the web page follows in a farm), and the page served there
set -u
bin="$1"
scenario="$2"
work=$(mktemp -d)
. "$(dirname "$0")/farm_lib.sh"
trap farm_cleanup EXIT
need_redis
start_redis
mkdir -p "$work/data"

# Long enough to be interrupted mid-pass on one thread per node, short enough for CI.
job='{"scene":"cornell_spheres","width":160,"height":120,"spp":256,"max_depth":4,"tile_size":16}'

# One API node and one render node render the job as one process does, bit for bit, and the
# farm's report says what the pattern matches. The render node starts after the job is queued,
# and after `between` (a command) has run.
farm_renders_as_one_process() {  # job-json report-pattern [between]
  local ref id
  ref=$(reference "$1")
  start_api api
  id=$(submit api "$1")
  [ -n "$id" ] || fail "job not accepted"
  [ -z "${3:-}" ] || eval "$3"
  start_worker w1 --threads 2
  wait_state_on api "$id" 60 succeeded
  same_image api "$id" "$ref"
  api "$(url api)/v1/jobs/$id/report.json" | grep -q "$2" || fail "the farm's report does not say '$2'"
}

case "$scenario" in
events)
  start_api api1
  start_api api2
  start_worker w1 --threads 2
  api -N --max-time 120 "$(url api2)/v1/events" > "$work/events.txt" &
  stream=$!
  for _ in $(seq 1 100); do [ -s "$work/events.txt" ] && break; sleep 0.05; done
  [ -s "$work/events.txt" ] || fail "the event stream did not open"
  id=$(submit api1 "$job")
  [ -n "$id" ] || fail "job not accepted"
  wait_state_on api1 "$id" 120 succeeded
  # The watcher looks every 300 ms: give it two looks past the end.
  for _ in $(seq 1 50); do grep -q "\"id\":\"$id\".*\"state\":\"succeeded\"" "$work/events.txt" && break; sleep 0.1; done
  kill "$stream" 2> /dev/null; wait "$stream" 2> /dev/null
  mine=$(grep "^data: .*\"id\":\"$id\"" "$work/events.txt" | sed 's/.*"state":"\([a-z]*\)".*/\1/' | uniq | tr '\n' ' ')
  types=$(grep -B1 "^data: .*\"id\":\"$id\"" "$work/events.txt" | sed -n 's/^event: //p' | uniq | tr '\n' ' ')
  echo "events of job $id on api2: $types; states: $mine"
  # The watcher looks every 300 ms: the job may be running by its first look.
  case "$types" in "created "*) ;; *) fail "events should start with created: $types" ;; esac
  case "$mine" in *"running succeeded ") ;; *) fail "states seen: $mine (want running, then succeeded)" ;; esac
  echo "$types" | grep -q progress || fail "no progress event for a 256-spp job on one node"
  code=$(api -o "$work/page.html" -w '%{http_code}' "$(url api2)/")
  [ "$code" = 200 ] && grep -q "<html" "$work/page.html" || fail "the web page on an API node: $code"
  ;;
environment)
  # An environment map on the farm: published by the API node with the job, read by the render
  # node from Redis (the file is gone from disk before the node starts), the image the same as
  # one process's.
  mkdir -p "$work/envs"
  cp "$(dirname "$0")/../../scenes/sky.exr" "$work/envs/night.exr"
  export TESSERA_SCENES="$work/envs"
  farm_renders_as_one_process \
    '{"scene":"cornell_box","environment":"night","width":64,"height":48,"spp":16,"max_depth":2,"tile_size":16}' \
    "environment light: .*night.exr" 'rm "$work/envs/night.exr"'
  code=$(api -o "$work/unknown.json" -w '%{http_code}' -X POST -H 'Content-Type: application/json' \
    -d '{"scene":"cornell_box","environment":"no_such_sky"}' "$(url api)/v1/jobs")
  [ "$code" = 404 ] && grep -q unknown-environment "$work/unknown.json" || fail "an unknown environment map on the farm: $code"
  ;;
no_lights)
  # A scene without lights is lit by the default sky on the farm's nodes as in one process:
  # the Cornell box with its lamp turned off, from a scene folder both servers read.
  mkdir -p "$work/scenes"
  sed 's/"emissiveStrength": 10.0/"emissiveStrength": 0.0/' "$(dirname "$0")/../../scenes/cornell_box.gltf" > "$work/scenes/dark_box.gltf"
  grep -q '"emissiveStrength": 0.0' "$work/scenes/dark_box.gltf" || fail "the lamp of scenes/cornell_box.gltf was not found to turn off"
  export TESSERA_SCENES="$work/scenes"
  farm_renders_as_one_process '{"scene":"dark_box","width":64,"height":48,"spp":16,"max_depth":2,"tile_size":16}' \
    "default uniform white sky"
  ;;
kill_render_node)
  ref=$(reference "$job")
  start_api api
  start_worker w1
  start_worker w2
  id=$(submit api "$job")
  [ -n "$id" ] || fail "job not accepted"
  wait_state_on api "$id" 30 running
  while [ "$(tiles_done_on api "$id")" = 0 ] || [ -z "$(tiles_done_on api "$id")" ]; do sleep 0.05; done
  sleep 0.5
  stop_while_holding w1
  kill_node w1 9
  echo "killed render node w1 (kill -9) while job $id was running"
  wait_state_on api "$id" 120 succeeded
  same_image api "$id" "$ref"
  grep -q "took over" "$work/w2.log" || fail "w2 never took over a task of the killed node"
  # Both nodes' shares in the report, and the survivor's metrics on the API node.
  api "$(url api)/v1/jobs/$id/report.json" | grep -q '"node": "w2"' || fail "report.json has no share for w2"
  api "$(url api)/metrics" | grep -q 'tessera_node_tiles_total{node="w2"}' || fail "/metrics shows no tiles for w2"
  ;;
kill_api_node)
  ref=$(reference "$job")
  start_api api1
  start_api api2
  start_worker w1 --threads 2
  id=$(submit api1 "$job")
  wait_state_on api1 "$id" 30 running
  kill_node api1 9
  echo "killed API node api1 (kill -9), which accepted job $id"
  wait_state_on api2 "$id" 120 succeeded
  same_image api2 "$id" "$ref"
  code=$(api -o /dev/null -w '%{http_code}' "$(url api2)/v1/jobs/$id/report.json")
  [ "$code" = 200 ] || fail "report.json through api2: $code"
  ;;
blocklist)
  ref=$(reference "$job")
  start_api api
  # The good node first, live (its heartbeat seen): a node alone that fails is the only node
  # that could take the job, which then fails for want of one.
  start_worker good
  for _ in $(seq 1 100); do api "$(url api)/v1/nodes" | grep -q '"name":"good"' && break; sleep 0.1; done
  start_worker bad --max-triangles 1
  id=$(submit api "${job%\}},\"blocklist_after\":2}")
  [ -n "$id" ] || fail "job not accepted"
  wait_state_on api "$id" 120 succeeded
  same_image api "$id" "$ref"
  status=$(api "$(url api)/v1/jobs/$id")
  echo "$status" | grep -q '"blocklisted":\["bad"\]' || fail "the status does not name the blocklisted node: $status"
  echo "$status" | grep -q '"latest":\["bad: ' || fail "the status does not give the reasons: $status"
  api "$(url api)/v1/jobs/$id/report.json" | grep -q '"node":"bad"' && fail "the failing node stored a tile"
  api "$(url api)/v1/jobs/$id/log" | grep '"outcome":"failed"' | grep -q '"node":"bad"' || fail "the log has no failed task of the node"
  for _ in $(seq 1 100); do
    api "$(url api)/v1/nodes" | grep -q '"blocklisted_jobs":1,"busy":[0-9.e-]*,"failed_tasks":[1-9]' && break
    sleep 0.1
  done
  api "$(url api)/v1/nodes" | grep -q '"blocklisted_jobs":1' || fail "/v1/nodes does not count the blocklisting: $(api "$(url api)/v1/nodes")"
  api "$(url api)/metrics" | grep -q '^tessera_node_blocklisted_jobs_total{node="bad"} 1' || fail "/metrics does not count it"
  ;;
tags)
  ref=$(reference "$job")
  start_api api
  start_worker plain
  id=$(submit api "${job%\}},\"requires\":[\"bigmem\"]}")
  [ -n "$id" ] || fail "job not accepted"
  sleep 2
  [ "$(state_on api "$id")" = queued ] || fail "a node without the tag took the job"
  api "$(url api)/v1/jobs/$id" | grep -q '"unplaceable":"no live render node has every tag the job requires' || fail "the status does not say why it waits: $(api "$(url api)/v1/jobs/$id")"
  start_worker big --tags gpu,bigmem
  wait_state_on api "$id" 120 succeeded
  same_image api "$id" "$ref"
  api "$(url api)/v1/jobs/$id/report.json" | grep -q '"node":"plain"' && fail "the node without the tag rendered a tile"
  api "$(url api)/v1/nodes" | grep -q '"tags":\["bigmem","gpu"\]' || fail "/v1/nodes does not list the tags"
  ;;
poison_task)
  # --max-deliveries 1: the first takeover is already one delivery too many.
  start_api api
  start_worker w1 --max-deliveries 1
  id=$(submit api "$job")
  wait_state_on api "$id" 30 running
  while [ "$(tiles_done_on api "$id")" = 0 ] || [ -z "$(tiles_done_on api "$id")" ]; do sleep 0.05; done
  stop_while_holding w1
  kill_node w1 9
  start_worker w2 --max-deliveries 1
  wait_state_on api "$id" 60 failed
  api "$(url api)/v1/jobs/$id" | grep -q 'was delivered 2 times' || fail "the failed job does not say why: $(api "$(url api)/v1/jobs/$id")"
  # The farm goes on: the next job succeeds.
  id2=$(submit api '{"scene":"cornell_spheres","width":32,"height":24,"spp":4,"tile_size":16}')
  wait_state_on api "$id2" 60 succeeded
  ;;
sigstop_node)
  ref=$(reference "$job")
  start_api api
  start_worker w1
  start_worker w2
  id=$(submit api "$job")
  wait_state_on api "$id" 30 running
  while [ "$(tiles_done_on api "$id")" = 0 ] || [ -z "$(tiles_done_on api "$id")" ]; do sleep 0.05; done
  stop_while_holding w1
  echo "stopped w1 (SIGSTOP) for twice the visibility timeout"
  sleep $(( (visibility_ms * 2 + 999) / 1000 ))
  kill_node w1 CONT
  wait_state_on api "$id" 120 succeeded
  same_image api "$id" "$ref"
  grep -q "took over" "$work/w2.log" || fail "w2 never took over the stopped node's task"
  # The resumed node finds its task taken: it drops its result (or stores a duplicate that the
  # pass check refuses); either way the image above is unchanged.
  sleep 1
  kill_node w1 TERM
  ;;
redis_restart)
  ref=$(reference "$job")
  start_api api
  start_worker w1
  start_worker w2
  ids=()
  for _ in 1 2 3; do ids+=("$(submit api "$job")"); done
  wait_state_on api "${ids[0]}" 30 running
  sleep 1.5  # past appendfsync everysec's window: all three acceptances are on disk
  kill -9 "$redis_pid"; wait "$redis_pid" 2> /dev/null
  echo "killed redis-server (kill -9) mid-job; restarting it from its AOF"
  # Without Redis the API node is not ready (a balancer sends jobs elsewhere), its liveness
  # and metrics still answer, the metrics saying the store's figures are missing.
  code=$(api -o /dev/null -w '%{http_code}' "$(url api)/readyz")
  [ "$code" = 503 ] || fail "/readyz answered $code while Redis was down (expected 503)"
  code=$(api -o "$work/metrics.txt" -w '%{http_code}' "$(url api)/metrics")
  [ "$code" = 200 ] || fail "/metrics answered $code while Redis was down (expected 200)"
  grep -q '^tessera_store_up 0$' "$work/metrics.txt" || fail "/metrics did not say tessera_store_up 0 while Redis was down"
  [ "$(api -o /dev/null -w '%{http_code}' "$(url api)/healthz")" = 200 ] || fail "/healthz failed while Redis was down"
  sleep 0.5
  start_redis
  for id in "${ids[@]}"; do
    wait_state_on api "$id" 180 succeeded
    same_image api "$id" "$ref"
  done
  ;;
cancel_priority)
  start_api api
  start_worker w1
  low=$(submit api '{"scene":"cornell_spheres","width":160,"height":120,"spp":1024,"max_depth":4,"tile_size":16}')
  wait_state_on api "$low" 30 running
  high=$(submit api '{"scene":"cornell_box","width":64,"height":48,"spp":16,"priority":10}')
  wait_state_on api "$high" 60 succeeded
  [ "$(state_on api "$low")" = running ] || fail "the low-priority job finished before the high-priority one"
  api -X DELETE "$(url api)/v1/jobs/$low" > /dev/null
  [ "$(state_on api "$low")" = canceled ] || fail "cancel did not take"
  # Within a tile's time, no more tiles of it are stored: the worker's tile count stops.
  sleep 1
  before=$(redis-cli -p "$redis_port" hget "tessera:job:$low" tiles_done)
  sleep 1.5
  after=$(redis-cli -p "$redis_port" hget "tessera:job:$low" tiles_done)
  [ "$before" = "$after" ] || fail "tiles of the canceled job were still stored ($before, then $after)"
  code=$(api -o /dev/null -w '%{http_code}' "$(url api)/v1/jobs/$low/image.png")
  [ "$code" = 410 ] || fail "a canceled job's image answered $code, not 410"
  ;;
random_kills)
  visibility_ms=1000
  specs=('{"scene":"cornell_box","width":48,"height":36,"spp":32,"max_depth":3,"tile_size":8}'
         '{"scene":"cornell_spheres","width":48,"height":36,"spp":16,"max_depth":4,"tile_size":16,"priority":3}'
         '{"scene":"builtin:cornell_spheres","width":40,"height":30,"spp":64,"adaptive":{"batch":8,"tolerance":0.05},"tile_size":8}')
  refs=()
  for s in "${specs[@]}"; do refs+=("$(reference "$s")"); done
  names=(n1 n2 n3)
  for n in "${names[@]}"; do start_api "$n" --render --threads 1; done
  declare -A spec_of=()
  accepted=0
  kills=0
  for i in $(seq 0 49); do
    k=$((i % 3))
    id=""
    for try in 0 1 2; do  # a node killed under the request: the client tries the next one
      n=${names[$(( (i + try) % 3 ))]}
      id=$(submit "$n" "${specs[$k]}")
      [ -n "$id" ] && break
    done
    [ -n "$id" ] || fail "job $i was accepted by no node"
    spec_of[$id]=$k
    accepted=$((accepted + 1))
    if [ $((i % 6)) = 5 ]; then
      victim=${names[$((RANDOM % 3))]}
      kill_node "$victim" 9
      kills=$((kills + 1))
      start_api "$victim" --render --threads 1
    fi
  done
  echo "50 jobs accepted, $kills nodes killed with kill -9 and restarted"
  while :; do  # kills go on while the jobs finish
    pending=$(api "$(url n1)/v1/jobs?state=queued&limit=1" | field total)
    running=$(api "$(url n1)/v1/jobs?state=running&limit=1" | field total)
    [ "${pending:-1}" = 0 ] && [ "${running:-1}" = 0 ] && break
    [ $kills -ge 14 ] && { sleep 0.5; continue; }
    victim=${names[$((1 + RANDOM % 2))]}  # n1 stays up to answer the polls
    kill_node "$victim" 9
    kills=$((kills + 1))
    sleep 0.$((RANDOM % 9 + 1))
    start_api "$victim" --render --threads 1
    sleep 1
  done
  n_ok=0
  for id in "${!spec_of[@]}"; do
    s=$(state_on n1 "$id")
    [ "$s" = succeeded ] || fail "job $id ended '$s'"
    same_image n1 "$id" "${refs[${spec_of[$id]}]}"
    n_ok=$((n_ok + 1))
  done
  [ "$n_ok" = 50 ] || fail "$n_ok of 50 jobs accounted for"
  total=$(api "$(url n1)/v1/jobs?limit=1" | field total)
  [ "$total" = 50 ] || fail "the store lists $total jobs, not 50"
  echo "all 50 jobs succeeded with images identical to one process's, after $kills kills"
  ;;
*)
  fail "unknown scenario $scenario"
  ;;
esac
echo "PASS: $scenario"
