#!/usr/bin/env bash
# hostile_folder_test.sh — a scene folder from a stranger (ctest: tools.hostile_folder/shell,
# tools.hostile_folder/inputs). The test makes the folders itself, in a temporary folder, and runs
# `make -f pipelines/render.mk SCENE=...` (also `make -n` where the folder's files are read while
# make reads its makefiles) and `render --scene FILE` on each. It asserts, for every run:
#   - a canary file, which every hostile text tries to create, never appears: not in the checkout,
#     not in the temporary folder, not in the runs' working folders;
#   - nothing is written outside OUT (the checkout, the scene folder and the working folder are
#     as before; `-o elsewhere.h5` in an options file writes nowhere);
#   - the run exits 0 with an image, or exits 2 with one line on stderr (for make: the one line
#     besides make's own "make: *** [target] Error 2");
#   - the run ends within PF_HOSTILE_TIMEOUT seconds (default 20; a run killed there fails).
#
# Groups (the first argument; default: both):
#   shell   shell syntax in NAME.bake-options (; $(...) ` && | > and a quote that breaks out of a
#           single-quoted string), an output option in it (-o elsewhere.h5), and shell syntax, a
#           space, a quote and a newline in the scene's file name.
#   inputs  what a scene file references: a glTF buffer that is a FIFO, an image URI /dev/zero
#           (both: exit 2 naming it), an image that is a symlink out of the folder, a ../ URI and
#           an absolute URI (/etc/passwd) (exit 0 or 2; with --confine-inputs exit 2 naming it).
# PF_BIN: the tools (default build/bin of the checkout); PF_SOURCE_DIR: the checkout whose
# pipelines/ it runs (default the one holding this script).
set -u
T=hostile_folder_test
GROUPS_RUN=${1:-shell inputs}
SRC=${PF_SOURCE_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}
BIN=${PF_BIN:-$SRC/build/bin}
LIMIT=${PF_HOSTILE_TIMEOUT:-20}
for tool in scene-bake render; do
  [[ -x $BIN/$tool ]] || { echo "$T: FAIL: no $BIN/$tool (set PF_BIN)" >&2; exit 1; }
