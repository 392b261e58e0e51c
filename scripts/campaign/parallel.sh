#!/usr/bin/env bash
# A campaign on one machine with GNU parallel: N shards, J at a time (each with its share of the
# cores), then one merged report. Killed, it resumes when run again: finished items are skipped.
#
#   scripts/campaign/parallel.sh PLAN OUT [N] [J]     # N shards (default 4), J at once (default 2)
#
# Writes OUT/shard-1 .. OUT/shard-N and the report OUT/report/{index.html,campaign.md,campaign.json}.
# RTDIFF names the rtdiff binary (default: rtdiff on the PATH). Needs GNU parallel (Debian: parallel).
set -euo pipefail
[[ $# -ge 2 ]] || { sed -n '2,9s/^# \{0,1\}//p' "${BASH_SOURCE[0]}" >&2; exit 2; }
plan="$1" out="$2" n="${3:-4}" j="${4:-2}"
rtdiff="${RTDIFF:-rtdiff}"
command -v parallel >/dev/null || { echo "parallel.sh: GNU parallel not found (apt-get install parallel)" >&2; exit 1; }
mkdir -p "$out"
# Each of the J shards running at once gets its share of the cores.
export RAYON_NUM_THREADS=$(( ($(nproc) + j - 1) / j ))
parallel --will-cite --jobs "$j" --halt now,fail=1 \
    "$rtdiff" campaign "$plan" --shard "{}/$n" -o "$out/shard-{}" --quiet ::: $(seq 1 "$n")
shards=()
for k in $(seq 1 "$n"); do shards+=("$out/shard-$k"); done
"$rtdiff" campaign merge "${shards[@]}" -o "$out/report" --require-complete
