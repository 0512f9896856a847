#!/usr/bin/env bash
# equal_time.sh — issue 34 item 2: photonflow with its defaults against Mitsuba 3's path tracer at
# equal wall time, RMSE against long independent references (Mitsuba, unlimited path length) with
# the references' own error printed beside. Benchmark-only (Mitsuba never enters photonflow's
# build or tests). docs/RESULTS.md section 8 describes the method and holds the figures.
#
#   bench/mitsuba/equal_time.sh [SCENE ...]            (default: cornell-box cornell-spheres box-200k)
#
# SCENE is any scene make_refs.sh knows: cornell-box, cornell-spheres, box-200k, glossy-room,
# showcase (its thin lens from data/showcase.bake-options is in the baked scene.h5 every method
# renders), showcase-caustics, window-room, hdri-object (their environment map likewise).
# Per scene, REFS/<scene>/ must hold scene.h5 (the baked scene the reference was rendered from)
# and ref/ref-s0.exr, ref/ref-s1.exr (two references from disjoint seeds: bench/mitsuba/make_refs.sh
# makes all of it). Per run r = 1..RUNS, round robin (run 1 of every method, then run 2, ...), so
# that a change of the machine's load falls on all methods alike:
#
#   defaults  render --time T                          (DEFAULTS ONLY: sppm, shadow rays, auto photons and radius)
#   pppm      render --time T --estimator pppm
#   pppm-issue render --time T --estimator pppm --direct photons --photons 100000 --emission-spp 0
#             --gather-area disc --radius R (the baseline the mirror-and-glass box's target is stated
#             against: "today's --estimator pppm" when issue 34 was filed, i.e. render's defaults
#             then, 18c2973^, beside pppm; R the radius rule of then, max(diagonal / 200, 4 pixel
#             footprints), computed from scene.h5 by issue_radius below)
#   <name>    with FLAGS_<name> set in the environment (a shell identifier): render --time T
#             $FLAGS_<name>, for trying settings under the same harness, e.g.
#             FLAGS_ss2="--shadow-samples 2" METHODS="defaults ss2"
#   pt        pathtrace --time T --spp 1000000         (photonflow's path tracer; --spp only lifts its 64-spp cap)
#   mi-<S>    mi_render.py --time T --sampler S        (Mitsuba llvm_ad_rgb, path, max_depth -1, passes of
#             MI_SPP spp with new seeds averaged by spp, the last ones sized to the time left; S:
#             independent is Mitsuba's default, multijitter converged fastest per spp here; kernel
#             compilation is kept out by warm-up renders into the same DRJIT_CACHE_DIR before the
#             timed runs, as accuracy.mk keeps PoCL's out)
#   mi1-<S>   mi_render1.py --time T --sampler S    (Mitsuba as mi-<S>, but ONE mi.render call of N spp,
#             N calibrated by short calls before it so that the call takes about T seconds; its
#             actual seconds are the run's. Mitsuba's best at equal time: passes of MI_SPP spp with
#             new seeds lose most of a stratified sampler's stratification and pay a call overhead
#             each, which understates Mitsuba by about a third, ../shared/toolchain.md. The
#             calibration calls are not counted, as the kernel compilation is not)
#
# every one with --threads THREADS (the machine's size, not a rendering choice) and seed r. Each run
# records the 1-minute load average before and after it. The error of each image:
#   imgcompare IMG ref-s0.exr ref-s1.exr [--mask mask.exr] --json    (all pixels; away from the lights)
# against the mean of the two references (its own error, "reference_rmse", printed beside, and the
# RMSE net of it, sqrt(MSE - reference MSE): the references are independent of the runs, so the
# net figure estimates the error against the exact image without the references' noise);
# mask.exr = emitter-mask --spp MASK_SPP (the pixels that see an emitter directly or through mirrors
# and glass, dilated by one pixel, left out). The summary (OUT/summary.md) gives per method the
# median RMSE over the runs, the median rendering seconds, and the ratios to Mitsuba.
#
# Environment: BUILD (build), REFS (/work/refs/mitsuba-acc), OUT (out/mitsuba-equal-time),
# TIME (30), THREADS (2), RUNS (3), METHODS (defaults pppm pt mi-independent mi-multijitter),
# MI_SPP (16), MASK_SPP (64: the masks of RESULTS section 8 were made when emitter-mask kept every
# eye sample's hitpoint, 2.6 GB at 512x512 x 64; it now holds one sample per pixel at a time; with
# the default dilation of one pixel more samples change little), PY (.venv-mitsuba/bin/python), DRJIT_LIBLLVM_PATH (default
# .llvm19/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1), DRY=1: 3 s, 1 run (proves the script, no figures).
set -euo pipefail
BUILD=${BUILD:-build}
BIN=$BUILD/bin
REFS=${REFS:-/work/refs/mitsuba-acc}
OUT=${OUT:-out/mitsuba-equal-time}
TIME=${TIME:-30}
THREADS=${THREADS:-2}
RUNS=${RUNS:-3}
METHODS=${METHODS:-defaults pppm pt mi-independent mi-multijitter}
MI_SPP=${MI_SPP:-16}
MASK_SPP=${MASK_SPP:-64}
PY=${PY:-.venv-mitsuba/bin/python}
HERE=$(cd "$(dirname "$0")" && pwd)
# The issue-time automatic radius of a scene: max(diag / 200, 4 pixel footprints at the look-at
# distance), the rule before the surface gather area scaled it (eye_pass.h default_radius).
issue_radius() {
  "$PY" - "$1" <<'PYEOF'
import math, sys
import h5py
import numpy as np
with h5py.File(sys.argv[1], "r") as f:
    cam = f["camera"][0]
    tris = f["geometry/triangles"][:]
    v = np.concatenate([tris["v0"], tris["v1"], tris["v2"]]).astype(np.float32)
    diag = float(np.linalg.norm(v.max(0) - v.min(0)))
    dist = float(np.linalg.norm(cam["look_at"].astype(np.float64) - cam["eye"]))
    pixel_angle = 2 * math.tan(math.radians(0.5 * float(cam["fov_y_deg"]))) / float(cam["height"])
    print("%.9g" % max(diag / 200, 4 * pixel_angle * dist))
PYEOF
}
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-$PWD/.llvm19/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
export DRJIT_CACHE_DIR=${DRJIT_CACHE_DIR:-$OUT/drjit-cache}
if [ "${DRY:-0}" = 1 ]; then TIME=3; RUNS=1; OUT=$OUT-dry; export DRJIT_CACHE_DIR=$OUT/drjit-cache; fi
SCENES=${*:-cornell-box cornell-spheres box-200k}

