#!/usr/bin/env python3
"""Tables and figures of scripts/chapter5.sh (thesis Sec. 5.3.3, Figs. 5.9-5.14), written into the block
between the chapter5 markers of docs/dynamics.md and docs/figures/ch5_*.png.

Definitions (fixed before any measurement; docs/dynamics.md repeats them):
  * contact episode: from the first step with a node active in the solution (active_solution > 0) to
    the last such step of the run; 'free' = the step after it (none if the run ends in contact);
  * peak = the step of the largest total normal contact force; it splits the episode into impact
    (compression, first contact .. peak) and detachment (restitution, peak .. free);
  * energy lost at impact = (E_0 - E_peak)/E_0, at detachment = (E_peak - E_free)/E_0, after the
    episode = (E_free - E_end)/E_0 (E_0 = the initial energy; before the first contact every member of
    the family conserves E exactly);
  * predictor-only / solution-only: nodes active for the predictor and not for the solution and the
    other way round (StepRecord, timeseries.csv), summed over the steps of a phase (node-steps) and
    their largest count in one step;
  * force extrema: the number of strict local extrema of the total normal contact force inside the
    episode (differences below 1e-6 of the peak force ignored): 1 for a single smooth hump, every
    oscillation adds two;
  * kink: the largest second difference |F_{n+1} - 2 F_n + F_{n-1}| of the total force in the episode,
    in % of the peak force, its time, and the number of steps where it exceeds 1 % (a kink = a jump of
    the slope, which need not be an extremum);
  * tracked node (the lowest point of Geometry 1): velocity at the step of its first contact and the
    number of steps after it until its normal velocity is zero (|v| <= 1e-9 v0); the number of
    strict local extrema of its normal displacement while it is in contact.
"""
import argparse
import csv
import json
import math
import os
import sys

SCHEMES = [("improved-contact-stabilized", "alpha(p)"), ("contact-stabilized", "alpha = 0"),
           ("alpha-half", "alpha = 1/2"), ("alpha-one-zero", "alpha = {1, 0}"),
           ("contact-implicit", "alpha, beta = 0")]
LABEL = dict(SCHEMES)


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    cols = {k: [float(r[k]) if r[k] not in ("", None) else math.nan for r in rows] for k in rows[0]}
    return cols


def summary(work, d):
    with open(os.path.join(work, d, "summary.json")) as f:
        return json.load(f)


def series(work, d, scheme):
    return read(os.path.join(work, d, f"timeseries_{scheme}.csv"))


def force(s):
    return [math.sqrt(x * x + y * y + z * z)
            for x, y, z in zip(s["contact_force_x"], s["contact_force_y"], s["contact_force_z"])]


def extrema(values, threshold):
    d = [b - a for a, b in zip(values, values[1:])]
    d = [x for x in d if abs(x) > threshold]
    return sum(1 for a, b in zip(d, d[1:]) if a * b < 0)


