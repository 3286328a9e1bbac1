#!/usr/bin/env python3
"""Cattaneo-Mindlin in 2D under refinement (docs/verification.md#friction-verification).

Runs data/scenes/cattaneo_mindlin.toml with `obs run --refine K` for each K and compares the
half-width c of the stick zone (summary.json pairs[0].friction.stick_radius) with the formula
c = b sqrt(1 - Q / (mu P)) of two bodies of equal material, b = pairs[0].radius the measured
half-width of the contact zone, Q = |tangential force|, P = load_P. Both widths are measured the
same way (the faces all of whose vertices are in contact / stick), so each is short of the true one by
less than a face; the table gives the error of c in units of the face size h at the contact zone
(the contact width over the faces in contact).

    python3 scripts/cattaneo_mindlin.py [--obs build/drivers/obs] [--refine 4,5,6,7] [--out DIR]

Prints a markdown table on stdout (progress on stderr).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--obs", default=os.path.join(ROOT, "build", "drivers", "obs"))
    ap.add_argument("--refine", default="4,5,6,7")
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "cattaneo_mindlin"))
    args = ap.parse_args()
    scene = os.path.join(ROOT, "data", "scenes", "cattaneo_mindlin.toml")
    mu = 0.3
    rows = []
    for k in [int(x) for x in args.refine.split(",")]:
        out = os.path.join(args.out, f"refine{k}")
        t0 = time.time()
        subprocess.run([args.obs, "run", scene, "--refine", str(k), "--output", out], check=True,
                       stdout=subprocess.DEVNULL)
        seconds = time.time() - t0
        j = json.load(open(os.path.join(out, "summary.json")))
        p = j["pairs"][0]
        f = p["friction"]
        b, c = p["radius"], f["stick_radius"]
        q, load = abs(f["tangential_force"][0]), p["load_P"]
        formula = b * math.sqrt(max(0.0, 1 - q / (mu * load)))
        faces = 0
        # the face size at the contact zone: the contact width over the faces in contact
        # (contact vertices - 1 of a connected zone)
        faces = max(1, p["actual_vertices"] - 1)
        h = p["width"] / faces
        rows.append((k, j["dofs"], p["actual_vertices"], q / (mu * load), b, c, formula, (c - formula) / h,
                     j["solver"]["friction"]["iterations"], seconds))
        print(f"refine {k}: c = {c:.5f}, formula {formula:.5f}, {seconds:.1f} s", file=sys.stderr)
    print("| refine | unknowns | contact vertices | Q / (mu P) | b | c (stick) | b sqrt(1 - Q/(mu P)) | "
          "(c - formula) / h | Tresca solves | s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.4f} | {r[4]:.5f} | {r[5]:.5f} | {r[6]:.5f} | {r[7]:+.2f} | "
              f"{r[8]} | {r[9]:.1f} |")


if __name__ == "__main__":
    main()
