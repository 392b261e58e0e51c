#!/usr/bin/env bash
# A campaign as a Slurm job array: one array task per shard, then a merge job.
#
#   n=16
#   job=$(sbatch --parsable --array=1-$n scripts/campaign/slurm-array.sh PLAN OUT)
#   sbatch --dependency=afterany:$job --wrap "rtdiff campaign merge OUT/shard-* -o OUT/report"
#
# A task that is preempted or killed (scancel, node failure, time limit) resumes when requeued or
# resubmitted: finished items are skipped and only the one in progress is redone. Shards write to
# OUT/shard-K on the shared file system. RTDIFF names the rtdiff binary (default: rtdiff on PATH).
#SBATCH --job-name=rtdiff-campaign
#SBATCH --cpus-per-task=8
#SBATCH --time=01:00:00
#SBATCH --requeue
#SBATCH --output=rtdiff-campaign-%A-%a.log
set -euo pipefail
[[ $# -eq 2 ]] || { sed -n '2,11s/^# \{0,1\}//p' "${BASH_SOURCE[0]}" >&2; exit 2; }
plan="$1" out="$2"
: "${SLURM_ARRAY_TASK_ID:?run as a job array: sbatch --array=1-N $0 PLAN OUT}"
n="${SLURM_ARRAY_TASK_COUNT:?SLURM_ARRAY_TASK_COUNT is not set (Slurm 18.08 or later)}"
# Shards count from 1 whatever the array's first index (--array=0-15 works too).
k=$(( SLURM_ARRAY_TASK_ID - ${SLURM_ARRAY_TASK_MIN:-1} + 1 ))
export RAYON_NUM_THREADS="${SLURM_CPUS_PER_TASK:-$(nproc)}"
mkdir -p "$out"
exec "${RTDIFF:-rtdiff}" campaign "$plan" --shard "$k/$n" -o "$out/shard-$k" --quiet
