#!/bin/bash
# Submits a sharded study: a job array of SHARDS tasks, then a merge job that
# starts only if every task succeeded.
#
#   SCENE=configs/corner3.toml SHARDS=16 OUT=results/corner3-shards bash deploy/slurm/submit.sh
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
SCENE="${SCENE:-configs/corner3.toml}"
SHARDS="${SHARDS:-8}"
OUT="${OUT:-results/shards}"
export SCENE SHARDS OUT
array=$(sbatch --parsable --array=0-$((SHARDS - 1)) --export=ALL "$here/impactmc-shard.sbatch")
array="${array%%;*}"
sbatch --dependency=afterok:"$array" --export=ALL "$here/impactmc-merge.sbatch"
echo "submitted shard array $array and its merge job"
