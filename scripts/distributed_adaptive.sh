#!/usr/bin/env bash
# The adaptive examples with `obs run` on one process and under `mpirun -np 2`
# (docs/architecture.md#distributed-adaptivity): Example 1A (flat punch, quadrilaterals), Example 3A
# (ball, hexahedra) and Example 3B (ball, tetrahedra), both from their thesis grids refined once
# (the coarse level is replicated on ranks), and the adaptive two-body scenes (a half-cylinder on a
# block in 2D, a half ball on a box in 3D; one mortar pair). Prints per run: steps, the final cells and unknowns,
# the solve and total seconds (summary.json times), the peak memory of the largest rank, the
# TNNMG iterations of the last step, the final eta, the largest deviation of eta from the one
# process's over all steps (relative), the imbalance of the owned cells of the first and last steps
# (largest over mean, balance.csv), the largest imbalance of a refined grid before balancing, the
# rebalances, and the leaves the largest rank's grid holds in the last step, relative to all
# cells. Two ranks run twice: with the partition fixed (--imbalance-tolerance inf) and balanced
# (the default tolerance 1.1; docs/architecture.md#load-balancing). Runs in OUT (default
# out/distributed_adaptive).
#   scripts/distributed_adaptive.sh [OUT]
set -euo pipefail
out=${1:-out/distributed_adaptive}
obs=${OBS:-$PWD/build/drivers/obs}
scenes=("example1a --set adaptivity.steps=16" "example3a --refine 1 --set adaptivity.steps=7"
        "example3b --refine 1 --set adaptivity.steps=8" "twobody_cylinders_adaptive --set adaptivity.steps=10"
        "twobody_hertz_adaptive --set adaptivity.steps=5")
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE OPENBLAS_NUM_THREADS=1
mkdir -p "$out"
names=()
for entry in "${scenes[@]}"; do
  read -r s args <<<"$entry"
  names+=("$s")
  # shellcheck disable=SC2086
  "$obs" run "data/scenes/$s.toml" $args --output "$out/$s.1" -q
  # shellcheck disable=SC2086
  mpirun --oversubscribe -np 2 "$obs" run "data/scenes/$s.toml" $args --imbalance-tolerance inf --output "$out/$s.2f" -q
  # shellcheck disable=SC2086
  mpirun --oversubscribe -np 2 "$obs" run "data/scenes/$s.toml" $args --output "$out/$s.2" -q
done
/usr/bin/python3 - "$out" "${names[@]}" <<'PY'
import csv, json, sys
out, scenes = sys.argv[1], sys.argv[2:]

def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))

print('| scene | ranks | steps | cells | unknowns | solve s | total s | memory MB (largest rank) | TNNMG its (last) | eta | eta dev. | imbalance first / last | largest refined | rebalances | held / cells (last) |')
print('|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|')
for s in scenes:
    serial = rows(f'{out}/{s}.1/steps.csv')
    for n in ('1', '2f', '2'):
        j = json.load(open(f'{out}/{s}.{n}/summary.json'))
        st = rows(f'{out}/{s}.{n}/steps.csv')
        memory = j.get('peak_memory_mb_largest_rank', j.get('peak_memory_mb'))
        if n == '1':
            dev, imbalance, refined, rebalances, held = '-', '-', '-', '-', '-'
        else:
            dev = f"{max(abs(float(a['eta']) - float(b['eta'])) / float(a['eta']) for a, b in zip(serial, st)):.1e}"
            bal = rows(f'{out}/{s}.{n}/balance.csv')
            imbalance = f"{float(bal[0]['cells_imbalance']):.2f} / {float(bal[-1]['cells_imbalance']):.2f}"
            held = f"{float(bal[-1]['held_leaves_max']) / float(st[-1]['cells']):.2f}"
            refined = f"{max(float(b['refined_imbalance']) for b in bal):.2f}"
            rebalances = str(j['rebalances'])
        last = st[-1]
        ranks = {'1': '1', '2f': '2, fixed', '2': '2, balanced'}[n]
        print(f"| {s} | {ranks} | {len(st)} | {int(last['cells']):,} | {int(last['unknowns']):,} | {j['times']['solve_s']:.3g} | "
              f"{j['times']['total_s']:.3g} | {memory:.0f} | {last['iterations']} | {float(last['eta']):.4g} | {dev} | {imbalance} | {refined} | {rebalances} | {held} |")
PY
