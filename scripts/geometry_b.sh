#!/usr/bin/env bash
# Regenerates the "Two bodies: Geometry B" block of docs/dynamics.md (between the geometry-b markers)
# and its figures docs/figures/dyn_geomB_*.png (face on face), dyn_geomB_edge_*.png (upper cube on an
# edge) and dyn_geomB_corner_*.png (on a corner): `obs run SCENE --compare-schemes` for the three
# readings of the thesis' placement of the cubes, all at the thesis' size (4 refinements of each cube):
#   data/scenes/dynamics_two_body.toml          (40 steps)
#   data/scenes/dynamics_two_body_edge.toml     (120 steps)
#   data/scenes/dynamics_two_body_corner.toml   (120 steps)
# scripts/geometry_b.py writes the tables. About 15 minutes on one free core.
#   scripts/geometry_b.sh [build dir, default build] [extra obs options, e.g. --refine 3]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build}"
shift || true
obs="$build/drivers/obs"
python=python3
python3 -c "import matplotlib" 2>/dev/null || python=/usr/bin/python3
export OPENBLAS_NUM_THREADS=1
for reading in face edge corner; do
  if [ $reading = face ]; then scene=dynamics_two_body; prefix=dyn_geomB_; title="Geometry B, face on face"
  else scene=dynamics_two_body_$reading; prefix=dyn_geomB_${reading}_; title="Geometry B, on an $reading"; fi
  [ $reading = corner ] && title="Geometry B, on a corner"
  work="$build/geometry_b_$reading"
  rm -rf "$work"
  echo "geometry_b.sh: $scene --compare-schemes" >&2
  "$obs" run "$root/data/scenes/$scene.toml" --compare-schemes -q -o "$work" "$@"
  "$python" "$root/scripts/plot_dynamics.py" "$work" --output "$root/docs/figures" --prefix "$prefix" \
    --title "$title" || echo "geometry_b.sh: plots skipped" >&2
done
"$python" "$root/scripts/geometry_b.py" --face "$build/geometry_b_face" --edge "$build/geometry_b_edge" \
  --corner "$build/geometry_b_corner" \
  --doc "$root/docs/dynamics.md"
