#!/usr/bin/env bash
# Tessera against Blender Cycles on the same glTF scene, at equal error: for each Cycles sample
# count, Cycles' time and relative MSE, and the time Tessera takes to reach that error. A
# benchmark, not a test: it needs Debian's blender (3.4) and numpy (`sudo apt-get install blender
# python3-numpy`), which nothing else in the project does, and it is not run in CI.
#
#   bash scripts/bench_cycles.sh            # cornell_box.gltf, 320x240, depth 5, 2 threads
#   SCENE=... WIDTH=... HEIGHT=... DEPTH=... THREADS=... CYCLES_SPP="16 64 256 1024" \
#   REF_SPP=4096 REPS=3 OUT=dir bash scripts/bench_cycles.sh
#   REUSE_REFS=1 OUT=dir bash scripts/bench_cycles.sh   # keeps the references already in dir
#   CLASS=glossy|environment|lamps|diffuse bash scripts/bench_cycles.sh   # one scene class
#   CLASS=all OUT=dir bash scripts/bench_cycles.sh      # every class, each in dir/CLASS
#   DENOISE=1 bash scripts/bench_cycles.sh              # Tessera denoised (`--denoise true`), Cycles not
#
# Scene classes (CLASS): `diffuse` the Cornell box (the default, SCENE may name another);
# `glossy` the Cornell box with a rough gold sphere (metallic 1, roughness 0.3) and a glossy
# plastic one (roughness 0.15), `tessera generate cornell_glossy`; `environment`
# CesiumMilkTruck.gltf (GLTF_PBR, the shared Khronos samples) lit only by scenes/sky.exr, seen
# from Tessera's default camera (written into a copy of the file for Blender); `lamps` the
# Cornell box lit by 1,000 small ceiling lamps, `tessera generate lamp_room`. Where materials are
# not Lambertian, Cycles renders them as Blender's glTF importer makes them (Principled BSDF,
# caustics on: CYCLES_MATERIALS=gltf in scripts/cycles/cycles_render.py). VARIANTS="on off" also
# times Cycles with roulette off; the classes other than `diffuse` use its defaults only.
#
# DENOISE=1: Tessera's renders denoise (after every pass, as a job does) and its error is its
# denoised image's, against its undenoised reference; its time is the whole render_seconds, the
# denoising included. Cycles stays undenoised: Debian's Blender has no Open Image Denoise.
#
# Every timed render runs once in each of REPS rounds, both renderers in every round; the tables
# give each time's median with its minimum and maximum, and each ratio's median over the rounds
# with its minimum and maximum: this machine's speed drifts by 10-30% within minutes, and one
# render per count, or all of one renderer's renders before the other's, hid that.
#
# Each renderer's error is measured against its own converged render (REF_SPP samples), so a
# small difference between the two renderers' images does not count as noise; the two
# references' relative MSE against each other is printed too (how far they agree). Tessera's
# time is its render_seconds (sampling only, as the EXR's metadata records it); Cycles' runs from
# its render_pre to its render_post handler, in a render after a first one has synchronised the
# scene and built its BVH (persistent data), so both leave out loading, building and writing. Cycles runs twice: with its
# defaults (Russian roulette on) and with roulette off (min_light_bounces = max_bounces), as
# Tessera's default has none.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
T=${TESSERA:-$root/build/release/cli/tessera}
CLASS=${CLASS:-diffuse}
if [ "$CLASS" = all ]; then
  OUT=${OUT:-$(mktemp -d)}
  for c in diffuse glossy environment lamps; do
    echo "==== scene class $c"
    CLASS=$c OUT="$OUT/$c" bash "$0"
  done
  exit 0
fi
OUT=${OUT:-$(mktemp -d)}
mkdir -p "$OUT"
ENVIRONMENT=${ENVIRONMENT:-}
export CYCLES_MATERIALS=${CYCLES_MATERIALS:-gltf}
case "$CLASS" in
  diffuse)
    SCENE=${SCENE:-$root/scenes/cornell_box.gltf}
    CYCLES_MATERIALS=diffuse
    VARIANTS=${VARIANTS:-on off} ;;
  glossy)
    SCENE="$OUT/cornell_glossy.gltf"
    "$T" generate cornell_glossy "$SCENE" > /dev/null ;;
  lamps)
    SCENE="$OUT/lamp_room.gltf"
    CYCLES_MATERIALS=diffuse
    "$T" generate lamp_room "$SCENE" > /dev/null ;;
  environment)
    GLTF_PBR=${GLTF_PBR:-$root/../shared/scenes/gltf-pbr}
    ENVIRONMENT=$root/scenes/sky.exr
    SCENE="$OUT/truck.gltf"
    # The file has no camera: Tessera's default one (its report says where it stands) is written
    # into a copy, so that both renderers see the same view.
    line=$("$T" render -s 1 -m 0 -r 16 12 -f "$OUT/camera_probe.exr" "$GLTF_PBR/CesiumMilkTruck.gltf" 2>&1 | grep 'default camera framing')
    python3 - "$GLTF_PBR/CesiumMilkTruck.gltf" "$SCENE" "$line" <<'PY'
