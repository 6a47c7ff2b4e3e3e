#!/usr/bin/env bash
# checkpoint_kill9.sh TESSERA: a running job's film is checkpointed every --checkpoint-s; the
# server is SIGKILLed mid-render and started again, and the job continues from its checkpoint:
# it ends with the image of the same job rendered without interruption, bit for bit (idiff
# -fail 0), its report says how many samples it recovered, and the render time lost is no more
# than the interval (plus a tile and the write). Then a job killed twice, and a damaged
# checkpoint, which is refused and rendered afresh to the same image.
set -u
bin="$1"
data=$(mktemp -d)
log=$(mktemp)
work=$(mktemp -d)
cleanup() { [ -n "$pid" ] && kill -9 "$pid" 2>/dev/null; rm -rf "$data" "$log" "$work"; }
trap cleanup EXIT
. "$(dirname "$0")/server_lib.sh"
submit() { api -X POST -H 'Content-Type: application/json' -d "$1" "http://127.0.0.1:$port/v1/jobs" | field id; }
interval=1
job='{"scene":"builtin:cornell_spheres","width":160,"height":120,"spp":512,"max_depth":4,"seed":3,"tile_size":16,"denoise":true}'
ckpt() { echo "$data/jobs/$1/checkpoint.tck"; }
kill_server() { kill -9 "$pid"; wait "$pid" 2>/dev/null; pid=""; }
now() { date +%s.%N; }
calc() { awk "BEGIN { print $* }"; }
# The status's "recovered" object, as "samples render_s" (empty when there is none).
recovered_of() {
  api "http://127.0.0.1:$port/v1/jobs/$1" | sed -n 's/.*"recovered":{"render_s":\([0-9.e+-]*\),"samples":\([0-9]*\)}.*/\2 \1/p'
}

start --checkpoint-s "$interval"
# The uninterrupted image first.
whole=$(submit "$job")
wait_state "$whole" succeeded
api -o "$work/whole.exr" "http://127.0.0.1:$port/v1/jobs/$whole/image.exr"
api -o "$work/whole_denoised.exr" "http://127.0.0.1:$port/v1/jobs/$whole/denoised.exr"
[ -e "$(ckpt "$whole")" ] && fail "a finished job kept its checkpoint"

# Killed once, a few intervals into its render.
id=$(submit "$job")
wait_state "$id" running
t_run=$(now)
for _ in $(seq 1 100); do [ -e "$(ckpt "$id")" ] && break; sleep 0.05; done
[ -e "$(ckpt "$id")" ] || fail "no checkpoint after 5 s of rendering"
sleep 2.5
t_kill=$(now)
kill_server
echo "killed the server with SIGKILL $(calc "$t_kill - $t_run") s into job $id"
start --checkpoint-s "$interval"
wait_state "$id" succeeded
recovered=$(recovered_of "$id")
[ -n "$recovered" ] || fail "the status does not say what was recovered: $(api "http://127.0.0.1:$port/v1/jobs/$id" | head -c 800)"
api "http://127.0.0.1:$port/v1/jobs/$id/report.json" | grep -q '"recovered"' || fail "the report does not say what was recovered"
set -- $recovered
samples=$1 render_s=$2
[ "$samples" -gt 0 ] || fail "no samples recovered"
lost=$(calc "$t_kill - $t_run - $render_s")
echo "recovered $samples samples and $render_s s of rendering; lost $lost s (interval $interval s)"
# Loading and building the scene before the render count as lost here too: a generous bound.
[ "$(calc "($lost <= $interval + 1.5) ? 1 : 0")" = 1 ] || fail "lost $lost s of rendering, more than the $interval s interval"
api -o "$work/resumed.exr" "http://127.0.0.1:$port/v1/jobs/$id/image.exr"
api -o "$work/resumed_denoised.exr" "http://127.0.0.1:$port/v1/jobs/$id/denoised.exr"
idiff -a -fail 0 -warn 0 "$work/whole.exr" "$work/resumed.exr" > "$work/idiff.txt" 2>&1 ||
  { cat "$work/idiff.txt"; fail "the resumed job's image differs from the uninterrupted one's"; }
idiff -a -fail 0 -warn 0 "$work/whole_denoised.exr" "$work/resumed_denoised.exr" > "$work/idiff.txt" 2>&1 ||
  { cat "$work/idiff.txt"; fail "the resumed job's denoised image differs"; }
[ -e "$(ckpt "$id")" ] && fail "the checkpoint outlived the job"

# Killed twice; then its checkpoint damaged before the third start: refused, rendered afresh.
for round in twice damaged; do
  id=$(submit "$job")
  for k in 1 2; do
    wait_state "$id" running
    for _ in $(seq 1 100); do [ -e "$(ckpt "$id")" ] && break; sleep 0.05; done
    sleep 1.2
    kill_server
    [ "$round" = damaged ] && [ "$k" = 2 ] && printf 'XXXX' | dd of="$(ckpt "$id")" bs=1 seek=100 conv=notrunc 2>/dev/null
    start --checkpoint-s "$interval"
  done
  wait_state "$id" succeeded
  api -o "$work/$round.exr" "http://127.0.0.1:$port/v1/jobs/$id/image.exr"
  idiff -a -fail 0 -warn 0 "$work/whole.exr" "$work/$round.exr" > "$work/idiff.txt" 2>&1 ||
    { cat "$work/idiff.txt"; fail "job killed $round: its image differs from the uninterrupted one's"; }
  if [ "$round" = damaged ]; then
    [ -z "$(recovered_of "$id")" ] || fail "a damaged checkpoint was resumed"
  else
    [ -n "$(recovered_of "$id")" ] || fail "a job killed twice recovered nothing"
  fi
  echo "ok: killed $round, the same image"
done
echo "ok: a job killed mid-render continues from its checkpoint to the same image"
