#!/usr/bin/env python3
"""Thesis Fig. 5.7 from obs runs: the factor theta(p) by which a scheme's velocity update scales the
normal velocity of a node at the step it comes into contact, against its local impact time
eta(p) = tau*(p) / tau, measured at every such node of dynamic runs written with a .vtu every step.

For a node p that is free at time level n (contact_state 1) and in contact at n + 1
(contact_state 2), with the gap gap_n = g(p) - nu_p . u^n (point array `gap`) and the normal
velocity w_n = nu_p . v^n > 0 (`normal_velocity`, positive towards the obstacle):

    eta   = gap_n / (tau w_n)      (the predictor u^n + t v^n reaches the obstacle at t = tau* = eta tau)
    theta = w_{n+1} / w_n

The predictor-based velocity update of the family (docs/theory.md#newmark-family) gives, at a node
active in the predictor (eta < 1) and in the solution, theta = 1 + 2 alpha(p) (eta - 1):
    improved-contact-stabilized, alpha(p) = 1 / (2 (1 - eta)) for eta <= 1/2, else 1:
                                 theta = 0 for eta <= 1/2, 2 eta - 1 above;
    contact-stabilized (alpha = 0): theta = 1;  alpha-half: theta = eta;  alpha-one-zero (alpha = 1): 2 eta - 1.
The script plots the measured points of each run over these curves and prints, per run, the number
of impacts and the largest |theta - formula|: the curves are exact, so that is round-off (of the
velocities and of the gap) unless the implementation departs from them.

    impact_factor.py OUT.png RUN_DIR:SCHEME [RUN_DIR:SCHEME ...] [--tau TAU]

RUN_DIR holds <scene>_NNNNNN.vtu for consecutive n (output_stride = 1) and summary.json; TAU is
read from summary.json (dynamics.tau) unless given. Exit code 1 if a run has no impact inside a step.
"""
import glob
import json
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import render_surface as rs  # noqa: E402  (the .vtu reader)

np = rs.np


def formula(scheme, eta):
    eta = np.asarray(eta, dtype=float)
    if scheme == "improved-contact-stabilized":
        return np.where(eta <= 0.5, 0.0, 2 * eta - 1)
    if scheme == "contact-stabilized":
        return np.ones_like(eta)
    if scheme == "alpha-half":
        return eta
    if scheme == "alpha-one-zero":
        return 2 * eta - 1
    raise ValueError(f"no theta(eta) for the scheme '{scheme}' (the four predictor schemes only)")


def impacts(run, tau):
    """(eta, theta) of every node that comes into contact inside a step of the run."""
    files = sorted(glob.glob(os.path.join(run, "*_[0-9][0-9][0-9][0-9][0-9][0-9].vtu")))
    steps = {int(re.search(r"_(\d{6})\.vtu$", f).group(1)): f for f in files}
    out = []
    prev = None
    for n in sorted(steps):
        cur = rs.read_vtu(steps[n])
        if prev is not None and prev[0] == n - 1:
            p = prev[1]
            new = (p.point_data["contact_state"] == 1) & (cur.point_data["contact_state"] == 2)
            w0 = p.point_data["normal_velocity"]
            hit = new & (w0 > 0)
            eta = p.point_data["gap"][hit] / (tau * w0[hit])
            theta = cur.point_data["normal_velocity"][hit] / w0[hit]
            inside = eta < 1  # reached within the step by the predictor
            out += list(zip(eta[inside], theta[inside]))
        prev = (n, cur)
    return out


def main(argv):
    tau_arg = None
    if "--tau" in argv:
        i = argv.index("--tau")
        tau_arg = float(argv[i + 1])
        argv = argv[:i] + argv[i + 2:]
    if len(argv) < 2:
        sys.stderr.write(__doc__)
        return 2
    png, runs = argv[0], [a.rsplit(":", 1) for a in argv[1:]]
    plt = rs._pyplot()
    fig, axes = plt.subplots(1, len(runs), figsize=(3.6 * len(runs), 3.4), squeeze=False)
    status = 0
    grid = np.linspace(0, 1, 201)
    for ax, (run, scheme) in zip(axes[0], runs):
        tau = tau_arg
        if tau is None:
            with open(os.path.join(run, "summary.json")) as f:
                tau = json.load(f)["dynamics"]["tau"]
        pts = impacts(run, tau)
        if not pts:
            print(f"{run}: no node comes into contact inside a step")
            status = 1
            continue
        eta, theta = np.array(pts).T
        dev = np.abs(theta - formula(scheme, eta))
        print(f"{scheme}: {len(pts)} impacts, eta in [{eta.min():.3g}, {eta.max():.3g}], "
              f"max |theta - formula| = {dev.max():.2e}")
        ax.plot(grid, formula(scheme, grid), "-", color="tab:red", lw=1.5, label="formula")
        ax.plot(eta, theta, "o", ms=3, color="k", label=f"obs ({len(pts)} impacts)")
        ax.set_xlim(0, 1)
        ax.set_ylim(-1.05, 1.05)
        ax.axhline(0, color="0.7", lw=0.5)
        ax.set_xlabel(r"$\eta(p) = \tau^*(p) / \tau$")
        ax.set_ylabel(r"$\theta(p) = \dot u^{n+1}_\nu / \dot u^n_\nu$")
        ax.set_title(scheme, fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    print(png)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
