#!/usr/bin/env python3
"""ctest scripts.render_surface: scripts/render_surface.py reads the .vtu files obs writes.

Runs two small scenes with the obs program (Example 4 on hexahedra, two adaptive steps, a .vtu per
step; Geometry 1 unrefined, two time steps) and checks the reader and the face selections against
facts that do not depend on it:
  - every scalar point array's min / max equal the RangeMin / RangeMax that VTK's writer put into
    the XML header (computed by VTK from the same data);
  - sizes and cell types of the 4 x 4 x 4 starting grid (125 points, 64 hexahedra), the Dirichlet
    value u = (0, 0, -0.05) at every vertex of the top z = 1, and the vertex field eta equal to
    (sum_k eta_k^2)^(1/2) (the estimator writes both);
  - the faces in the plane z = 0 (the contact boundary), in the plane y = 0.5 (a cross-section
    through a grid plane) and the exterior faces facing -z tile the unit square (area 1) on the
    starting grid and after refinement, each face once; the curved bottom of Geometry 1 facing -z
    projects onto the rectangle [0, 1.5] x [0, 1];
  - the dynamic .vtu has contact_pressure and normal_velocity, and `plot` writes a PNG.
  check_render_surface.py OBS RENDER_SURFACE_PY WORK_DIR DATA_DIR
"""
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys

obs, script, work, data = sys.argv[1:5]
spec = importlib.util.spec_from_file_location("render_surface", script)
rs = importlib.util.module_from_spec(spec)
spec.loader.exec_module(rs)
np = rs.np
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def area(vtu, selection):
    faces, xy, _ = rs.select_faces(vtu, selection)
    total = 0.0
    for f in faces:
        q = xy[f[f >= 0]]
        total += 0.5 * abs(np.dot(q[:, 0], np.roll(q[:, 1], -1)) - np.dot(q[:, 1], np.roll(q[:, 0], -1)))
    keys = {tuple(sorted(f[f >= 0])) for f in faces}
    return total, faces.shape[0], len(keys)


def header_ranges(path):
    head = open(path, "rb").read().split(b"<AppendedData")[0].decode()
    out = {}
    point_data = head.split("<PointData>")[1].split("</PointData>")[0]
    for tag in re.findall(r"<DataArray [^>]*>", point_data):
        if "NumberOfComponents" in tag:
            continue
        name = re.search(r'Name="([^"]+)"', tag).group(1)
        out[name] = (float(re.search(r'RangeMin="([^"]+)"', tag).group(1)),
                     float(re.search(r'RangeMax="([^"]+)"', tag).group(1)))
    return out


shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
ex4 = os.path.join(work, "example4")
subprocess.run([obs, "run", os.path.join(data, "scenes", "example4.toml"), "-q", "-o", ex4,
                "--set", "adaptivity.steps=2", "--set", 'adaptivity.vtk="every"'], check=True)
for k in (0, 1):
    path = os.path.join(ex4, f"step_{k:03d}.vtu")
    v = rs.read_vtu(path)
    ranges = header_ranges(path)
    check(len(ranges) >= 10, f"step {k}: {len(ranges)} scalar point arrays with header ranges")
    for name, (lo, hi) in ranges.items():
        a = v.point_data[name]
        check(abs(a.min() - lo) <= 1e-10 * max(1, abs(lo)) and abs(a.max() - hi) <= 1e-10 * max(1, abs(hi)),
              f"step {k}: {name} in [{a.min():.10g}, {a.max():.10g}] = header [{lo:.10g}, {hi:.10g}]")
    top = np.abs(v.points[:, 2] - 1) < 1e-12
    u = v.point_data["displacement"]
    check(top.sum() > 0 and np.all(np.abs(u[top] - [0, 0, -0.05]) < 1e-14),
          f"step {k}: u = (0, 0, -0.05) at the {top.sum()} top vertices")
    eta2 = sum(v.point_data[f"eta_{i}"] ** 2 for i in range(1, 9))
    check(np.allclose(v.point_data["eta"], np.sqrt(eta2), rtol=1e-12, atol=0),
          f"step {k}: eta = (sum_k eta_k^2)^(1/2) at every vertex")
    for sel in ("plane:z=0", "plane:y=0.5", "facing:-z", "facing:+x"):
        a, n, distinct = area(v, sel)
        check(abs(a - 1) < 1e-12 and n == distinct, f"step {k}: {sel}: {n} distinct faces, area {a:.15g}")
    if k == 0:
        check(v.num_points == 125 and v.num_cells == 64 and np.all(v.types == 12),
              f"step 0: {v.num_points} points, {v.num_cells} cells of VTK types {set(v.types.tolist())}")
        check(area(v, "plane:z=0")[1] == 16, "step 0: 16 faces on z = 0")
    else:
        with open(os.path.join(ex4, "summary.json")) as f:
            s = json.load(f)
        check(v.num_points == s["vertices"] and v.num_cells == s["cells"],
              f"step 1: {v.num_points} points / {v.num_cells} cells = summary.json")
        check(area(v, "plane:z=0")[1] > 16, "step 1: the contact boundary was refined")

g1 = os.path.join(work, "geometry1")
subprocess.run([obs, "run", os.path.join(data, "scenes", "dynamics_block.toml"), "-q", "-o", g1, "--refine", "0",
                "--set", "dynamics.steps=2"], check=True)
v = rs.read_vtu(os.path.join(g1, "dynamics_block_000002.vtu"))
for name in ("contact_pressure", "normal_velocity", "normal_displacement", "velocity"):
    check(name in v.point_data, f"dynamic .vtu has {name}")
a, n, distinct = area(v, "facing:-z")
check(abs(a - 1.5) < 1e-12 and n == distinct, f"Geometry 1: facing:-z projects to area {a:.15g} (1.5), {n} faces")
png = os.path.join(work, "eta5.png")
subprocess.run([sys.executable, script, "plot", os.path.join(ex4, "step_001.vtu"), "--field", "eta_5^2", "--log",
                "--edges", "-o", png], check=True)
check(os.path.getsize(png) > 1000, "plot writes a PNG")
print(f"{len(failures)} failure(s)")
sys.exit(1 if failures else 0)
