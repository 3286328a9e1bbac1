#!/usr/bin/env python3
"""TNNMG on the Hertz scene (data/scenes/hertz.toml, 16^3 hexahedra) as nu -> 1/2, with the standard
and the B-bar formulation and the smoothers of the linear correction ([solver] smoother,
krylov_steps, linear_smoothing; docs/theory.md#vertex-patch-smoother): iterations, V-cycles, convergence rate, load P,
solve time and peak memory per run, printed as the markdown table of docs/performance.md
("Nearly incompressible materials").

    python3 scripts/nearly_incompressible.py [build/drivers/obs] [max_iterations]
"""
import json
import subprocess
import sys
import tempfile

OBS = sys.argv[1] if len(sys.argv) > 1 else "build/drivers/obs"
MAXIT = sys.argv[2] if len(sys.argv) > 2 else "500"

# (formulation, smoother, krylov_steps, linear_smoothing); the first two are the defaults
SETTINGS = [("standard", "gauss-seidel", 0, 3), ("bbar", "gauss-seidel", 0, 3),
            ("bbar", "vertex-patch", 0, 3), ("bbar", "vertex-patch", 2, 3), ("bbar", "vertex-patch", 3, 1)]

print("| nu | formulation | smoother | cycle | CG steps | TNNMG iterations | V-cycles | rate | converged | load P | "
      "solve [s] | peak memory [MB] |")
print("|---:|---|---|---|---:|---:|---:|---:|---|---:|---:|---:|")
for nu in ["0.3", "0.45", "0.49", "0.499", "0.4999"]:
    for formulation, smoother, krylov, sweeps in SETTINGS:
        with tempfile.TemporaryDirectory() as out:
            cmd = [OBS, "run", "data/scenes/hertz.toml", "--quiet", "-o", out,
                   "--set", f"material.nu={nu}", "--set", f'material.formulation="{formulation}"',
                   "--set", f"solver.max_iterations={MAXIT}"]
            if smoother != "gauss-seidel" or krylov or sweeps != 3:
                cmd += ["--set", f'solver.smoother="{smoother}"', "--set", f"solver.krylov_steps={krylov}",
                        "--set", f"solver.linear_smoothing={sweeps}"]
            subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # non-converged: exit 1
            s = json.load(open(f"{out}/summary.json"))
        solver = s["solver"]
        print(f"| {nu} | {formulation} | {smoother} | V({sweeps},{sweeps}) | {krylov} | {solver['iterations']} | {solver['vcycles']} | "
              f"{solver['convergence_rate']:.3f} | {'yes' if solver['converged'] else 'no'} | "
              f"{s['contact']['load_P']:.2f} | {solver['time_s']:.2f} | {s['peak_memory_mb']:.0f} |", flush=True)
