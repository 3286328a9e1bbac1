#!/usr/bin/env python3
"""Tables of the Geometry B study (thesis Sec. 5.2.6, Figs. 5.2-5.5) for docs/dynamics.md.

Reads the output directories of `obs run SCENE --compare-schemes` for the three readings of the
thesis' placement of the cubes (scripts/geometry_b.sh runs them) and replaces the block between the
geometry-b markers of docs/dynamics.md.

    python3 scripts/geometry_b.py --face DIR --edge DIR --corner DIR --doc docs/dynamics.md

Metrics (fixed before the runs were compared with the thesis; the thesis reads its Fig. 5.3 in two
ways, and each of its statements is compared with the matching one):
  - "loss / increase of X %" at the end of a curve: E_end / E_0 - 1;
  - "up to X %" (classical +3.5 %, HHW's E +10 %, contact-implicit with M~ +15 %, its E~ -0.12 %):
    the extremum of E^n / E^0 - 1 over the run, reported as the range [min, max];
  - E = 1/2 v'Mv + 1/2 u'Au with the lumped mass M; E~ with the redistributed mass M~ (schemes
    that have one);
  - 'v after': the range of the relative normal velocity [v]_nu at tracked node 0 from its
    detachment to the end of the run (Fig. 5.5: classical -12..12, contact-implicit 2..5, HHW
    -18..22 "after detaching");
  - momentum: the largest relative change of the total momentum (z) over the run: of M~ v for the
    schemes with a redistributed mass M~ (the momentum they conserve, thesis (5.46)), of M v for
    the others;
  - penetration: the largest violation of a constraint over the run (the persistency schemes
    allow it by design).
Run times are not reported here (docs/performance.md#dynamic-contact has bench/dynamics' figures).
"""
import argparse
import csv
import json
import os
import sys

THESIS = {  # thesis Sec. 5.2.6 (Figs. 5.3, 5.5), as stated in its text
    "classical": "E up to +3.5 %; v -12..12",
    "contact-implicit": "E -0.16 %; v 2..5",
    "contact-stabilized": "E -0.4 %",
    "laursen-chawla": "E conserved",
    "khenous-laborde-renard": "E~ -11.5 %; E nearly -9 %, not monotone",
    "hager-huebner-wohlmuth": "E~ conserved; E up to +10 %; v -18..22",
    "hager-huebner-wohlmuth-nonpenetration": "E~ down to -0.12 %; E up to +15 %",
}


def read(directory):
    s = json.load(open(os.path.join(directory, "summary.json")))
    runs = []
    for d in s["dynamics_comparison"]:
        if "error" in d:
            runs.append((d, None))
            continue
        with open(os.path.join(directory, f"timeseries_{d['scheme']}.csv")) as f:
            rows = list(csv.DictReader(f))
        runs.append((d, rows))
    return s, runs


def col(rows, key):
    return [float(r[key]) if r[key] not in ("", None) else float("nan") for r in rows]


def energy_text(e):
    """'end (min..max)' of E^n / E^0 - 1 in per cent."""
    rel = [100 * (x / e[0] - 1) for x in e]
    return f"{rel[-1]:+.2f} % ({min(rel):+.2f}..{max(rel):+.2f})"


def row_of(d, rows):
    e = col(rows, "energy")
    er = col(rows, "energy_redistributed")
    text = energy_text(e)
    red = er and er[0] == er[0] and er[0] != 0
    tilde = energy_text(er) if red else ""
    p = col(rows, "momentum_redistributed_z") if red else col(rows, "momentum_z")
    mom = max(abs(x - p[0]) for x in p) / abs(p[0])
    det = d["tracked"][0]["detachment_time"] if d.get("tracked") else None
    t = col(rows, "t")
    v = col(rows, "tracked0_normal_velocity") if "tracked0_normal_velocity" in rows[0] else []
    after = [x for x, tt in zip(v, t) if det is not None and tt >= det]
    vr = f"{min(after):.3g}..{max(after):.3g}" if after else "in contact"
    active = col(rows, "active_solution")
    return {"E": text, "E~": tilde, "momentum": f"{mom:.1e}", "force": f"{d['max_contact_force']:.4g}",
            "tv": f"{d['contact_force_variation']:.3g}", "v": vr, "active": f"{max(active):.0f}",
            "pen": f"{d['max_penetration']:.2g}", "its": f"{d['mean_iterations_per_step']:.2f}"}


