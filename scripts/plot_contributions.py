#!/usr/bin/env python3
"""The dominant contributions of the contact estimator against the number of vertices (thesis
Fig. 4.22, Example 4): eta_1^2 (element residual), eta_2^2 (interior jumps), eta_4^2 + eta_5^2
(contact stress) and eta^2 = sum_k eta_k^2, one panel per starting grid, logarithmic scales.

Reads the step tables that scripts/examples_3d.sh writes (steps.csv of each run, copied to
docs/figures/ex4-9/example4_<grid>_adaptive.csv) and writes one PNG:

    /usr/bin/python3 scripts/plot_contributions.py \\
        --output docs/figures/fig4_22_example4_contributions.png \\
        docs/figures/ex4-9/example4_hexahedron_adaptive.csv \\
        docs/figures/ex4-9/example4_tetrahedron_adaptive.csv \\
        docs/figures/ex4-9/example4_prism_adaptive.csv

Each input's panel title is the grid named in its file name (example4_<grid>_...). Only python3 and
matplotlib (Agg backend); exit code 3 with a message on stderr if matplotlib is missing. Also
prints, per input, the first and the last step's shares of eta^2 (the table in docs/examples.md).
"""

import argparse
import csv
import os
import re
import sys

CURVES = [  # short name, label, the contributions summed (their squares), colour as in the thesis' figure
    ("eta_1^2", "eta_1^2 (element residual)", ["eta_1"], "goldenrod"),
    ("eta_2^2", "eta_2^2 (interior jump)", ["eta_2"], "red"),
    ("eta_4^2 + eta_5^2", "eta_4^2 + eta_5^2 (contact stress)", ["eta_4", "eta_5"], "blue"),
    ("eta^2", "eta^2 = sum_k eta_k^2", ["eta"], "black"),
]


def read(path):
    rows = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            if r.get("eta", "") == "":
                continue  # a step without an estimate (unconverged) has none
            rows.append(r)
    if not rows:
        raise SystemExit(f"{path}: no step with an estimate")
    for name in ("vertices", "eta", "eta_1", "eta_2", "eta_4", "eta_5"):
        if name not in rows[0]:
            raise SystemExit(f"{path}: no column '{name}' (a steps.csv of the contact-residual estimator?)")
    return rows


def value(row, names):
    return sum(float(row[n]) ** 2 for n in names)


def grid_name(path):
    m = re.search(r"example\d+_([a-z]+)_", os.path.basename(path))
    return m.group(1) if m else os.path.basename(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--output", required=True, help="the PNG to write")
    ap.add_argument("tables", nargs="+", help="steps.csv files, one panel each")
    args = ap.parse_args()
    data = [(grid_name(p), read(p)) for p in args.tables]

    for grid, rows in data:
        for step in (rows[0], rows[-1]):
            total = float(step["eta"]) ** 2
            shares = ", ".join(f"{short} {100 * value(step, names) / total:.0f} %"
                               for short, _, names, _ in CURVES[:-1])
            print(f"{grid}, step {step['step']} ({step['vertices']} vertices): {shares}")

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_contributions.py: matplotlib is not installed (run it with /usr/bin/python3 or "
              "install python3-matplotlib)", file=sys.stderr)
        return 3

    fig, axes = plt.subplots(1, len(data), figsize=(4.2 * len(data), 3.8), squeeze=False)
    for ax, (grid, rows) in zip(axes[0], data):
        n = [float(r["vertices"]) for r in rows]
        for _, label, names, colour in CURVES:
            ax.loglog(n, [value(r, names) for r in rows], "o-", color=colour, markersize=3, label=label)
        ax.set_title(f"Example 4, {grid}")
        ax.set_xlabel("vertices")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("squared contribution")
    axes[0][-1].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(args.output)), exist_ok=True)
    fig.savefig(args.output, dpi=110)
    print(f"written: {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
