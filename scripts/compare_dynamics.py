#!/usr/bin/env python3
"""Runs one [dynamics] scene with two obs binaries, alternately, and compares cost and results.

For performance work on the time stepping (docs/performance.md, "Dynamic contact"): the same scene
and options are run `--repeat` times with each binary, in the order A B A B ..., so that both see
the same machine load; each run is timed by the CPU time of the child process (user + system, which
a busy shared machine inflates far less than the wall clock). Then the time series of the last runs
are compared column by column, without the timing columns (solver_seconds, step_seconds):
"bitwise" if every value is the same string, else the largest difference per column (columns only
one of the two writes are listed by name).

    python3 scripts/compare_dynamics.py /tmp/main/build/drivers/obs build/drivers/obs \\
        data/scenes/dynamics_block.toml --refine 3 --set dynamics.steps=200 --repeat 3

Options after the scene are passed to `obs run` (--refine, --set ...); every run writes no VTU
files but the last (output_stride = steps). Only the standard library.
"""
import argparse
import csv
import os
import resource
import subprocess
import sys
import tempfile

TIMING = {"solver_seconds", "step_seconds"}


def run(binary, scene, extra, out):
    """One `obs run`; returns the CPU seconds of the child (user + system)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    cmd = [binary, "run", scene, "-q", "-o", out] + extra
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    res = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if res.returncode != 0:
        sys.exit(f"compare_dynamics: {' '.join(cmd)} failed ({res.returncode}): {res.stderr.strip()}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def compare(a, b):
    """Lines describing the differences of two timeseries.csv files (timing columns ignored)."""
    ha, ra = read(a)
    hb, rb = read(b)
    if len(ra) != len(rb):
        return [f"different number of rows: {len(ra)} / {len(rb)}"]
    # columns one version writes and the other does not are named, the common ones compared
    lines = [f"  only in A: {name}" for name in ha if name not in hb]
    lines += [f"  only in B: {name}" for name in hb if name not in ha]
    for ja, name in enumerate(ha):
        if name in TIMING or name not in hb:
            continue
        jb = hb.index(name)
        worst, scale, same = 0.0, 0.0, True
        for x, y in zip(ra, rb):
            if x[ja] == y[jb]:
                continue
            same = False
            try:
                fx, fy = float(x[ja]), float(y[jb])
            except ValueError:
                worst = float("inf")
                continue
            worst = max(worst, abs(fx - fy))
        if not same:
            for x in ra:
                try:
                    scale = max(scale, abs(float(x[ja])))
                except ValueError:
                    pass
            lines.append(f"  {name}: max |difference| {worst:.3g} (column max |value| {scale:.3g})")
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a", help="obs binary A (e.g. the old one)")
    ap.add_argument("b", help="obs binary B (e.g. the new one)")
    ap.add_argument("scene")
    ap.add_argument("--repeat", type=int, default=3, help="runs per binary (alternating)")
    ap.add_argument("--steps", type=int, help="dynamics.steps (default: the scene's)")
    args, extra = ap.parse_known_args()
    if args.steps:
        extra += ["--set", f"dynamics.steps={args.steps}", "--set", f"dynamics.output_stride={args.steps}"]
    work = tempfile.mkdtemp(prefix="compare_dynamics_")
    times = {"A": [], "B": []}
    for k in range(args.repeat):
        for tag, binary in (("A", args.a), ("B", args.b)):
            times[tag].append(run(binary, args.scene, extra, os.path.join(work, tag)))
            print(f"run {k + 1} {tag}: {times[tag][-1]:.2f} s CPU", flush=True)
    ma, mb = min(times["A"]), min(times["B"])
    print(f"A {args.a}: CPU s min {ma:.2f}, all {', '.join(f'{t:.2f}' for t in times['A'])}")
    print(f"B {args.b}: CPU s min {mb:.2f}, all {', '.join(f'{t:.2f}' for t in times['B'])}")
    print(f"ratio A/B (min CPU time): {ma / mb:.2f}")
    diff = compare(os.path.join(work, "A", "timeseries.csv"), os.path.join(work, "B", "timeseries.csv"))
    print("timeseries.csv (without timing columns): " + ("bitwise identical" if not diff else "differences:"))
    for line in diff:
        print(line)
    print(f"outputs in {work}")


if __name__ == "__main__":
    main()
