#!/usr/bin/env python3
"""obs against GetFEM on a 2D Coulomb friction problem (docs/verification.md#friction-peer).

Runs data/scenes/friction_peer.toml with `obs run --refine K` and solves the same problem with GetFEM
(python3-getfem): the same unit square of Q1 quadrilaterals (a cartesian mesh of 4 * 2^K cells per
side has the vertices of obs' box mesh), plane-strain linear elasticity, the top moved by
(0.004, -0.02), nodal contact with the rigid disk of radius 0.5 around (0.5, -0.5) given by its
signed distance, and nodal Coulomb friction mu = 0.3 (GetFEM's nodal contact brick, Alart-Curnier
augmented Lagrangian with Newton's method). Both solve the same discrete problem, so the
displacements, the forces and the stick/slip zones must agree to the solvers' tolerances. P is the sum
of the normal nodal forces, Q the sum of the tangential nodal forces along each node's tangent (GetFEM's
multipliers lambda_n, lambda_t; obs' .vtu contact_pressure and friction_force with the constraint
direction).

    /usr/bin/python3 scripts/getfem_friction.py [--obs build/drivers/obs] [--refine 3,4,5] [--out DIR]
                                                [--obstacle disk|plane]

Prints a markdown table on stdout (progress on stderr).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
from render_surface import read_vtu  # noqa: E402

E, NU, MU = 3e5, 0.3, 0.3
TOP = (0.004, -0.02)


OBSTACLES = {  # obs [contact] lines, GetFEM's signed distance
    "disk": ('obstacle = "disk"\ncentre = [0.5, -0.5]\nradius = 0.5\ndirection = "normal"',
             "sqrt((x-0.5)*(x-0.5)+(y+0.5)*(y+0.5))-0.5"),
    "plane": ('obstacle = "plane"\npoint = [0, 0]\ndirection = [0, -1]', "y"),
}


def getfem_solve(n, obstacle="disk"):
    import getfem as gf
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    shear = E / (2 * (1 + NU))
    xs = np.linspace(0.0, 1.0, n + 1)
    m = gf.Mesh("cartesian", xs, xs)
    mfu = gf.MeshFem(m, 2)
    mfu.set_classical_fem(1)
    mim = gf.MeshIm(m, gf.Integ("IM_GAUSS_PARALLELEPIPED(2,2)"))
    faces = m.outer_faces()
    normals = m.normal_of_faces(faces)
    m.set_region(1, faces[:, np.abs(normals[1, :] - 1) < 1e-8])  # top
    m.set_region(2, faces[:, np.abs(normals[1, :] + 1) < 1e-8])  # bottom
    md = gf.Model("real")
    md.add_fem_variable("u", mfu)
    md.add_initialized_data("lambda", [lam])
    md.add_initialized_data("mu", [shear])
    md.add_isotropic_linearized_elasticity_brick(mim, "u", "lambda", "mu")
    md.add_initialized_data("top", list(TOP))
    md.add_Dirichlet_condition_with_simplification("u", 1, "top")
    ncontact = len(mfu.basic_dof_on_region(2)) // 2
    md.add_variable("lambda_n", ncontact)
    md.add_variable("lambda_t", ncontact)
    md.add_initialized_data("r", [E])
    md.add_initialized_data("friction_coeff", [MU])
    md.add_nodal_contact_with_rigid_obstacle_brick(mim, "u", "lambda_n", "lambda_t", "r", "friction_coeff", 2,
                                                   OBSTACLES[obstacle][1], 1)
    t0 = time.time()
    md.solve("max_res", 1e-10, "max_iter", 300)
    seconds = time.time() - t0
    u = md.variable("u")
    dofs = mfu.basic_dof_nodes()
    ln, lt = md.variable("lambda_n"), md.variable("lambda_t")
    return dofs, u, ln, lt, seconds


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--obs", default=os.path.join(ROOT, "build", "drivers", "obs"))
    ap.add_argument("--refine", default="3,4,5")
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "getfem_friction"))
    ap.add_argument("--obstacle", choices=sorted(OBSTACLES), default="disk",
                    help="disk: the scene as it is; plane: the rigid plane y = 0 instead (full contact)")
    args = ap.parse_args()
    scene = os.path.join(ROOT, "data", "scenes", "friction_peer.toml")
    if args.obstacle != "disk":  # the scene with another [contact] obstacle, next to the outputs
        text = open(scene).read()
        start = text.index('obstacle = "disk"')
        end = text.index('direction = "normal"') + len('direction = "normal"')
        os.makedirs(args.out, exist_ok=True)
        scene = os.path.join(args.out, "friction_peer.toml")
        with open(scene, "w") as f:
            f.write(text[:start] + OBSTACLES[args.obstacle][0] + text[end:])
    rows = []
    for k in [int(x) for x in args.refine.split(",")]:
        n = 4 * 2 ** k
        out = os.path.join(args.out, f"refine{k}")
        t0 = time.time()
        subprocess.run([args.obs, "run", scene, "--refine", str(k), "--output", out], check=True,
                       stdout=subprocess.DEVNULL)
        obs_seconds = time.time() - t0
        summary = json.load(open(os.path.join(out, "summary.json")))
        c = summary["contact"]
        vtu = read_vtu(os.path.join(out, "friction_peer.vtu"))
        points, disp = vtu.points, vtu.point_data["displacement"].reshape(-1, 3)
        # obs' tangential force along each node's tangent t = (-nu_y, nu_x) (nu the constraint direction),
        # the quantity GetFEM's lambda_t is (friction_force is the force on the body, -f_T)
        nu = vtu.point_data["constraint_direction"].reshape(-1, 3)
        friction = vtu.point_data["friction_force"].reshape(-1, 3)
        q_obs = abs(sum(-(friction[p, 0] * -nu[p, 1] + friction[p, 1] * nu[p, 0]) for p in range(points.shape[0])))
        dofs, ug, ln, lt, gf_seconds = getfem_solve(n, args.obstacle)
        # GetFEM's displacement at obs' vertices (Q1 dofs sit at the vertices; matched by coordinates)
        key = lambda x, y: (round(x * n), round(y * n))
        gfu = {}
        for i in range(0, dofs.shape[1], 2):
            gfu[key(dofs[0, i], dofs[1, i])] = (ug[i], ug[i + 1])
        diff = max(math.hypot(disp[p, 0] - gfu[key(*points[p, :2])][0], disp[p, 1] - gfu[key(*points[p, :2])][1])
                   for p in range(points.shape[0]))
        umax = np.abs(disp).max()
        # GetFEM's contact state: nodal forces (lambda_n <= 0 in contact), stick where |lambda_t| < mu |lambda_n|
        P = -ln.sum()
        Q = abs(lt.sum())
        scale = np.abs(ln).max()
        contact = ln < -1e-8 * scale
        slip = contact & (np.abs(lt) >= MU * np.abs(ln) * (1 - 1e-6))
        rows.append((k, 2 * (n + 1) ** 2, diff / umax, c["load_P"], P, q_obs, Q,
                     c["actual_vertices"], int(contact.sum()), c["friction"]["slip_vertices"], int(slip.sum()),
                     obs_seconds, gf_seconds))
        print(f"refine {k}: max |u_obs - u_getfem| / max |u| = {diff / umax:.2e}", file=sys.stderr)
    print("| refine | unknowns | max \\|u_obs - u_GetFEM\\| / max \\|u\\| | P obs | P GetFEM | Q obs | Q GetFEM | "
          "contact obs / GetFEM | slip obs / GetFEM | obs run s | GetFEM solve s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.1e} | {r[3]:.6f} | {r[4]:.6f} | {r[5]:.6f} | {r[6]:.6f} | {r[7]} / {r[8]} | "
              f"{r[9]} / {r[10]} | {r[11]:.2f} | {r[12]:.2f} |")


if __name__ == "__main__":
    main()