done
TMP=$(mktemp -d "${TMPDIR:-/tmp}/pf-hostile.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
CAN=pf-canary-$$
IN=$TMP/in        # the hostile folders
OUT=$TMP/out      # every run's OUT (make) and -o (render)
CWD=$TMP/cwd      # render's working folder
mkdir -p "$IN" "$OUT" "$CWD"
failures=0
cases=0
fail() {
  echo "$T: FAIL: $*" >&2
  failures=$((failures + 1))
}

# The files written since the marker outside OUT: in the checkout (not its build folders or .git),
# in the temporary folder (not OUT) and anywhere named like the canary.
written_outside() {
  find "$SRC" \( -path "$SRC/.git" -o -path "$SRC/build*" \) -prune -o -newer "$TMP/.marker" -print
  find "$TMP" -path "$OUT" -prune -o -newer "$TMP/.marker" ! -path "$TMP" ! -name .stderr \
    ! -name .stdout -print
  find "$SRC" "$TMP" "${TMPDIR:-/tmp}" -maxdepth 3 -name "$CAN" 2>/dev/null
}

# check LABEL KIND STATUS NEED  — judges the run that just ended (its stderr in $TMP/.stderr).
# KIND: make (make's own "*** ... Error" lines are not counted) or tool. NEED: "" (exit 0 with an
# image or exit 2 with one line), "refuse" (exit 2 with one line), or "refuse:TEXT" (exit 2 with
# one line that holds TEXT).
check() {
  local label=$1 kind=$2 status=$3 need=$4 image=$5
  cases=$((cases + 1))
  local lines
  if [[ $kind == make ]]; then
    lines=$(grep -Ev '^make(\[[0-9]+\])?: \*\*\* (\[.*\] Error [0-9]+|No rule to make target)' \
            "$TMP/.stderr" | grep -c '')
  else
    lines=$(grep -c '' "$TMP/.stderr")
  fi
  local what
  what="$label: exit $status, stderr: $(head -c 600 "$TMP/.stderr" | tr '\n' '|')"
  local outside
  outside=$(written_outside)
  if [[ -n $outside ]]; then
    fail "$label: wrote outside OUT or made the canary: $(echo "$outside" | sort -u | tr '\n' ' ')"
    # Removed, so that the next case is judged on its own.
    find "$SRC" "$TMP" "${TMPDIR:-/tmp}" -maxdepth 3 -name "$CAN" -delete 2>/dev/null
  fi
  if [[ $status == 124 || $status == 137 ]]; then
    fail "$what: did not end within $LIMIT s"
    return
  fi
  case $need in
    "")
      if [[ $status == 0 ]]; then
        [[ -z $image || -s $image ]] || fail "$what: exit 0 without the image $image"
      elif [[ $status == 2 ]]; then
        [[ $lines == 1 ]] || fail "$what: exit 2 with $lines lines on stderr, not one"
      else
        fail "$what: neither exit 0 with an image nor exit 2 with one line"
      fi ;;
    refuse*)
      [[ $status == 2 && $lines == 1 ]] || fail "$what: expected exit 2 with one line"
      local text=${need#refuse}
      text=${text#:}
      [[ -z $text ]] || grep -qF -- "$text" "$TMP/.stderr" || fail "$what: the line does not name $text" ;;
  esac
}

# run_make LABEL NEED SCENE [VAR=value ...] — make render of SCENE into a fresh OUT, then make -n.
run_make() {
  local label=$1 need=$2 scene=$3
  shift 3
  rm -rf "$OUT"/* && touch "$TMP/.marker"
  (cd "$SRC" && timeout -s KILL "$LIMIT" make --no-print-directory -n -f pipelines/render.mk \
     BIN="$BIN" SCENE="$scene" OUT="$OUT" WIDTH=32 HEIGHT=32 PASSES=2 PHOTONS=2000 THREADS=2 "$@") \
    > "$TMP/.stdout" 2> "$TMP/.stderr"
  local status=$?
  # make -n runs no tool: it exits 0 (or 2 with one line: a name refused while make reads its
  # makefiles), and creates nothing.
  check "make -n: $label" make "$status" "$([[ $need == refuse:SCENE=* ]] && echo "$need")" ""
  rm -rf "$OUT"/* && touch "$TMP/.marker"
  (cd "$SRC" && timeout -s KILL "$LIMIT" make --no-print-directory -f pipelines/render.mk \
     BIN="$BIN" SCENE="$scene" OUT="$OUT" WIDTH=32 HEIGHT=32 PASSES=2 PHOTONS=2000 THREADS=2 "$@") \
    > "$TMP/.stdout" 2> "$TMP/.stderr"
  status=$?
  local image
  image=$(find "$OUT" -name render.exr | head -1)
  check "make: $label" make "$status" "$need" "${image:-$OUT/missing-render.exr}"
}

# run_render LABEL NEED SCENE [OPTION ...] — render --scene SCENE -o OUT/r.exr, from CWD.
run_render() {
  local label=$1 need=$2 scene=$3
  shift 3
  rm -rf "$OUT"/* && touch "$TMP/.marker"
  (cd "$CWD" && timeout -s KILL "$LIMIT" "$BIN/render" --scene "$scene" -o "$OUT/r.exr" \
     --passes 2 --width 32 --height 32 --photons 2000 --threads 2 "$@") \
    > "$TMP/.stdout" 2> "$TMP/.stderr"
  check "render --scene: $label" tool "$?" "$need" "$OUT/r.exr"
}

CORNELL=$SRC/data/cornell-box.dae
[[ -f $CORNELL ]] || { echo "$T: FAIL: no $CORNELL" >&2; exit 1; }

shell_group() {
  # Shell syntax in the options file: each would run `touch CANARY` (or create it by >) if the
  # file's text reached a shell. The canary's path is absolute, inside the temporary folder.
  local c=$TMP/$CAN
  local -a texts=(
    "--aperture 0.1; touch $c"
    "--aperture 0.1 \$(touch $c)"
    "--aperture 0.1\`touch $c\`"
    "--aperture 0.1 && touch $c"
    "--aperture 0.1 | touch $c"
    "--aperture 0.1 > $c"
    "--aperture 0.1'; touch $c; echo '"
    "--aperture \"0.1\"; touch $c #"
  )
  local i=0
  for text in "${texts[@]}"; do
    i=$((i + 1))
    mkdir -p "$IN/opt$i"
    cp "$CORNELL" "$IN/opt$i/scene.dae"
    printf '# a stranger'\''s options\n%s\n' "$text" > "$IN/opt$i/scene.bake-options"
    run_make "options file '$text'" "" "$IN/opt$i/scene.dae"
    run_render "options file '$text'" "" "$IN/opt$i/scene.dae"
  done
  # An output option in the options file: refused naming the file and line; nothing written.
  mkdir -p "$IN/optout"
  cp "$CORNELL" "$IN/optout/scene.dae"
  printf '# writes elsewhere\n--aperture 0.01\n-o elsewhere.h5\n' > "$IN/optout/scene.bake-options"
  run_make "options file -o elsewhere.h5" "refuse:scene.bake-options:3" "$IN/optout/scene.dae"
  run_render "options file -o elsewhere.h5" "refuse:scene.bake-options:3" "$IN/optout/scene.dae"
  [[ -z $(find "$SRC" "$TMP" "$CWD" -name elsewhere.h5 2>/dev/null) ]] || fail "elsewhere.h5 was written"
  # A benign options file is still read by both (the lens is applied; the run succeeds).
  mkdir -p "$IN/optok"
  cp "$CORNELL" "$IN/optok/scene.dae"
  printf '# fine\n--aperture 0.01 # lens\n' > "$IN/optok/scene.bake-options"
  run_render "a benign options file" "" "$IN/optok/scene.dae"

  # Shell syntax, a space, quotes and a newline in the scene's file name: make refuses the name
  # with one line (pipelines/names.mk); render --scene takes it as one argument and renders it.
  local nl=$'\n'
  local -a names=(
    "c;touch $CAN;.dae"
    "\$(touch $CAN).dae"
    "\`touch $CAN\`.dae"
    "a b.dae"
    "x';touch $CAN;'.dae"
    "new${nl}line.dae"
  )
  mkdir -p "$IN/names"
  for name in "${names[@]}"; do
    cp "$CORNELL" "$IN/names/$name"
    run_make "file name '$name'" "refuse:SCENE=" "$IN/names/$name"
    run_render "file name '$name'" "" "$IN/names/$name"
    # A relative name, as `make render SCENE=...` is typed in the checkout's folder.
    cp "$CORNELL" "$CWD/$name"
    run_render "relative file name '$name'" "" "./$name"
    rm -f "$CWD/$name"
  done
}

# A small glTF folder (data/showcase.gltf and its files) with one change made by python3: the
# buffer or the first image's URI. Prints nothing; the folder is $IN/$1.
gltf_folder() {
  local dir=$IN/$1 what=$2 uri=$3
  mkdir -p "$dir"
  cp "$SRC"/data/showcase.gltf "$SRC"/data/showcase.bin "$SRC"/data/showcase_*.png "$dir"/
  python3 - "$dir/scene.gltf" "$SRC/data/showcase.gltf" "$what" "$uri" <<'PY'
import json, sys
out, src, what, uri = sys.argv[1:]
doc = json.load(open(src))
if what == "buffer":
    doc["buffers"][0]["uri"] = uri
else:
    doc["images"][0]["uri"] = uri
json.dump(doc, open(out, "w"))
PY
}

inputs_group() {
  mkdir -p "$TMP/outside"
  cp "$SRC"/data/showcase_tiles.png "$TMP/outside/secret.png"
  gltf_folder fifo buffer fifo.bin
  mkfifo "$IN/fifo/fifo.bin"
  run_make "glTF buffer that is a FIFO" "refuse:fifo.bin" "$IN/fifo/scene.gltf"
  run_render "glTF buffer that is a FIFO" "refuse:fifo.bin" "$IN/fifo/scene.gltf"
  gltf_folder zero image /dev/zero
  run_make "image URI /dev/zero" "refuse:/dev/zero" "$IN/zero/scene.gltf"
  run_render "image URI /dev/zero" "refuse:/dev/zero" "$IN/zero/scene.gltf"
  gltf_folder link image link.png
  ln -s "$TMP/outside/secret.png" "$IN/link/link.png"
  gltf_folder up image ../../outside/secret.png
  gltf_folder abs image /etc/passwd
  for f in link up abs; do
    local name
    name=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["images"][0]["uri"])' \
           "$IN/$f/scene.gltf")
    run_make "image $name, out of the folder" "" "$IN/$f/scene.gltf"
    run_render "image $name, out of the folder" "" "$IN/$f/scene.gltf"
    run_make "image $name, --confine-inputs" "refuse:${name##*/}" "$IN/$f/scene.gltf" \
      BAKE_FLAGS=--confine-inputs
    run_render "image $name, --confine-inputs" "refuse:${name##*/}" "$IN/$f/scene.gltf" \
      --confine-inputs
  done
}

for g in $GROUPS_RUN; do
  case $g in
    shell) shell_group ;;
    inputs) inputs_group ;;
    *) echo "$T: FAIL: unknown group $g (shell, inputs)" >&2; exit 1 ;;
  esac
done
if ((failures > 0)); then
  echo "$T: $failures failures in $cases checks ($GROUPS_RUN)" >&2
  exit 1
fi
echo "$T: $cases checks passed ($GROUPS_RUN)"
