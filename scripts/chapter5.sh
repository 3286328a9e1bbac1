#!/usr/bin/env bash
# Chapter 5 of the reference thesis, one body, at the thesis' parameters (Sec. 5.3.3, Figs. 5.9-5.14):
# regenerates the block between the chapter5 markers of docs/dynamics.md and docs/figures/ch5_*.png.
#  1. Geometry 1 (data/scenes/dynamics_block.toml) at refine 3 (11,475 unknowns; the thesis' 12,552 is
#     not 3 x the vertex count of any uniformly refined tensor-product hexahedral grid, docs/dynamics.md)
#     to t = 0.25 with the five members of the family (alpha(p), alpha = 0, alpha = 1/2, alpha = {1, 0},
#     alpha, beta = 0) at the thesis' tau = 5e-4 (Figs. 5.10a, 5.11a) and the three with a predictor
#     at 5e-5 (Figs. 5.10b/c, 5.11b/c); FULL=1 adds tau = 5e-6 (Fig. 5.9; the three schemes);
#  2. the bar of Fig. 5.13 (tau = 5e-3, h = 0.1: 100 cells along L = 10);
#  3. Fig. 5.14: energy loss of alpha(p) and alpha = 0 on Geometry 1 against tau and h.
# The tables (energy lost at impact / detachment / after, predictor-only and solution-only node counts,
# smoothness of force and tracked velocity) and the figures come from scripts/chapter5.py.
#
#   scripts/chapter5.sh [BUILD_DIR=build] [WORK_DIR=out/chapter5]
#   QUICK=1 scripts/chapter5.sh     # refine 1, short runs: a smoke test of the script (~1 min)
#   FULL=1 scripts/chapter5.sh      # adds Fig. 5.9's tau = 5e-6 (50,000 steps per scheme; hours)
#   REUSE=1 scripts/chapter5.sh     # keeps the run directories that are complete (after an interruption)
# The default mode takes about 31 minutes of runs on the shared machine (1,860 s measured; Release build); the
# times of every run are in the tables it writes.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build}"
work="${2:-$root/out/chapter5}"
obs="$build/drivers/obs"
[ -x "$obs" ] || { echo "chapter5.sh: $obs not found (build the obs_cli target first)" >&2; exit 1; }
python=python3
python3 -c "import matplotlib" 2>/dev/null || python=/usr/bin/python3
scenes="$root/data/scenes"
mkdir -p "$work"
quick="${QUICK:-0}"
full="${FULL:-0}"
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1

# compared with the scene's alpha(p): all five members at tau >= 5e-4 (Figs. 5.10a, 5.11a), the three with a
# predictor below (the thesis restricts Figs. 5.10b/c, 5.11b/c to them)
five='["contact-stabilized", "alpha-half", "alpha-one-zero", "contact-implicit"]'
three='["contact-stabilized", "alpha-half"]'
run() {  # run DIR SCENE ARGS...: one obs run, quiet, its wall time in DIR/wall_s (REUSE=1: keep a finished DIR)
  local dir="$1" scene="$2"; shift 2
  if [ "${REUSE:-0}" = 1 ] && [ -f "$dir/summary.json" ] && [ -f "$dir/wall_s" ]; then
    echo "chapter5.sh: reusing $dir" >&2; return 0; fi
  rm -rf "$dir"
  local t0; t0=$(date +%s.%N)
  "$obs" run "$scene" -q -o "$dir" "$@"
  "$python" -c "print(f'{$(date +%s.%N) - $t0:.1f}')" > "$dir/wall_s"
}
steps_for() { "$python" -c "print(round($1 / $2))"; }  # steps_for END_TIME TAU

# tracked: the lowest point (reaches the plane exactly at t = 0.01, a time level: tau* = 0, where alpha(p) =
# 1/2) and the bottom vertex at x = 0.875 (reaches it at t = 0.015214: tau* = 0.43 tau at tau = 5e-4,
# 0.28 tau at 5e-5, where alpha(p) and alpha = 1/2 differ)
tracked='[[0.75, 0.5, 0], [0.875, 0.5, 0.0052]]'
# g1_end: Geometry 1 hits the plane at t = 0.01 and leaves it at t = 0.22-0.23 (refine 2, 3)
if [ "$quick" = 1 ]; then g1_refine=1; g1_end=0.25; taus="1e-3"; loss_refines="0 1"; loss_taus="2e-3 1e-3"
else g1_refine=3; g1_end=0.25; taus="5e-4 5e-5"; loss_refines="1 2 3"; loss_taus="1e-3 5e-4 2.5e-4"; fi
[ "$full" = 1 ] && taus="$taus 5e-6"
taus="${TAUS:-$taus}"  # overrides, e.g. TAUS="5e-4" LOSS_TAUS="1e-3 5e-4"
loss_refines="${LOSS_REFINES:-$loss_refines}"
loss_taus="${LOSS_TAUS:-$loss_taus}"

for tau in $taus; do
  steps=$(steps_for $g1_end $tau)
  compare=$five; "$python" -c "import sys; sys.exit(0 if $tau >= 5e-4 else 1)" || compare=$three
  echo "chapter5.sh: Geometry 1, refine $g1_refine, tau $tau, compare $compare ($steps steps each)" >&2
  run "$work/g1_t$tau" "$scenes/dynamics_block.toml" --refine $g1_refine \
    --set dynamics.tau=$tau --set dynamics.steps=$steps --set "dynamics.compare=$compare" --set "dynamics.tracked=$tracked" \
    --set dynamics.output_stride=100000000
done

echo "chapter5.sh: bar, tau 5e-3, h = 0.1" >&2
run "$work/bar" "$scenes/dynamics_bar.toml" --set 'mesh.cells=[1, 100]' --set dynamics.tau=5e-3 \
  --set dynamics.steps=$(steps_for 1.5 5e-3) --set 'dynamics.compare=["contact-stabilized"]' \
  --set dynamics.output_stride=100000000

for r in $loss_refines; do
  for tau in $loss_taus; do
    steps=$(steps_for $g1_end $tau)
    echo "chapter5.sh: Fig. 5.14, Geometry 1, refine $r, tau $tau ($steps steps, two schemes)" >&2
    run "$work/loss_r${r}_t$tau" "$scenes/dynamics_block.toml" --refine $r --set dynamics.tau=$tau \
      --set dynamics.steps=$steps --set 'dynamics.compare=["contact-stabilized"]' \
      --set dynamics.output_stride=100000000
  done
done

"$python" "$root/scripts/chapter5.py" "$work" --doc "$root/docs/dynamics.md" --figures "$root/docs/figures" \
  --taus "$taus" --loss-refines "$loss_refines" --loss-taus "$loss_taus" --mode "$( [ "$quick" = 1 ] && echo quick || ([ "$full" = 1 ] && echo full || echo default))"
