#!/usr/bin/env bash
# Weak scaling counts of distributed TNNMG (bench/distributed): step-42's problem on a box that
# grows with the ranks, 1 rank on 4x4x4 coarse cells, 2 on 8x4x4, 4 on 8x8x4, 8 on 8x8x8, and so on
# doubling x, y, z in turn up to 64 ranks on 16x16x16 (refine K, default 3: about 108,000 unknowns
# per rank; RANKS, default "1 2 4 8", picks the runs). More ranks than cores are oversubscribed, so
# the tables report counts, not times (docs/performance.md#distributed-weak): the first the grid,
# the halo and the memory, the second the communication per TNNMG iteration (largest rank).
# PARTITION_LEVEL=0 distributes the coarse level too (hypre's CG + BoomerAMG solves it; by default
# the levels below the partition level, at least level 0, are replicated on every rank).
#   [RANKS="1 2 4 8 16 32 64"] [PARTITION_LEVEL=0] scripts/distributed_weak.sh OUT.tsv [REFINE]
set -euo pipefail
out=${1:?usage: [RANKS=...] scripts/distributed_weak.sh OUT.tsv [REFINE]}
refine=${2:-3}
bench=${BENCH:-build/bench/distributed}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE
declare -A box=([1]=4,4,4 [2]=8,4,4 [4]=8,8,4 [8]=8,8,8 [16]=16,8,8 [32]=16,16,8 [64]=16,16,16)
rm -f "$out"
for np in ${RANKS:-1 2 4 8}; do
  [[ -n "${box[$np]:-}" ]] || { echo "distributed_weak.sh: no box for $np ranks (1, 2, 4, ..., 64)" >&2; exit 2; }
  # shellcheck disable=SC2086
  mpirun --oversubscribe -np "$np" "$bench" "$out" --refine "$refine" --cells "${box[$np]}" ${PARTITION_LEVEL:+--partition-level $PARTITION_LEVEL}
done
/usr/bin/python3 "$(dirname "$0")/distributed_tables.py" weak "$out"
