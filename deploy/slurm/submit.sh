#!/bin/bash
# Submits a sharded study: a job array of SHARDS tasks, then a merge job that
# starts only if every task succeeded (afterok).
#
#   SCENE=configs/corner3.toml SHARDS=16 OUT=results/corner3-shards bash deploy/slurm/submit.sh
#
# What each task gets comes from the submission, with these defaults:
#   CPUS_PER_TASK=1     CPUs per shard (the shard runs that many threads)
#   TIME_LIMIT=02:00:00 per shard; MERGE_TIME_LIMIT=00:30:00 for the merge
#   PARTITION=          the cluster's default partition when empty
# IMPACTMC (the binary), EXTRA_ARGS (more `impactmc run` options) and
# MERGED (the merged folder, default OUT/merged) are passed on to the jobs.
#
# Prints the two job ids as `array=ID merge=ID` on its last line.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
SCENE="${SCENE:-configs/corner3.toml}"
SHARDS="${SHARDS:-8}"
OUT="${OUT:-results/shards}"
CPUS_PER_TASK="${CPUS_PER_TASK:-1}"
TIME_LIMIT="${TIME_LIMIT:-02:00:00}"
MERGE_TIME_LIMIT="${MERGE_TIME_LIMIT:-00:30:00}"
PARTITION="${PARTITION:-}"
export SCENE SHARDS OUT
partition=()
if [ -n "$PARTITION" ]; then
    partition=(--partition="$PARTITION")
fi
array=$(sbatch --parsable --array=0-$((SHARDS - 1)) --cpus-per-task="$CPUS_PER_TASK" \
    --time="$TIME_LIMIT" "${partition[@]}" --export=ALL "$here/impactmc-shard.sbatch")
array="${array%%;*}"
merge=$(sbatch --parsable --dependency=afterok:"$array" --cpus-per-task=1 \
    --time="$MERGE_TIME_LIMIT" "${partition[@]}" --export=ALL "$here/impactmc-merge.sbatch")
merge="${merge%%;*}"
echo "submitted shard array $array and its merge job $merge (it starts when every shard has succeeded)"
echo "array=$array merge=$merge"
