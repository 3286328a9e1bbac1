#!/usr/bin/env python3
"""Plots of `obs run` adaptive runs ([adaptivity], docs/scenes.md, docs/examples.md).

Reads one or more steps.csv files (one per run: adaptive contact-residual, adaptive residual,
uniform, ...) and writes into --output:
  estimator.png       eta against the number of vertices (log-log; slope = -eoc, docs/theory.md#eoc);
  pressure_error.png  relative L2 pressure error (docs/theory.md#pressure-error) against the actual contact
                      vertices (log-log), if the runs have a reference;
  radius_error.png    relative contact radius error against the actual contact vertices (if given);
  pressure.png        with --pressure pressure.csv: s_p and the exact pressure along the contact
                      boundary (coordinate s along the boundary in 2D, radius in 3D).
Only python3 and matplotlib (Agg backend). Exit code 3 (and a message on stderr) if matplotlib is
missing, so that callers can warn instead of failing.

  python3 scripts/plot_adaptivity.py --output out/ex1 out/ex1-cr/steps.csv out/ex1-res/steps.csv \
      --labels "contact-residual,residual" --pressure out/ex1-cr/pressure.csv
"""
import argparse
import csv
import os
import sys


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def column(rows, key):
    out = []
    for r in rows:
        v = r.get(key, "")
        out.append(float(v) if v not in ("", None) else None)
    return out


def pairs(xs, ys):
    return [(x, y) for x, y in zip(xs, ys) if x is not None and y is not None and x > 0 and y > 0]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("steps", nargs="+", help="steps.csv files of obs run with [adaptivity]")
    ap.add_argument("--output", "-o", default=".", help="directory of the PNG files")
    ap.add_argument("--labels", help="legend labels separated by ';' (or ','); default: the parent directory names")
    ap.add_argument("--label", help="label of a single run")
    ap.add_argument("--pressure", help="pressure.csv of a run (s_p and exact p along Gamma_C)")
    ap.add_argument("--title", default="", help="title prefix")
    ap.add_argument("--prefix", default="", help="file name prefix of the PNGs")
    args = ap.parse_args()
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_adaptivity.py: matplotlib is not installed; no plots written", file=sys.stderr)
        return 3

    runs = [read_csv(p) for p in args.steps]
    if args.labels:
        labels = args.labels.split(";" if ";" in args.labels else ",")
    elif args.label and len(runs) == 1:
        labels = [args.label]
    else:
        labels = [os.path.basename(os.path.dirname(os.path.abspath(p))) for p in args.steps]
    labels += [os.path.basename(p) for p in args.steps[len(labels):]]
    os.makedirs(args.output, exist_ok=True)
    title = (args.title + ": ") if args.title else ""

    def loglog(xkey, ykey, xlabel, ylabel, name, what):
        fig, ax = plt.subplots(figsize=(5, 3.6), dpi=90)
        drawn = False
        for rows, label in zip(runs, labels):
            pts = pairs(column(rows, xkey), column(rows, ykey))
            if pts:
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", ms=3, label=label)
                drawn = True
        if drawn:
            ax.set_xlabel(xlabel)
            ax.set_ylabel(ylabel)
            ax.set_title(title + what, fontsize=10)
            ax.grid(True, which="both", lw=0.3)
            ax.legend(fontsize=8)
            fig.tight_layout()
            fig.savefig(os.path.join(args.output, args.prefix + name))
        plt.close(fig)

    loglog("vertices", "eta", "vertices N", "estimator eta", "estimator.png", "estimator vs vertices")
    loglog("actual_contact", "pressure_error", "actual contact vertices", "relative L2 pressure error",
           "pressure_error.png", "pressure error")
    loglog("actual_contact", "radius_error", "actual contact vertices", "relative radius error",
           "radius_error.png", "contact radius error")
    loglog("actual_contact", "centre_error", "actual contact vertices", "relative centre error",
           "centre_error.png", "error at the centre node")

    if args.pressure:
        rows = read_csv(args.pressure)
        s, sp, ex = column(rows, "s"), column(rows, "s_p"), column(rows, "exact_p")
        fig, ax = plt.subplots(figsize=(5, 3.6), dpi=90)
        ax.plot([a for a, b in zip(s, sp) if b is not None], [b for b in sp if b is not None], "r.", ms=3,
                label="s_p (obs)")
        pe = [(a, b) for a, b in zip(s, ex) if a is not None and b is not None]
        if pe:
            ax.plot([p[0] for p in pe], [p[1] for p in pe], "b.", ms=2, label="exact p")
            finite = sorted(b for b in sp if b is not None)
            if finite:
                ax.set_ylim(0, 1.5 * finite[-1] if finite[-1] > 0 else 1)
        ax.set_xlabel("s (along the contact boundary; radius in 3D)")
        ax.set_ylabel("contact pressure")
        ax.set_title(title + "contact pressure, last step", fontsize=10)
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(args.output, args.prefix + "pressure.png"))
        plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
