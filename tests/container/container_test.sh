#!/usr/bin/env bash
# container_test.sh: the image as a user gets it, with a real container engine (Debian's
# podman). Builds docker/Dockerfile (on a debian:12 base made here from Debian's packages),
# checks its size, starts it with a token on a loopback port and waits for health, renders a
# job with curl and fetches its PNG and EXR, renders a shot and fetches its preview video (the
# image's ffmpeg) and a frame, checks the server runs as a user other than root and serves its
# web page,
# stops it with SIGTERM (exit status 0), starts a new container on the same volume and finds
# the job and its image there. Then docker/compose.yaml with podman-compose: Redis, an API
# node and one render node from the same image; a job submitted to the API node is rendered
# by the render node; then, in the middle of a longer job, two more render nodes join
# (podman-compose run of the worker service) and leave again (SIGTERM), and the job ends with
# the image the single container gave, bit for bit (idiff).
#
# Skips (77) where podman is not installed, unless TESSERA_REQUIRE_CONTAINER=1 (CI). The
# image's size bound is TESSERA_IMAGE_MAX_MB (650: the image measured 535 MB before it carried
# ffmpeg for shots' previews, 597 MB with it). TESSERA_CONTAINER_IMAGE names an image
# built before, to test it without building.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
if ! command -v podman > /dev/null || ! command -v debootstrap > /dev/null || ! command -v runc > /dev/null \
   || ! command -v podman-compose > /dev/null; then
  if [ "${TESSERA_REQUIRE_CONTAINER:-0}" = 1 ]; then echo "FAIL: podman, runc or debootstrap missing (bash scripts/setup.sh)"; exit 1; fi
  echo "SKIP: podman, runc or debootstrap missing: bash scripts/setup.sh"; exit 77
fi
source "$here/podman_env.sh"

tag="localhost/tessera-test:$$"
name="tessera-test-$$"
volume="tessera-test-data-$$"
token=$(od -An -N24 -tx1 /dev/urandom | tr -d ' \n')
project="tessera-ct-$$"
redis_tag="localhost/tessera-redis-test:$$"
compose() { podman-compose -p "$project" -f "$root/docker/compose.yaml" "$@"; }
cleanup() {
  podman rm -f -t 0 "${project}_worker_extra2" "${project}_worker_extra3" > /dev/null 2>&1 || true
  compose down -v > /dev/null 2>&1 || true
  podman rmi -f "$redis_tag" > /dev/null 2>&1 || true
  podman rm -f -t 0 "$name" > /dev/null 2>&1 || true
  podman volume rm -f "$volume" > /dev/null 2>&1 || true
  podman rmi -f "$tag" > /dev/null 2>&1 || true
  podman image prune -f > /dev/null 2>&1 || true  # the replaced build stages; the layer cache stays
  rm -rf "$podman_conf_dir"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*"
  podman logs "$name" 2>&1 | tail -n 30 || true
  exit 1
}

ensure_debian_base || fail "cannot make the debian:12 base image"

echo "== build"
t0=$(date +%s)
if [ -n "${TESSERA_CONTAINER_IMAGE:-}" ]; then  # iterating on this script: an image built before
  podman tag "$TESSERA_CONTAINER_IMAGE" "$tag"
else podman build --isolation chroot --network host --format docker -f "$root/docker/Dockerfile" -t "$tag" "$root" > "$podman_conf_dir/build.log" 2>&1 \
  || { tail -n 40 "$podman_conf_dir/build.log"; fail "the image does not build"; }
fi
size=$(podman image inspect --format '{{.Size}}' "$tag")
size_mb=$((size / 1000000))
echo "built in $(( $(date +%s) - t0 )) s: $size_mb MB"
[ "$size_mb" -le "${TESSERA_IMAGE_MAX_MB:-650}" ] || fail "the image is $size_mb MB, over ${TESSERA_IMAGE_MAX_MB:-650} MB"

