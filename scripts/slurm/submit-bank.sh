#!/usr/bin/env bash
# Submits a bank build to Slurm: an array of N shard jobs, then the merge job that runs only
# if every shard succeeded (afterok dependency).
#   scripts/slurm/submit-bank.sh N CALIBRATION.toml BANK_DIR [extra `bank generate` args]
# The extra args (e.g. --instances, --seed, --shard-size) must be the same for both steps:
# they determine the bank's identity. WHEELFLAT_SBATCH_ARGS adds sbatch options to both
# submissions (e.g. "--cpus-per-task=4 --partition=short"); they override the scripts'
# #SBATCH lines. With `--speeds FROM:TO:STEP` and/or `--loads FROM:TO:STEP` (a bank family) every task builds its part of
# every member, and the merge completes each member and then writes family.json.
set -euo pipefail
n=${1:?number of shards}
calibration=${2:?calibration file}
bank=${3:?bank directory}
shift 3
here=$(cd "$(dirname "$0")" && pwd)
read -r -a extra <<<"${WHEELFLAT_SBATCH_ARGS:-}"
array=$(sbatch --parsable "${extra[@]}" --array="0-$((n - 1))" "$here/bank-array.sbatch" "$calibration" "$bank" "$@")
merge=$(sbatch --parsable "${extra[@]}" --dependency="afterok:${array}" "$here/bank-merge.sbatch" "$calibration" "$bank" "$@")
echo "submitted shard array $array ($n tasks) and merge job $merge"
