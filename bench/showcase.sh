#!/usr/bin/env bash
# showcase.sh — issue 32 item 8: on the showcase scene (data/showcase.gltf: textures, a glossy
# metal sphere, a rough-glass sphere, an alpha-masked fence, a spot light, depth of field) and on
# its glossy-caustics variant (data/showcase-caustics.gltf: the ceiling light dimmed, the spot light
# 3× stronger, so that light reflected and refracted by the two glossy spheres carries much of the
# image; pinhole camera), SPPM with render's defaults against photonflow's path tracer at equal
# time, against a long path-traced reference.
#
#   bench/showcase.sh [BUILD]      (BUILD default build; results in $OUT/showcase.md)
#
# Per scene of SCENES, in $OUT/<scene>/:
#   scene.h5      scene-bake data/<scene>.gltf at W×H, with the scene's own bake options
#                 (data/<scene>.bake-options, as `make render` uses them: pipelines/scene.mk)
#   mask.exr      emitter-mask: 1 where a pixel sees no emitter (directly or through mirrors and
#                 glass), for the masked metric (imgcompare --mask)
#   ref1.exr, ref2.exr   the reference: two path-traced parts of REF_TIME seconds each, seeds
#                 REF_SEED and REF_SEED + 1 (pathtrace --time; unbiased: every surface of the scene
#                 is non-delta or a light's, so next-event estimation reaches every path). The
#                 reference is their mean. Its own error: e = RMSE(ref1 − ref2) / √2 is one part's
#                 (each part's noise), e / √2 the mean's (what the figures below are compared with;
#                 imgcompare's "reference RMSE" estimates the same from the parts' spread).
#   pt.exr        pathtrace --time TIME, seed SEED (its defaults otherwise)
#   <m>.exr       render --time TIME, seed SEED, for each method m of METHODS:
#                   defaults   render's defaults (render_defaults.h: estimator, shadow rays,
#                              photons per pass, radius and glossy merge rule automatic)
#                   sppm, pppm --estimator sppm / pppm (the rest automatic)
#                   <name>     render $FLAGS_<name> (a shell identifier; e.g.
#                              FLAGS_first="--glossy-merge first")
# and prints, all pixels and masked: each method's RMSE against the mean reference, the same net
# of the reference's noise (imgcompare "RMSE net"), method / pt, and the reference's own error.
# The timed runs go one after another, each with the load average before and after it
# (<scene>/load.txt): run on a machine with no other job.
#
# Environment (defaults): SCENES="showcase showcase-caustics" METHODS=defaults W=512 H=512 TIME=30 REF_TIME=600
# SEED=1 REF_SEED=1001 MASK_SPP=256 THREADS=0 (all cores; the timed runs and the references)
# OUT=out/showcase-bench. KEEP=1 keeps finished images whose settings are unchanged: e.g.
# `KEEP=1 REF_TIME=2400 bench/showcase.sh` after a run re-renders the references alone (the mask,
# references and timed runs each remember their own settings). Without KEEP everything is rendered
# again (the right thing after a change to the renderer).
set -euo pipefail
BUILD=${1:-build}
B=$BUILD/bin
SCENES=${SCENES:-showcase showcase-caustics}
METHODS=${METHODS:-defaults}
# flags_of M: render's options of method M (above); exits 2 for an unknown one.
flags_of() {
  case $1 in
    defaults) echo "" ;;
    sppm|pppm) echo "--estimator $1" ;;
    *) local v=FLAGS_$1
       [[ $1 =~ ^[A-Za-z_][A-Za-z0-9_]*$ && -n ${!v:-} ]] || {
         echo "showcase.sh: unknown method $1 (defaults, sppm, pppm, or set FLAGS_$1)" >&2; exit 2; }
       echo "${!v}" ;;
  esac
}
for m in $METHODS; do flags_of "$m" > /dev/null; done
W=${W:-512}
H=${H:-512}
TIME=${TIME:-30}
REF_TIME=${REF_TIME:-600}
SEED=${SEED:-1}
REF_SEED=${REF_SEED:-1001}
MASK_SPP=${MASK_SPP:-256}
THREADS=${THREADS:-0}
OUT=${OUT:-out/showcase-bench}
KEEP=${KEEP:-0}
PY=${PY:-/usr/bin/python3}
for t in scene-bake emitter-mask pathtrace render imgcompare; do
  [ -x "$B/$t" ] || { echo "showcase.sh: $B/$t not built (cmake --build $BUILD --target tools)" >&2; exit 2; }
done
mkdir -p "$OUT"
SETTINGS="W=$W H=$H TIME=$TIME REF_TIME=$REF_TIME SEED=$SEED REF_SEED=$REF_SEED MASK_SPP=$MASK_SPP THREADS=$THREADS"

# need FILE SETTINGS: true when FILE must be (re)made: no KEEP=1, no FILE, or FILE made with other
# settings (FILE.settings); records SETTINGS for it.
need() {
  local f=$1 set=$2 old=""
  [ -f "$f.settings" ] && old=$(cat "$f.settings")
  echo "$set" > "$f.settings"
  [ "$KEEP" != 1 ] || [ ! -s "$f" ] || [ "$old" != "$set" ]
}
load() { echo "$1 $(cat /proc/loadavg)" >> "$D/load.txt"; }

