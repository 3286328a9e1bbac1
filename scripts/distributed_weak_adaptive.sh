#!/usr/bin/env bash
# Adaptive weak scaling on 1, 2, 4 and 8 ranks (oversubscribed on a small machine: the figures
# are counts, not times; docs/performance.md#distributed-adaptive-weak-scaling). Example 3B
# (tetrahedra, from its thesis grid refined once) runs its adaptive loop under
# `mpirun -np N` until the leaf view has N x VERTICES vertices (default 25000 per rank), with load
# balancing at the default tolerance (docs/architecture.md#load-balancing). Prints per rank count:
# the steps, the final vertices and vertices per rank, the TNNMG iterations of the last step, the
# owned cells of the largest rank and the mean in the last step, the imbalance of each step's
# refined grid before and after balancing (balance.csv: refined_imbalance -> cells_imbalance), the
# contact nodes' imbalance and the leaves the largest rank's grid holds over its owned cells in
# the last step; then the same with `--balance-contact` (the contact faces balanced with the
# leaves, METIS multi-constraint), a row "N, contact" per count. Runs in OUT (default
# out/distributed_weak_adaptive).
#   scripts/distributed_weak_adaptive.sh [OUT]
set -euo pipefail
out=${1:-out/distributed_weak_adaptive}
obs=${OBS:-$PWD/build/drivers/obs}
per=${VERTICES:-25000}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE OPENBLAS_NUM_THREADS=1
mkdir -p "$out"
counts=(1 2 4 8)
for n in "${counts[@]}"; do
  mpirun --oversubscribe -np "$n" "$obs" run data/scenes/example3b.toml --refine 1 \
    --set adaptivity.steps=30 --set "adaptivity.max_vertices=$((n * per))" --output "$out/np$n" -q
  if [ "$n" -gt 1 ]; then
    mpirun --oversubscribe -np "$n" "$obs" run data/scenes/example3b.toml --refine 1 --balance-contact \
      --set adaptivity.steps=30 --set "adaptivity.max_vertices=$((n * per))" --output "$out/np${n}_contact" -q
  fi
done
/usr/bin/python3 - "$out" "${counts[@]}" <<'PY'
import csv, json, sys
out, counts = sys.argv[1], sys.argv[2:]

def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))

print('| ranks | steps | vertices | per rank | TNNMG its (last) | owned cells max / mean (last) | imbalance before -> after, per step | contact imbalance (last) | held / owned (last) |')
print('|---|---|---|---|---|---|---|---|---|')
runs = [(n, '') for n in counts] + [(n, '_contact') for n in counts if n != '1']
for n, variant in runs:
    st = rows(f'{out}/np{n}{variant}/steps.csv')
    last = st[-1]
    if n == '1':
        print(f"| 1 | {len(st)} | {int(last['vertices']):,} | {int(last['vertices']):,} | {last['iterations']} | - | - | - | - |")
        continue
    bal = rows(f'{out}/np{n}{variant}/balance.csv')
    steps = ', '.join(f"{float(b['refined_imbalance']):.2f}" + (f"->{float(b['cells_imbalance']):.2f}" if b['rebalanced'] == '1' else '')
                      for b in bal[1:])
    b = bal[-1]
    print(f"| {n}{', contact' if variant else ''} | {len(st)} | {int(last['vertices']):,} | {int(last['vertices']) // int(n):,} | {last['iterations']} | "
          f"{float(b['owned_cells_max']):,.0f} / {float(b['owned_cells_mean']):,.0f} | {steps} | {float(b['contact_imbalance']):.2f} | "
          f"{float(b['held_leaves_max']) / float(b['owned_cells_max']):.2f} |")
PY
