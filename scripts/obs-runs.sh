# Sourced by the scripts that make the figures and tables of docs/examples.md and docs/dynamics.md
# from their own `obs run`s (surface_figures.sh, grid_figures.sh, dynamics_figures.sh,
# examples_deep.sh). Before sourcing, the script sets default_work (its run directory under the
# repository, e.g. out/grid_figures); its arguments are [BUILD_DIR=build] [WORK_DIR=$default_work].
# Sets root, build, work, obs, python (a python3 with numpy and matplotlib), scenes; exports one
# BLAS / OpenMP thread; defines obs_run.
set -euo pipefail
me="$(basename "$0")"
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build}"
work="${2:-$root/$default_work}"
obs="$build/drivers/obs"
[ -x "$obs" ] || { echo "$me: $obs not found (build the obs_cli target first)" >&2; exit 1; }
python=python3
python3 -c "import numpy, matplotlib" 2>/dev/null || python=/usr/bin/python3
scenes="$root/data/scenes"
mkdir -p "$work"
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1

# obs_run NAME SCENE ARGS...: one quiet `obs run SCENE ARGS...` into $work/NAME; its wall time is
# printed and kept in $work/NAME/wall_s. REUSE=1 keeps a run directory that has a summary.json.
obs_run() {
  local name="$1" scene="$2"; shift 2
  local dir="$work/$name"
  if [ "${REUSE:-0}" = 1 ] && [ -f "$dir/summary.json" ]; then echo "$me: reusing $dir" >&2; return 0; fi
  rm -rf "$dir"
  local t0 wall
  t0=$(date +%s.%N)
  "$obs" run "$scene" -q -o "$dir" "$@"
  wall=$(echo "$(date +%s.%N) - $t0" | bc)
  printf '%.1f\n' "$wall" > "$dir/wall_s"
  printf '%s: %-44s %6.1f s\n' "$me" "$name" "$wall" >&2
}
