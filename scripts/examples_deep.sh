#!/usr/bin/env bash
# Examples 4 and 5 of the thesis (Sec. 4.2.3) at the thesis' depth, beyond the 40,000-vertex cap of
# scripts/examples_3d.sh: Example 4 on prisms to k = 7 (thesis Fig. 4.25 shows k = 1 ... 7) and
# Example 5 on pyramids and on hexahedra to k = 9 (the thesis refines Example 5 nine times), adaptive,
# contact-residual estimator, mean marking with theta = 1.1, from the scenes' starting grids.
# Writes the step tables docs/figures/ex4-9/deep/example<N>_<grid>.csv (steps.csv of each run),
# docs/figures/fig4_25_example4_contact_ratios.png (scripts/plot_contact_ratios.py) and prints a
# Markdown table per run (docs/examples.md#examples-4-5-deep quotes them) with the wall time and peak
# memory of each run (summary.json).
#   scripts/examples_deep.sh [BUILD_DIR=build] [WORK_DIR=out/examples_deep]
#   REUSE=1 scripts/examples_deep.sh     # keep the run directories that have a summary.json
# MAX_VERTICES (default 6000000): [adaptivity] max_vertices of every run, which stops a run after the
# first solve above it (the machine has 24 GB; obs needs about 0.4 KB per unknown).
default_work=out/examples_deep
source "$(cd "$(dirname "$0")" && pwd)/obs-runs.sh"  # scripts/obs-runs.sh: root, build, work, obs, python, obs_run
deep="$root/docs/figures/ex4-9/deep"
mkdir -p "$deep"

run() {  # run NAME EXAMPLE GRID SOLVES
  local name="$1" ex="$2" grid="$3" solves="$4"
  local dir="$work/$name"
  obs_run "$name" "$scenes/$ex.toml" --set "mesh.type=\"$grid\"" --set "adaptivity.steps=$solves" \
    --set "adaptivity.max_vertices=${MAX_VERTICES:-6000000}" --set 'adaptivity.vtk="none"'
  cp "$dir/steps.csv" "$deep/$name.csv"
  "$python" - "$dir" "$name" <<'PY'
import csv, json, os, sys
d, name = sys.argv[1:3]
rows = list(csv.DictReader(open(os.path.join(d, "steps.csv"))))
s = json.load(open(os.path.join(d, "summary.json")))
wall = open(os.path.join(d, "wall_s")).read().strip()
print(f"\n{name}: {len(rows)} solves, {wall} s wall, {s['peak_memory_mb'] / 1024:.2f} GB peak\n")
eoc = lambda r: f"{float(r['eoc']):.2f}" if r["eoc"] else ""
print("| k | N | unknowns | aC/C | sC/C | fC/C | eta | eoc |")
print("|---|---|---|---|---|---|---|---|")
for r in rows:
    pc = float(r["potential_contact"])
    q = lambda k: f"{float(r[k]) / pc:.3f}"
    print(f"| {r['step']} | {r['vertices']} | {r['unknowns']} | {q('actual_contact')} | {q('semi_contact')} | "
          f"{q('full_contact')} | {float(r['eta']):.3g} | {eoc(r)} |")
PY
}

run example4_prism example4 prism 8
run example5_pyramid example5 pyramid 10
run example5_hexahedron example5 hexahedron 10
"$python" "$root/scripts/plot_contact_ratios.py" --output "$root/docs/figures/fig4_25_example4_contact_ratios.png" \
  --title "Example 4, prisms" "$deep/example4_prism.csv"
