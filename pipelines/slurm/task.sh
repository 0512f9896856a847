#!/usr/bin/env bash
# task.sh RUN — one task of a run of pipelines/slurm/ (the batch script of the job array; local.mk
# runs it with SLURM_ARRAY_TASK_ID set): task k renders passes k*PPT .. (k+1)*PPT-1 into its part,
# RUN/parts/passes-FIRST-LAST.h5 (render --sums). render writes the part atomically: a task killed
# at any moment leaves the whole part or none. A part already there (a requeued task that had
# finished) is kept: its range, scene, seed and options are those of this run.
set -euo pipefail
RUN=${1:?usage: task.sh RUN}
# Slurm runs a copy of this script from its spool folder: common.sh is found through run.env.
[[ -f $RUN/run.env ]] || { echo "task.sh: $RUN/run.env: no such file (not a run folder)" >&2; exit 2; }
# shellcheck disable=SC1091
source "$RUN/run.env"
PF_SCRIPT=task.sh
# shellcheck disable=SC1091
source "$PIPE/common.sh"
pf_load "$RUN"

k=${SLURM_ARRAY_TASK_ID:?task.sh runs as a task of a Slurm job array (or from local.mk)}
[[ $k =~ ^[0-9]+$ ]] && ((k < TASKS)) || pf_die "task $k is not one of the run's tasks 0..$((TASKS - 1))"
part=$(pf_part "$k")
first=$((k * PPT))
if [[ -f $part ]]; then
  echo "task.sh: task $k: $part is there already (passes $first..$((first + PPT - 1))); nothing to do"
  exit 0
fi
# A task killed outright (SIGKILL, a node lost) may have left its temporary file (FORMATS.md).
rm -f "$part".tmp.*
# On a Slurm node: as many threads as the task has cores; elsewhere (local.mk) THREADS, 0 = all.
threads=${SLURM_CPUS_PER_TASK:-${THREADS:-0}}
echo "task.sh: task $k on $(hostname): passes $first..$((first + PPT - 1)) -> $part"
exec "$BIN/render" --scene "$RUN/scene.h5" --estimator pppm --first-pass "$first" --passes "$PPT" \
  --photons "$PHOTONS" --seed "$SEED" --alpha "$ALPHA" --radius "$RADIUS" --threads "$threads" \
  --sums "$part"
