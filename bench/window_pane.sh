#!/usr/bin/env bash
# window_pane.sh — photon guidance where only photons carry the light (issue 50 item 6, the
# ≤ 0.33× target): bench/scenes/window-pane.gltf, data/window-room with its window glazed, at
# equal time, --photon-guide visibility against uniform photons (and Mitsuba 3 beside them).
#
#   bench/window_pane.sh            (from the repository root, after building the tools)
#
# 1. Bakes the scene at 512×512 into REFS/window-pane/scene.h5 and writes its Mitsuba XML
#    (bench/mitsuba/scene_to_mitsuba.py), as bench/mitsuba/make_refs.sh does for its scenes.
# 2. References: two photonflow renders of REF_TIME seconds each, --photon-guide visibility,
#    seeds 101 and 102 (ref/ref-s0.exr, ref-s1.exr). Not an independent renderer's: a path
#    tracer cannot render this room. The sun (1.1e-3 sr) lights the room only through glass,
#    which next-event estimation cannot see through, so a path reaches it only when a BSDF
#    sample from a sunlit point happens to leave through the pane towards the sun disc (about
#    2.5e-4 of its cosine-weighted directions); Mitsuba's own run below shows what that costs.
#    A photonflow reference cannot see photonflow's bias: the figures are the guide's error
#    against uniform photons', the target's own terms, with both methods' common bias hidden.
#    docs/RESULTS.md "Photons where the camera looks" has them, and the error_split.py command
#    that says where the error lies.
# 3. bench/mitsuba/equal_time.sh window-pane with METHODS (default: defaults guided
#    mi1-multijitter), RUNS runs of TIME seconds (defaults 3 and 30).
#
# Environment: BUILD (build), REFS (/work/refs/pf-acc), REF_TIME (600), OUT
# (out/window-pane), PY (.venv-mitsuba/bin/python), and equal_time.sh's.
set -euo pipefail
BUILD=${BUILD:-build}
BIN=$BUILD/bin
REFS=${REFS:-/work/refs/pf-acc}
REF_TIME=${REF_TIME:-600}
PY=${PY:-.venv-mitsuba/bin/python}
D=$REFS/window-pane
mkdir -p "$D/ref"
if [ ! -f "$D/scene.h5" ]; then
  "$BIN/scene-bake" bench/scenes/window-pane.gltf \
    --options-file bench/scenes/window-pane.bake-options \
    -o "$D/scene.h5" --width 512 --height 512 > "$D/bake.log"
  "$PY" bench/mitsuba/scene_to_mitsuba.py "$D/scene.h5" "$D/mi" > /dev/null
fi
for s in 0 1; do
  [ -f "$D/ref/ref-s$s.exr" ] && continue
  "$BIN/render" --scene "$D/scene.h5" -o "$D/ref/ref-s$s.exr" --time "$REF_TIME" \
    --photon-guide visibility --seed $((101 + s)) --stats "$D/ref/ref-s$s.json"
done
METHODS=${METHODS:-defaults guided mi1-multijitter} FLAGS_guided="--photon-guide visibility" \
  REFS=$REFS OUT=${OUT:-out/window-pane} PY=$PY "$(dirname "$0")/mitsuba/equal_time.sh" window-pane