import json, math, re, sys
src, dst, line = sys.argv[1:4]
nums = [float(x) for x in re.findall(r"-?[0-9.]+(?:e[-+]?[0-9]+)?", line.split(":", 1)[1])]
p, t, fov = nums[0:3], nums[3:6], nums[6]
f = [t[i] - p[i] for i in range(3)]
n = math.sqrt(sum(x * x for x in f)); f = [x / n for x in f]
r = [-f[2], 0.0, f[0]]; n = math.hypot(r[0], r[2]); r = [x / n for x in r]   # right = f x up(0,1,0)
u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]]
m = [[r[0], u[0], -f[0]], [r[1], u[1], -f[1]], [r[2], u[2], -f[2]]]  # columns: the camera's x, y, z
w = math.sqrt(max(0.0, 1 + m[0][0] + m[1][1] + m[2][2])) / 2
q = [(m[2][1] - m[1][2]) / (4 * w), (m[0][2] - m[2][0]) / (4 * w), (m[1][0] - m[0][1]) / (4 * w), w]
g = json.load(open(src))
g.pop("animations", None)
g.setdefault("cameras", []).append({"type": "perspective", "perspective": {"yfov": math.radians(fov), "znear": 0.01}})
g["nodes"].append({"name": "tessera_default_camera", "camera": len(g["cameras"]) - 1, "translation": p, "rotation": q})
g["scenes"][g.get("scene", 0)]["nodes"].append(len(g["nodes"]) - 1)
json.dump(g, open(dst, "w"))
PY
    ;;
  *) echo "bench_cycles: CLASS is diffuse, glossy, environment, lamps or all" >&2; exit 2 ;;
esac
VARIANTS=${VARIANTS:-on}
tessera_args=()
if [ -n "$ENVIRONMENT" ]; then
  tessera_args=(-e "$ENVIRONMENT")
  export CYCLES_ENVIRONMENT=$ENVIRONMENT
fi
# The reference is never denoised; the timed renders are with DENOISE=1, and then the image
# measured is the one the CLI writes beside NAME.exr, NAME_denoised.exr (two samples at least).
ref_args=(${tessera_args[@]+"${tessera_args[@]}"})
DENOISE=${DENOISE:-0}
case "$DENOISE" in 0|1) ;; *) echo "bench_cycles: DENOISE is 0 or 1" >&2; exit 2 ;; esac
measured=""
if [ "$DENOISE" = 1 ]; then
  tessera_args+=(--denoise true)
  measured=_denoised
  LADDER=${LADDER:-2 4 8 16 32 64 128 256 512 1024}
fi
WIDTH=${WIDTH:-320}
HEIGHT=${HEIGHT:-240}
DEPTH=${DEPTH:-5}
THREADS=${THREADS:-2}
CYCLES_SPP=${CYCLES_SPP:-16 64 256 1024}
REF_SPP=${REF_SPP:-4096}
REPS=${REPS:-3}
LADDER=${LADDER:-1 2 4 8 16 32 64 128 256 512 1024}
if ! command -v blender > /dev/null || ! blender -b --factory-startup --python-exit-code 1 --python-expr "import numpy" > /dev/null 2>&1; then
  echo "bench_cycles: needs Debian's blender and numpy (sudo apt-get install blender python3-numpy); a benchmark-only dependency" >&2
  exit 1
fi
[ -x "$T" ] || { echo "bench_cycles: build Tessera first (bash scripts/build.sh release)" >&2; exit 1; }
here="$root/scripts/cycles"
# Blender's own output is long; its script's lines are kept, and a failing script fails the bench.
blender_run() {
  if ! blender -b --factory-startup --python-exit-code 1 --python "$@" > "$OUT/blender.out" 2>&1; then
    tail -n 20 "$OUT/blender.out" >&2
    echo "bench_cycles: blender failed (whole output in $OUT/blender.out)" >&2
    exit 1
  fi
  grep -E '^(cycles_render|REL_MSE_JSON)' "$OUT/blender.out" || true
}

