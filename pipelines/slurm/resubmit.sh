#!/usr/bin/env bash
# resubmit.sh RUN — after a task of a run failed or was cancelled (or a node died): submits the
# tasks whose part is missing and that are not queued or running any more, alone, as one job
# array, and a new merge job after them; the run's old merge job, which would wait for ever on
# its failed array (afterok), is cancelled. The new tasks use the run's recorded scene, seed and
# options (RUN/run.env), so their parts merge with the others exactly.
#
#   pipelines/slurm/resubmit.sh RUN            submit what is missing (prints the job ids)
#   pipelines/slurm/resubmit.sh --status RUN   only say which tasks are done, queued or missing
#
# Nothing missing and the image there: says so and submits nothing. Exit 2 on a bad run folder.
set -euo pipefail
PF_SCRIPT=resubmit.sh
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
status_only=0
[[ ${1:-} == --status ]] && { status_only=1; shift; }
[[ $# -eq 1 ]] || pf_die "usage: resubmit.sh [--status] RUN"
pf_load "$1"
command -v squeue >/dev/null || pf_die "squeue not found: not a Slurm node (on one machine: make -j -f pipelines/slurm/local.mk RUN=$RUN)"

pf_check_queue
active=$(pf_active_tasks | sort -un)
todo=()
done_n=0
for ((k = 0; k < TASKS; ++k)); do
  if [[ -f $(pf_part "$k") ]]; then
    done_n=$((done_n + 1))
  elif ! grep -qx "$k" <<< "$active"; then
    todo+=("$k")
  fi
done
queued=$(grep -c . <<< "$active" || true)
echo "resubmit.sh: $RUN: $done_n of $TASKS parts done, $queued tasks queued or running, ${#todo[@]} missing${todo:+: ${todo[*]}}"
((status_only)) && exit 0

merges=$(pf_active_jobs merge)
if ((${#todo[@]} == 0)); then
  if [[ -f $RUN/image.exr && $done_n -eq $TASKS ]]; then echo "resubmit.sh: $RUN/image.exr is there; nothing to do"; exit 0; fi
  if [[ -n $merges ]]; then echo "resubmit.sh: merge job $(paste -sd' ' <<< "$merges") is queued; nothing to do"; exit 0; fi
  # All parts there (or coming) but no merge queued: only the merge.
  waits=$(pf_active_jobs tasks | paste -sd: -)
  merge_job=$(pf_submit_merge "${waits:+afterany:$waits}")
  echo "resubmit.sh: merge job $merge_job"
  exit 0
fi

# The old merge job depends (afterok) on an array with a failed task: it would never start.
for j in $merges; do scancel "$j" && echo "resubmit.sh: cancelled the old merge job $j"; done
ids=$(pf_submit "$(IFS=,; echo "${todo[*]}")")
read -r tasks_job merge_job <<< "$ids"
echo "resubmit.sh: tasks job $tasks_job (array $(IFS=,; echo "${todo[*]}")), merge job $merge_job"
echo "$tasks_job $merge_job"
