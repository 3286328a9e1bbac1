#!/usr/bin/env bash
# Example 3B (tetrahedra, from its thesis grid refined once) grown to the thesis' size on one
# process and under `mpirun -np 2` with load balancing (docs/performance.md#distributed-thesis-size).
# Nine steps end at 4.7 M unknowns; the thesis' 6.0 M lies between our eighth and ninth grids.
# Prints per step: the unknowns, the TNNMG iterations, the solve seconds and the step seconds
# (steps.csv: solve + estimator + refinement + transfer; on 2 ranks also the rebalance of
# balance.csv) of both runs, the imbalance of the refined grid before and after balancing, and the
# peak memory so far of the largest rank and of both ranks; then the totals and peak memory
# (summary.json). Runs in OUT (default out/distributed_thesis_size); needs about 16 GB.
#   scripts/distributed_thesis_size.sh [OUT]
set -euo pipefail
out=${1:-out/distributed_thesis_size}
obs=${OBS:-$PWD/build/drivers/obs}
args=(data/scenes/example3b.toml --refine 1 --set adaptivity.steps=9 --set adaptivity.vtk='"none"' -q)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE OPENBLAS_NUM_THREADS=1
mkdir -p "$out"
"$obs" run "${args[@]}" --output "$out/np1"
mpirun --oversubscribe -np 2 "$obs" run "${args[@]}" --output "$out/np2"
/usr/bin/python3 - "$out" <<'PY'
import csv, json, sys
out = sys.argv[1]

def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))

one, two, bal = rows(f'{out}/np1/steps.csv'), rows(f'{out}/np2/steps.csv'), rows(f'{out}/np2/balance.csv')
def step_s(r, b=None):
    t = sum(float(r[c] or 0) for c in ('solver_s', 'estimator_s', 'refinement_s', 'transfer_s'))
    return t + (float(b['rebalance_s']) if b else 0.0)

print('| step | unknowns | TNNMG its 1 / 2 | solve s 1 / 2 | step s 1 / 2 | imbalance before -> after | memory MB, largest rank / both (2 ranks) |')
print('|---:|---:|---|---|---|---|---|')
for a, b, c in zip(one, two, bal):
    moved = f"{float(c['refined_imbalance']):.2f} -> {float(c['cells_imbalance']):.2f}" if c['rebalanced'] == '1' else f"{float(c['cells_imbalance']):.2f}"
    print(f"| {a['step']} | {int(a['unknowns']):,} | {a['iterations']} / {b['iterations']} | {float(a['solver_s']):.2f} / {float(b['solver_s']):.2f} | "
          f"{step_s(a):.2f} / {step_s(b, c):.2f} | {moved} | {float(c['memory_mb_max']):.0f} / {float(c['memory_mb_sum']):.0f} |")
for n in ('1', '2'):
    j = json.load(open(f'{out}/np{n}/summary.json'))
    memory = j.get('peak_memory_mb_largest_rank', j.get('peak_memory_mb'))
    print(f"\n{n} rank(s): total {j['times']['total_s']:.1f} s, solve {j['times']['solve_s']:.1f} s, peak memory {memory:.0f} MB"
          + (f" (largest rank; {j['peak_memory_mb_all_ranks']:.0f} MB both), {j['rebalances']} rebalances" if n == '2' else ''), end='')
print()
PY