# Each round takes the Cycles counts one at a time: Cycles with its defaults, Cycles with roulette
# off, and straight after them Tessera at the ladder counts around that count (half, the same,
# double), whose times the ratios for that count use. The two renderers' times behind one ratio
# are then seconds apart, not minutes: this 2-core machine's speed drifts by 10-30% within
# minutes, and a round of all Cycles counts and then all Tessera counts lasts about five. The
# whole ladder follows, for the table of Tessera alone (and, where a count's errors fall outside
# its neighbours, for the ratio).
for rep in $(seq "$REPS"); do
  r="$OUT/round$rep"
  mkdir -p "$r"
  for n in $CYCLES_SPP; do
    echo "== round $rep of $REPS, $n spp: Cycles (roulette: $VARIANTS), then Tessera around $n"
    for v in $VARIANTS; do
      blender_run "$here/cycles_render.py" -- "$SCENE" "$r/cycles_${v}_$n" "$WIDTH" "$HEIGHT" "$DEPTH" "$THREADS" "$v" "$n"
    done
    : > "$r/tessera_near_$n.txt"
    for s in $LADDER; do
      [ "$s" -ge $((n / 2)) ] && [ "$s" -le $((n * 2)) ] || continue
      "$T" render -s "$s" -m "$DEPTH" -r "$WIDTH" "$HEIGHT" -t "$THREADS" ${tessera_args[@]+"${tessera_args[@]}"} -f "$r/tessera_again.exr" "$SCENE" > /dev/null
      printf '%s %s\n' "$s" "$(iinfo -v "$r/tessera_again.exr" | sed -n 's/.*tessera:render_seconds: "\(.*\)"/\1/p')" >> "$r/tessera_near_$n.txt"
    done
  done
  echo "== round $rep of $REPS: Tessera, $LADDER spp"
  # Times (spp seconds per line); the images of round 1 (every round has the same seed).
  : > "$r/tessera_times.txt"
  for s in $LADDER; do
    f="$OUT/tessera_$s.exr"
    [ "$rep" = 1 ] || f="$r/tessera_again.exr"
    "$T" render -s "$s" -m "$DEPTH" -r "$WIDTH" "$HEIGHT" -t "$THREADS" ${tessera_args[@]+"${tessera_args[@]}"} -f "$f" "$SCENE" > /dev/null
    printf '%s %s\n' "$s" "$(iinfo -v "$f" | sed -n 's/.*tessera:render_seconds: "\(.*\)"/\1/p')" >> "$r/tessera_times.txt"
  done
done
# The references: REUSE_REFS=1 keeps those already in OUT (they take as long as all the rounds).
if [ "${REUSE_REFS:-0}" != 1 ] || [ ! -f "$OUT/cycles_ref/cycles_$REF_SPP.exr" ]; then
  echo "== Cycles' reference ($REF_SPP spp)"
  blender_run "$here/cycles_render.py" -- "$SCENE" "$OUT/cycles_ref" "$WIDTH" "$HEIGHT" "$DEPTH" "$THREADS" on "$REF_SPP"
fi
if [ "${REUSE_REFS:-0}" != 1 ] || [ ! -f "$OUT/tessera_ref.exr" ]; then
  echo "== Tessera's reference ($REF_SPP spp)"
  "$T" render -s "$REF_SPP" -m "$DEPTH" -r "$WIDTH" "$HEIGHT" -t "$THREADS" ${ref_args[@]+"${ref_args[@]}"} -f "$OUT/tessera_ref.exr" "$SCENE" > /dev/null
fi
ours=()
for s in $LADDER; do ours+=("$OUT/tessera_$s$measured.exr"); done

echo "== errors"
cyc=()
for s in $CYCLES_SPP; do for v in $VARIANTS; do cyc+=("$OUT/round1/cycles_${v}_$s/cycles_$s.exr"); done; done
blender_run "$here/rel_mse.py" -- "$OUT/cycles_ref/cycles_$REF_SPP.exr" "${cyc[@]}" "$OUT/tessera_ref.exr" > "$OUT/cycles_err.txt"
blender_run "$here/rel_mse.py" -- "$OUT/tessera_ref.exr" "${ours[@]}" > "$OUT/tessera_err.txt"

