#!/usr/bin/env python3
"""Regenerates the tables and figures of docs/examples.md, section "Examples 1-3".

For each of the thesis' examples 1A/1B (punch), 2A/2B (wedge), 3A/3B (Hertz) it runs `obs run`
three times: adaptive with the contact-residual estimator, adaptive with the standard residual
estimator, and uniform refinement; then writes the PNG figures (scripts/plot_adaptivity.py) into
docs/figures/ and replaces the text between the markers
    <!-- examples-1-3:begin -->  and  <!-- examples-1-3:end -->
of docs/examples.md with the tables (the rest of the file, e.g. "Examples 4-9", is kept).

    python3 scripts/examples.py                    # default sizes, 1.5-5 minutes (machine load)
    python3 scripts/examples.py --quick            # 3 steps each (a smoke test, < 1 minute)
    python3 scripts/examples.py --obs build/drivers/obs --steps-2d 18 --steps-3d 9   # larger

Only the standard library; plots need matplotlib (the script looks for a python3 that has it).
"""
import argparse
import csv
import math
import os
import re
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

EXAMPLES = [
    ("example1a", "Example 1A", "punch, quadrilaterals (256 at the start)", 2),
    ("example1b", "Example 1B", "punch, triangles (512 at the start)", 2),
    ("example2a", "Example 2A", "wedge, quadrilaterals (256 at the start)", 2),
    ("example2b", "Example 2B", "wedge, triangles (512 at the start)", 2),
    ("example3a", "Example 3A", "Hertz, hexahedra (64 at the start)", 3),
    ("example3b", "Example 3B", "Hertz, tetrahedra (384 at the start)", 3),
]
RUNS = [("cr", "adaptive, contact-residual", []),
        ("res", "adaptive, residual", ["--set", 'adaptivity.estimator="residual"']),
        ("uni", "uniform", ["--set", 'adaptivity.refinement="uniform"'])]


def find_obs():
    for p in ("build/drivers/obs", "build-release/drivers/obs"):
        if os.path.exists(os.path.join(ROOT, p)):
            return os.path.join(ROOT, p)
    return "obs"


def python_with_matplotlib():
    for py in (os.environ.get("OBS_PYTHON"), sys.executable, "python3", "/usr/bin/python3"):
        if py and subprocess.call([py, "-c", "import matplotlib"], stderr=subprocess.DEVNULL) == 0:
            return py
    return None


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def f(row, key):
    v = row.get(key, "")
    return float(v) if v not in ("", None) else float("nan")


def fmt(x, digits=3):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return ""
    if isinstance(x, float) and not x.is_integer():
        return f"{x:.{digits}g}"
    return str(int(x))


