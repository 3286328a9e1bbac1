#!/usr/bin/env bash
# The static one-body contact scenes of data/scenes (hertz, punch, step42, wedge) with `obs run`
# serially and under `mpirun -np 2` and `-np 3`: prints dofs, TNNMG iterations, contact vertices,
# load, largest displacement and von Mises stress of each run side by side
# (docs/architecture.md#distributed-runner). Runs in OUT (default out/distributed_scenes).
#   scripts/distributed_scenes.sh [OUT]
set -euo pipefail
out=${1:-out/distributed_scenes}
obs=${OBS:-$PWD/build/drivers/obs}
scenes=(hertz punch step42 wedge)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE
mkdir -p "$out"
for s in "${scenes[@]}"; do
  "$obs" run "data/scenes/$s.toml" --output "$out/$s.1" -q
  for np in 2 3; do
    mpirun --oversubscribe -np "$np" "$obs" run "data/scenes/$s.toml" --output "$out/$s.$np" -q
  done
done
/usr/bin/python3 - "$out" "${scenes[@]}" <<'PY'
import json, sys
out, scenes = sys.argv[1], sys.argv[2:]
print('| scene | ranks | dofs | iterations | contact vertices | load | max displacement | max von Mises |')
print('|---|---|---|---|---|---|---|---|')
for s in scenes:
    for n in ('1', '2', '3'):
        j = json.load(open(f'{out}/{s}.{n}/summary.json'))
        c = j['contact']
        print(f"| {s} | {n} | {j['dofs']:,} | {j['solver']['iterations']} | {c['actual_vertices']} | "
              f"{c['load_P']:.10g} | {j['max_displacement']:.10g} | {j['max_von_mises']:.6g} |")
PY