def analyse(s, v0):
    n = len(s["t"])
    E = s["energy"]
    F = force(s)
    act = s["active_solution"]
    inside = [k for k in range(n) if act[k] > 0]
    out = {"steps": n - 1}
    if not inside:
        out["contact"] = False
        return out
    first, last = inside[0], inside[-1]
    peak = max(range(n), key=lambda k: F[k])
    free = last + 1 if last + 1 < n else None
    E0 = E[0]
    out.update(contact=True, t_first=s["t"][first], t_peak=s["t"][peak], t_free=None if free is None else s["t"][free],
               loss_impact=(E0 - E[peak]) / E0, loss_detach=None if free is None else (E[peak] - E[free]) / E0,
               loss_after=None if free is None else (E[free] - E[-1]) / E0, ratio=E[-1] / E0,
               max_force=F[peak], force_extrema=extrema(F[first:last + 1], 1e-6 * F[peak]))
    d2 = [abs(F[k + 1] - 2 * F[k] + F[k - 1]) / F[peak] for k in range(max(1, first), min(n - 1, last + 2))]
    k2 = max(range(len(d2)), key=lambda k: d2[k])
    out.update(kink=d2[k2], t_kink=s["t"][max(1, first) + k2], kinks=sum(1 for x in d2 if x > 0.01))
    for key in ("predictor_only", "solution_only"):
        c = s[key]
        out[key + "_impact"] = sum(c[first:peak + 1])
        out[key + "_detach"] = sum(c[peak + 1:(free if free is not None else n)])
        out[key + "_max"] = max(c)
    out["max_active"] = max(act)
    # oscillation of the active count: strict local extrema of active_solution inside the episode
    out["active_extrema"] = extrema(act[first:last + 1], 0.5)
    # tracked nodes
    out["tracked"] = []
    j = 0
    while f"tracked{j}_normal_velocity" in s:
        g = s[f"tracked{j}_gap"]
        v = s[f"tracked{j}_normal_velocity"]
        u = s[f"tracked{j}_normal_displacement"]
        j += 1
        touch = [k for k in range(n) if g[k] <= 1e-12]
        if not touch:
            out["tracked"].append(None)
            continue
        k0 = touch[0]
        t = {"t_first": s["t"][k0], "v_first": v[k0]}
        zero = next((k for k in range(k0, n) if abs(v[k]) <= 1e-9 * v0), None)
        t["steps_to_zero"] = None if zero is None else zero - k0
        k1 = k0
        while k1 + 1 < n and g[k1 + 1] <= 1e-12:
            k1 += 1
        t["u_extrema"] = extrema(u[k0:k1 + 2], 1e-12)
        t["v_extrema"] = extrema(v[k0:k1 + 2], 1e-9 * v0)
        t["contact_steps"] = k1 - k0 + 1
        t["v_sequence"] = v[k0:k0 + 4]
        out["tracked"].append(t)
    return out


def fmt(x, p=3):
    if x is None:
        return "–"
    if isinstance(x, float) and (math.isnan(x)):
        return "–"
    if isinstance(x, int):
        return str(x)
    return f"{x:.{p}g}"


