#!/usr/bin/env bash
# Weak scaling counts of distributed TNNMG (bench/distributed): step-42's problem on a box that
# grows with the ranks, 1 rank on 4x4x4 coarse cells, 2 on 8x4x4, 4 on 8x8x4, 8 on 8x8x8 (refine K,
# default 3: about 108,000 unknowns per rank). More ranks than cores are oversubscribed, so the
# table reports counts, not times (docs/performance.md#distributed-weak).
#   scripts/distributed_weak.sh OUT.tsv [REFINE]
set -euo pipefail
out=${1:?usage: scripts/distributed_weak.sh OUT.tsv [REFINE]}
refine=${2:-3}
bench=${BENCH:-build/bench/distributed}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE
rm -f "$out"
for run in "1 4,4,4" "2 8,4,4" "4 8,8,4" "8 8,8,8"; do
  read -r np cells <<<"$run"
  mpirun --oversubscribe -np "$np" "$bench" "$out" --refine "$refine" --cells "$cells"
done
/usr/bin/python3 - "$out" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1]), delimiter='\t'))
print('| ranks | coarse cells | unknowns | owned vertices per rank (min-max) | iterations | ghosts (largest) | colours | messages / values per update (largest) | leaves held (largest) / leaves per rank | memory per rank MB (largest) |')
print('|---|---|---|---|---|---|---|---|---|---|')
for r in rows:
    ranks = int(r['ranks'])
    per = int(r['leaves_global']) / ranks
    print(f"| {ranks} | {r['cells'].replace(',', ' x ')} | {int(r['unknowns']):,} | {int(r['owned_min']):,}-{int(r['owned_max']):,} | "
          f"{r['iterations']} | {int(r['ghosts_max']):,} | {r['colours']} | {int(r['messages_max'])} / {int(r['values_max']):,} | "
          f"{int(r['leaves_max']) / per:.2f} | {float(r['memory_max_mb']):.0f} |")
PY
