#!/usr/bin/env bash
# store_faults.sh TESSERA: the real server against real faults, on a tiny filesystem of its own
# (tmpfs, in a private mount namespace, so nothing outside the test sees it):
#   - results that cannot be written (the jobs folder replaced by a file): the job fails with
#     that reason, the next one runs;
#   - a full disk: new jobs and uploads get 507, the server keeps serving, and everything works
#     again once space is freed;
#   - a scene file that breaks between submission and run: the job fails with the loader's
#     reason, the next job runs;
#   - the database file deleted under the running server: jobs accepted afterwards survive a
#     kill -9 and restart;
#   - a read-only data directory: the server refuses to start with a clear message.
# Exits 77 (skipped) where no mount namespace can be made, unless TESSERA_REQUIRE_MOUNT=1 (CI).
set -u
bin="$1"
if [ -z "${TESSERA_FAULTS_IN_NS:-}" ]; then
  export TESSERA_FAULTS_IN_NS=1
  ns=(unshare -m --propagation private)
  [ "$(id -u)" = 0 ] || ns=(unshare -rm)
  if ! "${ns[@]}" true 2>/dev/null; then
    echo "cannot make a mount namespace here (${ns[*]})"
    [ "${TESSERA_REQUIRE_MOUNT:-0}" = 1 ] && exit 1
    exit 77
  fi
  exec "${ns[@]}" "$0" "$@"
fi

root=$(mktemp -d)
data="$root/data"
scenes="$root/scenes"
mkdir -p "$data" "$scenes"
if ! mount -t tmpfs -o size=3m tmpfs "$data" 2>/dev/null; then
  echo "cannot mount a tmpfs here (no mount namespace)"
  rm -rf "$root"
  [ "${TESSERA_REQUIRE_MOUNT:-0}" = 1 ] && exit 1
  exit 77
