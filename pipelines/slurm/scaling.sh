#!/usr/bin/env bash
# scaling.sh — the measurements of docs/SCALING.md on this machine: bytes per task and merge,
# merge time for 10, 100 and 1,000 parts (flat and as a tree), and throughput with 1 and 2 tasks
# side by side. Prints Markdown tables.
#
#   pipelines/slurm/scaling.sh [BIN [DIR]]    (defaults: build/bin, /tmp/pf-scaling)
#
# Variables: SIZE (merge image, default 128: SIZE x SIZE pixels), PARTS (default 1000),
# TP_SIZE, TP_PASSES, TP_PHOTONS (throughput runs: image size, passes per task, photons per pass;
# defaults 128, 8, 200000), SECTIONS (default "bytes merge throughput": the tables to make).
set -euo pipefail
BIN=$(cd "${1:-build/bin}" && pwd)
DIR=${2:-/tmp/pf-scaling}
src=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
SIZE=${SIZE:-128} PARTS=${PARTS:-1000}
TP_SIZE=${TP_SIZE:-128} TP_PASSES=${TP_PASSES:-8} TP_PHOTONS=${TP_PHOTONS:-200000}
SECTIONS=${SECTIONS:-bytes merge throughput}
mkdir -p "$DIR/parts"
want() { [[ " $SECTIONS " == *" $1 "* ]]; }
seconds() { awk -v a="$1" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.3f", b - a }'; }

if want bytes || want merge; then
# Parts: PARTS renders of one pass each (passes 0 .. PARTS-1) of a SIZE x SIZE Cornell box.
scene=$DIR/scene-$SIZE.h5
[[ -f $scene ]] || "$BIN/scene-bake" "$src/data/cornell-box.dae" -o "$scene" --width "$SIZE" --height "$SIZE" > /dev/null
part() { printf '%s/parts/pass-%05d.h5' "$DIR" "$1"; }
for ((p = 0; p < PARTS; ++p)); do
  [[ -f $(part $p) ]] || echo "$p"
done | xargs -r -P 2 -I{} sh -c '"$1/render" --scene "$2" --estimator pppm --first-pass {} --passes 1 \
  --photons 1000 --threads 1 --sums "$(printf "%s/parts/pass-%05d.h5" "$3" {})" > /dev/null' \
  sh "$BIN" "$scene" "$DIR"

fi
if want bytes; then
echo "### Bytes ($SIZE x $SIZE pixels)"
echo
echo "| file | bytes |"
echo "|---|---|"
echo "| scene.h5 (read by every task) | $(stat -c %s "$scene") |"
echo "| one part (render --sums) | $(stat -c %s "$(part 0)") |"
"$BIN/merge" "$(part 0)" "$(part 1)" --range 0:2 --sums "$DIR/merged.h5" -o "$DIR/merged.exr" > /dev/null
echo "| a merged partial (merge --sums) | $(stat -c %s "$DIR/merged.h5") |"
echo "| the image (merge -o, EXR + PNG) | $(( $(stat -c %s "$DIR/merged.exr") + $(stat -c %s "$DIR/merged.png") )) |"
echo

fi
if want merge; then
echo "### Merge time ($SIZE x $SIZE pixels, best of 3, seconds)"
echo
echo "| parts | flat | tree, fan-in 10 | tree, fan-in 32 |"
echo "|---|---|---|---|"
# merge_tree N F: merges parts 0..N-1 as merge.sh does with FANIN=F (one core), prints seconds.
merge_tree() {
  local n=$1 f=$2 t0 level=0 files=() next a
  for ((p = 0; p < n; ++p)); do files+=("$(part $p)"); done
  t0=$EPOCHREALTIME
  rm -rf "$DIR/tree" && mkdir -p "$DIR/tree"
  while ((${#files[@]} > f)); do
    level=$((level + 1)) next=()
    for ((a = 0; a < ${#files[@]}; a += f)); do
      if ((a + 1 == ${#files[@]})); then next+=("${files[a]}"); continue; fi
      local out=$DIR/tree/l$level-$a.h5
      "$BIN/merge" "${files[@]:a:f}" --sums "$out" > /dev/null
      next+=("$out")
    done
    files=("${next[@]}")
  done
  "$BIN/merge" "${files[@]}" --range "0:$n" -o "$DIR/tree.exr" > /dev/null
  seconds "$t0"
}
best() { sort -g | head -n 1; }
for n in 10 100 1000; do
  ((n <= PARTS)) || continue
  files=()
  for ((p = 0; p < n; ++p)); do files+=("$(part $p)"); done
  flat=$(for r in 1 2 3; do t0=$EPOCHREALTIME; "$BIN/merge" "${files[@]}" --range "0:$n" -o "$DIR/flat.exr" > /dev/null; seconds "$t0"; echo; done | best)
  t10=$(for r in 1 2 3; do merge_tree "$n" 10; echo; done | best)
  t32=$(for r in 1 2 3; do merge_tree "$n" 32; echo; done | best)
  echo "| $n | $flat | $t10 | $t32 |"
done
echo

fi
if want throughput; then
echo "### Throughput (${TP_SIZE} x ${TP_SIZE} pixels, $TP_PASSES passes of $TP_PHOTONS photons per task, 1 thread per task)"
echo
echo "| tasks side by side | wall s | CPU s | photons/s in all | photons per CPU-second |"
echo "|---|---|---|---|---|"
tscene=$DIR/scene-$TP_SIZE.h5
[[ -f $tscene ]] || "$BIN/scene-bake" "$src/data/cornell-box.dae" -o "$tscene" --width "$TP_SIZE" --height "$TP_SIZE" > /dev/null
for k in 1 2; do
  t0=$EPOCHREALTIME
  read -r -a c0 < <(awk '{ print $14 + $15 + $16 + $17 }' /proc/$$/stat)
  for ((i = 0; i < k; ++i)); do
    "$BIN/render" --scene "$tscene" --estimator pppm --first-pass $((i * TP_PASSES)) --passes "$TP_PASSES" \
      --photons "$TP_PHOTONS" --threads 1 --sums "$DIR/tp-$k-$i.h5" > /dev/null &
  done
  wait
  s=$(seconds "$t0")
  # CPU time of the finished children (utime + stime + cutime + cstime of this shell, in ticks).
  read -r -a c1 < <(awk '{ print $14 + $15 + $16 + $17 }' /proc/$$/stat)
  cpu=$(awk -v a="${c0[0]}" -v b="${c1[0]}" -v hz="$(getconf CLK_TCK)" 'BEGIN { printf "%.2f", (b - a) / hz }')
  awk -v k="$k" -v s="$s" -v c="$cpu" -v n=$((TP_PASSES * TP_PHOTONS)) \
    'BEGIN { printf "| %d | %.2f | %.2f | %.3g | %.3g |\n", k, s, c, k * n / s, k * n / c }'
  rm -f "$DIR"/tp-$k-*.h5
done
echo
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
fi
