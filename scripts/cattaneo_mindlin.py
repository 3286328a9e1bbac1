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

    /usr/bin/python3 scripts/cattaneo_mindlin.py [--dim 2|3] [--obs build/drivers/obs] [--refine 4,5,6,7] [--out DIR]
                                        [--curved-slave] [--scale F] [--no-run]

--curved-slave runs a copy of the scene with slave and master swapped, the curved body as the slave
(docs/verification.md#friction-verification shows why the scenes make the flat side the slave).
--no-run reads the outputs of an earlier run instead of running obs. --scale F multiplies the
prescribed displacements of the moving body by F (a smaller contact zone relative to the radius).

The tractions (flat slave only; the block's .vtu of the last increment): with P and Q of the run, the
Hertz half-width / radius of two equal bodies (R = 1, 1/E* = 2 (1 - nu^2)/E) and peak pressure,
  2D: b = sqrt(4 P R / (pi E*)), p0 = 2 P / (pi b);  3D: a = (3 P R / (4 E*))^(1/3), p0 = 3 P / (2 pi a^2),
c from Q / (mu P) as above, and the Cattaneo-Mindlin traction
  q(r) = mu p0 / b (sqrt(b^2 - r^2) - sqrt(c^2 - r^2) [r < c])     (2D: b; 3D: a; r = |x| or |(x, y)|).
The columns "p error" and "q error" are the relative l2 differences over the block's top vertices
with a positive contact pressure of the computed pressure s_p (contact_pressure) and tangential
traction along x (friction_force_x * s_p / |contact_force|, the nodal force over the boundary mass)
from Hertz's p and this q; "stick centre" the midpoint of the sticking vertices' x range (the
formula's zone is centred at 0). They need numpy (the /usr/bin/python3 of Debian has it).

Prints a markdown table on stdout (progress on stderr).
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def traction_errors(out, name, dim, load, q_force, mu):
    """(p error, q error, x of the stick zone's centre) of the block's last .vtu in `out` (see the
    file comment)."""
    try:
        import numpy as np
    except ImportError:
        sys.exit("cattaneo_mindlin.py: the traction profiles need numpy (run it with /usr/bin/python3 on Debian, "
                 "or apt-get install python3-numpy)")
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from render_surface import read_vtu
    v = read_vtu(os.path.join(out, f"{name}_block.vtu"))
    E, nu, R = 1.0, 0.3, 1.0
    estar = E / (2 * (1 - nu * nu))
    pd = v.point_data
    s = pd["contact_pressure"]
    force = np.linalg.norm(pd["contact_force"], axis=1)
    on = (s > 0) & (force > 0) & (np.abs(v.points[:, dim - 1]) < 1e-12)
    x = v.points[on]
    r = np.abs(x[:, 0]) if dim == 2 else np.hypot(x[:, 0], x[:, 1])
    traction = np.abs(pd["friction_force"][on, 0]) * s[on] / force[on]
    if dim == 2:
        a = math.sqrt(4 * load * R / (math.pi * estar))
        p0 = 2 * load / (math.pi * a)
        c = a * math.sqrt(max(0.0, 1 - q_force / (mu * load)))
    else:
        a = (3 * load * R / (4 * estar)) ** (1.0 / 3.0)
        p0 = 3 * load / (2 * math.pi * a * a)
        c = a * max(0.0, 1 - q_force / (mu * load)) ** (1.0 / 3.0)
    hertz = p0 * np.sqrt(np.clip(1 - (r / a) ** 2, 0, None))
    cm = mu * p0 / a * (np.sqrt(np.clip(a * a - r * r, 0, None)) - np.sqrt(np.clip(c * c - r * r, 0, None)))
    stick = (pd["stick_slip"] == 1) & (np.abs(v.points[:, dim - 1]) < 1e-12)
    xs = v.points[stick, 0]
    centre = 0.5 * (xs.min() + xs.max()) if xs.size else float("nan")
    return (float(np.linalg.norm(s[on] - hertz) / np.linalg.norm(hertz)),
            float(np.linalg.norm(traction - cm) / np.linalg.norm(cm)), float(centre))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--obs", default=os.path.join(ROOT, "build", "drivers", "obs"))
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3))
    ap.add_argument("--refine", default=None, help="default 4,5,6,7 (2D), 0,1,2 (3D)")
    ap.add_argument("--out", default=None)
    ap.add_argument("--curved-slave", action="store_true")
    ap.add_argument("--no-run", action="store_true")
    ap.add_argument("--scale", type=float, default=1.0)
    args = ap.parse_args()
    name = "cattaneo_mindlin" if args.dim == 2 else "cattaneo_mindlin_3d"
    refine = args.refine or ("4,5,6,7" if args.dim == 2 else "0,1,2")
    out_root = args.out or os.path.join(ROOT, "out", name)
    scene = os.path.join(ROOT, "data", "scenes", name + ".toml")
    if args.curved_slave or args.scale != 1.0:
        if args.curved_slave:
            out_root += "_curved_slave"
        if args.scale != 1.0:
            out_root += f"_scale{args.scale:g}"
        os.makedirs(out_root, exist_ok=True)
        text = open(scene).read()
        # the moving body's value = ["A * ...", ..., "B * ..."]: each leading factor times the scale
        text, count = re.subn(r'"(-?[0-9.]+) \* ', lambda m: f'"{float(m.group(1)) * args.scale:.10g} * ', text)
        if args.scale != 1.0 and count != 2:
            sys.exit("cattaneo_mindlin.py: expected two scaled displacements in the scene, found %d" % count)
        flat, curved = (('{ body = "block", boundary = "top" }', '{ body = "cylinder", boundary = "arc" }')
                        if args.dim == 2 else
                        ('{ body = "block", boundary = "block_top" }', '{ body = "ball", boundary = "surface" }'))
        old = f"slave = {flat}\nmaster = {curved}"
        if args.curved_slave:
            if old not in text:
                sys.exit("cattaneo_mindlin.py: the scene's [[contact]] pair is not the expected one")
            text = text.replace(old, f"slave = {curved}\nmaster = {flat}")
        text = text.replace('"../meshes/', '"' + os.path.join(ROOT, "data", "meshes") + "/")
        scene = os.path.join(out_root, name + ".toml")
        open(scene, "w").write(text)
    mu = 0.3
    rows = []
    for k in [int(x) for x in refine.split(",")]:
        out = os.path.join(out_root, f"refine{k}")
        t0 = time.time()
        if not args.no_run:
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
        perr, qerr, centre = (float("nan"),) * 3 if args.curved_slave else \
            traction_errors(out, name, args.dim, load, q, mu)
        rows.append((k, j["dofs"], p["actual_vertices"], q / (mu * load), b, c, formula, (c - formula) / h,
                     centre / b, perr, qerr, j["solver"]["friction"]["iterations"], seconds))
        print(f"refine {k}: c = {c:.5f}, formula {formula:.5f}, {seconds:.1f} s", file=sys.stderr)
    formula = "b sqrt(1 - Q/(mu P))" if args.dim == 2 else "a (1 - Q/(mu P))^(1/3)"
    print(f"| refine | unknowns | contact vertices | Q / (mu P) | {'b' if args.dim == 2 else 'a'} | c (stick) | "
          f"{formula} | (c - formula) / h | stick centre x / {'b' if args.dim == 2 else 'a'} | p error | q error | "
          f"Tresca solves | s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.4f} | {r[4]:.5f} | {r[5]:.5f} | {r[6]:.5f} | {r[7]:+.2f} | "
              f"{r[8]:+.3f} | {r[9]:.3f} | {r[10]:.3f} | {r[11]} | {r[12]:.1f} |")


if __name__ == "__main__":
    main()
