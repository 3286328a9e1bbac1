#!/usr/bin/env python3
"""Regenerates the tables and figures of docs/examples.md, section "Examples 1-3".

For each of the thesis' examples 1A/1B (punch), 2A/2B (wedge), 3A/3B (Hertz) it runs `obs run`
three times: adaptive with the contact-residual estimator, adaptive with the standard residual
estimator, and uniform refinement; then writes the PNG figures (scripts/plot_adaptivity.py) into
docs/figures/ and replaces the subsections of the examples it ran between the markers
    <!-- examples-1-3:begin -->  and  <!-- examples-1-3:end -->
of docs/examples.md with the tables (the other subsections and the rest of the file, e.g.
"Examples 4-9", are kept).

For the punch (1A/1B) the adaptive runs write pressure_NNN.csv per step and the script adds the
pressure errors of docs/examples.md ("The punch pressure error against the thesis' claim"):
E_P = steps.csv nodal_pressure_error_fixed_load (P* = reference_load = 1549.10 of the scene) and
E_ref against a fine reference run (the residual estimator with --ref-steps solves, cached in
<out>/<name>-ref and reused while its steps.csv has that many rows), plotted by
scripts/plot_punch_error.py.

    python3 scripts/examples.py                    # default sizes
    python3 scripts/examples.py --quick            # 3 steps each (a smoke test, < 1 minute)
    python3 scripts/examples.py --only example1a,example1b   # the punch only
    python3 scripts/examples.py --obs build/drivers/obs --steps-2d 18 --steps-3d 9   # larger

Only the standard library; plots need matplotlib (the script looks for a python3 that has it).
"""
import argparse
import bisect
import csv
import math
import os
import re
import shlex
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


def has_radius(rows):
    """Whether the run has a contact radius error to show: the wedge and Hertz scenes (the punch's is 0
    at every step, its contact zone being the punch by construction; a log plot of it is empty)."""
    return any(f(r, "radius_error") > 0 for r in rows)


