#!/usr/bin/env bash
# Runs a study as N shards under OpenMPI's launcher, then merges their CSVs into one.
# Usage: scripts/mpirun_study.sh N OUT.csv [snowsim study options, e.g. --preset full]
# Each rank runs `snowsim study --shard RANK+1/N` (no MPI calls: the rank comes from
# OMPI_COMM_WORLD_RANK); the shards' CSVs stay in OUT.shards/, so a rerun resumes them.
# SNOWSIM: the binary (default build/app/snowsim); MPIRUN_ARGS: extra mpirun options, e.g.
# "--oversubscribe --hostfile hosts".
set -euo pipefail
snowsim=${SNOWSIM:-$(cd "$(dirname "$0")/.." && pwd)/build/app/snowsim}

if [ -n "${OMPI_COMM_WORLD_RANK:-}" ]; then  # one rank: one shard
  shards=$1
  shift
  shard=$((OMPI_COMM_WORLD_RANK + 1))/$OMPI_COMM_WORLD_SIZE
  # The machine's cores shared between its ranks, unless OMP_NUM_THREADS or --threads says.
  cores=$(($(nproc) / ${OMPI_COMM_WORLD_LOCAL_SIZE:-1}))
  export OMP_NUM_THREADS=${OMP_NUM_THREADS:-$((cores > 0 ? cores : 1))}
  exec "$snowsim" study --shard "$shard" \
    -o "$shards/shard-$((OMPI_COMM_WORLD_RANK + 1))-of-$OMPI_COMM_WORLD_SIZE.csv" "$@"
fi

# shellcheck source=scripts/study_launch.sh
. "$(dirname "$0")/study_launch.sh"
read_launch_arguments "$@"
# shellcheck disable=SC2086  # MPIRUN_ARGS is a list of options
mpirun ${MPIRUN_ARGS:-} -np "$count" "$0" "$shards" ${study_args[@]+"${study_args[@]}"}
set_merge_command
"${merge_command[@]}"
