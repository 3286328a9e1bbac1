#!/usr/bin/env python3
"""Punch pressure errors against the number of actual contact vertices (docs/examples.md, Examples 1A/1B).

Reads the CSV written by scripts/examples.py (columns run, step, actual_contact, E_P, E_ref,
E_ref_interior; one row per run and step) and writes one log-log PNG: E_P (nodal L2 error against
p(.; P*) with the fixed load P*), E_ref (against the fine reference run, all potential contact
vertices) and E_ref without the two edge vertices, for each run, with the thesis' target 3e-3 as a
horizontal line. Needs matplotlib (Agg backend); exit code 3 without it.

  /usr/bin/python3 scripts/plot_punch_error.py out/examples/example1a-punch-errors.csv \
      docs/figures/example1a_punch_error_vs_contact.png --title "Example 1A"
"""
import argparse
import csv
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("errors", help="CSV: run, step, actual_contact, E_P, E_ref, E_ref_interior")
    ap.add_argument("png", help="output PNG")
    ap.add_argument("--title", default="")
    ap.add_argument("--target", type=float, default=3e-3)
    args = ap.parse_args()
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_punch_error.py: matplotlib is not installed; no plot written", file=sys.stderr)
        return 3
    with open(args.errors, newline="") as f:
        rows = list(csv.DictReader(f))
    runs = []
    for r in rows:
        if r["run"] not in runs:
            runs.append(r["run"])
    styles = {"E_P": ("-", "o", "E_P (p(.; P*), P* fixed, edges excluded)"),
              "E_ref": ("--", "s", "E_ref (fine reference, all vertices)"),
              "E_ref_interior": (":", "^", "E_ref without the two edge vertices")}
    colours = ["tab:blue", "tab:red", "tab:green", "tab:purple"]
    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    for i, run in enumerate(runs):
        sel = [r for r in rows if r["run"] == run]
        for key, (ls, marker, what) in styles.items():
            pts = [(float(r["actual_contact"]), float(r[key])) for r in sel
                   if r.get(key) not in ("", None) and float(r[key]) > 0 and float(r["actual_contact"]) > 0]
            if not pts:
                continue
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], linestyle=ls, marker=marker, markersize=4,
                      color=colours[i % len(colours)], label=f"{run}: {what}")
    ax.axhline(args.target, color="grey", linewidth=0.8)
    ax.text(ax.get_xlim()[0] * 1.1, args.target * 1.08, f"{args.target:g}", color="grey", fontsize=8)
    ax.set_xlabel("actual contact vertices")
    ax.set_ylabel("relative nodal L2 pressure error")
    ax.set_title(f"{args.title}: punch pressure error against actual contact vertices".strip(": "))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.png, dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
