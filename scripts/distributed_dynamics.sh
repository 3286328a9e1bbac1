#!/usr/bin/env bash
# The dynamic scenes with `obs run` serially and under `mpirun -np 2` and `-np 3`
# (docs/architecture.md#distributed-dynamics): Geometry 1 (dynamics_block), the ball (Geometry A,
# dynamics_ball) and Geometry B (two cubes coupled by dual mortar, dynamics_two_body) at the thesis'
# sizes, the tibia, and the sliding block with Coulomb friction. Prints
# per run: vertices, scheme, steps, TNNMG iterations per step, seconds per step (the step loop;
# summary.json dynamics.seconds_per_step), the peak memory of the largest rank, and the largest
# deviation of the time series from the serial one: energies relative to the largest energy,
# momentum and contact force relative to their largest norms (timeseries.csv).
# Runs in OUT (default out/distributed_dynamics).
#   scripts/distributed_dynamics.sh [OUT]
set -euo pipefail
out=${1:-out/distributed_dynamics}
obs=${OBS:-$PWD/build/drivers/obs}
scenes=("dynamics_block --refine 3 --set dynamics.steps=500" "dynamics_ball --refine 2 --set dynamics.steps=200"
        "dynamics_two_body" "dynamics_tibia" "dynamics_sliding_block")
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE OPENBLAS_NUM_THREADS=1
mkdir -p "$out"
names=()
for entry in "${scenes[@]}"; do
  read -r s args <<<"$entry"
  names+=("$s")
  # shellcheck disable=SC2086
  "$obs" run "data/scenes/$s.toml" $args --output "$out/$s.1" -q
  for np in 2 3; do
    # shellcheck disable=SC2086
    mpirun --oversubscribe -np "$np" "$obs" run "data/scenes/$s.toml" $args --output "$out/$s.$np" -q
  done
done
/usr/bin/python3 - "$out" "${names[@]}" <<'PY'
import csv, json, math, sys
out, scenes = sys.argv[1], sys.argv[2:]

def series(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return rows

def value(row, column):
    v = row.get(column, '')
    return float(v) if v not in ('', 'nan') else 0.0

def deviation(a, b, columns):
    scale = max(max(abs(value(r, c)) for c in columns) for r in a) or 1.0
    return max(max(abs(value(x, c) - value(y, c)) for c in columns) for x, y in zip(a, b)) / scale

print('| scene | ranks | vertices | scheme | steps | TNNMG its/step | s/step | memory MB (largest rank) | energy dev. | momentum dev. | force dev. |')
print('|---|---|---|---|---|---|---|---|---|---|---|')
for s in scenes:
    serial = series(f'{out}/{s}.1/timeseries.csv')
    for n in ('1', '2', '3'):
        j = json.load(open(f'{out}/{s}.{n}/summary.json'))
        d = j['dynamics']
        memory = j.get('peak_memory_mb_largest_rank', j.get('peak_memory_mb'))
        if n == '1':
            dev = '- | - | -'
        else:
            b = series(f'{out}/{s}.{n}/timeseries.csv')
            e = deviation(serial, b, ['energy', 'kinetic_energy', 'elastic_energy'])
            m = deviation(serial, b, ['momentum_x', 'momentum_y', 'momentum_z'])
            f = deviation(serial, b, ['contact_force_x', 'contact_force_y', 'contact_force_z'])
            dev = f'{e:.1e} | {m:.1e} | {f:.1e}'
        print(f"| {s} | {n} | {j['vertices']:,} | {d['scheme']} | {d['steps']} | {d['mean_iterations_per_step']:.3g} | "
              f"{d['seconds_per_step']:.3g} | {memory:.0f} | {dev} |")
PY
