#!/usr/bin/env bash
# Distributed TNNMG on step-42 (bench/distributed), 1 and 2 ranks side by side (RANKS="1 2 4 8" for
# more; oversubscribed beyond the cores, so compare counts, not times), for the given refinements
# (default 3 4): writes the rows to OUT.tsv and prints the Markdown tables of
# docs/performance.md#distributed (ratios to 1 rank from the same script run; the communication per
# TNNMG iteration of the largest rank). scripts/cluster_model.py reads OUT.tsv.
# PARTITION_LEVEL=0: the coarse level distributed too (hypre), as in distributed_weak.sh.
#   scripts/distributed_bench.sh OUT.tsv [REFINE...]
set -euo pipefail
out=${1:?usage: scripts/distributed_bench.sh OUT.tsv [REFINE...]}
shift
levels=("${@:-3 4}")
[[ $# -eq 0 ]] && levels=(3 4)
bench=${BENCH:-build/bench/distributed}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
rm -f "$out"
for k in "${levels[@]}"; do
  for np in ${RANKS:-1 2}; do
    # shellcheck disable=SC2086
    mpirun --oversubscribe -np "$np" "$bench" "$out" --refine "$k" ${PARTITION_LEVEL:+--partition-level $PARTITION_LEVEL}
  done
done
/usr/bin/python3 "$(dirname "$0")/distributed_tables.py" ranks "$out"
