#!/usr/bin/env bash
# test_slurm.sh — pipelines/slurm/ on a real Slurm cluster (ctest: tools.slurm_cluster).
#
# Starts a single-node cluster on this machine (tests/tools/slurm/cluster.sh: munged, slurmctld, slurmd
# under a temporary folder), submits a 4-task render of a small Cornell box through
# pipelines/slurm/submit.sh and checks that the merged image equals one `render` of the same passes
# (up to float summation order). Then a second run: one task is cancelled while it renders; the
# merge must refuse the run naming the missing task, the other parts must be whole, and after
# pipelines/slurm/resubmit.sh (which submits that task alone) the image must again equal the single
# render. The same parts run with make -j (pipelines/slurm/local.mk) give it too.
#
# Needs root (slurmd and munged) and the packages slurm-wlm and munge; without them it fails and
# says so. PF_SKIP_SLURM=1 skips it (exit 77, ctest's SKIP_RETURN_CODE). PF_BIN: the tools.
# PF_SLURM_WAIT bounds each wait for the jobs (seconds, default 240). Every daemon it started is
# stopped and its folder removed, also when it fails or is killed (a watchdog process).
set -euo pipefail
T=test_slurm
fail() { echo "$T: FAIL: $*" >&2; exit 1; }
if [[ ${PF_SKIP_SLURM:-0} == 1 ]]; then
  echo "$T: skipped: PF_SKIP_SLURM=1"
  exit 77
fi
src=$(cd "$(dirname "${BASH_SOURCE[0]}")/../../.." && pwd)
[[ $(id -u) -eq 0 ]] || fail "needs root to start munged and slurmd (CI runs as root); PF_SKIP_SLURM=1 skips this test"
for exe in munged slurmctld slurmd sbatch squeue scancel scontrol sinfo python3; do
  command -v "$exe" >/dev/null || fail "'$exe' not found: install the Debian packages slurm-wlm and munge (tools/setup/debian-packages-test.txt; make test installs them), or skip with PF_SKIP_SLURM=1"
done
BIN=${PF_BIN:?PF_BIN must name the folder of the tools (ctest sets it)}
for exe in scene-bake render merge imgcompare; do
  [[ -x $BIN/$exe ]] || fail "$BIN/$exe not built (cmake --build build --target $exe)"
done
wait_s=${PF_SLURM_WAIT:-240}

tmp=$(mktemp -d /tmp/pf-slurm-test.XXXXXX)
cluster=$tmp/cluster
cleanup() {
  "$src/tests/tools/slurm/cluster.sh" stop "$cluster" || true
  if [[ -n ${PF_KEEP_SLURM_TMP:-} ]]; then echo "$T: kept $tmp"; else rm -rf "$tmp"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM HUP
# The watchdog: if this script dies without its EXIT trap (SIGKILL, ctest's timeout), it stops
# the daemons (their pid files are still there) and removes the folder.
setsid bash -c 'while kill -0 "$1" 2>/dev/null; do sleep 1; done
  if [[ -e $3/munged.pid ]]; then "$2/tests/tools/slurm/cluster.sh" stop "$3"; rm -rf "$4"; fi' \
  watchdog $$ "$src" "$cluster" "$tmp" > /dev/null 2>&1 < /dev/null &

"$src/tests/tools/slurm/cluster.sh" start "$cluster" || fail "the cluster did not start (above)"
# shellcheck disable=SC1091
source "$cluster/env.sh"

# The scene and the settings of every run: 4 tasks of 2 passes, 8 passes in all.
TASKS=4 PPT=2 SEED=3 PHOTONS=${PF_SLURM_PHOTONS:-1000000}
"$BIN/scene-bake" "$src/data/cornell-box.dae" -o "$tmp/scene.h5" --width 64 --height 64 > /dev/null
run_opts=(--scene "$tmp/scene.h5" --bin "$BIN" --tasks "$TASKS" --passes-per-task "$PPT"
          --seed "$SEED" --photons "$PHOTONS" --mem 512M --time 10:00)
render() { "$BIN/render" --scene "$tmp/scene.h5" --estimator pppm --photons "$PHOTONS" --threads 1 "$@" > /dev/null; }
t0=$EPOCHREALTIME
render --passes $((TASKS * PPT)) --seed $SEED -o "$tmp/reference.exr"
echo "$T: single render of $((TASKS * PPT)) passes: $(awk -v a="$t0" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.1f", b - a }') s"

