#!/usr/bin/env python3
"""How much the results of obs runs differ between OpenBLAS kernels (docs/reliability.md#blas-kernels).

Runs each scene once per kernel (OPENBLAS_CORETYPE; one BLAS thread and one obs thread unless given)
and compares every run with the first kernel's:
  - summary.json: every numeric leaf, timing and memory fields aside (keys with "time", "seconds",
    "_s", "memory", "mb" in their name, and file lists); difference |a - b| relative to the largest
    |value| of the quantity (all components of a vector: force[0..2]);
  - every CSV: per column, max |a - b| over the rows relative to the largest |value| of the
    quantity over all rows (all components of a vector: momentum_x/y/z); for dynamic runs (a
    timeseries.csv) only these: their summary holds last-step values such as the contact force
    after separation, zero up to round-off, whose relative difference says nothing;
  - counts (iterations, active-set sizes and mismatches, contact vertices) listed separately: equal
    or in how many rows they differ;
  - residuals (KKT residuals, the last correction, the convergence rate, constraint violation and
    penetration) are quantities of round-off size whose digits are all noise: they are not part of
    the relative difference; the table gives their largest value instead.
Writes a Markdown table to OUT/kernel_differences.md and prints it.

  python3 scripts/kernel_differences.py                      # step-42, Hertz, Geometry B
  python3 scripts/kernel_differences.py --kernels Haswell SkylakeX --scene data/scenes/hertz.toml
"""
import argparse
import csv
import json
import os
import re
import subprocess
import sys
import time

SCENES = [
    ("step-42 (16^3)", "data/scenes/step42.toml", []),
    ("Hertz 3D", "data/scenes/hertz.toml", []),
    ("Geometry B (its scene: 16^3 cells per cube, 40 steps)", "data/scenes/dynamics_two_body.toml", []),
]
KERNELS = ["Haswell", "Zen", "SkylakeX", "Sandybridge", "Prescott"]
SKIP = ("time", "seconds", "memory", "_mb", "_s", "output_files", "obs_version", "scene", "host")
RESIDUAL = ("kkt", "correction", "violation", "penetration", "error_bound")


def is_count(name):
    """Integers (iterations, active-set sizes and mismatches, vertex counts): listed when they differ."""
    last = name.split(".")[-1]
    return (last.endswith("iterations") or last.startswith("active") or last.endswith("_only")
            or last.endswith("_vertices"))


def group(name):
    """Components of one vector share a scale: force[0..2] -> force, momentum_x/y/z -> momentum."""
    return re.sub(r"(\[\d+\]|_[xyz])$", "", name)


def is_residual(key):
    return any(r in key for r in RESIDUAL)


def numeric_leaves(node, prefix=""):
    if isinstance(node, dict):
        for k, v in node.items():
            if any(s in k for s in SKIP):
                continue
            yield from numeric_leaves(v, f"{prefix}.{k}" if prefix else k)
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from numeric_leaves(v, f"{prefix}[{i}]")
    elif isinstance(node, bool):
        yield prefix, float(node)
    elif isinstance(node, (int, float)):
        yield prefix, float(node)


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        return {}
    header, cols = rows[0], {}
    for j, name in enumerate(header):
        if any(s in name for s in SKIP):
            continue
        values = []
        for r in rows[1:]:
            try:
                values.append(float(r[j]))
            except (ValueError, IndexError):
                values = None
                break
        if values:
            cols[name] = values
    return cols