def describe(s, label, scene):
    d0 = s["dynamics"]
    return (f"**{label}** (`obs run {scene} --compare-schemes`): {s['vertices']} vertices, {s['dofs']} unknowns, "
            f"tau = {d0['tau']:g}, {d0['steps']} steps (t = {d0['end_time']:.3g}).")


def detail_table(runs):
    out = ["| scheme | E: end (min..max) | E~: end (min..max) | momentum | max force | force TV | max active | "
           "penetration | v after | TNNMG its/step |", "|---|---|---|---|---|---|---|---|---|---|"]
    for d, rows in runs:
        if rows is None:
            out.append(f"| {d['scheme']} | not run: {d['error'][:120]} | | | | | | | | |")
            continue
        r = row_of(d, rows)
        out.append(f"| {d['scheme']} | {r['E']} | {r['E~']} | {r['momentum']} | {r['force']} | {r['tv']} | "
                   f"{r['active']} | {r['pen']} | {r['v']} | {r['its']} |")
    return out


READINGS = [  # option, label, scene, figure prefix
    ("face", "Face on face", "data/scenes/dynamics_two_body.toml", "dyn_geomB_"),
    ("edge", "On an edge", "data/scenes/dynamics_two_body_edge.toml", "dyn_geomB_edge_"),
    ("corner", "On a corner", "data/scenes/dynamics_two_body_corner.toml", "dyn_geomB_corner_"),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    for key, label, scene, _ in READINGS:
        ap.add_argument("--" + key, required=True, help=f"output of {scene} --compare-schemes")
    ap.add_argument("--doc", required=True)
    args = ap.parse_args()
    data = {key: read(getattr(args, key)) for key, *_ in READINGS}
    by_scheme = {}
    for key, *_ in READINGS:
        for d, rows in data[key][1]:
            by_scheme.setdefault(d["scheme"], {})[key] = row_of(d, rows) if rows else None

    def cell(x):
        if x is None:
            return "not run"
        return x["E"] + (f"; E~ {x['E~']}" if x["E~"] else "")

    # the source line of the block (scripts/provenance.py; the ctest docs.provenance checks it)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import provenance
    source = provenance.stamp(["scripts/geometry_b.sh"], os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    out = ["<!-- geometry-b:begin (scripts/geometry_b.sh; do not edit by hand) -->", "", source, "",
           "Energies in per cent of the initial value: the end value and, in brackets, the range over the run "
           "(module comment of `scripts/geometry_b.py` for every definition). E with the lumped mass M, E~ with the "
           "redistributed mass M~ (schemes that have one); 'v after' is the range of the relative normal velocity "
           "at tracked node 0 (the middle of the touching face, edge or corner) after it left contact.", "",
           "| scheme | thesis (Sec. 5.2.6) | " + " | ".join(f"{label.lower()}: E (E~)" for _, label, *_ in READINGS)
           + " | " + " | ".join(f"{label.lower()}: v after" for _, label, *_ in READINGS) + " |",
           "|---|---|" + "---|" * (2 * len(READINGS))]
    for scheme, r in by_scheme.items():
        out.append(f"| {scheme} | {THESIS.get(scheme, '')} | "
                   + " | ".join(cell(r.get(key)) for key, *_ in READINGS) + " | "
                   + " | ".join(r[key]["v"] if r.get(key) else "" for key, *_ in READINGS) + " |")
    for key, label, scene, _ in READINGS:
        out += ["", describe(data[key][0], label, scene), ""] + detail_table(data[key][1])
    for key, label, scene, prefix in READINGS:
        out += ["", label + ":", "",
                f"![energy](figures/{prefix}energy.png) ![contact force](figures/{prefix}contact_force.png)",
                f"![active nodes](figures/{prefix}active.png) "
                f"![normal displacement](figures/{prefix}displacement.png) "
                f"![normal velocity](figures/{prefix}velocity.png)"]
    out += ["", "<!-- geometry-b:end -->"]
    text = open(args.doc).read()
    a, b = text.find("<!-- geometry-b:begin"), text.find("<!-- geometry-b:end -->")
    if a < 0 or b < 0:
        sys.exit("geometry_b.py: the geometry-b markers are missing in " + args.doc)
    text = text[:a] + "\n".join(out) + text[b + len("<!-- geometry-b:end -->"):]
    open(args.doc, "w").write(text)
    print("geometry_b.py: wrote the Geometry B block of " + args.doc, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
