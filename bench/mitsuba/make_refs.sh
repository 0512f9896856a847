#!/usr/bin/env bash
# make_refs.sh — the scenes and long references of issue 34 item 2 (bench/mitsuba/equal_time.sh
# reads them). Benchmark-only. Per scene, into REFS/<scene>/:
#   scene.h5      scene-bake SOURCE --width 512 --height 512 [inserts]   (what every method renders)
#   mi/           scene_to_mitsuba.py scene.h5 mi                        (Mitsuba XML + OBJs)
#   ref/ref-s0.exr, ref/ref-s1.exr, ref/ref.exr (their mean), ref/ref.json (spp, seconds, own error)
#                 Mitsuba llvm_ad_rgb, path max_depth -1, multijitter sampler, passes of REF_SPP
#                 spp, seeds REF_SEED + i alternating between two streams, for REF_TIME seconds
#                 (nice 19: references are not timed)
# Scenes: cornell-box (data/cornell-box.dae), cornell-spheres (data/cornell-spheres.dae: mirror
# and glass balls), box-200k (cornell-box with the four meshes of ../shared/scenes inserted:
# ogre 124,008 + bunny 69,451 + teapot 6,320 + spot 5,856 triangles, 205,663 in all after 4
# zero-area ones are dropped; skipped with a message where ../shared/scenes is absent);
# glossy-room (bench/scenes/glossy-room.gltf: a white metal and a rough-glass ball), showcase
# (data/showcase.gltf with data/showcase.bake-options: textures, an alpha-masked fence, a spot
# light, the thin lens) and showcase-caustics (data/showcase-caustics.gltf: pinhole, the spot 3x,
# the ceiling light dimmed), window-room (data/window-room.gltf with data/window-room.bake-options:
# an interior lit only through a window by data/sky.hdr, a sky with a sun) and hdri-object
# (data/hdri-object.gltf with data/hdri-object.bake-options: an object on a floor outdoors under
# the same sky). These five are not in the default list.
#
#   bench/mitsuba/make_refs.sh [SCENE ...]                  (default: all three, one after another)
#   RESUME=1 REF_TIME=3600 bench/mitsuba/make_refs.sh S     (render REF_TIME more seconds onto S's reference)
#
# Environment: BUILD (build), REFS (/work/refs/mitsuba-acc), REF_TIME (5700), REF_SPP (128),
# REF_SEED (5000000), THREADS (2), PY (.venv-mitsuba/bin/python), SHARED (../shared, else
# /work/shared), DRJIT_LIBLLVM_PATH as equal_time.sh.
set -euo pipefail
BUILD=${BUILD:-build}
BIN=$BUILD/bin
REFS=${REFS:-/work/refs/mitsuba-acc}
REF_TIME=${REF_TIME:-5700}
REF_SPP=${REF_SPP:-128}
REF_SEED=${REF_SEED:-5000000}
THREADS=${THREADS:-2}
PY=${PY:-.venv-mitsuba/bin/python}
HERE=$(cd "$(dirname "$0")" && pwd)
SHARED=${SHARED:-$( [ -d ../shared/scenes ] && echo ../shared || echo /work/shared )}
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-$PWD/.llvm19/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
export DRJIT_CACHE_DIR=${DRJIT_CACHE_DIR:-$REFS/drjit-cache}
SCENES=${*:-cornell-box cornell-spheres box-200k}

bake() {  # $1 scene name, $2 output
  case $1 in
    cornell-box|cornell-spheres) "$BIN/scene-bake" "data/$1.dae" -o "$2" --width 512 --height 512 ;;
    box-200k)
      M=$SHARED/scenes
      for f in ogre stanford-bunny teapot spot; do
        [ -f "$M/$f.obj" ] || { echo "make_refs.sh: $M/$f.obj missing: box-200k needs ../shared/scenes" >&2; return 3; }
      done
      # Free floor (back right, front left) and the two blocks' tops (data/cornell-box.dae: short
      # block x 0.48–0.85, z 0.51–0.88, height 0.297; tall block x 0.15–0.52, z 0.18–0.56, height 0.595).
      "$BIN/scene-bake" data/cornell-box.dae -o "$2" --width 512 --height 512 \
        --insert "$M/ogre.obj" --insert-box 0.03,0,0.58,0.46,0.55,0.97 \
        --insert "$M/stanford-bunny.obj" --insert-box 0.55,0,0.03,0.97,0.45,0.48 \
        --insert "$M/teapot.obj" --insert-box 0.58,0.297,0.61,0.75,0.5,0.78 \
        --insert "$M/spot.obj" --insert-box 0.25,0.595,0.28,0.42,0.8,0.45 ;;
    glossy-room) "$BIN/scene-bake" bench/scenes/glossy-room.gltf -o "$2" --width 512 --height 512 ;;
    # data/showcase.bake-options (the thin lens) is read by scene-bake beside the source, named here
    # so that a missing file fails the bake instead of silently giving a pinhole.
    showcase) "$BIN/scene-bake" data/showcase.gltf --options-file data/showcase.bake-options -o "$2" \
                --width 512 --height 512 ;;
    showcase-caustics) "$BIN/scene-bake" data/showcase-caustics.gltf -o "$2" --width 512 --height 512 ;;
    # The environment map and its strength are bake options (--environment sky.hdr, relative to the
    # options file's folder), named as for the showcase.
    window-room|hdri-object) "$BIN/scene-bake" "data/$1.gltf" --options-file "data/$1.bake-options" -o "$2" \
                --width 512 --height 512 ;;
    *) echo "make_refs.sh: unknown scene $1" >&2; return 2 ;;
  esac
}

for s in $SCENES; do
  D=$REFS/$s
  mkdir -p "$D/ref"
  if [ "${RESUME:-0}" != 1 ]; then
    set +e; bake "$s" "$D/scene.h5" > "$D/bake.log" 2>&1; rc=$?; set -e
    if [ $rc != 0 ]; then cat "$D/bake.log" >&2; [ $rc = 3 ] && continue; exit $rc; fi
    grep -E "triangles|camera|scene_id" "$D/bake.log"
    "$PY" "$HERE/scene_to_mitsuba.py" "$D/scene.h5" "$D/mi" > /dev/null
  fi
  cmd=(nice -n 19 "$PY" "$HERE/mi_render.py" "$D/mi/scene.xml" "$D/ref/ref.exr" --time "$REF_TIME"
       --spp-per-pass "$REF_SPP" --streams 2 --sampler multijitter --seed-base "$REF_SEED" --threads "$THREADS")
  [ "${RESUME:-0}" = 1 ] && cmd+=(--resume)
  echo "$(date -u +%FT%TZ) ${cmd[*]}" >> "$D/ref/command.txt"
  "${cmd[@]}"
done