def pct(x):
    return "–" if x is None else f"{abs(100 * x) if abs(100 * x) < 5e-4 else 100 * x:.3f}"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("work")
    ap.add_argument("--doc", required=True)
    ap.add_argument("--figures", required=True)
    ap.add_argument("--taus", required=True)
    ap.add_argument("--loss-refines", required=True)
    ap.add_argument("--loss-taus", required=True)
    ap.add_argument("--mode", default="default")
    a = ap.parse_args()
    work, taus = a.work, a.taus.split()
    loss_refines, loss_taus = a.loss_refines.split(), a.loss_taus.split()
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        plt = None
    os.makedirs(a.figures, exist_ok=True)
    colors = {"improved-contact-stabilized": "tab:red", "contact-stabilized": "tab:green", "alpha-half": "tab:blue",
              "alpha-one-zero": "tab:orange", "contact-implicit": "tab:purple"}

    out = ["<!-- chapter5:begin (scripts/chapter5.sh; do not edit by hand) -->", ""]
    mode = {"quick": ", QUICK=1 (smoke run: coarse mesh, short)", "full": ", FULL=1"}.get(a.mode, "")
    # the source line of every subsection (scripts/provenance.py; the ctest docs.provenance checks it)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import provenance
    env = {"quick": "QUICK=1 ", "full": "FULL=1 "}.get(a.mode, "")
    source = provenance.stamp([f"{env}scripts/chapter5.sh"], os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    out += [f"Generated by `scripts/chapter5.sh`{mode} (`obs run` on `data/scenes/dynamics_block.toml` and "
            "`dynamics_bar.toml`, one core, Release). Definitions: see the module comment of `scripts/chapter5.py`; "
            "energies in % of E_0 (E with the lumped mass M), node counts in node-steps (sum over the steps of the "
            "phase) with the largest count in one step in brackets.", ""]
    results = {}
    for tau in taus:
        d = f"g1_t{tau}"
        s = summary(work, d)
        dyn = s["dynamics"]
        out += [f"#### Geometry 1, tau = {tau}", "", source, "",
                f"{s['vertices']} vertices, {s['dofs']} unknowns, {dyn['steps']} steps (t = {dyn['end_time']:.3g}), "
                f"`obs run data/scenes/dynamics_block.toml --refine {s.get('refine', '')}` with "
                f"`--set dynamics.tau={tau}`; run time {open(os.path.join(work, d, 'wall_s')).read().strip()} s "
                f"for the {len(s['dynamics_comparison'])} schemes.", "",
                "| scheme | lost at impact % | at detachment % | after % | E_end/E_0 | first contact | peak force (t) | free at | "
                "predictor-only impact / detachment | solution-only impact / detachment | force extrema | kink % (t; steps > 1 %) | active-count extrema | ms/step |",
                "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        per = {}
        for c in s["dynamics_comparison"]:
            sc = c["scheme"]
            ts = series(work, d, sc)
            r = analyse(ts, 1.0)
            r["ms"] = 1e3 * c["seconds_per_step"]
            per[sc] = (r, ts)
        results[tau] = per
        for sc, lab in SCHEMES:
            if sc not in per:
                continue
            r = per[sc][0]
            if not r.get("contact"):
                out.append(f"| {lab} | no contact | | | | | | | | | | | | |")
                continue
            out.append(
                f"| {lab} | {pct(r['loss_impact'])} | {pct(r['loss_detach'])} | {pct(r['loss_after'])} | {r['ratio']:.5f} | "
                f"{r['t_first']:.4g} | {r['max_force']:.4g} ({r['t_peak']:.4g}) | {fmt(r['t_free'], 4)} | "
                f"{r['predictor_only_impact']:.0f} / {r['predictor_only_detach']:.0f} ({r['predictor_only_max']:.0f}) | "
                f"{r['solution_only_impact']:.0f} / {r['solution_only_detach']:.0f} ({r['solution_only_max']:.0f}) | "
                f"{r['force_extrema']} | {100 * r['kink']:.2f} ({r['t_kink']:.4g}; {r['kinks']}) | {r['active_extrema']} | {r['ms']:.3g} |")
        out += ["", "Tracked nodes (node 0: the lowest point x = (0.75, 0.5, 0), on the plane exactly at the time level "
                "t = 0.01, tau* = 0; node 1: the bottom vertex at x = 0.875, on the plane at t = 0.0152, inside a step): "
                "the time level at which it first lies on the plane, its normal velocity there and in the next three "
                "levels (v0 = 1 towards the plane; negative = away), levels until the velocity is zero, levels in "
                "contact, and the strict local extrema of its normal displacement and velocity over its contact "
                "interval (a kink in either adds extrema):", "",
                "| scheme | node | on the plane at | v there, then | levels to v = 0 | levels in contact | extrema of u | extrema of v |",
                "|---|---|---|---|---|---|---|---|"]
        for sc, lab in SCHEMES:
            if sc not in per:
                continue
            for j, t in enumerate(per[sc][0].get("tracked", [])):
                if t is None:
                    out.append(f"| {lab} | {j} | no contact | | | | | |")
                    continue
                seq = ", ".join(f"{x:.3g}" for x in t["v_sequence"])
                out.append(f"| {lab} | {j} | {t['t_first']:.5g} | {seq} | {fmt(t['steps_to_zero'])} | "
                           f"{t['contact_steps']} | {t['u_extrema']} | {t['v_extrema']} |")
        out.append("")
        if plt:
            figs = []
            # Fig. 5.9: energy
            fig, ax = plt.subplots(1, 2, figsize=(11, 4))
            for sc, lab in SCHEMES:
                if sc in per:
                    ts = per[sc][1]
                    e0 = ts["energy"][0]
                    for axis in ax:
                        axis.plot(ts["t"], [e / e0 for e in ts["energy"]], color=colors[sc], label=lab)
            lo = min(per[sc][0].get("ratio", 1) for sc in ("improved-contact-stabilized", "alpha-half") if sc in per)
            ax[1].set_ylim(lo - 0.002, 1.0005)
            ax[1].set_title("zoom")
            for axis in ax:
                axis.set_xlabel("t"); axis.set_ylabel("E / E_0"); axis.grid(True, alpha=0.3)
            ax[0].legend(fontsize=7)
            fig.suptitle(f"Geometry 1, tau = {tau}: energy (cf. thesis Fig. 5.9)")
            fig.tight_layout(); fig.savefig(os.path.join(a.figures, f"ch5_g1_energy_t{tau}.png"), dpi=100); plt.close(fig)
            figs.append(("energy", f"ch5_g1_energy_t{tau}.png"))
            # Fig. 5.10: contact force
            fig, ax = plt.subplots(1, 3, figsize=(15, 4))
            for sc, lab in SCHEMES:
                if sc not in per:
                    continue
                ts = per[sc][1]
                F = force(ts)
                if sc in ("alpha-one-zero", "contact-implicit"):
                    ax[0].plot(ts["t"], F, color=colors[sc], label=lab, lw=0.8)
                else:
                    ax[1].plot(ts["t"], F, color=colors[sc], label=lab)
                    ax[2].plot(ts["t"], F, color=colors[sc], label=lab, marker=".", ms=2)
            ref = per.get("alpha-half", per.get("improved-contact-stabilized", (None, None)))[0]
            if ref and ref.get("contact"):  # zoom: around the largest kink of alpha = 1/2
                w = 0.04 * (ref["t_peak"] - ref["t_first"]) + 1e-12
                t0, t1 = ref["t_kink"] - w, ref["t_kink"] + w
                window = [f for sc in per if sc not in ("alpha-one-zero", "contact-implicit")
                          for t, f in zip(per[sc][1]["t"], force(per[sc][1])) if t0 <= t <= t1] or [0, 1]
                lo, hi = min(window), max(window)
                ax[2].set_xlim(t0, t1)
                ax[2].set_ylim(lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo) + 1e-12)
            if not ax[0].lines:
                ax[0].text(0.5, 0.5, "not run at this tau", ha="center", transform=ax[0].transAxes)
            ax[0].set_title("alpha = {1, 0} and alpha, beta = 0"); ax[1].set_title("alpha(p), alpha = 0, alpha = 1/2")
            ax[2].set_title("zoom: around the largest kink of alpha = 1/2")
            for axis in ax:
                axis.set_xlabel("t"); axis.set_ylabel("total normal contact force"); axis.grid(True, alpha=0.3)
                if axis.lines:
                    axis.legend(fontsize=7)
            fig.suptitle(f"Geometry 1, tau = {tau}: contact force (cf. thesis Fig. 5.10)")
            fig.tight_layout(); fig.savefig(os.path.join(a.figures, f"ch5_g1_force_t{tau}.png"), dpi=100); plt.close(fig)
            figs.append(("contact force", f"ch5_g1_force_t{tau}.png"))
            # Fig. 5.11: node counts
            fig, ax = plt.subplots(1, 3, figsize=(15, 4))
            for sc, lab in SCHEMES:
                if sc not in per:
                    continue
                ts = per[sc][1]
                ax[0].plot(ts["t"], ts["active_solution"], color=colors[sc], label=lab, lw=0.8)
                if sc not in ("alpha-one-zero", "contact-implicit"):
                    ax[1].plot(ts["t"], ts["predictor_only"], color=colors[sc], label=lab, lw=0.8)
                    ax[2].plot(ts["t"], ts["solution_only"], color=colors[sc], label=lab, lw=0.8)
            ax[0].set_title("active for the solution"); ax[1].set_title("active for the predictor only")
            ax[2].set_title("active for the solution only")
            for axis in ax:
                axis.set_xlabel("t"); axis.set_ylabel("nodes"); axis.grid(True, alpha=0.3); axis.legend(fontsize=7)
            fig.suptitle(f"Geometry 1, tau = {tau}: contact nodes (cf. thesis Fig. 5.11)")
            fig.tight_layout(); fig.savefig(os.path.join(a.figures, f"ch5_g1_nodes_t{tau}.png"), dpi=100); plt.close(fig)
            figs.append(("contact nodes", f"ch5_g1_nodes_t{tau}.png"))
            # Fig. 5.12: tracked node
            fig, ax = plt.subplots(1, 2, figsize=(11, 4))
            for sc, lab in SCHEMES:
                if sc in per and sc not in ("alpha-one-zero", "contact-implicit"):
                    ts = per[sc][1]
                    key = "tracked1" if "tracked1_gap" in ts else "tracked0"
                    ax[0].plot(ts["t"], ts[key + "_normal_velocity"], color=colors[sc], label=lab, marker=".", ms=2, lw=0.8)
                    ax[1].plot(ts["t"], ts[key + "_gap"], color=colors[sc], label=lab, marker=".", ms=2, lw=0.8)
            ax[0].set_ylabel("normal velocity (towards the plane)"); ax[1].set_ylabel("gap to the plane")
            for axis in ax:
                axis.set_xlabel("t"); axis.grid(True, alpha=0.3); axis.legend(fontsize=7)
            fig.suptitle(f"Geometry 1, tau = {tau}: the bottom vertex at x = 0.875 (cf. thesis Fig. 5.12)")
            fig.tight_layout(); fig.savefig(os.path.join(a.figures, f"ch5_g1_node_t{tau}.png"), dpi=100); plt.close(fig)
            figs.append(("tracked node", f"ch5_g1_node_t{tau}.png"))
            out.append(" ".join(f"![{t}](figures/{f})" for t, f in figs))
            out.append("")

    # Fig. 5.13: the bar
    s = summary(work, "bar")
    exact = 0.5 + 20 / 30
    tau = s["dynamics"]["tau"]
    out += ["#### The bar of Fig. 5.13 (tau = 5e-3, h = 0.1)", "", source, "",
            f"Column of 1 x 100 quadrilaterals (h = 0.1 along the bar), nu = 0, E = 900, rho = 1, L = 10, h0 = 5, v0 = 10, "
            f"tau = {tau:g}, {s['dynamics']['steps']} steps; `obs run data/scenes/dynamics_bar.toml --set 'mesh.cells=[1, 100]' "
            f"--set dynamics.tau=5e-3 --set dynamics.steps=300 --set 'dynamics.compare=[\"contact-stabilized\"]'`. Exact contact interval [0.5, {exact:.4f}] "
            f"(step {0.5 / tau:.0f} to {exact / tau:.1f}). 'lift-off' = first time level after the impact with an open "
            "gap, 'release' = first whose normal velocity points away from the obstacle.", "",
            "'height error' = mean of |height - exact height| over the 12 levels after the exact detachment.", "",
            "| scheme | first contact | lift-off | error | in steps | release | error | height error | E_end/E_0 |",
            "|---|---|---|---|---|---|---|---|---|"]
    bar = {}
    for c in s["dynamics_comparison"]:
        t = c["tracked"][0]
        det, rel = t["detachment_time"], t["release_time"]
        ts = series(work, "bar", c["scheme"])
        bar[c["scheme"]] = (ts, det, rel)
        after = [(tt, g) for tt, g in zip(ts["t"], ts["tracked0_gap"]) if exact < tt <= exact + 12 * tau + 1e-12]
        herr = sum(abs(g - 10 * (tt - exact)) for tt, g in after) / max(1, len(after))
        out.append(f"| {LABEL.get(c['scheme'], c['scheme'])} | {fmt(t['first_contact_time'], 4)} | {fmt(det, 4)} | "
                   f"{fmt(None if det is None else det - exact, 2)} | {fmt(None if det is None else (det - exact) / tau, 2)} | "
                   f"{fmt(rel, 4)} | {fmt(None if rel is None else rel - exact, 2)} | {herr:.4f} | {c['energy_ratio']:.4f} |")
    out.append("")
    if plt:
        fig, ax = plt.subplots(figsize=(7, 4))
        lo, hi = int(exact / tau) - 12, int(exact / tau) + 12
        ks = list(range(lo, hi + 1))
        ex = [max(0.0, 10 * (k * tau - exact)) for k in ks]
        ax.plot(ks, ex, color="k", label="exact")
        for sc, style in (("contact-stabilized", dict(color="tab:green", ls=":", marker="s", ms=3)),
                          ("improved-contact-stabilized", dict(color="tab:red", marker="o", ms=3))):
            if sc in bar:
                ts = bar[sc][0]
                steps = [int(round(x)) for x in ts["step"]]
                g = ts["tracked0_gap"]
                pts = [(k, gg) for k, gg in zip(steps, g) if lo <= k <= hi]
                ax.plot([p[0] for p in pts], [p[1] for p in pts], label=LABEL[sc], **style)
        ax.set_xlabel("time step n"); ax.set_ylabel("height of the contact end"); ax.grid(True, alpha=0.3)
        ax.legend(); ax.set_title("bar, tau = 5e-3, h = 0.1: detachment (cf. thesis Fig. 5.13)")
        fig.tight_layout(); fig.savefig(os.path.join(a.figures, "ch5_bar.png"), dpi=100); plt.close(fig)
        out += ["![bar](figures/ch5_bar.png)", ""]

    # Fig. 5.14
    out += ["#### Energy loss against tau and h (cf. thesis Fig. 5.14)", "", source, "",
            f"Geometry 1 to t = {summary(work, f'loss_r{loss_refines[0]}_t{loss_taus[0]}')['dynamics']['end_time']:.2g} "
            "(impact and detachment), 1 - E_end/E_0 in %, alpha(p) / alpha = 0; "
            "`obs run data/scenes/dynamics_block.toml --refine R --set dynamics.tau=TAU --set dynamics.steps=... "
            "--set 'dynamics.compare=[\"contact-stabilized\"]'`; run time of both schemes in brackets.", "",
            "| refine (unknowns) | " + " | ".join(f"tau = {t}" for t in loss_taus) + " |",
            "|---|" + "---|" * len(loss_taus)]
    loss = {}
    for r in loss_refines:
        cells = []
        dofs = None
        for t in loss_taus:
            d = f"loss_r{r}_t{t}"
            s = summary(work, d)
            dofs = s["dofs"]
            v = {c["scheme"]: 1 - c["energy_ratio"] for c in s["dynamics_comparison"]}
            loss[(r, t)] = v
            wall = open(os.path.join(work, d, "wall_s")).read().strip()
            cells.append(f"{pct(v.get('improved-contact-stabilized'))} / {pct(v.get('contact-stabilized'))} ({wall} s)")
        out.append(f"| {r} ({dofs}) | " + " | ".join(cells) + " |")
    out.append("")
    if plt:
        fig, ax = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
        for i, (sc, lab) in enumerate((("improved-contact-stabilized", "alpha(p)"), ("contact-stabilized", "alpha = 0"))):
            for r in loss_refines:
                ax[i].plot([float(t) for t in loss_taus], [100 * loss[(r, t)][sc] for t in loss_taus], marker="o",
                           label=f"refine {r}")
            ax[i].set_xscale("log"); ax[i].set_xlabel("tau"); ax[i].set_title(lab); ax[i].grid(True, alpha=0.3)
            ax[i].legend(fontsize=7)
        ax[0].set_ylabel("energy lost, % of E_0")
        fig.suptitle("Geometry 1: energy loss against tau and h (cf. thesis Fig. 5.14)")
        fig.tight_layout(); fig.savefig(os.path.join(a.figures, "ch5_energy_loss.png"), dpi=100); plt.close(fig)
        out += ["![energy loss](figures/ch5_energy_loss.png)", ""]
    out.append("<!-- chapter5:end -->")

    with open(a.doc) as f:
        text = f.read()
    begin, end = text.find("<!-- chapter5:begin"), text.find("<!-- chapter5:end -->")
    block = "\n".join(out)
    if begin >= 0 and end >= 0:
        text = text[:begin] + block + text[end + len("<!-- chapter5:end -->"):]
    else:
        at = text.find("\n## Results")
        if at < 0:
            sys.exit("chapter5.py: neither the chapter5 markers nor '## Results' in " + a.doc)
        text = text[:at] + "\n" + block + "\n" + text[at:]
    with open(a.doc, "w") as f:
        f.write(text)
    print("chapter5.py: wrote the chapter5 block of " + a.doc, file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
