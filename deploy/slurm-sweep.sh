#!/usr/bin/env bash
# The paper's simulation study as a SLURM array job: N shards, then a merge.
#
#   sbatch --array=0-15 deploy/slurm-sweep.sh            # 16 shards
#   sbatch --dependency=afterok:<jobid> --wrap \
#     "target/release/orchestrator merge study/ --out study/"
#
# Each task runs `orchestrator sweep --shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT`
# into the shared directory $OUT (default study/). Resubmitting a task resumes it.
#SBATCH --job-name=bycoms-sweep
#SBATCH --cpus-per-task=4
#SBATCH --mem=1G
#SBATCH --time=00:30:00
set -euo pipefail
OUT=${OUT:-study}
BIN=${BIN:-target/release/orchestrator}
SEED=${SEED:-1}
: "${SLURM_ARRAY_TASK_ID:?run this with sbatch --array=0-N}"
: "${SLURM_ARRAY_TASK_COUNT:?run this with sbatch --array=0-N}"
exec "$BIN" sweep --seed "$SEED" --out "$OUT" \
  --jobs "${SLURM_CPUS_PER_TASK:-1}" \
  --shard "${SLURM_ARRAY_TASK_ID}/${SLURM_ARRAY_TASK_COUNT}"
