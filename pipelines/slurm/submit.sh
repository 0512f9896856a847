#!/usr/bin/env bash
# submit.sh — render one image on a Slurm cluster: a job array of TASKS tasks, task k rendering
# passes k*P .. (k+1)*P-1 with the probabilistic PPM estimator (render --estimator pppm, whose
# passes are independent), then a merge job (--dependency=afterok on the array) that merges the
# parts into the image of all TASKS*P passes and its run record. Layout of the run folder:
# common.sh. The merged image equals `render --estimator pppm --passes TASKS*P` on one machine
# (same scene, seed and options) up to float summation order.
#
#   pipelines/slurm/submit.sh --scene scene.h5 --out RUN [options]
#
#   --scene FILE         baked scene (scene-bake's scene.h5); copied into RUN
#   --out RUN            the run folder, on a file system the nodes share; must not hold a run yet
#   --tasks K            tasks of the job array (default 4)
#   --passes-per-task P  passes each task renders (default 16)
#   --photons N          photons per pass, or auto: render's count from the image size
#                        (render_defaults.h; default auto)
#   --seed S             random seed (default 1)
#   --alpha A            PPM's alpha (default 0.7)
#   --radius R           initial radius, 0 = automatic (default 0)
#   --cpus-per-task C    cores per task (render uses that many threads) and for the merge (default 1)
#   --partition NAME     Slurm partition (default: the cluster's default)
#   --time LIMIT         Slurm time limit per task and for the merge, e.g. 30:00 (default: none)
#   --mem MEM            memory per task and for the merge, e.g. 2G (default: the cluster's default)
#   --fanin F            parts merged at once; more parts are merged as a tree (default 64)
#   --bin DIR            photonflow's executables, on the shared file system (default build/bin)
#   --prepare-only       write RUN and submit nothing (pipelines/slurm/local.mk then runs the
#                        same tasks and merge with make -j)
#
# A failed or cancelled task: pipelines/slurm/resubmit.sh RUN submits the missing ranges alone.
# Exit codes: 0 submitted (prints the two job ids), 2 bad options or sbatch refused.
set -euo pipefail
PF_SCRIPT=submit.sh
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

scene="" RUN="" TASKS=4 PPT=16 PHOTONS=auto SEED=1 ALPHA=0.7 RADIUS=0 CPUS_PER_TASK=1
PARTITION="" TIME_LIMIT="" MEM="" FANIN=64 BIN=build/bin prepare_only=0
while [[ $# -gt 0 ]]; do
  opt=$1
  case $opt in
    --prepare-only) prepare_only=1; shift; continue ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    --*) [[ $# -ge 2 ]] || pf_die "$opt needs a value" ;;
    *) pf_die "unexpected argument '$opt' (see --help)" ;;
  esac
  val=$2; shift 2
  case $opt in
    --scene) scene=$val ;;            --out) RUN=$val ;;
    --tasks) TASKS=$val ;;            --passes-per-task) PPT=$val ;;
    --photons) PHOTONS=$val ;;        --seed) SEED=$val ;;
    --alpha) ALPHA=$val ;;            --radius) RADIUS=$val ;;
    --cpus-per-task) CPUS_PER_TASK=$val ;;
    --partition) PARTITION=$val ;;    --time) TIME_LIMIT=$val ;;
    --mem) MEM=$val ;;                --fanin) FANIN=$val ;;
    --bin) BIN=$val ;;
    *) pf_die "unknown option '$opt' (see --help)" ;;
  esac
done

is_count() { [[ $1 =~ ^[1-9][0-9]*$ ]] && (($1 <= 1000000)); }
[[ -n $scene ]] || pf_die "--scene FILE is needed (a scene.h5 of scene-bake)"
[[ -n $RUN ]] || pf_die "--out RUN is needed (the run folder, on a file system the nodes share)"
[[ -f $scene ]] || pf_die "$scene: no such file (bake the scene first: build/bin/scene-bake)"
is_count "$TASKS" || pf_die "--tasks must be a whole number from 1 to 1000000, not '$TASKS'"
is_count "$PPT" || pf_die "--passes-per-task must be a whole number from 1 to 1000000, not '$PPT'"
is_count "$CPUS_PER_TASK" || pf_die "--cpus-per-task must be a whole number >= 1, not '$CPUS_PER_TASK'"
[[ $PHOTONS == auto || $PHOTONS =~ ^[1-9][0-9]*$ ]] || pf_die "--photons must be a whole number >= 1 or auto, not '$PHOTONS'"
[[ $SEED =~ ^[0-9]+$ ]] || pf_die "--seed must be a whole number >= 0, not '$SEED'"
is_real() { [[ $1 =~ ^[0-9]*\.?[0-9]+([eE][-+]?[0-9]+)?$ ]]; }
is_real "$ALPHA" || pf_die "--alpha must be a number in (0, 1], not '$ALPHA'"
is_real "$RADIUS" || pf_die "--radius must be a number >= 0, not '$RADIUS'"
[[ $FANIN =~ ^[0-9]+$ ]] && ((FANIN >= 2)) || pf_die "--fanin must be a whole number >= 2, not '$FANIN'"
((TASKS * PPT < 2147483647)) || pf_die "--tasks times --passes-per-task must be below 2^31"
for exe in render merge; do
  [[ -x $BIN/$exe ]] || pf_die "$BIN/$exe: not found (build photonflow, or give --bin DIR)"
done
if [[ -e $RUN/run.env ]]; then
  pf_die "$RUN: holds a run already (resubmit its missing tasks with pipelines/slurm/resubmit.sh $RUN, or choose another --out)"
fi
if ((!prepare_only)); then
  command -v sbatch >/dev/null || pf_die "sbatch not found: not a Slurm node (or use --prepare-only and pipelines/slurm/local.mk)"
  pf_check_queue
fi

mkdir -p "$RUN/parts" "$RUN/logs" || pf_die "$RUN: cannot create the run folder"
RUN=$(cd "$RUN" && pwd)
BIN=$(cd "$BIN" && pwd)
cp "$scene" "$RUN/scene.h5.tmp" && mv "$RUN/scene.h5.tmp" "$RUN/scene.h5" \
  || pf_die "$RUN: cannot copy the scene into the run folder"
NAME=$(basename "$RUN")
MERGE_CPUS=$CPUS_PER_TASK   # the merge job: a tree level's merges run side by side
{
  echo "# photonflow Slurm run, written by pipelines/slurm/submit.sh on $(date -u +%FT%TZ)"
  PIPE=$PF_SLURM_DIR
  for v in RUN BIN PIPE NAME TASKS PPT PHOTONS SEED ALPHA RADIUS CPUS_PER_TASK MERGE_CPUS PARTITION \
           TIME_LIMIT MEM FANIN; do
    printf '%s=%q\n' "$v" "${!v}"
  done
} > "$RUN/run.env.tmp" && mv "$RUN/run.env.tmp" "$RUN/run.env"

if ((prepare_only)); then
  echo "submit.sh: $RUN prepared ($TASKS tasks of $PPT passes); run: make -j -f pipelines/slurm/local.mk RUN=$RUN"
  exit 0
fi
ids=$(pf_submit "0-$((TASKS - 1))")
read -r tasks_job merge_job <<< "$ids"
echo "submit.sh: $RUN: tasks job $tasks_job (array 0-$((TASKS - 1)), $PPT passes each), merge job $merge_job"
echo "$tasks_job $merge_job"
