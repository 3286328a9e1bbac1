#!/usr/bin/env python3
"""Plots of an `obs sweep` (sweep.csv): accuracy against wall time and against peak memory, one
curve per combination of all varied keys but the last (the points of a curve follow the last key),
the Pareto front (runs that no other run beats in both accuracy and cost) circled.

Accuracy is the first of these columns that has values: analytic_error (the scene's analytic
reference), energy_error (dynamic runs: |E_end/E_0 - 1|), load_error, displacement_error (both
against the reference run, which has no error of its own and is left out).

    python3 scripts/plot_sweep.py out/sweep/sweep.csv      # writes accuracy_vs_time.png, accuracy_vs_memory.png
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

FIXED = ["run", "repeat", "status", "error", "unknowns", "vertices", "iterations", "load_P", "max_displacement", "eta",
         "analytic_error", "load_error", "displacement_error", "energy_ratio", "energy_error", "force_variation",
         "max_penetration", "wall_s", "solver_s", "peak_mb", "reference", "ranks"]


def number(s):
    try:
        return float(s)
    except ValueError:
        return None


def main():
    path = sys.argv[1]
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "ok"]
    if not rows:
        sys.exit("plot_sweep: no successful runs in " + path)
    keys = [k for k in rows[0].keys() if k not in FIXED]
    metric = next((m for m in ["analytic_error", "energy_error", "load_error", "displacement_error"]
                   if any(number(r[m]) for r in rows)), None)
    if metric is None:
        sys.exit("plot_sweep: no accuracy column with values (analytic_error, energy_error, load_error, displacement_error)")
    points = [r for r in rows if number(r[metric]) is not None and number(r[metric]) > 0]
    out = os.path.dirname(os.path.abspath(path))
    for cost, label, name in [("wall_s", "wall time [s]", "accuracy_vs_time.png"),
                              ("peak_mb", "peak memory [MB]", "accuracy_vs_memory.png")]:
        fig, ax = plt.subplots(figsize=(7, 5))
        curves = {}
        for r in points:
            curves.setdefault(tuple(r[k] for k in keys[:-1]), []).append(r)
        for group, rs in curves.items():
            rs.sort(key=lambda r: number(r[cost]))
            title = ", ".join(f"{k}={v}" for k, v in zip(keys[:-1], group)) or keys[-1]
            ax.plot([number(r[cost]) for r in rs], [number(r[metric]) for r in rs], "o-", label=title)
            for r in rs:
                ax.annotate(r[keys[-1]], (number(r[cost]), number(r[metric])), fontsize=7,
                            textcoords="offset points", xytext=(4, 4))
        front, best = [], float("inf")
        for r in sorted(points, key=lambda r: (number(r[cost]), number(r[metric]))):
            if number(r[metric]) < best:
                front.append(r)
                best = number(r[metric])
        ax.plot([number(r[cost]) for r in front], [number(r[metric]) for r in front], "o", mfc="none", ms=14,
                color="k", label="Pareto front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel(metric.replace("_", " ") + (" (against the reference run)" if metric in ("load_error", "displacement_error") else ""))
        ax.set_title(f"{len(points)} runs; labels: {keys[-1]}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(out, name), dpi=120)
        plt.close(fig)


if __name__ == "__main__":
    main()
