#!/usr/bin/env python3
"""Cattaneo-Mindlin under refinement (docs/verification.md#friction-verification).

Runs data/scenes/cattaneo_mindlin.toml (2D) or cattaneo_mindlin_3d.toml (--dim 3) with
`obs run --refine K` for each K and compares the half-width / radius c of the stick zone
(summary.json pairs[0].friction.stick_radius) with the formula of two bodies of equal material,
c = b sqrt(1 - Q / (mu P)) in 2D and c = a (1 - Q / (mu P))^(1/3) in 3D, with b or a =
pairs[0].radius the measured half-width / radius of the contact zone, Q = |tangential force along x|,
P = load_P. Both are measured the same way (the faces all of whose vertices are in contact / stick;
in 3D the radius of the disc of that area), so each is short of the true one by less than a face; the
table gives the error of c in units of the face size h at the contact zone (2D: the contact width
over the faces in contact; 3D: the edge of the equilateral triangle whose area is the contact area
per contact vertex).

    python3 scripts/cattaneo_mindlin.py [--dim 2|3] [--obs build/drivers/obs] [--refine 4,5,6,7] [--out DIR]
                                        [--curved-slave]

--curved-slave runs a copy of the scene with slave and master swapped, the curved body as the slave
(docs/verification.md#friction-verification shows why the scenes make the flat side the slave).

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
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3))
    ap.add_argument("--refine", default=None, help="default 4,5,6,7 (2D), 0,1,2 (3D)")
    ap.add_argument("--out", default=None)
    ap.add_argument("--curved-slave", action="store_true")
    args = ap.parse_args()
    name = "cattaneo_mindlin" if args.dim == 2 else "cattaneo_mindlin_3d"
    refine = args.refine or ("4,5,6,7" if args.dim == 2 else "0,1,2")
    out_root = args.out or os.path.join(ROOT, "out", name)
    scene = os.path.join(ROOT, "data", "scenes", name + ".toml")
    if args.curved_slave:
        out_root += "_curved_slave"
        os.makedirs(out_root, exist_ok=True)
        text = open(scene).read()
        flat, curved = (('{ body = "block", boundary = "top" }', '{ body = "cylinder", boundary = "arc" }')
                        if args.dim == 2 else
                        ('{ body = "block", boundary = "block_top" }', '{ body = "ball", boundary = "surface" }'))
        old = f"slave = {flat}\nmaster = {curved}"
        if old not in text:
            sys.exit("cattaneo_mindlin.py: the scene's [[contact]] pair is not the expected one")
        text = text.replace(old, f"slave = {curved}\nmaster = {flat}")
        text = text.replace('"../meshes/', '"' + os.path.join(ROOT, "data", "meshes") + "/")
        scene = os.path.join(out_root, name + "_curved_slave.toml")
        open(scene, "w").write(text)
    mu = 0.3
    rows = []
    for k in [int(x) for x in refine.split(",")]:
        out = os.path.join(out_root, f"refine{k}")
        t0 = time.time()
        subprocess.run([args.obs, "run", scene, "--refine", str(k), "--output", out], check=True,
                       stdout=subprocess.DEVNULL)
        seconds = time.time() - t0
        j = json.load(open(os.path.join(out, "summary.json")))
        p = j["pairs"][0]
        f = p["friction"]
        b, c = p["radius"], f["stick_radius"]
        q, load = abs(f["tangential_force"][0]), p["load_P"]
        formula = b * max(0.0, 1 - q / (mu * load)) ** (0.5 if args.dim == 2 else 1.0 / 3.0)
        if args.dim == 2:
            # the face size at the contact zone: the contact width over the faces in contact
            # (contact vertices - 1 of a connected zone)
            h = p["width"] / max(1, p["actual_vertices"] - 1)
        else:
            # the edge of an equilateral triangle of the contact area per contact vertex (a
            # triangulated disc has about two triangles per vertex)
            h = math.sqrt(2 * math.pi * b * b / (math.sqrt(3) * max(1, p["actual_vertices"])))
        rows.append((k, j["dofs"], p["actual_vertices"], q / (mu * load), b, c, formula, (c - formula) / h,
                     j["solver"]["friction"]["iterations"], seconds))
        print(f"refine {k}: c = {c:.5f}, formula {formula:.5f}, {seconds:.1f} s", file=sys.stderr)
    formula = "b sqrt(1 - Q/(mu P))" if args.dim == 2 else "a (1 - Q/(mu P))^(1/3)"
    print(f"| refine | unknowns | contact vertices | Q / (mu P) | {'b' if args.dim == 2 else 'a'} | c (stick) | "
          f"{formula} | (c - formula) / h | Tresca solves | s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.4f} | {r[4]:.5f} | {r[5]:.5f} | {r[6]:.5f} | {r[7]:+.2f} | "
              f"{r[8]} | {r[9]:.1f} |")


if __name__ == "__main__":
    main()
