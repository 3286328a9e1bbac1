#!/usr/bin/env bash
# Dynamic figures of the thesis (Walloth 2012, Sec. 5.2.6 and 5.3) that need their own runs:
#   docs/figures/fig5_6_geometry_a_stress.png  Fig. 5.6: the contact stress of Geometry A (the ball, tau = 5e-3,
#                                               refine 2) at time step n = 37, all ten schemes
#   docs/figures/fig5_7_impact_factor.png      Fig. 5.7: theta(p) against eta(p) = tau*(p)/tau, measured at every
#                                               node that comes into contact inside a step (Geometry 1, refine 2,
#                                               tau = 5e-4, the four predictor schemes; scripts/impact_factor.py)
#   docs/figures/fig5_3b_control_<reading>.png Fig. 5.3(b) and its control run: the energy of the contact-implicit
#                                               scheme with redistributed mass (hager-huebner-wohlmuth-nonpenetration)
#                                               on Geometry B (the three readings of the placement) with the
#                                               redistributed mass keeping the second moments (obs' default), only
#                                               mass and centre of gravity (the thesis' M~), and the control: the
#                                               contact rows of M zeroed without redistribution (scripts/energy_runs.py)
#   docs/figures/fig5_16_detachment.png        Fig. 5.16: the normal velocity on the bottom of Geometry 1 during
#                                               detachment, alpha(p) against alpha = 0 (refine 3, tau = 5e-4)
#   docs/figures/fig5_9_t5e-6_others.png       FIG59=1 only: Fig. 5.9 at the thesis' tau = 5e-6 for the two schemes
#                                               without a predictor in the velocity (alpha, beta = 0 and alpha = {1, 0};
#                                               scripts/chapter5.sh FULL=1 runs the other three): Geometry 1, refine 3,
#                                               50,000 steps each (about 30-45 minutes per scheme on one core)
# Runs go to out/dynamics_figures/<run>; docs/dynamics.md describes the figures.
#   scripts/dynamics_figures.sh [BUILD_DIR=build] [WORK_DIR=out/dynamics_figures]
#   REUSE=1 scripts/dynamics_figures.sh     # keep the run directories that have a summary.json
# The run times are printed (docs/dynamics.md quotes them).
default_work=out/dynamics_figures
source "$(cd "$(dirname "$0")" && pwd)/obs-runs.sh"  # scripts/obs-runs.sh: root, build, work, obs, python, obs_run

# Fig. 5.6: Geometry A at refine 2 (4,321 vertices; the thesis: four refinements of its own coarse grid),
# tau = 5e-3 (the scene's), 37 steps, the .vtu of step 37
for scheme in classical contact-implicit contact-stabilized improved-contact-stabilized alpha-half alpha-one-zero \
    laursen-chawla khenous-laborde-renard hager-huebner-wohlmuth hager-huebner-wohlmuth-nonpenetration; do
  obs_run "ball_$scheme" "$scenes/dynamics_ball.toml" --refine 2 --set "dynamics.scheme=\"$scheme\"" \
    --set dynamics.steps=37 --set dynamics.output_stride=37
done

# Fig. 5.7: Geometry 1 at refine 2, tau = 5e-4 to t = 0.15 (first contact at t = 0.01, the contact
# zone spreads until about t = 0.05 and forms again after the landing at t = 0.14), a .vtu every step
impact_runs=()
for scheme in improved-contact-stabilized contact-stabilized alpha-half alpha-one-zero; do
  obs_run "g1_impacts_$scheme" "$scenes/dynamics_block.toml" --refine 2 --set "dynamics.scheme=\"$scheme\"" \
    --set dynamics.tau=5e-4 --set dynamics.steps=300 --set dynamics.output_stride=1
  impact_runs+=("$work/g1_impacts_$scheme:$scheme")
done
"$python" "$root/scripts/impact_factor.py" "$root/docs/figures/fig5_7_impact_factor.png" "${impact_runs[@]}"

# Fig. 5.16: Geometry 1 at refine 3, tau = 5e-4 (as Fig. 5.15 in scripts/surface_figures.sh), a .vtu
# every step from n = 400 (the block leaves the plane at t = 0.22-0.23, n = 440-460)
for scheme in improved-contact-stabilized contact-stabilized; do
  obs_run "g1_detach_$scheme" "$scenes/dynamics_block.toml" --refine 3 --set "dynamics.scheme=\"$scheme\"" \
    --set dynamics.tau=5e-4 --set dynamics.steps=470 --set dynamics.output_stride=1
done

# Fig. 5.3(b): the thesis' control run belongs to its "contact-implicit Newmark scheme with redistributed
# mass" (hager-huebner-wohlmuth-nonpenetration) on Geometry B, the scenes' size and steps,
# [dynamics] redistribution_moments = 2, 1, 0
for reading in face edge corner; do
  scene=dynamics_two_body; [ $reading = face ] || scene=dynamics_two_body_$reading
  control_runs=()
  for moments in 2 1 0; do
    obs_run "geomB_${reading}_hhwn_m$moments" "$scenes/$scene.toml" \
      --set 'dynamics.scheme="hager-huebner-wohlmuth-nonpenetration"' \
      --set dynamics.redistribution_moments=$moments --set dynamics.output_stride=100000000
    label=$([ $moments = 2 ] && echo "M~ keeps mass, centre, second moments" || ([ $moments = 1 ] && echo "M~ keeps mass, centre (thesis)" || echo "control: contact rows zeroed, no redistribution"))
    control_runs+=("$label=$work/geomB_${reading}_hhwn_m$moments")
  done
  echo "Fig. 5.3(b), Geometry B, $reading:"
  "$python" "$root/scripts/energy_runs.py" "$root/docs/figures/fig5_3b_control_$reading.png" \
    --title "contact-implicit with M~, Geometry B ($reading)" "${control_runs[@]}"
done

# Fig. 5.9 at tau = 5e-6 for contact-implicit and alpha-one-zero (FIG59=1; the two runs in parallel
# with FIG59_JOBS=2): as scripts/chapter5.sh's Geometry 1 runs (refine 3, to t = 0.25)
if [ "${FIG59:-0}" = 1 ]; then
  fig59_runs=()
  for scheme in contact-implicit alpha-one-zero; do
    if [ "${FIG59_JOBS:-1}" = 2 ]; then
      obs_run "g1_t5e-6_$scheme" "$scenes/dynamics_block.toml" --refine 3 --set "dynamics.scheme=\"$scheme\"" \
        --set dynamics.tau=5e-6 --set dynamics.steps=50000 --set dynamics.output_stride=100000000 &
    else
      obs_run "g1_t5e-6_$scheme" "$scenes/dynamics_block.toml" --refine 3 --set "dynamics.scheme=\"$scheme\"" \
        --set dynamics.tau=5e-6 --set dynamics.steps=50000 --set dynamics.output_stride=100000000
    fi
    fig59_runs+=("$scheme=$work/g1_t5e-6_$scheme")
  done
  wait
  echo "Fig. 5.9, Geometry 1, tau = 5e-6:"
  "$python" "$root/scripts/energy_runs.py" "$root/docs/figures/fig5_9_t5e-6_others.png" \
    --title "Geometry 1, tau = 5e-6" "${fig59_runs[@]}"
fi

"$python" "$root/scripts/render_surface.py" figures --runs "$work" --output "$root/docs/figures" \
  --only fig5_6_geometry_a_stress,fig5_16_detachment --dyn "detach:5e-4:${DETACH_STEPS:-420,435,445,455}"