def table(rows, dim):
    head = ["step", "vertices", "actual contact", "eta", "eoc", "pressure error (4.4)", "nodal pressure error",
            "centre error"] + (["radius error"] if dim == 3 else []) + ["P", "time [s]"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    elapsed = 0.0
    for r in rows:
        elapsed += f(r, "solver_s") + f(r, "estimator_s") + (f(r, "refinement_s") or 0) + f(r, "transfer_s")
        cells = [fmt(f(r, "step")), fmt(f(r, "vertices")), fmt(f(r, "actual_contact")), fmt(f(r, "eta")),
                 fmt(f(r, "eoc"), 2), fmt(f(r, "pressure_error")), fmt(f(r, "nodal_pressure_error")),
                 fmt(f(r, "centre_error"))] + ([fmt(f(r, "radius_error"))] if dim == 3 else []) + \
                [fmt(f(r, "load"), 6), f"{elapsed:.2f}"]
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def reach(rows, key, target):
    """(actual contact vertices, vertices, seconds) of the first step with rows[key] <= target."""
    elapsed = 0.0
    for r in rows:
        elapsed += f(r, "solver_s") + f(r, "estimator_s") + f(r, "transfer_s")
        if f(r, key) <= target:
            return f"{fmt(f(r, 'actual_contact'))} / {fmt(f(r, 'vertices'))} / {elapsed:.2f} s"
        elapsed += f(r, "refinement_s") if not math.isnan(f(r, "refinement_s")) else 0
    return "not reached"


def interior_errors(*paths, b=0.0625):
    """Nodal relative L2 error of s_p on |s| <= f b (trapezoidal weights along Gamma_C), last step."""
    fracs = (1.0, 0.99, 0.95, 0.9)
    out = ["Punch, last step: nodal relative L2 error of s_p against p(., P) on the part |s| <= f b of the",
           "contact zone (trapezoidal weights; f = 1: all of it, the edge nodes where p is infinite left out):", "",
           "| run | actual contact | " + " | ".join(f"f = {f:g}" for f in fracs) + " |",
           "|---|---|" + "---|" * len(fracs)]
    for path in paths:
        rows = [(f(r, "s"), f(r, "s_p"), f(r, "exact_p")) for r in read(path)]
        cells = []
        for frac in fracs:
            num = den = 0.0
            for i, (s, sp, ex) in enumerate(rows):
                if abs(s) >= frac * b - 1e-12 or not ex > 0:
                    continue
                w = ((s - rows[i - 1][0]) / 2 if i > 0 else 0) + ((rows[i + 1][0] - s) / 2 if i + 1 < len(rows) else 0)
                num += w * (sp - ex) ** 2
                den += w * ex * ex
            cells.append(fmt(math.sqrt(num / den)) if den > 0 else "")
        contact = read(os.path.join(os.path.dirname(path), "steps.csv"))[-1]["actual_contact"]
        out.append(f"| {os.path.basename(os.path.dirname(path))} | {contact} | " + " | ".join(cells) + " |")
    return out + [""]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--obs", default=find_obs())
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "examples"))
    ap.add_argument("--steps-2d", type=int, default=12, help="solves of the adaptive 2D runs")
    ap.add_argument("--steps-3d", type=int, default=6, help="solves of the adaptive 3D runs")
    ap.add_argument("--uniform-2d", type=int, default=5)
    ap.add_argument("--uniform-3d", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="3 steps everywhere (smoke test)")
    ap.add_argument("--only", help="comma-separated scene names (default: all six)")
    ap.add_argument("--no-doc", action="store_true", help="do not rewrite docs/examples.md")
    ap.add_argument("--reuse", action="store_true", help="reuse the steps.csv files of an earlier run in --out")
    args = ap.parse_args()
    if args.quick:
        args.steps_2d = args.steps_3d = args.uniform_2d = args.uniform_3d = 3
    py = python_with_matplotlib()
    figures = os.path.join(ROOT, "docs", "figures")
    os.makedirs(figures, exist_ok=True)
    sections = []
    started = time.time()
    for name, title, what, dim in EXAMPLES:
        if args.only and name not in args.only.split(","):
            continue
        scene = os.path.join(ROOT, "data", "scenes", name + ".toml")
        results = {}
        for tag, label, extra in RUNS:
            steps = (args.uniform_2d if dim == 2 else args.uniform_3d) if tag == "uni" else \
                (args.steps_2d if dim == 2 else args.steps_3d)
            out = os.path.join(args.out, f"{name}-{tag}")
            cmd = [args.obs, "run", scene, "-q", "-o", out, "--set", f"adaptivity.steps={steps}",
                   "--set", 'adaptivity.vtk="none"'] + extra
            t0 = time.time()
            if not (args.reuse and os.path.exists(os.path.join(out, "steps.csv"))):
                subprocess.run(cmd, check=True)
            print(f"{name} {label}: {steps} steps, {time.time() - t0:.1f} s", file=sys.stderr)
            results[tag] = read(os.path.join(out, "steps.csv"))
        if py:
            subprocess.run([py, os.path.join(ROOT, "scripts", "plot_adaptivity.py"), "--output", figures,
                            "--prefix", name + "_", "--title", title,
                            "--labels", ";".join(label for _, label, _ in RUNS),
                            "--pressure", os.path.join(args.out, f"{name}-cr", "pressure.csv")] +
                           [os.path.join(args.out, f"{name}-{t}", "steps.csv") for t, _, _ in RUNS], check=True)
        text = [f"### {title}: {what}", ""]
        text.append(f"`obs run data/scenes/{name}.toml` (adaptive, contact-residual); the other runs add "
                    "`--set 'adaptivity.estimator=\"residual\"'` or `--set 'adaptivity.refinement=\"uniform\"'`.")
        text.append("")
        for tag, label, _ in RUNS:
            text += [f"**{label}**", "", table(results[tag], dim), ""]
        key = "pressure_error"
        text.append("Actual contact vertices / vertices / cumulative time (solve + estimate + transfer + "
                    "refine) at the first step reaching a pressure error (4.4):")
        text.append("")
        targets = [0.5, 0.3, 0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.003]
        text.append("| error <= | " + " | ".join(label for _, label, _ in RUNS) + " |")
        text.append("|---|" + "---|" * len(RUNS))
        for target in targets:
            cells = [reach(results[t], key, target) for t, _, _ in RUNS]
            if all(c == "not reached" for c in cells):
                continue
            text.append(f"| {target:g} | " + " | ".join(cells) + " |")
        text.append("")
        if name.startswith("example1"):
            text += interior_errors(os.path.join(args.out, f"{name}-cr", "pressure.csv"),
                                    os.path.join(args.out, f"{name}-res", "pressure.csv"))
        if py:
            text.append(" ".join(f"![{name} {k}](figures/{name}_{k}.png)" for k in
                                 ("estimator", "pressure_error", "pressure") +
                                 (("radius_error", "centre_error") if dim == 3 else ())))
            text.append("")
        sections.append("\n".join(text))
    print(f"all runs: {time.time() - started:.0f} s", file=sys.stderr)
    if args.no_doc:
        return 0
    doc = os.path.join(ROOT, "docs", "examples.md")
    body = "\n".join(sections)
    old = open(doc).read() if os.path.exists(doc) else ""
    begin, end = "<!-- examples-1-3:begin -->", "<!-- examples-1-3:end -->"
    if begin in old and end in old:
        new = re.sub(re.escape(begin) + ".*?" + re.escape(end), lambda m: begin + "\n" + body + "\n" + end,
                     old, flags=re.S)
    else:
        new = old + "\n" + begin + "\n" + body + "\n" + end + "\n"
    with open(doc, "w") as fh:
        fh.write(new)
    print(f"written {doc}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
