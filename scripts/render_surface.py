#!/usr/bin/env python3
"""Surface pictures of point fields from the .vtu files of `obs run` (docs/examples.md, docs/dynamics.md).

A small reader of the VTK XML unstructured grids obs writes (drivers/src/VtkWriter.cpp: appended raw
data, zlib-compressed blocks, header_type UInt32 or UInt64 as the file says; uncompressed files are
read too) and a renderer of one point field on a set of faces of the grid, with numpy and matplotlib
only (no vtk module). Two face selections, both exact and simple:

  plane:AXIS=VALUE   the cell faces lying in the plane x_AXIS = VALUE (all their vertices within
                     1e-9 of it), each face once. On the boundary (z=0: the contact boundary of the
                     unit cube) these are the boundary faces; inside the body they are a cross-section
                     only where the plane is a grid plane of the starting grid (red refinement and the
                     green closure keep such planes covered by faces), e.g. y=0.5 for the 4 x 4 x 4
                     grids. No cell is cut: the picture shows the vertex values of the faces in the
                     plane, linearly interpolated on their triangles (quadrilaterals split in two).
  facing:-z          the exterior faces (faces of exactly one cell) whose outward unit normal n has
                     n . (0, 0, -1) > 0.5, drawn in the (x, y) plane: the bottom of a body, curved or
                     not (the contact boundary of the dynamic scenes). Any of +x, -x, +y, -y, +z, -z.

Fields: a point array by name; NAME^2 squares it (the estimator contributions are written as
eta_{k,p}, the figures show eta_{k,p}^2); NAME:x / :y / :z / :mag picks a component of a vector.
Log colour scales clip at max * 10^-decades; exact zeros (and values below the clip) get the colour
for values under the range (light grey), so the support of a contribution is visible.

  render_surface.py info FILE.vtu                     # arrays, sizes, ranges
  render_surface.py plot FILE.vtu --field eta_5^2 --select plane:z=0 --log --edges -o eta5.png
  render_surface.py figures --runs out/surface_figures --output docs/figures
                                                      # the thesis figures (scripts/surface_figures.sh)

Exit code 3 (and a message on stderr) if numpy or matplotlib is missing.
"""
import argparse
import base64
import json
import os
import re
import sys
import xml.etree.ElementTree as ET
import zlib

try:
    import numpy as np
except ImportError:  # pragma: no cover
    sys.stderr.write("render_surface.py: numpy is missing (use /usr/bin/python3)\n")
    sys.exit(3)

# ------------------------------------------------------------------------------------------------
# reader

_DTYPES = {"Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4", "UInt32": "u4",
           "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8"}


class Vtu:
    """One piece of a VTK XML unstructured grid: points (n, 3), connectivity, offsets, types, and the
    point and cell arrays by name ((n,) or (n, components))."""

    def __init__(self, points, connectivity, offsets, types, point_data, cell_data):
        self.points = points
        self.connectivity = connectivity
        self.offsets = offsets
        self.types = types
        self.point_data = point_data
        self.cell_data = cell_data

    @property
    def num_points(self):
        return self.points.shape[0]

    @property
    def num_cells(self):
        return self.types.shape[0]

    def cell(self, c):
        start = self.offsets[c - 1] if c > 0 else 0
        return self.connectivity[start:self.offsets[c]]


def _decode(raw, start, dtype, header, compressed):
    """The values of one appended DataArray whose data begins at raw[start]."""
    hsize = np.dtype(header).itemsize
    if not compressed:
        (nbytes,) = np.frombuffer(raw, dtype=header, count=1, offset=start)
        return np.frombuffer(raw, dtype=dtype, count=int(nbytes) // np.dtype(dtype).itemsize,
                             offset=start + hsize)
    nblocks, block, last = (int(x) for x in np.frombuffer(raw, dtype=header, count=3, offset=start))
    sizes = np.frombuffer(raw, dtype=header, count=nblocks, offset=start + 3 * hsize).astype(np.int64)
    pos = start + (3 + nblocks) * hsize
    chunks = []
    for i, s in enumerate(sizes):
        data = zlib.decompress(raw[pos:pos + int(s)])
        expected = last if (i == nblocks - 1 and last != 0) else block
        if len(data) != expected:
            raise ValueError(f"block {i}: {len(data)} bytes after decompression, expected {expected}")
        chunks.append(data)
        pos += int(s)
    return np.frombuffer(b"".join(chunks), dtype=dtype)