for t in render pathtrace imgcompare emitter-mask; do
  [ -x "$BIN/$t" ] || { echo "equal_time.sh: $BIN/$t missing; build the tools first (make build-tools)" >&2; exit 2; }
done
[ -x "$PY" ] || { echo "equal_time.sh: $PY missing; make the Mitsuba venv (bench/mitsuba/README.md)" >&2; exit 2; }
[ -f "$DRJIT_LIBLLVM_PATH" ] || { echo "equal_time.sh: libLLVM 19 not at $DRJIT_LIBLLVM_PATH (bench/mitsuba/README.md)" >&2; exit 2; }

load() { cut -d' ' -f1 /proc/loadavg; }
mkdir -p "$OUT"
TSV=$OUT/runs.tsv
[ -f "$TSV" ] || printf 'scene\tmethod\trun\tseconds\tpasses_or_spp\trmse_all\trmse_masked\tref_rmse_all\tref_rmse_masked\trmse_net_all\trmse_net_masked\tload_before\tload_after\tstarted_utc\n' > "$TSV"

for s in $SCENES; do
  D=$REFS/$s
  for f in scene.h5 ref/ref-s0.exr ref/ref-s1.exr mi/scene.xml; do
    [ -f "$D/$f" ] || { echo "equal_time.sh: $D/$f missing (bench/mitsuba/make_refs.sh $s)" >&2; exit 2; }
  done
  O=$OUT/$s
  mkdir -p "$O"
  [ -f "$O/mask.exr" ] || "$BIN/emitter-mask" --scene "$D/scene.h5" -o "$O/mask.exr" --spp "$MASK_SPP" --threads 0 > /dev/null
  # Warm Dr.Jit's kernel cache for every sampler (not timed): Dr.Jit builds one kernel for
  # power-of-two spp and one for the others (the last pass is sized to the time left).
  for m in $METHODS; do
    case $m in mi-*|mi1-*)
      s_=${m#mi-}; s_=${s_#mi1-}
      for k in 1 3; do
        "$PY" "$HERE/mi_render.py" "$D/mi/scene.xml" "$O/warmup.exr" --time 0 --spp-per-pass $k \
          --sampler "$s_" --threads "$THREADS" > /dev/null
      done ;;
    esac
  done
  for r in $(seq 1 "$RUNS"); do
    for m in $METHODS; do
      img=$O/$m-r$r.exr
      rec=$O/$m-r$r.json
      l0=$(load); t0=$(date -u +%FT%TZ)
      case $m in
        defaults) "$BIN/render" --scene "$D/scene.h5" -o "$img" --time "$TIME" --seed "$r" --threads "$THREADS" \
                    --stats "$rec" | tail -1 ;;
        pppm)     "$BIN/render" --scene "$D/scene.h5" -o "$img" --time "$TIME" --seed "$r" --threads "$THREADS" \
                    --estimator pppm --stats "$rec" | tail -1 ;;
        pppm-issue) "$BIN/render" --scene "$D/scene.h5" -o "$img" --time "$TIME" --seed "$r" --threads "$THREADS" \
                    --estimator pppm --direct photons --photons 100000 --emission-spp 0 --gather-area disc \
                    --radius "$(issue_radius "$D/scene.h5")" --stats "$rec" | tail -1 ;;
        pt)       "$BIN/pathtrace" --scene "$D/scene.h5" -o "$img" --time "$TIME" --spp 1000000 --seed "$r" \
                    --threads "$THREADS" --png none --stats "$rec" | tail -1 ;;
        mi-*)     "$PY" "$HERE/mi_render.py" "$D/mi/scene.xml" "$img" --time "$TIME" --spp-per-pass "$MI_SPP" \
                    --sampler "${m#mi-}" --seed-base $((100000000 + r * 100000)) --threads "$THREADS" | tail -1 ;;
        mi1-*)    "$PY" "$HERE/mi_render1.py" "$D/mi/scene.xml" "$img" --time "$TIME" --sampler "${m#mi1-}" \
                    --seed $((200000000 + r)) --threads "$THREADS" | tail -1 ;;
        *) v=FLAGS_$m
           [[ $m =~ ^[A-Za-z_][A-Za-z0-9_]*$ && -n ${!v:-} ]] || {
             echo "equal_time.sh: unknown method $m (built in: defaults pppm pppm-issue pt mi-<sampler> mi1-<sampler>; or set FLAGS_$m)" >&2; exit 2; }
           # shellcheck disable=SC2086 # FLAGS_<name> is a list of options
           "$BIN/render" --scene "$D/scene.h5" -o "$img" --time "$TIME" --seed "$r" --threads "$THREADS" \
             ${!v} --stats "$rec" | tail -1 ;;
      esac
      l1=$(load)
      "$BIN/imgcompare" "$img" "$D/ref/ref-s0.exr" "$D/ref/ref-s1.exr" --json "$O/$m-r$r.all.json" > /dev/null
      "$BIN/imgcompare" "$img" "$D/ref/ref-s0.exr" "$D/ref/ref-s1.exr" --mask "$O/mask.exr" \
        --json "$O/$m-r$r.masked.json" > /dev/null
      /usr/bin/python3 - "$s" "$m" "$r" "$rec" "$O/$m-r$r.all.json" "$O/$m-r$r.masked.json" "$l0" "$l1" "$t0" >> "$TSV" <<'EOF'
import json, sys
s, m, r, rec, fa, fm, l0, l1, t0 = sys.argv[1:]
R = json.load(open(rec))
if "render_seconds" in R:                       # mi_render.py
    sec, work = R["render_seconds"], "%d spp" % sum(R["spp"])
else:                                           # photonflow --stats: the last image written
    im = R["images"][-1]
    sec = im.get("seconds", im.get("render_seconds"))
    work = ("%d spp" % im["samples"]) if "samples" in im else ("%d passes" % im["passes"])
A, M = json.load(open(fa)), json.load(open(fm))
print("\t".join(str(x) for x in (s, m, r, "%.2f" % sec, work, "%.6f" % A["rmse"], "%.6f" % M["rmse"],
                                 "%.6f" % A["reference_rmse"], "%.6f" % M["reference_rmse"],
                                 "%.6f" % A["rmse_net"], "%.6f" % M["rmse_net"], l0, l1, t0)))
EOF
      tail -1 "$TSV"
    done
  done
done

/usr/bin/python3 "$HERE/equal_time_summary.py" "$TSV" "$TIME" "$THREADS" > "$OUT/summary.md"
cat "$OUT/summary.md"