start_container() {
  # podman's complaints that it cannot reach systemd for health-check timers go to a file.
  podman_run -d --name "$name" -p 127.0.0.1::8080 -v "$volume:/data" -e "TESSERA_TOKENS=$token" "$tag" \
    > /dev/null 2> "$podman_conf_dir/run.err" || { cat "$podman_conf_dir/run.err"; fail "the container does not start"; }
  port=$(podman port "$name" 8080 | head -n 1 | sed 's/.*://')
  [ -n "$port" ] || fail "no published port"
  for _ in $(seq 1 100); do
    curl -fsS --noproxy '*' "http://127.0.0.1:$port/healthz" > /dev/null 2>&1 && return 0
    sleep 0.2
  done
  fail "no health answer on 127.0.0.1:$port"
}
api() { curl -sS --noproxy '*' -H "Authorization: Bearer $token" "$@"; }
field() { sed -n "s/.*\"$1\":\"\{0,1\}\([^,\"}]*\).*/\1/p" | head -n 1; }
# wait_job ID [POLLS]: waits (0.2 s a poll, 300 by default) until the job on $port ends; fails
# unless it succeeds.
wait_job() {
  local state=""
  for _ in $(seq 1 "${2:-300}"); do
    state=$(api "http://127.0.0.1:$port/v1/jobs/$1" | field state || true)
    [ "$state" = succeeded ] || [ "$state" = failed ] && break
    sleep 0.2
  done
  [ "$state" = succeeded ] || { compose logs 2>&1 | tail -n 30; fail "job $1 ended '$state'"; }
}
# render_job BODY: submits a job to the server on $port, waits for it, sets id; fails unless it
# succeeds.
render_job() {
  id=$(api -X POST "http://127.0.0.1:$port/v1/jobs" -H 'Content-Type: application/json' -d "$1" | field id || true)
  [ -n "$id" ] || fail "no job id for $1"
  wait_job "$id"
}

echo "== run"
start_container
podman healthcheck run "$name" > /dev/null || fail "the image's HEALTHCHECK does not pass"
user=$(podman exec "$name" id -u)
[ "$user" != 0 ] || fail "the server runs as root"
code=$(curl -s -o /dev/null -w '%{http_code}' --noproxy '*' "http://127.0.0.1:$port/v1/jobs" || true)
[ "$code" = 401 ] || fail "without a token /v1/jobs answered $code, not 401"
# The web page is compiled into the binary: served without a token, nothing beside it needed.
page=$(curl -s --noproxy '*' "http://127.0.0.1:$port/" || true)
case "$page" in *"<html"*) ;; *) fail "the image does not serve its web page at /" ;; esac
code=$(curl -s -o /dev/null -w '%{http_code}' --noproxy '*' "http://127.0.0.1:$port/ui/app.js" || true)
[ "$code" = 200 ] || fail "the page's script /ui/app.js answered $code"

render_job '{"scene": "cornell_box", "width": 64, "height": 48, "spp": 4, "max_depth": 2}'
api -o "$podman_conf_dir/image.png" "http://127.0.0.1:$port/v1/jobs/$id/image.png"
api -o "$podman_conf_dir/image.exr" "http://127.0.0.1:$port/v1/jobs/$id/image.exr"
[ "$(od -An -N4 -tx1 "$podman_conf_dir/image.png" | tr -d ' ')" = 89504e47 ] || fail "image.png is not a PNG"
[ "$(od -An -N4 -tx1 "$podman_conf_dir/image.exr" | tr -d ' ')" = 762f3101 ] || fail "image.exr is not an EXR"

