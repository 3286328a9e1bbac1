#!/usr/bin/env python3
"""TNNMG on the Hertz scene (data/scenes/hertz.toml, 16^3 hexahedra) as nu -> 1/2, with the standard
and the B-bar formulation: iterations, convergence rate, load P and solve time per run, printed as
the markdown table of docs/performance.md ("Nearly incompressible materials").

    python3 scripts/nearly_incompressible.py [build/drivers/obs] [max_iterations]
"""
import json
import subprocess
import sys
import tempfile

OBS = sys.argv[1] if len(sys.argv) > 1 else "build/drivers/obs"
MAXIT = sys.argv[2] if len(sys.argv) > 2 else "500"

print("| nu | formulation | TNNMG iterations | rate | converged | load P | solve [s] |")
print("|---:|---|---:|---:|---|---:|---:|")
for nu in ["0.3", "0.45", "0.49", "0.499", "0.4999"]:
    for formulation in ["standard", "bbar"]:
        with tempfile.TemporaryDirectory() as out:
            cmd = [OBS, "run", "data/scenes/hertz.toml", "--quiet", "-o", out,
                   "--set", f"material.nu={nu}", "--set", f'material.formulation="{formulation}"',
                   "--set", f"solver.max_iterations={MAXIT}"]
            subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # non-converged: exit 1
            s = json.load(open(f"{out}/summary.json"))
        solver = s["solver"]
        print(f"| {nu} | {formulation} | {solver['iterations']} | {solver['convergence_rate']:.3f} | "
              f"{'yes' if solver['converged'] else 'no'} | {s['contact']['load_P']:.2f} | {solver['time_s']:.2f} |")
