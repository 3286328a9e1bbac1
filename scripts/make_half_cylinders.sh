#!/bin/sh
# Writes data/meshes/half_cylinder_upper.msh and half_cylinder_lower.msh (Gmsh format 4.1) from
# data/meshes/half_cylinder.geo: the two graded half-cylinders of data/scenes/twobody_gmsh_cylinders.toml.
# Needs Gmsh (Debian: apt-get install gmsh); the committed files were written by Gmsh 4.8.4.
#   scripts/make_half_cylinders.sh [output directory] [hmin] [hmax]
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$root/data/meshes}
hmin=${2:-0.003}
hmax=${3:-0.06}
if ! command -v gmsh >/dev/null 2>&1; then
  echo "make_half_cylinders.sh: gmsh not found (apt-get install gmsh)" >&2
  exit 2
fi
gmsh -2 "$root/data/meshes/half_cylinder.geo" -setnumber yc 1 -setnumber hmin "$hmin" -setnumber hmax "$hmax" \
  -format msh41 -o "$out/half_cylinder_upper.msh" >/dev/null
gmsh -2 "$root/data/meshes/half_cylinder.geo" -setnumber yc -1 -setnumber hmin "$hmin" -setnumber hmax "$hmax" \
  -format msh41 -o "$out/half_cylinder_lower.msh" >/dev/null
echo "wrote $out/half_cylinder_upper.msh, $out/half_cylinder_lower.msh"
