#!/usr/bin/env bash
# The static scenes of data/scenes that run on ranks, with `obs run` serially and under
# `mpirun -np 2` and `-np 3`: the one-body contact scenes (hertz, punch, step42, wedge; TNNMG), those
# with Coulomb friction (friction_cylinder, friction_peer, friction_slip: the fixed point over TNNMG's
# Tresca solves), the scenes without contact (cantilever, block_compression at refine 2 and 1,
# mixed_bar; direct serially, distributed multigrid on ranks) and the two-body scenes (twobody_*,
# cattaneo_mindlin with Coulomb friction in [loading] increments: TNNMG with the stacked multigrid
# correction serially and on ranks). Prints dofs, solver and
# iterations (with friction: Tresca solves / TNNMG iterations), contact vertices, load (of the
# [contact] or of the mortar pair), stick / slip vertices, friction force, largest displacement and
# von Mises stress, and the solve time of each run side by side
# (docs/architecture.md#distributed-runner, #distributed-two-body).
# Runs in OUT (default out/distributed_scenes).
#   scripts/distributed_scenes.sh [OUT]
set -euo pipefail
out=${1:-out/distributed_scenes}
obs=${OBS:-$PWD/build/drivers/obs}
# scene and its extra options (the scenes without refinement get some: ranks need refine >= 1)
scenes=("hertz" "punch" "step42" "wedge" "friction_cylinder" "friction_peer" "friction_slip" "cantilever --refine 2"
        "block_compression --refine 1" "mixed_bar" "twobody_patch --refine 1" "twobody_gmsh --refine 1"
        "twobody_cylinders" "twobody_gmsh_cylinders" "twobody_hertz" "twobody_friction" "cattaneo_mindlin")
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE
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
import json, sys
out, scenes = sys.argv[1], sys.argv[2:]
print('| scene | ranks | dofs | solver | iterations | contact vertices | load | stick / slip | friction force | max displacement | max von Mises | solve s |')
print('|---|---|---|---|---|---|---|---|---|---|---|---|')
for s in scenes:
    for n in ('1', '2', '3'):
        j = json.load(open(f'{out}/{s}.{n}/summary.json'))
        c = j.get('contact') or (j.get('pairs') or [None])[0]
        contact = f"{c['actual_vertices']} | {c['load_P']:.10g}" if c else '- | -'
        f = c.get('friction') if c else None
        friction = f"{f['stick_vertices']} / {f['slip_vertices']} | {f['tangential_force'][0]:.8g}" if f else '- | -'
        fi = j['solver'].get('friction')
        iterations = f"{fi['iterations']} / {fi['inner_iterations']}" if fi else str(j['solver']['iterations'])
        solver = j['solver']['type']
        print(f"| {s} | {n} | {j['dofs']:,} | {solver} | {iterations} | {contact} | {friction} | "
              f"{j['max_displacement']:.10g} | {j['max_von_mises']:.6g} | {j['solver']['time_s']:.3g} |")
PY