for s in $SCENES; do
  D=$OUT/$s
  mkdir -p "$D"
  opts=""
  [ -f "data/$s.bake-options" ] && opts=$(sed -e 's/#.*//' "data/$s.bake-options")
  # shellcheck disable=SC2086  # the options are words
  $B/scene-bake "data/$s.gltf" -o "$D/scene.h5" --width "$W" --height "$H" $opts > "$D/bake.txt" 2>&1 \
    || { cat "$D/bake.txt" >&2; exit 1; }
  if need "$D/mask.exr" "$W $H $MASK_SPP $opts"; then
    $B/emitter-mask --scene "$D/scene.h5" -o "$D/mask.exr" --spp "$MASK_SPP" --threads "$THREADS" > /dev/null
  fi
  for part in 1 2; do
    if need "$D/ref$part.exr" "$W $H $REF_TIME $REF_SEED $THREADS $opts"; then
      load "ref$part-before"
      $B/pathtrace --scene "$D/scene.h5" -o "$D/ref$part.exr" --png none --spp 100000000 \
        --time "$REF_TIME" --seed $((REF_SEED + part - 1)) --stats "$D/ref$part.json" \
        --threads "$THREADS" | tail -1
      load "ref$part-after"
    fi
  done
  if need "$D/pt.exr" "$W $H $TIME $SEED $THREADS $opts"; then
    load pt-before
    $B/pathtrace --scene "$D/scene.h5" -o "$D/pt.exr" --png none --spp 100000000 --time "$TIME" \
      --seed "$SEED" --stats "$D/pt.json" --threads "$THREADS" | tail -1
    load pt-after
  fi
  for m in $METHODS; do
    flags=$(flags_of "$m")
    if need "$D/$m.exr" "$W $H $TIME $SEED $THREADS $opts $flags"; then
      load "$m-before"
      # shellcheck disable=SC2086  # the flags are words
      $B/render --scene "$D/scene.h5" -o "$D/$m.exr" --time "$TIME" --passes 1000000 \
        --seed "$SEED" --stats "$D/$m.json" --threads "$THREADS" $flags | tail -1
      load "$m-after"
    fi
  done
  # Metrics: every run against the two-part reference, all pixels and masked; the parts against
  # each other (the reference's own error).
  for m in pt $METHODS; do
    $B/imgcompare "$D/$m.exr" "$D/ref1.exr" "$D/ref2.exr" --json "$D/$m-all.cmp.json" > /dev/null
    $B/imgcompare "$D/$m.exr" "$D/ref1.exr" "$D/ref2.exr" --mask "$D/mask.exr" \
      --json "$D/$m-masked.cmp.json" > /dev/null
  done
  $B/imgcompare "$D/ref1.exr" "$D/ref2.exr" --json "$D/refs-all.cmp.json" > /dev/null
  $B/imgcompare "$D/ref1.exr" "$D/ref2.exr" --mask "$D/mask.exr" --json "$D/refs-masked.cmp.json" > /dev/null
done

"$PY" - "$OUT" "$SETTINGS" "$METHODS" $SCENES <<'PY' | tee "$OUT/showcase.md"
import json, math, sys
out, settings, methods, scenes = sys.argv[1], sys.argv[2], sys.argv[3].split(), sys.argv[4:]
def js(path):
    with open(path) as f:
        return json.load(f)
print("# bench/showcase.sh: photon mapping (render) against the path tracer at equal time\n")
print("Settings: " + settings + "; methods: " + " ".join(methods) + "\n")
print("| scene | pixels | method | RMSE (net) | pt RMSE (net) | method / pt (net) | ref. part e | ref. mean e = e/√2 | ref. mean / method |")
print("|---|---|---|---:|---:|---:|---:|---:|---:|")
for s in scenes:
    d = f"{out}/{s}"
    for which in ("all", "masked"):
        pt = js(f"{d}/pt-{which}.cmp.json")
        e_part = js(f"{d}/refs-{which}.cmp.json")["rmse"] / math.sqrt(2)
        e_mean = e_part / math.sqrt(2)
        for m in methods:
            sp = js(f"{d}/{m}-{which}.cmp.json")
            ratio = sp["rmse"] / pt["rmse"] if pt["rmse"] > 0 else float("nan")
            net = sp["rmse_net"] / pt["rmse_net"] if pt["rmse_net"] > 0 else float("nan")
            print(f"| {s} | {which} ({sp['pixels'] - sp['masked_out']}) | {m} | {sp['rmse']:.5f} ({sp['rmse_net']:.5f}) "
                  f"| {pt['rmse']:.5f} ({pt['rmse_net']:.5f}) | **{ratio:.2f}** ({net:.2f}) | {e_part:.5f} "
                  f"| {e_mean:.5f} | {e_mean / sp['rmse']:.2f} |")
print("\nRuns (from the run records):\n")
print("| scene | run | seconds | samples per pixel / passes |")
print("|---|---|---:|---:|")
for s in scenes:
    d = f"{out}/{s}"
    for run in ["pt"] + methods + ["ref1", "ref2"]:
        last = js(f"{d}/{run}.json")["images"][-1]  # rendering seconds (start and writes excluded)
        work = f"{last['passes']} passes" if "passes" in last else f"{last['samples']} spp"
        print(f"| {s} | {run} | {last['seconds']:.1f} | {work} |")
PY
echo "showcase.sh: table in $OUT/showcase.md; load averages in $OUT/<scene>/load.txt"
