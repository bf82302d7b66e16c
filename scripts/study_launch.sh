# shellcheck shell=bash
# Shared by scripts/mpirun_study.sh and scripts/slurm_study.sh (sourced, not run).

# Reads "N OUT.csv [snowsim study options]" into count, out, shards (OUT.shards/, created) and
# study_args; exits with the usage when N is not a whole number >= 1.
read_launch_arguments() {
  if [ $# -lt 2 ] || ! [[ $1 =~ ^[1-9][0-9]*$ ]]; then
    echo "usage: $0 N OUT.csv [snowsim study options]  (N: shards, a whole number >= 1)" >&2
    exit 2
  fi
  count=$1
  out=$2
  shift 2
  study_args=("$@")
  shards=${out%.csv}.shards
  mkdir -p "$shards"
}

# Sets merge_command: the command that joins the count shards' CSVs (shard-I-of-N.csv in
# shards/) into out.
set_merge_command() {
  local files=() shard
  for ((shard = 1; shard <= count; ++shard)); do files+=("$shards/shard-$shard-of-$count.csv"); done
  # shellcheck disable=SC2034  # read by the scripts that source this file
  merge_command=("$snowsim" study ${study_args[@]+"${study_args[@]}"} --merge "${files[@]}" -o "$out")
}
