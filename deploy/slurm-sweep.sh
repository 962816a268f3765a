#!/usr/bin/env bash
# The paper's simulation study as a Slurm array job: N shards, then a merge.
#
#   sbatch --array=0-15 deploy/slurm-sweep.sh            # 16 shards
#   sbatch --dependency=afterok:<jobid> --kill-on-invalid-dep=yes \
#     --wrap "target/release/orchestrator merge study/ --out study/"
#
# Each task runs `orchestrator sweep --shard $SLURM_ARRAY_TASK_ID/$SHARDS`
# into the shared directory $OUT (default study/), with one worker thread
# per CPU Slurm gives it (`--cpus-per-task`, default 1). Arguments after the
# script are the sweep's own (the plan: `--eps 1,3 --terrains-per-bin 10`,
# …); give every task the same ones.
#
# A task that was cancelled, preempted or timed out resumes its shard when
# resubmitted alone; say how many shards the study has, since Slurm's count
# is then the resubmitted array's:
#
#   SHARDS=16 sbatch --array=3 deploy/slurm-sweep.sh
#
# Run by tests/tests/slurm.rs on a one-host Slurm cluster (see deploy/README.md).
#SBATCH --job-name=bycoms-sweep
#SBATCH --cpus-per-task=1
#SBATCH --mem=1G
#SBATCH --time=00:30:00
set -euo pipefail
OUT=${OUT:-study}
BIN=${BIN:-target/release/orchestrator}
SEED=${SEED:-1}
: "${SLURM_ARRAY_TASK_ID:?run this with sbatch --array=0-N}"
: "${SLURM_ARRAY_TASK_COUNT:?run this with sbatch --array=0-N}"
if [ -z "${SHARDS:-}" ]; then
  # Slurm's count is the shard count only for a whole array 0..N-1, N ≥ 2
  # (a single task is a resubmitted one: its count says nothing).
  if [ "$SLURM_ARRAY_TASK_COUNT" -lt 2 ] || [ "${SLURM_ARRAY_TASK_MIN:-0}" != 0 ] ||
    [ "$((SLURM_ARRAY_TASK_MAX + 1))" != "$SLURM_ARRAY_TASK_COUNT" ]; then
    echo "slurm-sweep.sh: the array is not 0-$((SLURM_ARRAY_TASK_COUNT - 1)) but" \
      "${SLURM_ARRAY_TASK_MIN}-${SLURM_ARRAY_TASK_MAX} (${SLURM_ARRAY_TASK_COUNT} tasks):" \
      "set SHARDS to the study's shard count, e.g. SHARDS=16 sbatch --array=3 …" >&2
    exit 2
  fi
  SHARDS=$SLURM_ARRAY_TASK_COUNT
fi
exec "$BIN" sweep --seed "$SEED" --out "$OUT" \
  --jobs "${SLURM_CPUS_PER_TASK:-1}" \
  --shard "${SLURM_ARRAY_TASK_ID}/${SHARDS}" "$@"