fi
log="$root/server.log"
cleanup() {
  [ -n "$pid" ] && kill -9 "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
  umount "$data" 2>/dev/null
  rm -rf "$root"
}
trap cleanup EXIT
. "$(dirname "$0")/server_lib.sh"
post() {  # body: prints the HTTP status, leaves the answer in $root/answer
  api -o "$root/answer" -w '%{http_code}' -X POST -H 'Content-Type: application/json' -d "$1" "http://127.0.0.1:$port/v1/jobs"
}
healthy() { [ "$(api -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port/healthz")" = 200 ] || fail "healthz failed: $1"; }

small='{"scene":"builtin:cornell_box","width":32,"height":24,"spp":2}'
long='{"scene":"builtin:cornell_spheres","width":320,"height":240,"spp":4096,"max_depth":5}'

cp "$(dirname "$0")/../../scenes/cornell_box.gltf" "$scenes/vanishing.gltf"
start --scenes "$scenes"
[ "$(post "$small")" = 202 ] || fail "first job refused: $(cat "$root/answer")"
first=$(field id < "$root/answer")
wait_state "$first" succeeded

# 1. A scene file that breaks after the job was accepted.
[ "$(post "$long")" = 202 ] || fail "long job refused"
blocker=$(field id < "$root/answer")
wait_state "$blocker" running
[ "$(post '{"scene":"vanishing","width":32,"height":24}')" = 202 ] || fail "job on vanishing refused: $(cat "$root/answer")"
broken=$(field id < "$root/answer")
printf 'not a glTF file' > "$scenes/vanishing.gltf"
api -X DELETE "http://127.0.0.1:$port/v1/jobs/$blocker" > /dev/null
wait_state "$broken" failed
api "http://127.0.0.1:$port/v1/jobs/$broken" | grep -q '"error":"scene: .*vanishing.gltf' ||
  fail "the failed job does not name the scene file: $(api "http://127.0.0.1:$port/v1/jobs/$broken")"
echo "ok: a scene broken after submission fails its job with the loader's reason"

# 2. Results that cannot be written: the jobs folder is a file.
rm -rf "$data/jobs"
: > "$data/jobs"
[ "$(post "$small")" = 202 ] || fail "job refused: $(cat "$root/answer")"
unwritable=$(field id < "$root/answer")
wait_state "$unwritable" failed
api "http://127.0.0.1:$port/v1/jobs/$unwritable" | grep -q '"error":"[^"]*jobs/'"$unwritable" ||
  fail "the failed job does not name its results folder: $(api "http://127.0.0.1:$port/v1/jobs/$unwritable")"
rm -f "$data/jobs"
[ "$(post "$small")" = 202 ] || fail "job refused: $(cat "$root/answer")"
wait_state "$(field id < "$root/answer")" succeeded
echo "ok: results that cannot be written fail the job, naming where; the next job runs"

# 3. A full disk.
dd if=/dev/zero of="$data/filler" bs=16k 2>/dev/null
code=$(post "$small")
[ "$code" = 507 ] || fail "a full disk answered $code: $(cat "$root/answer")"
grep -q '"type":"/problems/insufficient-storage"' "$root/answer" || fail "507 without its problem type: $(cat "$root/answer")"
healthy "with the disk full"
[ "$(api -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port/v1/jobs/$first")" = 200 ] || fail "status of an old job"
[ "$(api -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port/v1/jobs?limit=3")" = 200 ] || fail "list with the disk full"
up=$(api -o "$root/answer" -w '%{http_code}' -X POST --data-binary @"$(dirname "$0")/../../scenes/cornell_box.gltf" \
  "http://127.0.0.1:$port/v1/scenes?name=box.gltf")
[ "$up" = 507 ] || fail "an upload on a full disk answered $up: $(cat "$root/answer")"
[ -z "$(ls -A "$data/uploads" 2>/dev/null)" ] || fail "a refused upload left files behind: $(ls -R "$data/uploads")"
kill -0 "$pid" 2>/dev/null || fail "the server died on a full disk"
echo "ok: a full disk refuses new jobs and uploads with 507 and keeps serving"
rm -f "$data/filler"
[ "$(post "$small")" = 202 ] || fail "no recovery after space returned: $(cat "$root/answer")"
wait_state "$(field id < "$root/answer")" succeeded
echo "ok: space freed, jobs accepted and rendered again without a restart"

# 3b. The disk filled by the jobs' own results while they run (the failure that used to abort
# the process): submissions end in 507, the server stays up, and once results are removed
# every accepted job reaches a final state by itself.
accepted=()
code=202
for _ in $(seq 1 600); do
  code=$(post '{"scene":"builtin:cornell_box","width":64,"height":48,"spp":1}')
  [ "$code" = 202 ] || break
  accepted+=("$(field id < "$root/answer")")
done
[ "$code" = 507 ] || fail "600 jobs did not fill a 3 MB disk (last answer $code)"
healthy "with results filling the disk"
kill -0 "$pid" 2>/dev/null || fail "the server died while results filled the disk"
rm -rf "$data/jobs/"*
for id in "${accepted[@]}"; do wait_state "$id" succeeded failed; done
failed=0
for id in "${accepted[@]}"; do
  st=$(api "http://127.0.0.1:$port/v1/jobs/$id")
  if printf '%s' "$st" | grep -q '"state":"failed"'; then
    failed=$((failed + 1))
    printf '%s' "$st" | grep -q '"error":"[^"]*\(write\|space\)' || fail "job $id failed without saying why: $st"
  fi
done
[ "$(post "$small")" = 202 ] || fail "no recovery after results were removed: $(cat "$root/answer")"
wait_state "$(field id < "$root/answer")" succeeded
echo "ok: ${#accepted[@]} jobs filled the disk with results; then 507, no crash; after clean-up all reached a final state ($failed failed for want of space, with that reason)"

# 4. The database file deleted under the running server.
rm -f "$data/tessera.db" "$data/tessera.db-wal" "$data/tessera.db-shm"
[ "$(post "$small")" = 202 ] || fail "job refused after the database was deleted: $(cat "$root/answer")"
survivor=$(field id < "$root/answer")
wait_state "$survivor" succeeded
kill -9 "$pid"; wait "$pid" 2>/dev/null; pid=""
start --scenes "$scenes"
[ "$(state_of "$survivor")" = succeeded ] || fail "the job accepted after the database was deleted was lost at restart"
[ "$(state_of "$first")" = succeeded ] || fail "the job accepted before the database was deleted was lost at restart"
echo "ok: a deleted database is written anew; jobs before and after survive kill -9"
kill -TERM "$pid"; wait "$pid"; st=$?; pid=""
[ $st -eq 0 ] || fail "SIGTERM exit status $st"
grep -q "terminate called" "$log" && fail "an exception escaped"

# 5. A read-only data directory at start.
mount -o remount,ro "$data" || fail "cannot remount read-only"
out=$("$bin" serve --host 127.0.0.1 --port 0 --data-dir "$data" 2>&1)
st=$?
[ $st -eq 1 ] || fail "a read-only data directory: exit $st: $out"
printf '%s\n' "$out" | grep -q "tessera serve: data directory $data is not writable: Read-only file system" || fail "no clear reason: $out"
echo "ok: a read-only data directory stops the start with: $(printf '%s\n' "$out" | tail -n 1)"
mount -o remount,rw "$data"
echo "all store faults handled"
