#!/usr/bin/env bash
# Grid pictures of the thesis (Walloth 2012) for Examples 1-3, from the last step of adaptive runs
# (contact-residual estimator unless named), drawn by scripts/render_surface.py:
#   docs/figures/fig4_2_example1a_grid.png       Fig. 4.2: Example 1A, the grid after 15 refinements and two zooms
#   docs/figures/fig4_3_example1b_grid.png       Fig. 4.3: Example 1B, two zooms and u_2
#   docs/figures/fig4_7_4_8_example2a_grid.png   Figs. 4.7, 4.8: Example 2A (14 refinements), four zooms
#   docs/figures/fig4_9_example2b_grid.png       Fig. 4.9: Example 2B (14 refinements), a zoom and u_2
#   docs/figures/fig4_14_example3a_grids.png     Fig. 4.14: Example 3A, the contact boundary after 7 refinements,
#                                                contact-residual and residual estimator
#   docs/figures/fig4_15_example3b_grids.png     Fig. 4.15: Example 3B, u_3 in the cut y = 0.5 and the same two grids
# The 2D runs have the thesis' number of refinements (15 for the punch, 14 for the wedge); the 3D runs
# stop after 7 (the thesis: 10; docs/examples.md has the tables to 7 and 9). Runs go to
# out/grid_figures/<run> (one `obs run` each, the .vtu of the last step); docs/examples.md describes
# the figures.
#   scripts/grid_figures.sh [BUILD_DIR=build] [WORK_DIR=out/grid_figures]
#   REUSE=1 scripts/grid_figures.sh     # keep the run directories that have a summary.json
# The run and render times are printed (docs/examples.md quotes them).
default_work=out/grid_figures
source "$(cd "$(dirname "$0")" && pwd)/obs-runs.sh"  # scripts/obs-runs.sh: root, build, work, obs, python, obs_run

adaptive() {  # adaptive NAME EXAMPLE SOLVES [ARGS...]: one adaptive run into $work/NAME, the last step's .vtu
  local name="$1" example="$2" solves="$3"; shift 3
  obs_run "$name" "$scenes/$example.toml" --set "adaptivity.steps=$solves" --set adaptivity.max_vertices=100000000 \
    --set 'adaptivity.vtk="last"' "$@"
}
residual=(--set 'adaptivity.estimator="residual"')

adaptive example1a_cr example1a 16
adaptive example1b_cr example1b 16
adaptive example2a_cr example2a 15
adaptive example2b_cr example2b 15
adaptive example3a_cr example3a 8
adaptive example3a_res example3a 8 "${residual[@]}"
adaptive example3b_cr example3b 8
adaptive example3b_res example3b 8 "${residual[@]}"

t0=$(date +%s.%N)
"$python" "$root/scripts/render_surface.py" figures --runs "$work" --output "$root/docs/figures" \
  --only fig4_2_example1a_grid,fig4_3_example1b_grid,fig4_7_4_8_example2a_grid,fig4_9_example2b_grid,fig4_14_example3a_grids,fig4_15_example3b_grids
printf 'grid_figures.sh: rendering %6.1f s\n' "$(echo "$(date +%s.%N) - $t0" | bc)" >&2
# symmetry of the grids about x = 0.5 (docs/examples.md: the triangle and tetrahedron grids are not symmetric)
for run in example1a_cr example1b_cr example2a_cr example2b_cr example3a_cr example3b_cr; do
  last=$(ls "$work/$run"/step_*.vtu | tail -1)
  "$python" "$root/scripts/render_surface.py" symmetry "$last" --plane x=0.5
done
