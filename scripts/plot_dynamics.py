#!/usr/bin/env python3
"""Figures of a dynamic `obs run` (scenes with [dynamics], drivers/DynamicScene.hpp).

Reads <dir>/timeseries.csv (one scheme) or <dir>/timeseries_<scheme>.csv (a comparison, all
overlaid) and writes into <dir> (or --output DIR, with --prefix):
  dyn_energy.png         E / E_0 against t (and E~ / E~_0 for the redistributed schemes, dashed)
  dyn_contact_force.png  the normal contact force |sum_p F_p nu_p| against t
  dyn_active.png         nodes active in the solution (solid) and predictor-only / solution-only
                         mismatches (dotted) against t
  dyn_velocity.png       normal velocity nu'v of the tracked vertices against t (if any)
  dyn_displacement.png   normal displacement nu'u of the tracked vertices against t, with the
                         initial gap of each as a dashed line (if any); at a slave node of a
                         mortar pair both are those of the normal jump [u]_nu

  python3 scripts/plot_dynamics.py out/dynamics_ball
  python3 scripts/plot_dynamics.py out/cmp --output docs/figures --prefix dyn_ball_ --title "Geometry A"

Exit codes: 0 written, 2 no time series found, 3 matplotlib missing (the driver then warns).
"""
import argparse
import csv
import glob
import math
import os
import sys


def read_series(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    cols = {}
    for key in rows[0].keys() if rows else []:
        vals = []
        for r in rows:
            v = r[key]
            vals.append(float(v) if v not in ("", None) else math.nan)
        cols[key] = vals
    return cols


def series_in(directory):
    single = os.path.join(directory, "timeseries.csv")
    out = []
    if os.path.isfile(single):
        out.append(("", read_series(single)))
    for path in sorted(glob.glob(os.path.join(directory, "timeseries_*.csv"))):
        name = os.path.basename(path)[len("timeseries_"):-len(".csv")]
        out.append((name, read_series(path)))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("directory")
    ap.add_argument("--output", default=None, help="directory of the PNG files (default: the input)")
    ap.add_argument("--prefix", default="dyn_", help="file name prefix (default dyn_)")
    ap.add_argument("--title", default="", help="title prefix of every figure")
    args = ap.parse_args()

    series = series_in(args.directory)
    if not series:
        print(f"plot_dynamics: no timeseries.csv or timeseries_*.csv in {args.directory}", file=sys.stderr)
        return 2
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_dynamics: matplotlib is not installed (pip install matplotlib)", file=sys.stderr)
        return 3
    out = args.output or args.directory
    os.makedirs(out, exist_ok=True)
    title = (args.title + ": ") if args.title else ""
    cmap = plt.get_cmap("tab10")

    def figure(name, ylabel, draw, log=False):
        fig, ax = plt.subplots(figsize=(7.5, 4.5))
        any_line = False
        for i, (scheme, s) in enumerate(series):
            any_line |= draw(ax, scheme or "run", s, cmap(i % 10))
        if not any_line:
            plt.close(fig)
            return
        ax.set_xlabel("t")
        ax.set_ylabel(ylabel)
        ax.set_title(title + ylabel)
        if log:
            ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="best")
        fig.tight_layout()
        fig.savefig(os.path.join(out, args.prefix + name + ".png"), dpi=110)
        plt.close(fig)

    def energy(ax, label, s, color):
        e0 = s["energy"][0]
        if e0 == 0:
            return False
        ax.plot(s["t"], [e / e0 for e in s["energy"]], color=color, label=label)
        er = s.get("energy_redistributed", [])
        if er and not math.isnan(er[0]) and er[0] != 0:
            ax.plot(s["t"], [e / er[0] for e in er], color=color, ls="--", lw=0.8, label=label + " (E~)")
        return True

    def force(ax, label, s, color):
        f = [math.sqrt(x * x + y * y + z * z)
             for x, y, z in zip(s["contact_force_x"], s["contact_force_y"], s["contact_force_z"])]
        ax.plot(s["t"], f, color=color, label=label)
        return True

    def active(ax, label, s, color):
        ax.plot(s["t"], s["active_solution"], color=color, label=label)
        mismatch = [a + b for a, b in zip(s["predictor_only"], s["solution_only"])]
        if any(m > 0 for m in mismatch):
            ax.plot(s["t"], mismatch, color=color, ls=":", lw=0.8)
        return True

    def velocity(ax, label, s, color):
        keys = [k for k in s if k.startswith("tracked") and k.endswith("_normal_velocity")]
        for k in keys:
            suffix = "" if len(keys) == 1 else " " + k.split("_")[0]
            ax.plot(s["t"], s[k], color=color, label=label + suffix)
        return bool(keys)

    def displacement(ax, label, s, color):
        keys = [k for k in s if k.startswith("tracked") and k.endswith("_normal_displacement")]
        for k in keys:
            node = k.split("_")[0]
            suffix = "" if len(keys) == 1 else " " + node
            ax.plot(s["t"], s[k], color=color, label=label + suffix)
            gap = s.get(node + "_gap", [])
            if gap and not math.isnan(gap[0]):  # gap = g - nu'u, so g = gap + nu'u at t = 0
                g0 = gap[0] + s[k][0]
                ax.axhline(g0, color=color, ls="--", lw=0.6)
        return bool(keys)

    figure("energy", "E / E_0", energy)
    figure("contact_force", "contact force |F|", force)
    figure("active", "active contact nodes (dotted: predictor/solution mismatch)", active)
    figure("velocity", "normal velocity of the tracked vertex", velocity)
    figure("displacement", "normal displacement (dashed: initial gap)", displacement)
    return 0


if __name__ == "__main__":
    sys.exit(main())