def _decode_inline(element, dtype, header, compressed):
    """format="binary" arrays (base64 in the element text); obs does not write them, kept for
    files from elsewhere."""
    text = "".join((element.text or "").split())
    if not compressed:
        raw = base64.b64decode(text)
        return np.frombuffer(raw, dtype=dtype, offset=np.dtype(header).itemsize)
    hsize = np.dtype(header).itemsize
    first = base64.b64decode(text[:((3 * hsize + 2) // 3) * 4])
    nblocks = int(np.frombuffer(first, dtype=header, count=1)[0])
    hlen = (3 + nblocks) * hsize
    hchars = ((hlen + 2) // 3) * 4
    head = base64.b64decode(text[:hchars])
    raw = head[:hlen] + base64.b64decode(text[hchars:])
    return _decode(raw, 0, dtype, header, True)


def read_vtu(path):
    """Reads a .vtu written by obs (or any single-piece VTK XML unstructured grid with appended raw,
    inline binary or ascii arrays)."""
    with open(path, "rb") as f:
        data = f.read()
    marker = data.find(b"<AppendedData")
    if marker >= 0:
        underscore = data.index(b"_", data.index(b">", marker)) + 1
        head = data[:marker] + b"</VTKFile>"
        raw = data[underscore:]
        enc = re.search(rb'encoding="(\w+)"', data[marker:underscore])
        if enc and enc.group(1) != b"raw":
            raise ValueError(f"{path}: appended data encoding {enc.group(1).decode()} is not supported")
    else:
        head, raw = data, b""
    root = ET.fromstring(head)
    if root.get("type") != "UnstructuredGrid":
        raise ValueError(f"{path}: not an UnstructuredGrid file ({root.get('type')})")
    if root.get("byte_order", "LittleEndian") != "LittleEndian":
        raise ValueError(f"{path}: big-endian files are not supported")
    header = _DTYPES[root.get("header_type", "UInt32")]
    compressor = root.get("compressor", "")
    if compressor and compressor != "vtkZLibDataCompressor":
        raise ValueError(f"{path}: compressor {compressor} is not supported")
    compressed = bool(compressor)
    pieces = root.findall("./UnstructuredGrid/Piece")
    if len(pieces) != 1:
        raise ValueError(f"{path}: {len(pieces)} pieces (one expected)")
    piece = pieces[0]
    npts, ncells = int(piece.get("NumberOfPoints")), int(piece.get("NumberOfCells"))

    def array(e, tuples):
        dtype = _DTYPES[e.get("type")]
        fmt = e.get("format")
        if fmt == "appended":
            v = _decode(raw, int(e.get("offset")), dtype, header, compressed)
        elif fmt == "binary":
            v = _decode_inline(e, dtype, header, compressed)
        else:
            v = np.array((e.text or "").split(), dtype=dtype)
        comps = int(e.get("NumberOfComponents", "1"))
        if tuples is not None and v.size != tuples * comps:
            raise ValueError(f"{path}: array {e.get('Name')} has {v.size} values, "
                             f"expected {tuples} x {comps}")
        return v.reshape(-1, comps) if comps > 1 else v

    points = array(piece.find("./Points/DataArray"), npts).astype(float).reshape(npts, 3)
    cells = {e.get("Name"): array(e, None) for e in piece.findall("./Cells/DataArray")}
    point_data = {e.get("Name"): array(e, npts) for e in piece.findall("./PointData/DataArray")}
    cell_data = {e.get("Name"): array(e, ncells) for e in piece.findall("./CellData/DataArray")}
    types = cells["types"].astype(np.int64)
    offsets = cells["offsets"].astype(np.int64)
    if types.size != ncells or offsets.size != ncells:
        raise ValueError(f"{path}: {types.size} types / {offsets.size} offsets for {ncells} cells")
    return Vtu(points, cells["connectivity"].astype(np.int64), offsets, types, point_data, cell_data)


# ------------------------------------------------------------------------------------------------
# faces

# local faces of the VTK cell types obs writes (VTK vertex order; faces as cycles)
_FACES = {
    5: [(0, 1, 2)],                                                   # triangle (2D meshes)
    9: [(0, 1, 2, 3)],                                                # quadrilateral
    10: [(0, 1, 2), (0, 1, 3), (1, 2, 3), (0, 2, 3)],                 # tetrahedron
    12: [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)],  # hexahedron
    13: [(0, 1, 2), (3, 4, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5)],  # wedge (prism)
    14: [(0, 1, 2, 3), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)],   # pyramid
}
_NVERTS = {5: 3, 9: 4, 10: 4, 12: 8, 13: 6, 14: 5}


def all_faces(vtu):
    """Every face of every 3D cell: (faces (F, 4) with -1 padding for triangles, owner cell (F,))."""
    faces, owners = [], []
    for t in np.unique(vtu.types):
        if t not in _FACES:
            raise ValueError(f"VTK cell type {t} is not supported")
        cells = np.nonzero(vtu.types == t)[0]
        n = _NVERTS[t]
        starts = vtu.offsets[cells] - n
        conn = vtu.connectivity[starts[:, None] + np.arange(n)[None, :]]
        for local in _FACES[t]:
            f = np.full((cells.size, 4), -1, dtype=np.int64)
            f[:, :len(local)] = conn[:, list(local)]
            faces.append(f)
            owners.append(cells)
    return np.concatenate(faces), np.concatenate(owners)


def _unique_faces(faces):
    """Indices of one copy of each face and how often it occurs (faces equal as vertex sets)."""
    key = np.sort(np.where(faces < 0, np.iinfo(np.int64).max, faces), axis=1)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    return first, counts


def select_faces(vtu, selection):
    """Faces (F, 4) and the 2D coordinates (n, 2) of all points in the picture plane, and the two
    axis labels, for 'plane:AXIS=VALUE' or 'facing:(+|-)AXIS' (module docstring)."""
    axes = "xyz"
    faces, owners = all_faces(vtu)
    kind, _, arg = selection.partition(":")
    if kind == "plane":
        m = re.fullmatch(r"([xyz])=([-+0-9.eE]+)", arg)
        if not m:
            raise ValueError(f"selection '{selection}': expected plane:AXIS=VALUE")
        a, value = axes.index(m.group(1)), float(m.group(2))
        on = np.abs(vtu.points[:, a] - value) <= 1e-9 * max(1.0, abs(value))
        keep = np.all(np.where(faces < 0, True, on[np.maximum(faces, 0)]), axis=1)
        faces = faces[keep]
        first, _ = _unique_faces(faces)
        faces = faces[np.sort(first)]
        plane = [i for i in range(3) if i != a]
    elif kind == "facing":
        m = re.fullmatch(r"([+-]?)([xyz])", arg)
        if not m:
            raise ValueError(f"selection '{selection}': expected facing:(+|-)AXIS")
        a = axes.index(m.group(2))
        d = np.zeros(3)
        d[a] = -1.0 if m.group(1) == "-" else 1.0
        first, counts = _unique_faces(faces)
        ext = first[counts == 1]
        faces, owners = faces[ext], owners[ext]
        p = vtu.points
        p0, p1, p2 = p[faces[:, 0]], p[faces[:, 1]], p[faces[:, 2]]
        normal = np.cross(p1 - p0, p2 - p0)
        quad = faces[:, 3] >= 0
        p3 = p[np.maximum(faces[:, 3], 0)]
        normal[quad] = np.cross(p2[quad] - p0[quad], p3[quad] - p1[quad])
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        # orient outward: away from the centroid of the owning cell
        centroid = np.array([p[vtu.cell(c)].mean(axis=0) for c in owners])
        fc = np.where(quad[:, None], (p0 + p1 + p2 + p3) / 4, (p0 + p1 + p2) / 3)
        normal *= np.sign(np.einsum("ij,ij->i", normal, fc - centroid))[:, None]
        faces = faces[normal @ d > 0.5]
        plane = [i for i in range(3) if i != a]
    else:
        raise ValueError(f"selection '{selection}': expected plane:... or facing:...")
    if faces.shape[0] == 0:
        raise ValueError(f"selection '{selection}': no faces")
    return faces, vtu.points[:, plane], (axes[plane[0]], axes[plane[1]])


def field_values(vtu, spec):
    """Point values of NAME, NAME^2, NAME:x|y|z|mag (module docstring)."""
    square = spec.endswith("^2")
    name = spec[:-2] if square else spec
    name, _, comp = name.partition(":")
    if name not in vtu.point_data:
        raise ValueError(f"no point array '{name}' (have: {', '.join(sorted(vtu.point_data))})")
    v = np.asarray(vtu.point_data[name], dtype=float)
    if comp:
        if v.ndim != 2:
            raise ValueError(f"'{name}' is a scalar, no component {comp}")
        v = np.linalg.norm(v, axis=1) if comp == "mag" else v[:, "xyz".index(comp)]
    elif v.ndim != 1:
        raise ValueError(f"'{name}' has {v.shape[1]} components: pick one with :x, :y, :z or :mag")
    return v * v if square else v


def triangles(faces):
    """Triangles of the faces (quadrilaterals split along the diagonal 0-2)."""
    tri = faces[:, :3]
    quad = faces[faces[:, 3] >= 0]
    return np.concatenate([tri, quad[:, [0, 2, 3]]])


# ------------------------------------------------------------------------------------------------
# drawing


def _pyplot():
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        return plt
    except ImportError:
        sys.stderr.write("render_surface.py: matplotlib is missing (use /usr/bin/python3)\n")
        sys.exit(3)


def draw(ax, vtu, field, selection, log=False, decades=6.0, edges=False, vmin=None, vmax=None,
         cmap="jet", title=None, colorbar=True, categories=None, zoom=None, mark=None):
    """One panel: `field` on the faces of `selection` (field None: the grid's edges only). Returns
    the range drawn (min, max of the values at the vertices of the faces drawn). categories:
    {value: (label, colour)} for integer fields (faces coloured by the largest value of their
    vertices); zoom: (x0, x1, y0, y1) of the picture plane, only the faces meeting it are drawn;
    mark: a node_class value whose vertices are drawn as dots (2: the semi-contact vertices, the
    edges of the contact zone)."""
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import BoundaryNorm, ListedColormap, LogNorm, Normalize
    from matplotlib.tri import Triangulation
    plt = _pyplot()
    faces, xy, labels = select_faces(vtu, selection)
    if zoom:
        corners = np.where(faces[:, :, None] >= 0, xy[np.maximum(faces, 0)], np.nan)
        fmin, fmax = np.nanmin(corners, axis=1), np.nanmax(corners, axis=1)
        meets = (fmax[:, 0] >= zoom[0]) & (fmin[:, 0] <= zoom[1]) & (fmax[:, 1] >= zoom[2]) & (fmin[:, 1] <= zoom[3])
        faces = faces[meets]
        if faces.shape[0] == 0:
            raise ValueError(f"selection '{selection}': no faces in the zoom window {zoom}")
    values = field_values(vtu, field) if field else None
    used = np.unique(faces[faces >= 0])
    polys = [xy[f[f >= 0]] for f in faces]
    vrange = None
    if values is not None:
        vals = values[used]
        vrange = (float(vals.min()), float(vals.max()))
        tri = Triangulation(xy[:, 0], xy[:, 1], triangles(faces))
        # points outside the selection are not referenced by any triangle
        if categories:
            keys = sorted(categories)
            cm = ListedColormap([categories[k][1] for k in keys])
            norm = BoundaryNorm([k - 0.5 for k in keys] + [keys[-1] + 0.5], len(keys))
            coll = PolyCollection(polys, array=np.array([values[f[f >= 0]].max() for f in faces]),
                                  cmap=cm, norm=norm, edgecolors="none")
            ax.add_collection(coll)
            if colorbar:
                cb = plt.colorbar(coll, ax=ax, ticks=keys, fraction=0.046, pad=0.04)
                cb.ax.set_yticklabels([categories[k][0] for k in keys])
        else:
            cm = plt.get_cmap(cmap).copy()
            if log:
                top = vmax if vmax is not None else max(vrange[1], 1e-300)
                bottom = vmin if vmin is not None else top * 10.0 ** (-decades)
                norm = LogNorm(vmin=bottom, vmax=top)
                cm.set_under("0.85")
                cm.set_bad("0.85")
                # zeros and values below the range: the 'under' colour (exactly zero is not on a
                # log scale; the panel title gives the true minimum)
                shown = np.where(values > 0, np.maximum(values, bottom * 0.5), bottom * 0.5)
            else:
                norm = Normalize(vmin=vrange[0] if vmin is None else vmin,
                                 vmax=vrange[1] if vmax is None else vmax)
                if norm.vmin == norm.vmax:
                    norm = Normalize(vmin=norm.vmin - 1, vmax=norm.vmax + 1)
                shown = values
            # gouraud: the colours of the vertices interpolated linearly on each triangle
            m = ax.tripcolor(tri, shown, shading="gouraud", cmap=cm, norm=norm)
            if colorbar:
                plt.colorbar(m, ax=ax, fraction=0.046, pad=0.04, extend="min" if log else "neither")
    lo, hi = xy[used].min(axis=0), xy[used].max(axis=0)
    if zoom:
        lo, hi = np.array([zoom[0], zoom[2]]), np.array([zoom[1], zoom[3]])
    if edges or values is None:
        # line width by the number of faces in view
        inside = [q for q in polys if np.all(q.max(axis=0) >= lo) and np.all(q.min(axis=0) <= hi)]
        lw = 0.4 if len(inside) < 500 else 0.2 if len(inside) < 3000 else 0.08 if len(inside) < 30000 else 0.04
        ax.add_collection(PolyCollection(inside, facecolors="none", edgecolors="k", linewidths=lw))
    if mark is not None and "node_class" in vtu.point_data:
        at = used[vtu.point_data["node_class"][used] == mark]
        at = at[np.all((xy[at] >= lo) & (xy[at] <= hi), axis=1)]
        ax.plot(xy[at, 0], xy[at, 1], "o", color="#d83b3b", markersize=3, zorder=5)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    if title:
        ax.set_title(title, fontsize=9)
    return vrange


def fmt(x):
    return "0" if x == 0 else f"{x:.2g}"


def by_class(vtu, field, selection, classes="node_class", previous=None):
    """Per class of the vertices of `selection` (classes: the point array node_class of adaptive
    runs, 0 off Gamma_C / 1 no contact / 2 semi / 3 full, or contact_state of dynamic runs, 1 potential
    / 2 actual contact): (class, vertices, vertices with a non-zero value, min, max). With the .vtu of
    the previous time step (`previous`, same grid) the actual contact nodes are split into 2 (in
    contact at both steps) and 4 (new: not in contact at the previous step)."""
    if classes not in vtu.point_data:
        return []
    faces, _, _ = select_faces(vtu, selection)
    used = np.unique(faces[faces >= 0])
    values, cls = field_values(vtu, field)[used], vtu.point_data[classes][used].copy()
    if previous is not None:
        cls[(cls == 2) & (previous.point_data[classes][used] != 2)] = 4
    out = []
    for c in np.unique(cls):
        v = values[cls == c]
        out.append((int(c), int(v.size), int(np.count_nonzero(v)), float(v.min()), float(v.max())))
    return out


# ------------------------------------------------------------------------------------------------
# the thesis figures (scripts/surface_figures.sh runs the scenes into RUNS first)

# node_class of the adaptive .vtu on the contact boundary (0, not on it, does not occur there)
NODE_CLASSES = {1: ("no contact", "#3b6fd8"), 2: ("semi", "#f2f2f2"), 3: ("full", "#d83b3b")}


def _step(runs, run, k):
    return os.path.join(runs, run, f"step_{k:03d}.vtu")


def _last_step(runs, run):
    """The .vtu of the last step of an adaptive run written with adaptivity.vtk = "last" (or
    "every"): step_NNN.vtu with the largest NNN; a name that does not exist if there is none."""
    d = os.path.join(runs, run)
    steps = sorted(f for f in os.listdir(d) if re.fullmatch(r"step_\d{3}\.vtu", f)) if os.path.isdir(d) else []
    return os.path.join(d, steps[-1]) if steps else os.path.join(d, "step_last.vtu")


def _k(path):
    """The step number k of a step_NNN.vtu path (for the panel titles)."""
    m = re.search(r"step_(\d{3})\.vtu$", path)
    return int(m.group(1)) if m else -1


def _eta(k):
    return rf"$\eta_{{{k},p}}^2$"


def _estimator_panels(runs, run, k, contributions, selection, where, **extra):
    return [dict(file=_step(runs, run, k), field=f"eta_{c}^2", selection=selection, log=True,
                 title=f"{_eta(c)}, k = {k}, {where}", **extra) for c in contributions]


def _dyn_file(runs, run, n):
    summary = os.path.join(runs, run, "summary.json")
    if not os.path.exists(summary):
        return os.path.join(runs, run, f"missing_{n:06d}.vtu")
    with open(summary) as f:
        name = os.path.splitext(os.path.basename(json.load(f)["scene"]))[0]
    return os.path.join(runs, run, f"{name}_{n:06d}.vtu")


def thesis_figures(runs, dyn_steps):
    """The figures of docs/examples.md and docs/dynamics.md: name -> dict(cols, panels)."""
    z0, cut = "plane:z=0", "plane:y=0.5"
    ex4, ex5, ex6, ex7 = "example4_prism", "example5_pyramid", "example6_hexahedron", "example7_pyramid"
    figs = {}
    # Fig. 4.23: k = 2, 4, 6 (as the thesis) and a zoom at k = 6
    figs["fig4_23_example4_eta5"] = dict(cols=2, panels=[
        _estimator_panels(runs, ex4, k, (5,), z0, "contact boundary z = 0", edges=True)[0] for k in (2, 4, 6)] + [
        _estimator_panels(runs, ex4, 6, (5,), z0, "zoom at the strip edge x = 0.2", edges=True,
                          zoom=(0.15, 0.25, 0.45, 0.55))[0]])
    figs["fig4_24_example4_cut"] = dict(cols=3, panels=_estimator_panels(
        runs, ex4, 4, (1, 2, 5), cut, "cut y = 0.5", edges=True))
    figs["fig4_29_example5_pyramid"] = dict(cols=3, panels=(
        _estimator_panels(runs, ex5, 6, (1, 2, 5), z0, "contact boundary z = 0") +
        _estimator_panels(runs, ex5, 6, (1, 2), cut, "cut y = 0.5") +
        _estimator_panels(runs, ex5, 6, (5,), z0, "z = 0, zoom", edges=True, zoom=(0.35, 0.65, 0.35, 0.65))))
    grid6 = dict(file=_step(runs, ex6, 4), field="node_class", selection=z0, edges=True,
                 categories=NODE_CLASSES, title="grid and contact nodes, k = 4, z = 0")
    figs["fig4_32_example6_contact"] = dict(cols=2, panels=[grid6] + _estimator_panels(
        runs, ex6, 4, (5, 6, 8), z0, "z = 0"))
    grid7 = dict(grid6, file=_step(runs, ex7, 4))
    figs["fig4_35_example7_contact"] = dict(cols=3, panels=[grid7] + _estimator_panels(
        runs, ex7, 4, (5, 6, 7, 8), z0, "z = 0"))
    # Fig. 4.36: Example 8 (sine wave), the grid at the start and after three refinements, and
    # eta_{8,p}^2 before the crests are found (k = 0, 1)
    ex8 = "example8_hexahedron"
    grid8 = [dict(grid6, file=_step(runs, ex8, k), title=f"grid and contact nodes, k = {k}, z = 0") for k in (0, 3)]
    figs["fig4_36_example8_eta8"] = dict(cols=2, panels=grid8 + [
        _estimator_panels(runs, ex8, k, (8,), z0, "z = 0", edges=True)[0] for k in (0, 1)])
    # Fig. 4.37: Example 9 (smiley), the grid of the contact boundary at k = 2, 4, 6; left the
    # starting grid of pyramids, right of hexahedra
    figs["fig4_37_example9_grids"] = dict(cols=2, panels=[
        dict(grid6, file=_step(runs, f"example9_{grid}", k), title=f"starting grid of {plural}, k = {k}, z = 0")
        for k in (2, 4, 6) for grid, plural in (("pyramid", "pyramids"), ("hexahedron", "hexahedra"))])
    # Figs. 4.27, 4.28, 4.30, 4.33: the last step of the runs above (Example 5 on hexahedra: its own
    # run); -u_nu = u_z for the constraint direction nu = -e_3 of these scenes; the thesis' diagonal
    # cut is the grid plane y = 0.5 here (faces are drawn, cells are not cut)
    classes = dict(field="node_class", categories=NODE_CLASSES, edges=True)
    f5 = _step(runs, ex5, 6)
    figs["fig4_27_example5_pyramid"] = dict(cols=3, panels=[
        dict(file=f5, field=None, selection=z0, zoom=(0.2, 0.8, 0.2, 0.8),
             title="grid of the contact boundary z = 0, k = 6, zoom"),
        dict(classes, file=f5, selection=z0, zoom=(0.2, 0.8, 0.2, 0.8), title="contact status, k = 6"),
        dict(file=f5, field="displacement:z", selection=z0, title=r"$-u_\nu = u_z$ on z = 0, k = 6")])
    f5h = _last_step(runs, "example5_hexahedron")
    figs["fig4_28_example5_hexahedron"] = dict(cols=2, panels=[
        dict(file=f5h, field="displacement:z", selection=z0, title=rf"$-u_\nu = u_z$ on z = 0, k = {_k(f5h)}"),
        dict(file=f5h, field="displacement:z", selection=cut, edges=True,
             title=rf"$u_z$ in the cut y = 0.5, k = {_k(f5h)}")])
    f6 = _step(runs, ex6, 4)
    figs["fig4_30_example6_hexahedron"] = dict(cols=3, panels=[
        dict(file=f6, field=None, selection=z0, title="grid of the contact boundary z = 0, k = 4"),
        dict(classes, file=f6, selection=z0, zoom=(0.25, 0.75, 0.25, 0.75),
             title="zoom, with the contact status, k = 4"),
        dict(file=f6, field=None, selection=cut, title="grid in the cut y = 0.5, k = 4")])
    f7 = _step(runs, ex7, 4)
    figs["fig4_33_example7_pyramid"] = dict(cols=3, panels=[
        dict(file=f7, field=None, selection=z0, title="grid of the contact boundary z = 0, k = 4"),
        dict(classes, file=f7, selection=z0, title="contact status, k = 4"),
        dict(file=f7, field="displacement:z", selection=z0, title=r"$-u_\nu = u_z$ on z = 0, k = 4")])
    # Figs. 4.2, 4.3, 4.7-4.9, 4.14, 4.15: the last step of the runs of scripts/grid_figures.sh
    # (2D: the whole square is the plane z = 0; the dots are the semi-contact vertices, the edges of
    # the contact zone)
    def grid2d(run, zoom, what):
        f = _last_step(runs, run)
        return dict(file=f, field=None, selection=z0, zoom=zoom, mark=2, title=f"{what}, k = {_k(f)}")

    def solution(run, field, what, selection=z0):
        f = _last_step(runs, run)
        return dict(file=f, field=field, selection=selection, title=f"{what}, k = {_k(f)}")
    def window(x, width):  # a window of the given width and half its height on the boundary y = 0 at x
        return (x - width / 2, x + width / 2, 0.0, width / 2)
    edge, tip = 0.5625, 0.5  # the punch's right edge; the wedge's apex (contact radius about 0.0136)
    wide = dict(cols=2, panel_size=(6.0, 3.6), dpi=150)
    figs["fig4_2_example1a_grid"] = dict(wide, panels=[
        grid2d("example1a_cr", (0.0, 1.0, 0.0, 0.5), "final grid, lower half"),
        grid2d("example1a_cr", window(0.5, 0.2), "zoom: the contact area"),
        grid2d("example1a_cr", window(edge, 0.02), "zoom: the right edge of the punch"),
        grid2d("example1a_cr", window(edge, 0.002), "zoom: the right edge, 10 x closer")])
    figs["fig4_3_example1b_grid"] = dict(wide, panels=[
        grid2d("example1b_cr", window(0.5, 0.2), "zoom: the contact area"),
        grid2d("example1b_cr", window(edge, 0.02), "zoom: the right edge of the punch"),
        grid2d("example1b_cr", window(edge, 0.002), "zoom: the right edge, 10 x closer"),
        solution("example1b_cr", "displacement:y", "$u_2$")])
    figs["fig4_7_4_8_example2a_grid"] = dict(wide, panels=[
        grid2d("example2a_cr", window(tip, 0.2), "zoom of the final grid"),
        grid2d("example2a_cr", window(tip, 0.04), "zoom: the contact area"),
        grid2d("example2a_cr", window(tip, 0.004), "zoom: the apex"),
        grid2d("example2a_cr", window(tip + 0.0136, 0.004), "zoom: the right side of the contact area")])
    figs["fig4_9_example2b_grid"] = dict(wide, panels=[
        grid2d("example2b_cr", window(tip, 0.04), "zoom: the contact area"),
        solution("example2b_cr", "displacement:y", "$u_2$")])
    hz = None  # the whole bottom (the contact zone's radius is about 0.06)
    edge3 = (0.54, 0.6, 0.47, 0.53)  # around the free boundary's point (0.56, 0.5)
    for key, ex, cut_too in (("fig4_14_example3a_grids", "example3a", False), ("fig4_15_example3b_grids", "example3b", True)):
        panels = [solution(f"{ex}_cr", "displacement:z", "$u_3$ in the cut y = 0.5, contact-residual", cut)] if cut_too else []
        for zoom, where in ((hz, "z = 0"), (edge3, "z = 0, free boundary")):
            for tag, est in (("cr", "contact-residual"), ("res", "residual")):
                f = _last_step(runs, f"{ex}_{tag}")
                panels.append(dict(classes, file=f, selection=z0, zoom=zoom,
                                   title=f"{where}, {est}, k = {_k(f)}"))
            if cut_too and zoom is hz:
                panels.append(dict(panels[1], field=None, edges=True, selection=cut,
                                   title=f"grid in the cut y = 0.5, contact-residual, k = {_k(panels[1]['file'])}"))
        figs[key] = dict(cols=3 if cut_too else 2, panels=panels, dpi=150)
    # Fig. 5.6: the contact stress of Geometry A at n = 37 for every scheme (scripts/dynamics_figures.sh),
    # each panel on its own scale (the panel titles give the ranges)
    schemes = ("classical", "contact-implicit", "contact-stabilized", "improved-contact-stabilized", "alpha-half",
               "alpha-one-zero", "laursen-chawla", "khenous-laborde-renard", "hager-huebner-wohlmuth",
               "hager-huebner-wohlmuth-nonpenetration")
    ball = (-0.45, 0.45, -0.45, 0.45)
    figs["fig5_6_geometry_a_stress"] = dict(cols=5, panel_size=(3.6, 3.2), panels=[
        dict(file=_dyn_file(runs, f"ball_{sc}", 37), field="contact_pressure", selection="facing:-z", zoom=ball,
             title=f"{sc}, n = 37") for sc in schemes])
    # Fig. 5.16: the normal velocity on the bottom of Geometry 1 during detachment, alpha(p) against
    # alpha = 0, one symmetric colour scale for all panels
    detach = dyn_steps.get("detach")
    if detach:
        steps, tau = detach
        figs["fig5_16_detachment"] = dict(cols=len(steps), shared_rows=True, panels=[
            dict(file=_dyn_file(runs, f"g1_detach_{sc}", n), field="normal_velocity", selection="facing:-z",
                 dyn="normal_velocity", previous=_dyn_file(runs, f"g1_detach_{sc}", n - 1),
                 title=rf"{label}: $\nu_p \cdot v_p$, n = {n}, t = {n * tau:.3g}")
            for sc, label in (("improved-contact-stabilized", r"$\alpha(p)$"), ("contact-stabilized", r"$\alpha = 0$"))
            for n in steps])
    for key, run in (("fig5_15_geometry1", "dynamics_geometry1"), ("fig5_17_tibia", "dynamics_tibia")):
        if run not in dyn_steps:
            continue
        steps, tau = dyn_steps[run]
        panels = []
        for n in steps:
            f, prev = _dyn_file(runs, run, n), _dyn_file(runs, run, n - 1)
            t = f"n = {n}, t = {n * tau:.3g}"
            for field, title in (("contact_pressure", "contact stress $s_p$"),
                                 ("normal_displacement", r"normal displacement $\nu_p \cdot u_p$"),
                                 ("normal_velocity", r"normal velocity $\nu_p \cdot v_p$")):
                panels.append(dict(file=f, field=field, selection="facing:-z", dyn=field, previous=prev,
                                   title=f"{title}, {t}"))
        figs[key] = dict(cols=3, panels=panels, shared_rows=True)
    return figs


def render_figure(fig, path):
    """Draws the panels of `fig` into one PNG; returns a list of (title, (min, max), (class array,
    by_class))."""
    plt = _pyplot()
    panel_size = fig.get("panel_size", (4.2, 3.6))
    panels = fig["panels"]
    cols = fig["cols"]
    rows = (len(panels) + cols - 1) // cols
    f, axes = plt.subplots(rows, cols, figsize=(panel_size[0] * cols, panel_size[1] * rows), squeeze=False)
    cache = {}

    def load(p):
        if p not in cache:
            cache[p] = read_vtu(p)
        return cache[p]

    # dynamic figures: one colour range per quantity over all time steps (comparable columns)
    shared = {}
    if fig.get("shared_rows"):
        for p in panels:
            v = field_values(load(p["file"]), p["field"])
            faces, _, _ = select_faces(load(p["file"]), p["selection"])
            vals = v[np.unique(faces[faces >= 0])]
            lo, hi = shared.get(p["dyn"], (np.inf, -np.inf))
            shared[p["dyn"]] = (min(lo, vals.min()), max(hi, vals.max()))
    report = []
    for i, p in enumerate(panels):
        ax = axes[i // cols][i % cols]
        kw = {k: p[k] for k in ("log", "edges", "categories", "zoom", "mark", "cmap") if k in p}
        if "dyn" in p:
            lo, hi = shared[p["dyn"]]
            if p["dyn"] == "normal_velocity":  # symmetric about zero: zero velocity is the middle colour
                m = max(abs(lo), abs(hi), 1e-300)
                lo, hi = -m, m
                kw["cmap"] = "coolwarm"
            kw["vmin"], kw["vmax"] = lo, hi
        r = draw(ax, load(p["file"]), p["field"], p["selection"], title=p["title"], **kw)
        classes = ("", [])
        if r and "categories" not in p:
            ax.set_title(p["title"] + f"\n[{fmt(r[0])}, {fmt(r[1])}]", fontsize=8)
            if p.get("log"):
                classes = ("node_class", by_class(load(p["file"]), p["field"], p["selection"]))
            elif "dyn" in p:
                prev = p.get("previous")
                prev = load(prev) if prev and os.path.exists(prev) else None
                classes = ("contact_state",
                           by_class(load(p["file"]), p["field"], p["selection"], "contact_state", prev))
        report.append((p["title"], r, classes))
    for j in range(len(panels), rows * cols):
        axes[j // cols][j % cols].axis("off")
    f.tight_layout()
    f.savefig(path, dpi=fig.get("dpi", 90))
    plt.close(f)
    return report


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("info", help="arrays, sizes and ranges of a .vtu")
    a.add_argument("file")
    a.add_argument("--select", help="also count the faces of a selection")
    a.add_argument("--json", action="store_true")
    a = sub.add_parser("plot", help="one field on one face selection")
    a.add_argument("file")
    a.add_argument("--field", required=True)
    a.add_argument("--select", default="plane:z=0")
    a.add_argument("--log", action="store_true")
    a.add_argument("--decades", type=float, default=6.0)
    a.add_argument("--edges", action="store_true")
    a.add_argument("--title")
    a.add_argument("-o", "--output", required=True)
    a = sub.add_parser("symmetry", help="how symmetric a grid is about a plane x_AXIS = VALUE")
    a.add_argument("file")
    a.add_argument("--plane", default="x=0.5", help="AXIS=VALUE (default x=0.5)")
    a = sub.add_parser("figures", help="the thesis figures from the runs of scripts/surface_figures.sh")
    a.add_argument("--runs", required=True)
    a.add_argument("--output", required=True)
    a.add_argument("--only", help="comma-separated figure names")
    a.add_argument("--dyn", action="append", default=[],
                   help="RUN:TAU:N1,N2,... time steps of a dynamic run to show (repeatable)")
    args = ap.parse_args(argv)

    if args.cmd == "info":
        v = read_vtu(args.file)
        out = {"points": v.num_points, "cells": v.num_cells,
               "cell_types": {int(t): int(c) for t, c in zip(*np.unique(v.types, return_counts=True))},
               "point_data": {k: [float(np.min(a)), float(np.max(a)), 1 if a.ndim == 1 else a.shape[1]]
                              for k, a in v.point_data.items()},
               "cell_data": {k: [float(np.min(a)), float(np.max(a)), 1 if a.ndim == 1 else a.shape[1]]
                             for k, a in v.cell_data.items()}}
        if args.select:
            faces, xy, _ = select_faces(v, args.select)
            area = 0.0
            for f in faces:
                q = xy[f[f >= 0]]
                area += 0.5 * abs(np.dot(q[:, 0], np.roll(q[:, 1], -1)) - np.dot(q[:, 1], np.roll(q[:, 0], -1)))
            out["selection"] = {"faces": int(faces.shape[0]), "vertices": int(np.unique(faces[faces >= 0]).size),
                                "projected_area": area}
        if args.json:
            print(json.dumps(out, indent=1))
        else:
            print(f"{args.file}: {out['points']} points, {out['cells']} cells, VTK types {out['cell_types']}")
            for kind in ("point_data", "cell_data"):
                for k, (lo, hi, c) in out[kind].items():
                    print(f"  {kind[:-5]:5s} {k:24s} {c} component(s)  [{lo:.6g}, {hi:.6g}]")
            if "selection" in out:
                print(f"  selection {args.select}: {out['selection']}")
        return 0
    if args.cmd == "symmetry":
        # vertices on each side of the plane, and the fraction whose mirror image is a vertex too
        # (coordinates compared after rounding to 2^-24, far below the finest cell of any run here)
        axis, value = args.plane.split("=")
        a, value = "xyz".index(axis), float(value)
        v = read_vtu(args.file)
        mirrored = v.points.copy()
        mirrored[:, a] = 2 * value - mirrored[:, a]
        key = lambda q: set(map(tuple, np.round(q * 2.0 ** 24).astype(np.int64)))
        own = key(v.points)
        share = len(own & key(mirrored)) / len(own)
        below, above = int((v.points[:, a] < value).sum()), int((v.points[:, a] > value).sum())
        print(f"{args.file}: {v.num_points} vertices, {below} with {axis} < {value:g}, {above} with {axis} > "
              f"{value:g}; {100 * share:.1f} % have their mirror image as a vertex")
        return 0
    if args.cmd == "plot":
        plt = _pyplot()
        f, ax = plt.subplots(figsize=(5.5, 4.6))
        r = draw(ax, read_vtu(args.file), args.field, args.select, log=args.log, decades=args.decades,
                 edges=args.edges, title=args.title or f"{args.field} on {args.select}")
        f.tight_layout()
        f.savefig(args.output, dpi=110)
        print(f"{args.output}: {args.field} in [{fmt(r[0])}, {fmt(r[1])}]")
        return 0
    dyn = {}
    for d in args.dyn:
        run, tau, steps = d.split(":")
        dyn[run] = ([int(s) for s in steps.split(",")], float(tau))
    figs = thesis_figures(args.runs, dyn)
    only = set(args.only.split(",")) if args.only else None
    os.makedirs(args.output, exist_ok=True)
    unknown = (only or set()) - set(figs)
    if unknown:
        sys.stderr.write(f"render_surface.py: no figure named {', '.join(sorted(unknown))}\n")
        return 2
    for name, fig in figs.items():
        if only and name not in only:
            continue
        missing = sorted({p["file"] for p in fig["panels"] if not os.path.exists(p["file"])})
        if missing:
            if only:
                sys.stderr.write(f"render_surface.py: {name}: missing {', '.join(missing)}\n")
                return 1
            print(f"{name}: skipped (no run: {missing[0]})")
            continue
        path = os.path.join(args.output, name + ".png")
        report = render_figure(fig, path)
        print(path)
        for title, r, classes in report:
            if r:
                print(f"  {title.replace('$', '')}: [{fmt(r[0])}, {fmt(r[1])}]")
            names = {"node_class": {0: "off Gamma_C", 1: "no contact", 2: "semi", 3: "full"},
                     "contact_state": {0: "off Gamma_C", 1: "potential", 2: "actual", 4: "actual, new"}
                     }.get(classes[0], {})
            for c, n, nz, lo, hi in classes[1]:
                print(f"      {names.get(c, str(c)):11s} vertices {n:6d}, non-zero {nz:6d}, in [{fmt(lo)}, {fmt(hi)}]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
