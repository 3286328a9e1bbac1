#!/usr/bin/env python3
"""Thesis Fig. 4.25: the numbers of actual (aC), semi- (sC) and full-contact (fC) vertices divided by
the number of potential contact vertices (C), against the adaptive step k = 1, 2, ..., from the
steps.csv of an adaptive run (columns potential_contact, actual_contact, semi_contact,
full_contact).

    plot_contact_ratios.py --output OUT.png [--title TITLE] STEPS.csv

Prints the ratios per step. Only python3 and matplotlib (Agg); exit code 3 if matplotlib is missing.
"""
import argparse
import csv
import sys


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("steps")
    ap.add_argument("--output", required=True)
    ap.add_argument("--title", default="")
    args = ap.parse_args(argv)
    with open(args.steps, newline="") as f:
        rows = [r for r in csv.DictReader(f) if int(r["step"]) >= 1]
    if not rows:
        sys.stderr.write(f"plot_contact_ratios.py: {args.steps} has no step k >= 1\n")
        return 1
    ks = [int(r["step"]) for r in rows]
    series = {}
    for key, label in (("actual_contact", "aC / C"), ("semi_contact", "sC / C"), ("full_contact", "fC / C")):
        series[label] = [float(r[key]) / float(r["potential_contact"]) for r in rows]
    print("| k | N | C | " + " | ".join(series) + " |")
    print("|---|---|---|" + "---|" * len(series))
    for i, r in enumerate(rows):
        print(f"| {ks[i]} | {r['vertices']} | {r['potential_contact']} | "
              + " | ".join(f"{v[i]:.3f}" for v in series.values()) + " |")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        sys.stderr.write("plot_contact_ratios.py: matplotlib is missing (use /usr/bin/python3)\n")
        return 3
    fig, ax = plt.subplots(figsize=(5.6, 3.8))
    for (label, v), style in zip(series.items(), ("o-", "s-", "^-")):
        ax.plot(ks, v, style, label=label)
    ax.set_xlabel("adaptive step k")
    ax.set_ylabel("share of the potential contact vertices")
    ax.set_xticks(ks)
    ax.set_ylim(0, 1)
    ax.set_title(args.title + (": " if args.title else "") + "contact vertices / potential contact vertices",
                 fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.output, dpi=100)
    print(args.output, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
