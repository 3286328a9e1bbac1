#!/usr/bin/env python3
"""TNNMG iterations on meshes made outside obs: data/scenes/twobody_gmsh_cylinders.toml (two graded
half-cylinders from Gmsh files, refined twice by obs) with its meshes written by Gmsh at several
gradings (scripts/make_half_cylinders.sh), with and without the projection of the refined arcs onto
the circles, against the generated two-body scene data/scenes/twobody_cylinders.toml.

    python3 scripts/imported_iterations.py OUTPUT.md [--obs build/drivers/obs]

Needs gmsh (apt-get install gmsh). Writes a markdown table (one row per run: triangles per body at
level 0, unknowns, slave vertices in contact, TNNMG iterations, solve seconds); progress on stderr.
"""

import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# (hmin, hmax) of half_cylinder.geo: the committed meshes, about 9,500 triangles per body, and two
# stronger gradings (hmax / hmin = 20, 15, 70, 350)
GRADINGS = [(0.003, 0.06), (0.002, 0.031), (0.0005, 0.035), (0.0001, 0.035)]


def run(obs: Path, scene: Path, out: Path, *extra: str):
    subprocess.run([str(obs), "run", str(scene), "--output", str(out), "--quiet", *extra], check=True)
    return json.loads((out / "summary.json").read_text())


def triangles(msh: Path) -> int:
    text = msh.read_text()
    block = text[text.index("$Elements"):text.index("$EndElements")].split("\n")[2:]
    count, i = 0, 0
    while i < len(block) and block[i].strip():
        _, _, kind, n = map(int, block[i].split())
        if kind == 2:
            count += n
        i += 1 + n
    return count


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("output")
    ap.add_argument("--obs", default=str(ROOT / "build" / "drivers" / "obs"))
    args = ap.parse_args()
    obs = Path(args.obs).resolve()
    scene = (ROOT / "data" / "scenes" / "twobody_gmsh_cylinders.toml").read_text()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # the generated scene at the imported scene's tolerance
        s = run(obs, ROOT / "data" / "scenes" / "twobody_cylinders.toml", tmp / "generated", "--set",
                "solver.tolerance=1e-12")
        rows.append(("generated (twobody_cylinders.toml, tolerance 1e-12)", "-", s))
        for hmin, hmax in GRADINGS:
            mesh_dir = tmp / f"h{hmin}_{hmax}"
            mesh_dir.mkdir()
            subprocess.run([str(ROOT / "scripts" / "make_half_cylinders.sh"), str(mesh_dir), str(hmin), str(hmax)],
                           check=True, stdout=subprocess.DEVNULL)
            n = triangles(mesh_dir / "half_cylinder_upper.msh")
            for projected in (True, False):
                text = scene.replace('"../meshes/', f'"{mesh_dir}/')
                if not projected:
                    text = "\n".join(line for line in text.splitlines() if not line.startswith("projection"))
                path = mesh_dir / f"scene_{int(projected)}.toml"
                path.write_text(text)
                label = f"Gmsh, hmin {hmin}, hmax {hmax}" + ("" if projected else ", no projection")
                print(label, "...", file=sys.stderr, flush=True)
                rows.append((label, n, run(obs, path, mesh_dir / f"out_{int(projected)}")))
    lines = ["| mesh | triangles per body (level 0) | unknowns | in contact | TNNMG iterations | solve s |",
             "|---|---:|---:|---:|---:|---:|"]
    for label, n, s in rows:
        pair = s["pairs"][0]
        lines.append(f"| {label} | {n} | {s['dofs']} | {pair['actual_vertices']} | {s['solver']['iterations']} | "
                     f"{s['times']['solve_s']:.3g} |")
    Path(args.output).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