# relMSE of image $1 against image $2 (imgcompare).
relmse() {
  "$BIN/imgcompare" "$1" "$2" --json - | python3 -c 'import json, sys; print(json.load(sys.stdin)["relmse"])'
}
# Asserts that image $1 equals the reference up to float summation order, and says what it found.
# Differences of summation order are ~1e-7 relative per pixel (relMSE ~1e-14); another seed or a
# missing pass range gives relMSE of 1e-3 and more (checked below).
same_as_reference() {
  local e
  e=$(relmse "$1" "$tmp/reference.exr") || fail "imgcompare failed on $1"
  python3 -c "import sys; sys.exit(0 if $e < 1e-9 else 1)" \
    || fail "$1 differs from the single render of the same passes: relMSE $e (expected < 1e-9)"
  echo "$T: $1 equals the single render (relMSE $e)"
}

# Waits until none of the run's jobs is pending or running (bounded), then shows their states.
wait_jobs() {
  local run=$1 ids i
  ids=$(awk '{ printf "%s%s", sep, $3; sep = "," }' "$run/jobs.log")
  for ((i = 0; i < wait_s * 5; i++)); do
    [[ -z $(squeue -h -j "$ids" -t PENDING,RUNNING,CONFIGURING,COMPLETING -o %i 2>/dev/null) ]] && return 0
    sleep 0.2
  done
  squeue -j "$ids" >&2 || true
  tail -n 5 "$run"/logs/* >&2 || true
  fail "the jobs of $run did not end within $wait_s s"
}
job_state() { scontrol show job "$1" | grep -o 'JobState=[A-Z_]*' | head -n 1 | cut -d= -f2; }

# 1. The whole run.
run1=$tmp/run1
ids=$("$src/pipelines/slurm/submit.sh" "${run_opts[@]}" --out "$run1" | tail -n 1)
read -r tasks_job merge_job <<< "$ids"
wait_jobs "$run1"
[[ $(job_state "$merge_job") == COMPLETED ]] \
  || fail "merge job $merge_job of run 1 ended $(job_state "$merge_job"): $(cat "$run1"/logs/merge-*.out)"
for ((k = 0; k < TASKS; ++k)); do
  [[ $(job_state "${tasks_job}_$k") == COMPLETED ]] || fail "task $k of run 1 ended $(job_state "${tasks_job}_$k")"
done
[[ -f $run1/image.exr && -f $run1/image.png && -f $run1/run.json ]] || fail "run 1 wrote no image.exr, image.png and run.json"
same_as_reference "$run1/image.exr"
# The comparison can fail: the parts of tasks 0..2 alone (6 of the 8 passes) are far from it.
parts1=("$run1"/parts/passes-*.h5)
[[ ${#parts1[@]} -eq $TASKS ]] || fail "run 1 left ${#parts1[@]} parts, not $TASKS"
"$BIN/merge" "${parts1[@]:0:TASKS-1}" -o "$tmp/fewer-passes.exr" > /dev/null
e=$(relmse "$tmp/fewer-passes.exr" "$tmp/reference.exr")
python3 -c "import sys; sys.exit(0 if $e > 1e-6 else 1)" \
  || fail "the image of $(((TASKS - 1) * PPT)) passes is as close to the reference as the merge must be (relMSE $e): the comparison cannot fail"
# Parts that must not merge: task 1's range rendered with another seed, and a part given twice.
render --seed $((SEED + 1)) --first-pass "$PPT" --passes "$PPT" --sums "$tmp/other-seed.h5"
for set in other-seed duplicate; do
  if [[ $set == other-seed ]]; then
    parts=("${parts1[0]}" "$tmp/other-seed.h5" "${parts1[@]:2}"); culprit=other-seed.h5
  else
    parts=("${parts1[@]}" "${parts1[1]}"); culprit=$(basename "${parts1[1]}")
  fi
  if out=$("$BIN/merge" "${parts[@]}" --range "0:$((TASKS * PPT))" -o "$tmp/$set.exr" 2>&1); then
    fail "merge accepted the $set part"
  fi
  grep -q "$culprit" <<< "$out" || fail "merge's refusal of the $set part does not name it: $out"
  [[ ! -e $tmp/$set.exr ]] || fail "merge refused the $set part but wrote $tmp/$set.exr"
  echo "$T: merge refuses the $set part: $out"
done

# 2. One task cancelled while it renders, then resubmitted alone.
run2=$tmp/run2
victim=1
ids=$("$src/pipelines/slurm/submit.sh" "${run_opts[@]}" --out "$run2" | tail -n 1)
read -r tasks_job merge_job <<< "$ids"
log=$run2/logs/task-${tasks_job}_$victim.out
for ((i = 0; i < wait_s * 20; i++)); do
  grep -q "task $victim on" "$log" 2>/dev/null && break
  sleep 0.05
done
grep -q "task $victim on" "$log" 2>/dev/null || fail "task $victim of run 2 did not start within $wait_s s"
scancel "${tasks_job}_$victim"
# The others finish; the merge job waits for ever (afterok on an array with a cancelled task).
for ((i = 0; i < wait_s * 5; i++)); do
  [[ -z $(squeue -h -r -j "$tasks_job" -o %i) ]] && break
  sleep 0.2
done
[[ -z $(squeue -h -r -j "$tasks_job" -o %i) ]] || fail "the tasks of run 2 did not end within $wait_s s"
[[ $(job_state "${tasks_job}_$victim") == CANCELLED ]] \
  || fail "task $victim of run 2 ended $(job_state "${tasks_job}_$victim"), not CANCELLED: it finished before it could be cancelled (raise PF_SLURM_PHOTONS)"
[[ $(job_state "$merge_job") == PENDING ]] || fail "merge job $merge_job ran ($(job_state "$merge_job")) although task $victim was cancelled"
# Nothing half-written: exactly the parts of the other tasks, each whole (merge reads it).
mapfile -t files < <(cd "$run2/parts" && ls -A)
[[ ${#files[@]} -eq $((TASKS - 1)) ]] || fail "run 2's parts folder holds ${files[*]} (expected the $((TASKS - 1)) parts of the tasks not cancelled, nothing else)"
for f in "${files[@]}"; do
  first=$((10#$(cut -d- -f2 <<< "$f")))
  "$BIN/merge" "$run2/parts/$f" --range "$first:$((first + PPT))" --sums "$tmp/check.h5" > /dev/null \
    || fail "part $f of run 2 is not a whole part of passes $first..$((first + PPT - 1))"
done
# The merge refuses the run and names the missing task.
if out=$("$src/pipelines/slurm/merge.sh" "$run2" 2>&1); then fail "merge.sh merged run 2 without task $victim"; fi
grep -q "task $victim (passes $((victim * PPT))..$((victim * PPT + PPT - 1))" <<< "$out" \
  || fail "merge.sh's refusal does not name task $victim: $out"
[[ $(wc -l <<< "$out") -eq 1 && ! -e $run2/image.exr ]] || fail "merge.sh's refusal is not one line without an image: $out"
# Resubmitted: only the missing task, and a new merge.
ids=$("$src/pipelines/slurm/resubmit.sh" "$run2" | tail -n 1)
read -r tasks_job2 merge_job2 <<< "$ids"
grep -q "^.* tasks $tasks_job2 $victim\$" "$run2/jobs.log" || fail "resubmit.sh did not submit task $victim alone: $(cat "$run2/jobs.log")"
wait_jobs "$run2"
[[ $(job_state "$merge_job") == CANCELLED ]] || fail "the old merge job $merge_job was left $(job_state "$merge_job")"
[[ $(job_state "$merge_job2") == COMPLETED ]] \
  || fail "merge job $merge_job2 of run 2 ended $(job_state "$merge_job2"): $(cat "$run2"/logs/merge-"$merge_job2".out)"
same_as_reference "$run2/image.exr"
out=$("$src/pipelines/slurm/resubmit.sh" "$run2")
grep -q "nothing to do" <<< "$out" || fail "resubmit.sh of a finished run did something: $out"

# 3. The same parts with make -j on this machine, merged as a tree (fan-in 2).
run3=$tmp/run3
"$src/pipelines/slurm/submit.sh" "${run_opts[@]}" --out "$run3" --fanin 2 --prepare-only > /dev/null
make -s -C "$src" -j2 -f pipelines/slurm/local.mk RUN="$run3" > "$tmp/local.log" 2>&1 \
  || fail "make -f pipelines/slurm/local.mk failed: $(tail -n 5 "$tmp/local.log")"
grep -q "level 1: 2 merged" "$tmp/local.log" || fail "run 3 was not merged as a tree: $(cat "$tmp/local.log")"
same_as_reference "$run3/image.exr"

echo "$T: passed"