def table(rows, extra=None):
    """The step table; extra: {column title: [value per step]} appended before P (the punch errors)."""
    extra = extra or {}
    radius = has_radius(rows)
    head = ["step", "vertices", "actual contact", "eta", "eoc", "pressure error (4.4)", "nodal pressure error",
            "centre error"] + (["radius error"] if radius else []) + list(extra) + ["P", "time [s]"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    elapsed = 0.0
    for i, r in enumerate(rows):
        elapsed += f(r, "solver_s") + f(r, "estimator_s") + (f(r, "refinement_s") or 0) + f(r, "transfer_s")
        cells = [fmt(f(r, "step")), fmt(f(r, "vertices")), fmt(f(r, "actual_contact")), fmt(f(r, "eta")),
                 fmt(f(r, "eoc"), 2), fmt(f(r, "pressure_error")), fmt(f(r, "nodal_pressure_error")),
                 fmt(f(r, "centre_error"))] + ([fmt(f(r, "radius_error"))] if radius else []) + \
                [fmt(v[i] if i < len(v) else float("nan")) for v in extra.values()] + \
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


TARGET = 3e-3  # the thesis' punch pressure error (Walloth 2012, Sec. 4.2.1)


def pressure_rows(path):
    """(x, s_p, m_p) of the potential contact vertices of a pressure.csv / pressure_NNN.csv, sorted by x."""
    return sorted((f(r, "x"), f(r, "s_p"), f(r, "m_p")) for r in read(path))


def interpolant(rows):
    """x -> piecewise-linear interpolation of the nodal values s_p of `rows` (sorted by x) along Gamma_C."""
    xs = [r[0] for r in rows]
    vs = [r[1] for r in rows]

    def at(x):
        i = bisect.bisect_left(xs, x)
        if i < len(xs) and xs[i] == x:
            return vs[i]
        if i == 0 or i == len(xs):
            raise ValueError(f"x = {x} outside the reference's potential contact boundary [{xs[0]}, {xs[-1]}]")
        t = (x - xs[i - 1]) / (xs[i] - xs[i - 1])
        return (1 - t) * vs[i - 1] + t * vs[i]
    return at


def reference_error(rows, ref, exclude_edges=False):
    """E_ref = sqrt(sum_p m_p (s_p - s_ref(x_p))^2 / sum_p m_p s_ref(x_p)^2) over the potential contact
    vertices of `rows` (all of them; exclude_edges: without the first and the last, the punch edges)."""
    if exclude_edges:
        rows = rows[1:-1]
    num = den = 0.0
    for x, sp, m in rows:
        r = ref(x)
        num += m * (sp - r) ** 2
        den += m * r * r
    return math.sqrt(num / den) if den > 0 else float("nan")


def first_reaching(rows, values, target=TARGET):
    """'N' (actual contact vertices of the first step with value <= target) or 'not reached (min ...)'."""
    for r, v in zip(rows, values):
        if v <= target:
            return f"{fmt(f(r, 'actual_contact'))} (step {fmt(f(r, 'step'))}, {v:.3g})"
    pairs = [(v, r) for r, v in zip(rows, values) if not math.isnan(v)]
    if not pairs:
        return "not computed"
    v, r = min(pairs, key=lambda p: p[0])
    return f"not reached (smallest {v:.3g}, step {fmt(f(r, 'step'))}, {fmt(f(r, 'actual_contact'))} actual contact)"


def punch_errors(name, title, out_dir, results, obs, ref_steps, figures, py):
    """E_P and E_ref per step of the adaptive punch runs; the figure, the table and the per-step columns."""
    ref_dir = os.path.join(out_dir, f"{name}-ref")
    scene = os.path.join(ROOT, "data", "scenes", name + ".toml")
    ref_csv = os.path.join(ref_dir, "steps.csv")
    if not (os.path.exists(ref_csv) and len(read(ref_csv)) == ref_steps):
        t0 = time.time()
        subprocess.run([obs, "run", scene, "-q", "-o", ref_dir, "--set", f"adaptivity.steps={ref_steps}",
                        "--set", 'adaptivity.estimator="residual"', "--set", 'adaptivity.vtk="none"'], check=True)
        print(f"{name} reference (residual, {ref_steps} solves): {time.time() - t0:.1f} s", file=sys.stderr)
    ref_steps_rows = read(ref_csv)
    ref = interpolant(pressure_rows(os.path.join(ref_dir, "pressure.csv")))
    extra, series = {}, []
    for tag, label in (("cr", "contact-residual"), ("res", "residual")):
        rows = results[tag]
        ep = [f(r, "nodal_pressure_error_fixed_load") for r in rows]
        eref, eint, cref = [], [], []
        for r in rows:
            pr = pressure_rows(os.path.join(out_dir, f"{name}-{tag}", f"pressure_{int(f(r, 'step')):03d}.csv"))
            eref.append(reference_error(pr, ref))
            eint.append(reference_error(pr, ref, exclude_edges=True))
            # the centre value against the reference run's (the vertex nearest to x = 0.5, as the
            # steps.csv centre error against p): separates the discretisation error from the formula's
            xc, sc, _ = min(pr, key=lambda q: abs(q[0] - 0.5))
            cref.append(abs(sc - ref(xc)) / abs(ref(xc)))
        extra[tag] = {"E_P": ep, "E_ref": eref, "E_ref without edges": eint, "centre error vs reference": cref}
        series.append((label, rows, ep, eref, eint))
    csv_path = os.path.join(out_dir, f"{name}-punch-errors.csv")
    with open(csv_path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["run", "step", "vertices", "actual_contact", "E_P", "E_ref", "E_ref_interior"])
        for label, rows, ep, eref, eint in series:
            for r, a, b, c in zip(rows, ep, eref, eint):
                w.writerow([label, fmt(f(r, "step")), fmt(f(r, "vertices")), fmt(f(r, "actual_contact")),
                            repr(a), repr(b), repr(c)])
    png = f"{name}_punch_error_vs_contact.png"
    if py:
        subprocess.run([py, os.path.join(ROOT, "scripts", "plot_punch_error.py"), csv_path,
                        os.path.join(figures, png), "--title", title], check=True)
    last = ref_steps_rows[-1]
    ref_centre = pressure_rows(os.path.join(ref_dir, "pressure.csv"))
    xc, sc, _ = min(ref_centre, key=lambda q: abs(q[0] - 0.5))
    text = ["**Punch pressure error against the thesis' claim** ([definitions and outcome](#punch-error)): E_P = `nodal_pressure_error_fixed_load` (P* = 1549.10, the two edge "
            "vertices excluded), E_ref against the reference run (the residual estimator, "
            f"{ref_steps} solves: {fmt(f(last, 'vertices'))} vertices, {fmt(f(last, 'unknowns'))} unknowns, "
            f"{fmt(f(last, 'actual_contact'))} actual contact vertices, P = {fmt(f(last, 'load'), 7)}; "
            "all potential contact vertices, and without the two edge vertices). "
            f"Actual contact vertices at the first step with error <= {TARGET:g}:", "",
            "| estimator | E_P <= 3e-3 | E_ref <= 3e-3 | E_ref without edges <= 3e-3 |", "|---|---|---|---|"]
    for label, rows, ep, eref, eint in series:
        text.append(f"| {label} | {first_reaching(rows, ep)} | {first_reaching(rows, eref)} | "
                    f"{first_reaching(rows, eint)} |")
    text.append("")
    text.append(f"Centre: the reference run's own centre error against p is {fmt(f(last, 'centre_error'))} "
                f"(s_c = {sc:.7g} at x = {xc:.6g}); the column 'centre error vs reference' is |s_c - s_ref(x_c)| / "
                "s_ref(x_c) for the vertex x_c nearest to 0.5. If it falls while the centre error against p stays "
                "put, the plateau of the latter is the formula's (the half-space solution applied to the unit "
                "square), not the discretisation's.")
    text.append("")
    # the two estimators step by step: largest relative difference of each error (all steps / second half)
    (_, _, ep1, er1, ei1), (_, _, ep2, er2, ei2) = series
    diffs = []
    for what, a, b in (("E_P", ep1, ep2), ("E_ref", er1, er2), ("E_ref without edges", ei1, ei2)):
        d = [abs(x - y) / y for x, y in zip(a, b) if y > 0]
        diffs.append(f"{what} {100 * max(d):.2g} % / {100 * max(d[len(d) // 2:]):.2g} %")
    text.append("Largest relative difference between the two estimators at the same step (all steps / from step "
                f"{len(ep1) // 2} on): " + ", ".join(diffs) + ".")
    text.append("")
    # the resolution at the edges: distance of the vertex next to each edge, per step (equal for both runs?)
    spacing = {}
    for tag, label in (("cr", "contact-residual"), ("res", "residual")):
        spacing[label] = []
        for r in results[tag]:
            pr = pressure_rows(os.path.join(out_dir, f"{name}-{tag}", f"pressure_{int(f(r, 'step')):03d}.csv"))
            spacing[label].append(max(pr[1][0] - pr[0][0], pr[-1][0] - pr[-2][0]))
    same = spacing["contact-residual"] == spacing["residual"]
    text.append(f"Distance of the vertex next to each punch edge (pressure_NNN.csv): "
                f"{'the same in both runs at every step' if same else 'different in the two runs'}, "
                f"{spacing['contact-residual'][0]:.4g} at step 0, {spacing['contact-residual'][-1]:.4g} at step "
                f"{len(spacing['contact-residual']) - 1} (contact-residual; residual {spacing['residual'][-1]:.4g}).")
    text.append("")
    # how fast E_P falls: 1/E_P^2 against the step k (least squares over the second half of the steps)
    for label, rows, ep, eref, eint in series:
        pts = [(f(r, "step"), 1 / v ** 2) for r, v in zip(rows, ep) if v > 0 and f(r, "step") >= len(rows) // 2]
        if len(pts) < 3:
            continue
        n = len(pts)
        mk, my = sum(p[0] for p in pts) / n, sum(p[1] for p in pts) / n
        slope = sum((p[0] - mk) * (p[1] - my) for p in pts) / sum((p[0] - mk) ** 2 for p in pts)
        reach_k = mk + (1 / TARGET ** 2 - my) / slope if slope > 0 else float("nan")
        text.append(f"{label}: 1/E_P^2 grows by {slope:.3g} per refinement step (least squares over steps "
                    f"{fmt(pts[0][0])}-{fmt(pts[-1][0])}: from {pts[0][1]:.4g} to {pts[-1][1]:.4g}); extrapolated, "
                    f"E_P = {TARGET:g} (1/E_P^2 = {1 / TARGET ** 2:.4g}) at step {reach_k:.0f}.")
        text.append("")
    if py:
        text += [f"![{name} punch error vs contact](figures/{png})", ""]
    return extra, text


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--obs", default=find_obs())
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "examples"))
    ap.add_argument("--steps-punch", type=int, default=12,
                    help="solves of the adaptive runs of Examples 1A/1B (the thesis: 16, 15 refinements; docs/examples.md)")
    ap.add_argument("--ref-steps", type=int, default=None,
                    help="solves of the punch reference run (residual estimator; default: --steps-punch + 2)")
    ap.add_argument("--steps-2d", type=int, default=12, help="solves of the other adaptive 2D runs (wedge)")
    ap.add_argument("--steps-3d", type=int, default=6, help="solves of the adaptive 3D runs")
    ap.add_argument("--uniform-2d", type=int, default=5)
    ap.add_argument("--uniform-3d", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="3 steps everywhere (smoke test)")
    ap.add_argument("--only", help="comma-separated scene names (default: all six)")
    ap.add_argument("--no-doc", action="store_true", help="do not rewrite docs/examples.md")
    ap.add_argument("--figures", default=os.path.join(ROOT, "docs", "figures"),
                    help="directory of the PNG figures (default docs/figures)")
    ap.add_argument("--reuse", action="store_true", help="reuse the steps.csv files of an earlier run in --out")
    args = ap.parse_args()
    if args.quick:
        args.steps_2d = args.steps_3d = args.uniform_2d = args.uniform_3d = args.steps_punch = 3
    if args.ref_steps is None:
        args.ref_steps = args.steps_punch + 2
    py = python_with_matplotlib()
    figures = args.figures
    # the source line of every subsection written (scripts/provenance.py; the ctest docs.provenance checks it)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import provenance
    source = provenance.stamp([" ".join(["python3 scripts/examples.py"] + [shlex.quote(a) for a in sys.argv[1:]])], ROOT)
    os.makedirs(figures, exist_ok=True)
    sections = {}
    started = time.time()
    for name, title, what, dim in EXAMPLES:
        if args.only and name not in args.only.split(","):
            continue
        scene = os.path.join(ROOT, "data", "scenes", name + ".toml")
        results = {}
        for tag, label, extra in RUNS:
            punch = name.startswith("example1")
            steps = (args.uniform_2d if dim == 2 else args.uniform_3d) if tag == "uni" else \
                args.steps_punch if punch else (args.steps_2d if dim == 2 else args.steps_3d)
            out = os.path.join(args.out, f"{name}-{tag}")
            cmd = [args.obs, "run", scene, "-q", "-o", out, "--set", f"adaptivity.steps={steps}",
                   "--set", 'adaptivity.vtk="none"'] + extra
            if punch and tag != "uni":
                cmd += ["--set", 'adaptivity.pressure="every"']
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
        extra, punch_text = {}, []
        if name.startswith("example1"):
            extra, punch_text = punch_errors(name, title, args.out, results, args.obs, args.ref_steps, figures, py)
        text = [f"### {title}: {what}", "", source, ""]
        text.append(f"`obs run data/scenes/{name}.toml` (adaptive, contact-residual); the other runs add "
                    "`--set 'adaptivity.estimator=\"residual\"'` or `--set 'adaptivity.refinement=\"uniform\"'`.")
        text.append("")
        for tag, label, _ in RUNS:
            text += [f"**{label}**", "", table(results[tag], extra.get(tag)), ""]
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
        text += punch_text
        if py:
            text.append(" ".join(f"![{name} {k}](figures/{name}_{k}.png)" for k in
                                 ("estimator", "pressure_error", "pressure") +
                                 (("radius_error",) if has_radius(results["cr"]) else ()) +
                                 (("centre_error",) if dim == 3 else ())))
            text.append("")
        sections[title] = "\n".join(text)
    print(f"all runs: {time.time() - started:.0f} s", file=sys.stderr)
    if args.no_doc:
        return 0
    doc = os.path.join(ROOT, "docs", "examples.md")
    old = open(doc).read() if os.path.exists(doc) else ""
    begin, end = "<!-- examples-1-3:begin -->", "<!-- examples-1-3:end -->"
    # the subsections "### Example ..." between the markers, in the order of EXAMPLES; those not run now are kept
    kept = {}
    if begin in old and end in old:
        block = old[old.index(begin) + len(begin):old.index(end)]
        for part in re.split(r"\n(?=### )", "\n" + block.strip("\n")):
            part = part.strip("\n")
            m = re.match(r"### (Example \w+):", part)
            if m:
                kept[m.group(1)] = part
    kept.update({t: v.strip("\n") for t, v in sections.items()})
    body = "\n\n".join(kept[t] for _, t, _, _ in EXAMPLES if t in kept)
    if begin in old and end in old:
        new = old[:old.index(begin)] + begin + "\n" + body + "\n\n" + old[old.index(end):]
    else:
        new = old + "\n" + begin + "\n" + body + "\n\n" + end + "\n"
    with open(doc, "w") as fh:
        fh.write(new)
    print(f"written {doc}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
