# shellcheck shell=bash
# common.sh — shared by the scripts of pipelines/slurm/ (sourced, not run).
#
# A run lives in one folder RUN on a file system every node sees:
#   RUN/run.env          the run's description (written once by submit.sh, sourced by every script)
#   RUN/scene.h5         the baked scene, copied in so that every task reads the same bytes
#   RUN/parts/           one partial result per task ("photonflow.pass-sums", render --sums)
#   RUN/jobs.log         every job submitted for the run: kind, Slurm job id, array tasks
#   RUN/logs/            the jobs' stdout and stderr
#   RUN/image.exr, RUN/image.png, RUN/run.json   the merged image and its run record (merge.sh)
# Task k renders passes k*PPT .. (k+1)*PPT-1 (0-based) of the TASKS*PPT passes.

pf_die() { echo "$PF_SCRIPT: $*" >&2; exit 2; }

# The folder of these scripts (absolute), for the jobs, whose batch script Slurm copies away.
PF_SLURM_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)

# pf_load RUN: checks RUN and sources its run.env.
pf_load() {
  [[ -f $1/run.env ]] || pf_die "$1: no run.env here: not a run folder of pipelines/slurm/submit.sh (give the --out folder of submit.sh)"
  # shellcheck disable=SC1091
  source "$1/run.env"
}

# pf_part K: the partial result of task K (zero-padded first and last pass, so names sort by range).
pf_part() {
  local first=$(($1 * PPT))
  printf '%s/parts/passes-%08d-%08d.h5' "$RUN" "$first" $((first + PPT - 1))
}

# pf_missing: the tasks whose part is absent, one per line.
pf_missing() {
  local k
  for ((k = 0; k < TASKS; ++k)); do [[ -f $(pf_part "$k") ]] || echo "$k"; done
}

# pf_log KIND JOBID [TASKS]: appends a line to RUN/jobs.log.
pf_log() { printf '%s %s %s %s\n' "$(date -u +%FT%TZ)" "$1" "$2" "${3:-}" >> "$RUN/jobs.log"; }

# pf_check_queue: stops the script unless squeue answers (the controller is reachable); after it,
# pf_queued's failures are the ids Slurm has forgotten.
pf_check_queue() {
  local out
  out=$(squeue -h -o %i 2>&1) || pf_die "squeue failed, so the queue is unknown: $out"
}

# pf_queued ID FORMAT: squeue's FORMAT field of job ID's tasks still in the queue (none once the
# job has left it, also when Slurm has forgotten the id). Any other failure of squeue stops the
# script: a controller that does not answer must not make running tasks look missing.
pf_queued() {
  local out
  if ! out=$(squeue -h -r -j "$1" -o "$2" 2>&1); then
    [[ $out == *"Invalid job id"* ]] && return 0
    pf_die "squeue -j $1 failed: $out"
  fi
  [[ -n $out ]] && echo "$out"
  return 0
}

# pf_active_tasks: array tasks of this run's task jobs still queued or running, one per line.
pf_active_tasks() {
  local id
  for id in $(awk '$2 == "tasks" { print $3 }' "$RUN/jobs.log" 2>/dev/null); do
    pf_queued "$id" %K | grep -E '^[0-9]+$' || true
  done
}

# pf_active_jobs KIND: this run's jobs of KIND (tasks | merge) still in the queue, one per line.
pf_active_jobs() {
  local id
  for id in $(awk -v k="$1" '$2 == k { print $3 }' "$RUN/jobs.log" 2>/dev/null); do
    [[ -n $(pf_queued "$id" %i) ]] && echo "$id"
  done
  return 0
}

# pf_opts: the run's Slurm options for every job, into the array PF_OPTS.
pf_opts() {
  PF_OPTS=(--ntasks 1)
  [[ -n $PARTITION ]] && PF_OPTS+=(--partition "$PARTITION")
  [[ -n $TIME_LIMIT ]] && PF_OPTS+=(--time "$TIME_LIMIT")
  [[ -n $MEM ]] && PF_OPTS+=(--mem "$MEM")
  return 0
}

# pf_submit_merge [DEPENDENCY]: submits the merge job (after DEPENDENCY); prints its id.
pf_submit_merge() {
  local dep=() id
  [[ -n ${1:-} ]] && dep=(--dependency "$1")
  pf_opts
  id=$(sbatch --parsable --job-name "pf-${NAME}-merge" "${dep[@]}" --cpus-per-task "$MERGE_CPUS" \
    --output "$RUN/logs/merge-%j.out" "${PF_OPTS[@]}" "$PF_SLURM_DIR/merge.sh" "$RUN") \
    || pf_die "sbatch refused the merge job (see above)"
  id=${id%%;*}
  pf_log merge "$id"
  echo "$id"
}

# pf_submit K,K,...: submits those tasks as one job array (--requeue: Slurm reruns a task whose
# node failed), then the merge job after it. Prints the two job ids.
pf_submit() {
  local tasks_job merge_job dep waits
  mkdir -p "$RUN/logs" "$RUN/parts"
  waits=$(pf_active_jobs tasks | paste -sd: -)
  pf_opts
  tasks_job=$(sbatch --parsable --job-name "pf-${NAME}" --array "$1" --requeue \
    --cpus-per-task "$CPUS_PER_TASK" --output "$RUN/logs/task-%A_%a.out" \
    "${PF_OPTS[@]}" "$PF_SLURM_DIR/task.sh" "$RUN") || pf_die "sbatch refused the task array (see above)"
  tasks_job=${tasks_job%%;*}
  pf_log tasks "$tasks_job" "$1"
  # afterok: the merge runs only when every task of the new array succeeded. Tasks of earlier
  # arrays still queued (a resubmission) may yet fail, so for them afterany; merge.sh checks
  # that every part is there.
  dep="afterok:$tasks_job"
  [[ -n $waits ]] && dep+=",afterany:$waits"
  merge_job=$(pf_submit_merge "$dep")
  echo "$tasks_job $merge_job"
}