python3 - "$OUT" "$REF_SPP" "$WIDTH" "$HEIGHT" "$DEPTH" "$THREADS" "$SCENE${ENVIRONMENT:+ under $ENVIRONMENT}" "$REPS" "$VARIANTS" "$measured" $CYCLES_SPP <<'EOF'
import json, math, statistics, sys
out, ref_spp, w, h, depth, threads, scene, reps, variants, measured = sys.argv[1:11]
variants = variants.split()
cycles_spp = [int(s) for s in sys.argv[11:]]
rounds = range(1, int(reps) + 1)
load = lambda f: json.loads(open(f"{out}/{f}").read().split("REL_MSE_JSON ", 1)[1])
cerr, terr = load("cycles_err.txt"), load("tessera_err.txt")
read_times = lambda f: {int(s): float(t) for s, t in (l.split() for l in open(f"{out}/{f}"))}
ours = []      # per round: spp -> Tessera's render_seconds (the whole ladder)
near = []      # per round: Cycles spp -> {spp -> Tessera's seconds, rendered right after that count}
cycles = []    # per round: (variant, spp) -> Cycles' seconds
for r in rounds:
    ours.append(read_times(f"round{r}/tessera_times.txt"))
    near.append({n: read_times(f"round{r}/tessera_near_{n}.txt") for n in cycles_spp})
    cycles.append({(v, n): float(json.load(open(f"{out}/round{r}/cycles_{v}_{n}/cycles_times.json"))["seconds"][str(n)])
                   for v in variants for n in cycles_spp})
errors = {s: terr["images"][f"{out}/tessera_{s}{measured}.exr"]["rel_mse"] for s in ours[0]}

def time_to(err, times):
    """Tessera's time to reach `err` with one round's `times`: log-log between the counts either side."""
    prev = None
    for s in sorted(times):
        t, e = times[s], errors[s]
        if e <= err:
            if prev is None:
                return t, f"<= {s} spp"
            (t0, e0, s0) = prev
            f = math.log(err / e0) / math.log(e / e0)
            return math.exp(math.log(t0) + f * (math.log(t) - math.log(t0))), f"{s0}-{s} spp"
        prev = (t, e, s)
    return None, "not reached"

spread = lambda v, f="%.3f": f"{f % statistics.median(v)} ({f % min(v)}-{f % max(v)})"
version = json.load(open(f"{out}/round1/cycles_{variants[0]}_{cycles_spp[0]}/cycles_times.json"))["version"]
agree = cerr["images"][f"{out}/tessera_ref.exr"]
print(f"\nScene {scene}, {w}x{h}, Tessera {'denoised (time includes denoising), ' if measured else ''}max_depth {depth} (Cycles max_bounces {int(depth) - 1}), {threads} threads, "
      f"Blender {version}, {reps} rounds (both renderers in each); times and ratios are median (min-max) over the "
      f"rounds, each ratio from Cycles' render and Tessera's renders around that count right after it; references {ref_spp} spp each; the two references' relative MSE "
      f"against each other: {agree['rel_mse']:.2e} (means {agree['mean']:.5f} Tessera, {cerr['reference_mean']:.5f} Cycles)\n")
print("| Cycles | spp | Cycles time (s) | relMSE | Tessera time to that relMSE (s) | between | Tessera / Cycles time |")
print("|---|---:|---:|---:|---:|---|---:|")
for variant in variants:
    for s in cycles_spp:
        e = cerr["images"][f"{out}/round1/cycles_{variant}_{s}/cycles_{s}.exr"]["rel_mse"]
        c = [cycles[i][(variant, s)] for i in range(len(ours))]
        # The renders right after this count where they bracket its error, else the ladder's.
        paired = time_to(e, near[0][s])[1] == time_to(e, ours[0])[1]
        src = [near[i][s] if paired else ours[i] for i in range(len(ours))]
        t = [time_to(e, x)[0] for x in src]
        where = time_to(e, ours[0])[1] + ("" if paired else " (ladder)")
        label = "defaults" if variant == "on" else "roulette off"
        if any(x is None for x in t):
            print(f"| {label} | {s} | {spread(c)} | {e:.3e} | - | {where} | - |")
            continue
        ratios = [a / b for a, b in zip(t, c)]
        print(f"| {label} | {s} | {spread(c)} | {e:.3e} | {spread(t)} | {where} | {spread(ratios, '%.2f')} |")
print("\nTessera alone (relMSE against its own reference):\n\n| spp | time (s) | relMSE | relMSE x spp |\n|---:|---:|---:|---:|")
for s in sorted(errors):
    print(f"| {s} | {spread([o[s] for o in ours])} | {errors[s]:.3e} | {errors[s] * s:.3f} |")
EOF
echo "(images and raw figures in $OUT)"
