#!/bin/sh
# Writes data/meshes/cattaneo_mindlin_3d.msh (Gmsh format 4.1) from data/meshes/cattaneo_mindlin_3d.geo:
# the graded half ball and block of data/scenes/cattaneo_mindlin_3d.toml. Needs Gmsh (Debian:
# apt-get install gmsh); the committed file was written by Gmsh 4.8.4.
#   scripts/make_cattaneo_mindlin_3d.sh [output directory] [hmin] [grade]
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$root/data/meshes}
hmin=${2:-0.015}
grade=${3:-0.2}
if ! command -v gmsh >/dev/null 2>&1; then
  echo "make_cattaneo_mindlin_3d.sh: gmsh not found (apt-get install gmsh)" >&2
  exit 2
fi
gmsh -3 "$root/data/meshes/cattaneo_mindlin_3d.geo" -setnumber hmin "$hmin" -setnumber grade "$grade" \
  -format msh41 -o "$out/cattaneo_mindlin_3d.msh" >/dev/null
echo "wrote $out/cattaneo_mindlin_3d.msh"
