#!/usr/bin/env bash
# A study across a Slurm cluster: a job array of shards, then a merge job that waits for them.
# Usage (on the login node, from the repository):
#   scripts/slurm_study.sh N OUT.csv [snowsim study options, e.g. --preset full]
# submits `sbatch --array=1-N` of this script (each task runs
# `snowsim study --shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT` into OUT.shards/) and a
# merge job with --dependency=afterok on the array. A failed task leaves the merge unrun; resubmit
# and the shards resume (rows already measured are skipped). SNOWSIM: the binary (default
# build/app/snowsim, on a file system the nodes share). SBATCH_ARGS: options for both sbatch
# calls, e.g. "--partition=short --account=snow --time=02:00:00" (sbatch's own SBATCH_PARTITION,
# SBATCH_ACCOUNT and SBATCH_TIMELIMIT work too). SBATCH: the sbatch command (default: sbatch).
#SBATCH --job-name=snowsim-study
#SBATCH --cpus-per-task=2
#SBATCH --array=1-8
#SBATCH --output=slurm-study-%A_%a.out
set -euo pipefail
snowsim=${SNOWSIM:-$(cd "$(dirname "$0")/.." && pwd)/build/app/snowsim}

if [ -n "${SLURM_ARRAY_TASK_ID:-}" ]; then  # one array task: one shard
  shards=$1
  shift
  task=$SLURM_ARRAY_TASK_ID
  count=${SLURM_ARRAY_TASK_COUNT:?is not set: run as a task of the array this script submits}
  # The task's CPUs as the solver's threads, unless the study options give --threads.
  export OMP_NUM_THREADS=${SLURM_CPUS_PER_TASK:-${OMP_NUM_THREADS:-1}}
  exec "$snowsim" study --shard "$task/$count" -o "$shards/shard-$task-of-$count.csv" "$@"
fi

sbatch=${SBATCH:-sbatch}
if ! command -v "$sbatch" > /dev/null; then
  echo "$0: sbatch not found: run it on a Slurm login node (scripts/mpirun_study.sh runs the" \
    "shards under mpirun)" >&2
  exit 2
fi
# shellcheck source=scripts/study_launch.sh
. "$(dirname "$0")/study_launch.sh"
read_launch_arguments "$@"
read -r -a options <<< "${SBATCH_ARGS:-}"
# "${a[@]}" of an empty array is an unbound variable under set -u before bash 4.4.
submit=("$sbatch" ${options[@]+"${options[@]}"})
# sbatch runs a copy of this script, so the binary goes by its absolute path.
export SNOWSIM=$snowsim
array=$("${submit[@]}" --parsable --export=ALL --array="1-$count" "$0" "$shards" \
  ${study_args[@]+"${study_args[@]}"})
array=${array%%;*}  # "jobid;cluster" on federated clusters
set_merge_command
quoted=$(printf ' %q' "${merge_command[@]}")
merge=$("${submit[@]}" --parsable --job-name=snowsim-study-merge \
  --dependency="afterok:$array" \
  --wrap="${quoted# }")
echo "submitted shards as job array $array and the merge as job ${merge%%;*}"