def compare(ref_dir, dir_):
    """(largest relative difference, where; iteration counts that differ; largest residual)."""
    worst, where, iters, residual, equal = 0.0, "-", [], 0.0, True
    a = dict(numeric_leaves(json.load(open(os.path.join(ref_dir, "summary.json")))))
    b = dict(numeric_leaves(json.load(open(os.path.join(dir_, "summary.json")))))
    dynamic = os.path.exists(os.path.join(ref_dir, "timeseries.csv"))
    scale = {}
    for k in set(a) & set(b):
        scale[group(k)] = max(scale.get(group(k), 0.0), abs(a[k]), abs(b[k]))
    for k in sorted(set(a) & set(b)):
        equal = equal and a[k] == b[k]
        if is_count(k):
            if a[k] != b[k]:
                iters.append(f"{k} {a[k]:g}/{b[k]:g}")
            continue
        if is_residual(k):
            residual = max(residual, abs(a[k]), abs(b[k]))
            continue
        if dynamic:
            continue  # compared step by step in timeseries.csv, on the scale of the whole run
        r = 0.0 if a[k] == b[k] else abs(a[k] - b[k]) / scale[group(k)]
        if r > worst:
            worst, where = r, f"summary {k}"
    for name in sorted(os.listdir(ref_dir)):
        if not name.endswith(".csv") or not os.path.exists(os.path.join(dir_, name)):
            continue
        if dynamic and name != "timeseries.csv":
            continue  # runs.csv: the summary's last-step values, see above
        ca, cb = read_csv(os.path.join(ref_dir, name)), read_csv(os.path.join(dir_, name))
        common = sorted(set(ca) & set(cb))
        cscale = {}
        for col in common:
            m = max(abs(x) for x in ca[col] + cb[col])
            cscale[group(col)] = max(cscale.get(group(col), 0.0), m)
        for col in common:
            va, vb = ca[col], cb[col]
            equal = equal and va == vb
            if len(va) != len(vb):
                iters.append(f"{name}: {len(va)}/{len(vb)} rows")
                continue
            if is_residual(col):
                residual = max(residual, max(abs(x) for x in va + vb))
                continue
            if is_count(col):
                diff = sum(x != y for x, y in zip(va, vb))
                if diff:
                    iters.append(f"{name}:{col} differs in {diff} of {len(va)} rows "
                                 f"(sum {sum(va):g}/{sum(vb):g})")
                continue
            if cscale[group(col)] == 0:
                continue
            r = max(abs(x - y) for x, y in zip(va, vb)) / cscale[group(col)]
            if r > worst:
                worst, where = r, f"{name} column {col}"
    return worst, where, iters, residual, equal


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--obs", default="build/drivers/obs")
    ap.add_argument("--out", default="out/kernel_differences")
    ap.add_argument("--kernels", nargs="+", default=KERNELS)
    ap.add_argument("--scene", action="append", help="scene file (default: step-42, Hertz, Geometry B)")
    ap.add_argument("--threads", type=int, default=1, help="obs run --threads")
    ap.add_argument("--blas-threads", type=int, default=1, help="OPENBLAS_NUM_THREADS")
    args = ap.parse_args()
    scenes = [(s, s, []) for s in args.scene] if args.scene else SCENES
    lines = [f"Reference kernel: {args.kernels[0]}; obs --threads {args.threads}, "
             f"OPENBLAS_NUM_THREADS={args.blas_threads}.", "",
             "| scene | kernel | bitwise equal | largest relative difference | where | counts "
             "| largest residual (round-off size, not compared) |",
             "|---|---|---|---:|---|---|---:|"]
    for label, scene, extra in scenes:
        stem = os.path.splitext(os.path.basename(scene))[0]
        dirs = []
        for k in args.kernels:
            d = os.path.join(args.out, stem, k)
            env = dict(os.environ, OPENBLAS_CORETYPE=k, OPENBLAS_NUM_THREADS=str(args.blas_threads))
            t0 = time.time()
            cmd = [args.obs, "run", scene, "--output", d, "--threads", str(args.threads)] + extra
            p = subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            if p.returncode != 0:
                sys.exit(f"kernel_differences: {' '.join(cmd)} failed:\n{p.stderr}")
            print(f"{stem} {k}: {time.time() - t0:.1f} s", file=sys.stderr)
            dirs.append(d)
        for k, d in zip(args.kernels[1:], dirs[1:]):
            worst, where, iters, residual, equal = compare(dirs[0], d)
            same = "yes" if equal else "no"
            lines.append(f"| {label} | {k} | {same} | {worst:.1e} | {where} | "
                         f"{'; '.join(iters) if iters else 'equal'} | {residual:.1e} |")
    text = "\n".join(lines) + "\n"
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "kernel_differences.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
