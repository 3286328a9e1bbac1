#!/usr/bin/env bash
# Surface pictures of the thesis (Walloth 2012) from obs' .vtu output, drawn by scripts/render_surface.py:
#   docs/figures/fig4_23_example4_eta5.png    Fig. 4.23: eta_{5,p}^2 on the contact boundary, Example 4, prisms
#   docs/figures/fig4_24_example4_cut.png     Fig. 4.24: eta_{1,p}^2, eta_{2,p}^2, eta_{5,p}^2 in the cut y = 0.5
#   docs/figures/fig4_27_example5_pyramid.png Fig. 4.27: grid, contact status and u_z on the contact boundary,
#                                             Example 5, pyramids, k = 6
#   docs/figures/fig4_28_example5_hexahedron.png Fig. 4.28: u_z on the contact boundary and in the cut y = 0.5,
#                                             Example 5, hexahedra, k = 5
#   docs/figures/fig4_29_example5_pyramid.png Fig. 4.29: eta_{1,p}^2, eta_{2,p}^2, eta_{5,p}^2, Example 5, pyramids
#   docs/figures/fig4_30_example6_hexahedron.png Fig. 4.30: the grid of the contact boundary, a zoom with the
#                                             contact status and the grid in the cut y = 0.5, Example 6, k = 4
#   docs/figures/fig4_32_example6_contact.png Fig. 4.32: grid, eta_{5,p}^2, eta_{6,p}^2, eta_{8,p}^2, Example 6
#   docs/figures/fig4_35_example7_contact.png Fig. 4.35: grid, eta_{5,p}^2 ... eta_{8,p}^2, Example 7, pyramids
#   docs/figures/fig4_33_example7_pyramid.png Fig. 4.33: grid, contact status and u_z on the contact boundary,
#                                             Example 7, pyramids, k = 4
#   docs/figures/fig4_36_example8_eta8.png    Fig. 4.36: grid at k = 0, 3 and eta_{8,p}^2 at k = 0, 1, Example 8
#   docs/figures/fig4_37_example9_grids.png   Fig. 4.37: the contact boundary's grid at k = 2, 4, 6, Example 9,
#                                             pyramids and hexahedra (k = 6: 1.0 M vertices, 1.8 GB, 35 s)
#   docs/figures/fig5_15_geometry1.png        Fig. 5.15: contact stress, normal displacement and velocity,
#                                             Geometry 1, alpha(p), tau = 5e-4
#   docs/figures/fig5_17_tibia.png            Fig. 5.17: the same for the cube on the tibial plateau, tau = 5e-3
# The runs go to out/surface_figures/<run> (one `obs run` each, with .vtu files of every step / every
# output_stride time steps); docs/examples.md and docs/dynamics.md describe the figures.
#   scripts/surface_figures.sh [BUILD_DIR=build] [WORK_DIR=out/surface_figures]
#   REUSE=1 scripts/surface_figures.sh     # keep the run directories that have a summary.json
# About 2 minutes on the shared 2-core machine: the runs about 97 s (their times are printed), drawing
# about 25 s.
default_work=out/surface_figures
source "$(cd "$(dirname "$0")" && pwd)/obs-runs.sh"  # scripts/obs-runs.sh: root, build, work, obs, python, obs_run

adaptive() {  # adaptive NAME EXAMPLE GRID SOLVES: a .vtu per step k = 0 .. SOLVES-1, no vertex cap
  obs_run "$1" "$scenes/$2.toml" --set "mesh.type=\"$3\"" --set "adaptivity.steps=$4" \
    --set adaptivity.max_vertices=100000000 --set 'adaptivity.vtk="every"'
}

# Example 4, prisms: k = 2, 4, 6 as the thesis (k = 6: 428,566 vertices)
adaptive example4_prism example4 prism 7
adaptive example5_pyramid example5 pyramid 7
adaptive example5_hexahedron example5 hexahedron 6
adaptive example6_hexahedron example6 hexahedron 5
adaptive example7_pyramid example7 pyramid 5
adaptive example8_hexahedron example8 hexahedron 4
adaptive example9_pyramid example9 pyramid 7
adaptive example9_hexahedron example9 hexahedron 7

# Geometry 1 with alpha(p) at the thesis' tau = 5e-4 to t = 0.25 (impact at t = 0.01, release near
# t = 0.22), refine 3 (3,825 vertices; refine 4, nearer the thesis' five refinements, took 159 s:
# G1_REFINE=4), a .vtu every 20 steps (contact from step 20 to about 250 and from about 280 to 450,
# timeseries.csv); the cube on the tibial plateau at
# tau = 5e-3 with one refinement more than the scene (17 x 17 bottom vertices), a .vtu every step to
# t = 0.15 (contact in steps 2-25)
g1_tau=5e-4
obs_run dynamics_geometry1 "$scenes/dynamics_block.toml" --refine "${G1_REFINE:-3}" --set dynamics.tau=$g1_tau \
  --set dynamics.steps=500 --set dynamics.output_stride=20
tibia_tau=5e-3
obs_run dynamics_tibia "$scenes/dynamics_tibia.toml" --refine 2 --set dynamics.tau=$tibia_tau --set dynamics.steps=30 \
  --set dynamics.output_stride=1

figures=fig4_23_example4_eta5,fig4_24_example4_cut,fig4_27_example5_pyramid,fig4_28_example5_hexahedron
figures+=,fig4_29_example5_pyramid,fig4_30_example6_hexahedron,fig4_32_example6_contact,fig4_33_example7_pyramid
figures+=,fig4_35_example7_contact,fig4_36_example8_eta8,fig4_37_example9_grids,fig5_15_geometry1,fig5_17_tibia
"$python" "$root/scripts/render_surface.py" figures --runs "$work" --output "$root/docs/figures" --only "$figures" \
  --dyn "dynamics_geometry1:$g1_tau:${G1_STEPS:-40,100,200,320,420}" \
  --dyn "dynamics_tibia:$tibia_tau:${TIBIA_STEPS:-2,4,9,20,23}"
