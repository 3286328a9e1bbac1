#!/usr/bin/env python3
"""Energy of several dynamic runs against time, relative to the initial value (thesis Fig. 5.3(b),
the control run of docs/dynamics.md), from their timeseries.csv.

    energy_runs.py OUT.png --title TITLE LABEL=RUN_DIR [LABEL=RUN_DIR ...]

Plots E/E_0 (E with the lumped mass M, column `energy`) of every run in one panel and, for runs
with a redistributed mass (column `energy_redistributed` not empty), E~/E~_0 in a second. Prints a
Markdown table row per run: E_end/E_0, max and min over t of E/E_0, and the same for E~; then a
second table with the energy lost at impact, at detachment and after the contact episode and the
largest increase of E/E_0 from one step to the next, computed by scripts/chapter5.py's analyse()
(episode: the steps with active_solution > 0; peak: the largest total contact force).
Only the standard library and matplotlib (the table is printed without matplotlib too).
"""
import csv
import math
import os
import sys


def series(run, column):
    with open(os.path.join(run, "timeseries.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    t = [float(r["t"]) for r in rows]
    v = [float(r[column]) if r.get(column) not in (None, "") else math.nan for r in rows]
    if not v or math.isnan(v[0]) or v[0] == 0:
        return t, None
    return t, [x / v[0] for x in v]


def main(argv):
    title = ""
    if "--title" in argv:
        i = argv.index("--title")
        title = argv[i + 1]
        argv = argv[:i] + argv[i + 2:]
    if len(argv) < 2:
        sys.stderr.write(__doc__)
        return 2
    png, runs = argv[0], [a.split("=", 1) for a in argv[1:]]
    data = []
    print("| run | E_end/E_0 | max E/E_0 | min E/E_0 | E~_end/E~_0 | max E~/E~_0 | min E~/E~_0 |")
    print("|---|---|---|---|---|---|---|")
    for label, run in runs:
        t, e = series(run, "energy")
        _, er = series(run, "energy_redistributed")
        data.append((label, t, e, er))
        cell = lambda s: ("%.4f | %.4f | %.4f" % (s[-1], max(s), min(s))) if s else "– | – | –"
        print(f"| {label} | {cell(e)} | {cell(er)} |")
    print()
    print("| run | first contact | peak force (t) | free at | lost at impact % | at detachment % | after % | "
          "largest step increase of E/E_0 |")
    print("|---|---|---|---|---|---|---|---|")
    # the phases by scripts/chapter5.py's own analysis (one definition of impact and detachment)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import chapter5
    pct = lambda x: "" if x is None else f"{100 * x:.2f}"
    for label, run in runs:
        s = chapter5.read(os.path.join(run, "timeseries.csv"))
        E = s["energy"]
        rise = max(b - a for a, b in zip(E, E[1:])) / E[0]
        # v0 only scales the tracked-node figures of analyse(), which are not printed here
        r = chapter5.analyse(s, v0=1.0)
        if not r["contact"]:
            print(f"| {label} | no contact | | | | | | {rise:.2g} |")
            continue
        free = "" if r["t_free"] is None else f"{r['t_free']:.4g}"
        print(f"| {label} | {r['t_first']:.4g} | {r['max_force']:.4g} ({r['t_peak']:.4g}) | {free} | "
              f"{pct(r['loss_impact'])} | {pct(r['loss_detach'])} | {pct(r['loss_after'])} | {rise:.2g} |")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        sys.stderr.write("energy_runs.py: matplotlib is missing, no figure\n")
        return 0
    two = any(er for _, _, _, er in data)
    fig, axes = plt.subplots(1, 2 if two else 1, figsize=(11 if two else 5.6, 3.8), squeeze=False)
    for label, t, e, er in data:
        axes[0][0].plot(t, e, label=label)
        if two and er:
            axes[0][1].plot(t, er, label=label)
    axes[0][0].set_title((title + ": " if title else "") + "E / E_0 (lumped M)", fontsize=9)
    if two:
        axes[0][1].set_title("E~ / E~_0 (redistributed M~)", fontsize=9)
    for ax in axes[0]:
        ax.set_xlabel("t")
        ax.axhline(1, color="0.7", lw=0.5)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    print(png, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