# A shot: numbered frames and its preview video, encoded by the image's ffmpeg.
still_id=$id
render_job '{"scene": "cornell_shot", "width": 64, "height": 48, "spp": 2, "max_depth": 2, "frames": {"start": 1, "end": 6}}'
api -o "$podman_conf_dir/preview.mp4" "http://127.0.0.1:$port/v1/jobs/$id/preview.mp4"
[ "$(od -An -j4 -N4 -c "$podman_conf_dir/preview.mp4" | tr -d ' ')" = ftyp ] || fail "the shot's preview.mp4 is not an MP4: $(head -c 300 "$podman_conf_dir/preview.mp4")"
api -o "$podman_conf_dir/frame.exr" "http://127.0.0.1:$port/v1/jobs/$id/frames/6/image.exr"
[ "$(od -An -N4 -tx1 "$podman_conf_dir/frame.exr" | tr -d ' ')" = 762f3101 ] || fail "frame 6's image.exr is not an EXR"
# The job the compose farm will render while it scales: its image here, from one process.
scale_job='{"scene": "cornell_spheres", "width": 320, "height": 240, "spp": 512, "max_depth": 4, "tile_size": 16}'
t0=$(date +%s)
render_job "$scale_job"
echo "the scaling job in one container: $(( $(date +%s) - t0 )) s"
api -o "$podman_conf_dir/scale_one.exr" "http://127.0.0.1:$port/v1/jobs/$id/image.exr"
id=$still_id

echo "== SIGTERM, then a new container on the same volume"
podman stop -t 30 "$name" > /dev/null 2>&1
status=$(podman inspect --format '{{.State.ExitCode}}' "$name")
[ "$status" = 0 ] || fail "the server's exit status on SIGTERM is $status"
logs=$(podman logs "$name" 2>&1 || true)
if grep -qF -- "$token" <<< "$logs"; then fail "the token appears in the log"; fi
podman rm "$name" > /dev/null 2>&1
start_container
state=$(api "http://127.0.0.1:$port/v1/jobs/$id" | field state || true)
[ "$state" = succeeded ] || fail "after the restart job $id is '$state'"
api -o "$podman_conf_dir/again.png" "http://127.0.0.1:$port/v1/jobs/$id/image.png"
cmp -s "$podman_conf_dir/image.png" "$podman_conf_dir/again.png" || fail "the image is not the same after the restart"

echo "== the image refuses to serve openly without a token"
podman rm -f -t 5 "$name" > /dev/null 2>&1
if timeout 60 podman --runtime runc run --name "$name" "$tag" > "$podman_conf_dir/open.log" 2>&1; then fail "started on 0.0.0.0 without a token"; fi
grep -q "without tokens" "$podman_conf_dir/open.log" || fail "no reason given: $(cat "$podman_conf_dir/open.log")"
podman rm -f -t 0 "$name" > /dev/null 2>&1

echo "== compose: Redis, an API node and one render node"
podman build --isolation chroot --network host -f "$root/docker/redis.Dockerfile" -t "$redis_tag" "$root" > "$podman_conf_dir/redis.log" 2>&1 \
  || { tail -n 20 "$podman_conf_dir/redis.log"; fail "the Redis image does not build"; }
# A free loopback port for the API node: one nothing answers on.
for _ in $(seq 1 50); do
  port=$((20000 + RANDOM % 30000))
  (exec 3<> "/dev/tcp/127.0.0.1/$port") 2> /dev/null || break
done
scenes="$root/../shared/scenes/cs184"
[ -d "$scenes" ] || { scenes="$podman_conf_dir/no-scenes"; mkdir -p "$scenes"; }
export TESSERA_IMAGE="$tag" TESSERA_REDIS_IMAGE="$redis_tag" TESSERA_TOKENS="$token" TESSERA_HOST_PORT="$port" CS184_SCENES="$scenes" \
  TESSERA_WORKERS=1
compose up -d > "$podman_conf_dir/compose.log" 2>&1 || { tail -n 30 "$podman_conf_dir/compose.log"; fail "compose up failed"; }
healthy=0
for _ in $(seq 1 150); do
  curl -fsS --noproxy '*' "http://127.0.0.1:$port/healthz" > /dev/null 2>&1 && { healthy=1; break; }
  sleep 0.2
