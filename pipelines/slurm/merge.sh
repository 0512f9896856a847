#!/usr/bin/env bash
# merge.sh RUN — the merge job of a run of pipelines/slurm/ (also run by local.mk): merges the
# parts of all TASKS tasks into RUN/image.exr (+ image.png) and the run record RUN/run.json
# (merge --stats), demanding with --range that they cover passes 0 .. TASKS*PPT-1 exactly.
# Up to FANIN parts are merged at once; more are merged as a tree: groups of FANIN consecutive
# parts into merged partial results (merge --sums, RUN/merge/), then those, and so on (each level
# divides the files by FANIN; a level's merges run MERGE_CPUS at a time).
# A missing part is named with its task and range (resubmit.sh RUN submits it), exit 2; merge
# itself refuses parts of another scene, seed or option set, or with overlapping ranges.
set -euo pipefail
RUN=${1:?usage: merge.sh RUN}
[[ -f $RUN/run.env ]] || { echo "merge.sh: $RUN/run.env: no such file (not a run folder)" >&2; exit 2; }
# shellcheck disable=SC1091
source "$RUN/run.env"
PF_SCRIPT=merge.sh
# shellcheck disable=SC1091
source "$PIPE/common.sh"
pf_load "$RUN"

missing=$(pf_missing)
if [[ -n $missing ]]; then
  n=$(wc -l <<< "$missing") list=""
  for k in $(head -n 5 <<< "$missing"); do
    list+="${list:+, }task $k (passes $((k * PPT))..$((k * PPT + PPT - 1)), $(basename "$(pf_part "$k")"))"
  done
  ((n > 5)) && list+=", ..."
  pf_die "$RUN: $n of $TASKS parts missing: $list; submit them with pipelines/slurm/resubmit.sh $RUN"
fi

start=$EPOCHREALTIME
# The current level's files and the pass range [first, end) each covers, in pass order.
files=() firsts=() ends=()
for ((k = 0; k < TASKS; ++k)); do
  files+=("$(pf_part "$k")"); firsts+=($((k * PPT))); ends+=($(((k + 1) * PPT)))
done
rm -rf "$RUN/merge"
trap 'rm -rf "$RUN/merge"' EXIT   # the tree's intermediate files, whatever happens
level=0
while ((${#files[@]} > FANIN)); do
  level=$((level + 1))
  mkdir -p "$RUN/merge"
  next=() nfirsts=() nends=() running=0 failed=0
  for ((g = 0; g * FANIN < ${#files[@]}; ++g)); do
    a=$((g * FANIN)) n=$FANIN
    ((a + n > ${#files[@]})) && n=$((${#files[@]} - a))
    first=${firsts[a]} end=${ends[a + n - 1]}
    if ((n == 1)); then   # a last group of one goes up a level as it is
      next+=("${files[a]}"); nfirsts+=("$first"); nends+=("$end"); continue
    fi
    out=$(printf '%s/merge/level%d-passes-%08d-%08d.h5' "$RUN" "$level" "$first" $((end - 1)))
    "$BIN/merge" "${files[@]:a:n}" --range "$first:$end" --sums "$out" > /dev/null &
    running=$((running + 1))
    if ((running >= MERGE_CPUS)); then wait -n || failed=1; running=$((running - 1)); fi
    next+=("$out"); nfirsts+=("$first"); nends+=("$end")
  done
  while ((running > 0)); do wait -n || failed=1; running=$((running - 1)); done
  ((failed == 0)) || pf_die "a merge of tree level $level failed (above); remove the part it names and resubmit it"
  files=("${next[@]}") firsts=("${nfirsts[@]}") ends=("${nends[@]}")
  echo "merge.sh: level $level: ${#files[@]} merged partial results"
done
"$BIN/merge" "${files[@]}" --range "0:$((TASKS * PPT))" -o "$RUN/image.exr" --stats "$RUN/run.json"
echo "merge.sh: $RUN/image.exr: $TASKS parts, $((TASKS * PPT)) passes, $level tree levels, $(awk -v a="$start" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.2f", b - a }') s"