done
[ "$healthy" = 1 ] || { compose logs 2>&1 | tail -n 30; fail "the farm's API node does not answer"; }
render_job '{"scene": "cornell_box", "width": 64, "height": 48, "spp": 8, "max_depth": 2, "tile_size": 16}'
nodes=$( (api "http://127.0.0.1:$port/v1/jobs/$id/report.json" || true) | grep -o '"tiles":[0-9]*' | grep -vc '"tiles":0' || true)
[ "$nodes" -ge 1 ] || fail "the report names no render node with tiles"
api -o "$podman_conf_dir/farm.png" "http://127.0.0.1:$port/v1/jobs/$id/image.png"
[ "$(od -An -N4 -tx1 "$podman_conf_dir/farm.png" | tr -d ' ')" = 89504e47 ] || fail "the farm's image.png is not a PNG"
echo "compose: a job rendered by $nodes render node(s)"

echo "== compose: from 1 to 3 render nodes and back, in the middle of a job"
# podman-compose 1.0 (Debian 12) does not change a running project's replicas (`up --scale`
# recreates nothing), so the nodes join as `run` of the worker service: the same image, network,
# volume and command, as `docker compose up -d --scale worker=3` adds them.
live_nodes() { (api "http://127.0.0.1:$port/v1/nodes" || true) | grep -o '"live":true' | wc -l; }
working_nodes() { (api "http://127.0.0.1:$port/v1/nodes" || true) | grep -o '"tiles":[0-9]*' | grep -vc '"tiles":0' || true; }
id=$(api -X POST "http://127.0.0.1:$port/v1/jobs" -H 'Content-Type: application/json' -d "$scale_job" | field id || true)
[ -n "$id" ] || fail "the scaling job was not accepted"
for _ in $(seq 1 300); do
  done_tiles=$( (api "http://127.0.0.1:$port/v1/jobs/$id" || true) | sed -n 's/.*"tiles_done":\([0-9]*\).*/\1/p' | head -n 1)
  [ "${done_tiles:-0}" -gt 0 ] && break
  sleep 0.1
done
[ "${done_tiles:-0}" -gt 0 ] || fail "the scaling job never started on the one node"
extra=("${project}_worker_extra2" "${project}_worker_extra3")
for c in "${extra[@]}"; do
  compose run -d --no-deps --name "$c" worker >> "$podman_conf_dir/compose.log" 2>&1 || fail "podman-compose run of a worker failed"
done
for _ in $(seq 1 300); do
  [ "$(live_nodes)" -ge 3 ] && [ "$(working_nodes)" -ge 3 ] && break
  sleep 0.1
done
[ "$(live_nodes)" -ge 3 ] && [ "$(working_nodes)" -ge 3 ] || fail "the new nodes took no tiles: $(api "http://127.0.0.1:$port/v1/nodes")"
[ "$(api "http://127.0.0.1:$port/v1/jobs/$id" | field state)" = running ] || fail "the job ended before the scale-down: make it longer"
podman stop -t 30 "${extra[@]}" > /dev/null 2>&1
for c in "${extra[@]}"; do
  status=$(podman inspect --format '{{.State.ExitCode}}' "$c")
  [ "$status" = 0 ] || fail "a render node scaled down ended with status $status"
done
[ "$(api "http://127.0.0.1:$port/v1/jobs/$id" | field state)" = running ] || fail "the job ended before the scale-down was over: make it longer"
wait_job "$id" 900
shares=$( (api "http://127.0.0.1:$port/v1/jobs/$id/report.json" || true) | grep -o '"tiles":[0-9]*' | grep -vc '"tiles":0' || true)
[ "$shares" -ge 3 ] || fail "the report names $shares nodes with tiles, not the three"
api -o "$podman_conf_dir/scale_farm.exr" "http://127.0.0.1:$port/v1/jobs/$id/image.exr"
idiff -a -fail 0 -warn 0 "$podman_conf_dir/scale_one.exr" "$podman_conf_dir/scale_farm.exr" > "$podman_conf_dir/idiff.txt" 2>&1 \
  || { cat "$podman_conf_dir/idiff.txt"; fail "the scaled farm's image differs from one container's"; }
echo "compose: 1 → 3 → 1 render nodes mid-job ($shares nodes stored tiles), the same image bit for bit"
echo "container: ok ($size_mb MB)"
