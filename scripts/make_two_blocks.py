#!/usr/bin/env python3
"""Writes data/meshes/two_blocks.msh (Gmsh format 4.1) and data/meshes/two_blocks_v22.msh (2.2):
two bodies in one file, told apart by their physical volumes, as the scene
data/scenes/twobody_gmsh.toml reads them ([body.mesh] physical = "lower" / "upper").

The bodies are the two blocks of data/scenes/twobody_patch.toml, built exactly as obs's box
generator builds them (libmesh/src/BoxMesh.cpp: vertex numbering, the six Kuhn tetrahedra per
block, the cell orientation, the outward vertex order of the boundary faces), so that a body read
from this file is the generator's mesh and the two scenes give the same results:
  - physical volume 1 "lower": [0, 1]^3, 3 x 3 x 3 blocks of 6 tetrahedra (162 cells, 64 nodes);
  - physical volume 2 "upper": [0, 1]^2 x [1, 2], 5 x 5 x 2 hexahedra (50 cells, 108 nodes).
The interface z = 1 does not match (triangles of a 3 x 3 grid below, quadrilaterals of a 5 x 5 grid
above); each body has its own nodes there, as Gmsh writes two volumes that share no surface.
Boundary faces: physical surfaces 1 left (x = min), 2 right (x = max), 3 bottom (z = min), 4 top
(z = max), 5 front (y = min), 6 back (y = max) of each block, one surface entity per block side;
each physical surface holds the side of both blocks (so the lower block's top and the upper
block's bottom, the contact interface, are "top" and "bottom" of their bodies).

    python3 scripts/make_two_blocks.py [output directory]
"""
import itertools
import os
import sys

SIDES = ["left", "right", "bottom", "top", "front", "back"]
# local faces in outward orientation (libmesh/src/MeshTopology.cpp)
TET_FACES = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]
HEX_FACES = [(0, 3, 2, 1), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (0, 4, 7, 3), (4, 5, 6, 7)]


def box(kind, n, lower, upper):
    """The vertices, cells and boundary faces (vertices, side id) of obs's boxMesh."""
    def coord(d, i):  # exact at both ends, as BoxMesh.cpp
        return (lower[d] * (n[d] - i) + upper[d] * i) / n[d]

    vertices = [(coord(0, i), coord(1, j), coord(2, k))
                for k in range(n[2] + 1) for j in range(n[1] + 1) for i in range(n[0] + 1)]

    def vid(i, j, k):
        return i + (n[0] + 1) * (j + (n[1] + 1) * k)

    def det(a, b, c):
        return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))

    def sub(p, q):
        return tuple(x - y for x, y in zip(p, q))

    cells = []
    for k in range(n[2]):
        for j in range(n[1]):
            for i in range(n[0]):
                if kind == "tet":
                    for axes in itertools.permutations(range(3)):  # lexicographic, as next_permutation
                        p = [0, 0, 0]
                        v = [vid(i, j, k)]
                        for a in axes:
                            p[a] = 1
                            v.append(vid(i + p[0], j + p[1], k + p[2]))
                        x = [vertices[w] for w in v]
                        if det(sub(x[1], x[0]), sub(x[2], x[0]), sub(x[3], x[0])) <= 0:
                            v[1], v[2] = v[2], v[1]  # BoxBuilder::addCell mirrors
                        cells.append(v)
                else:
                    cells.append([vid(i, j, k), vid(i + 1, j, k), vid(i + 1, j + 1, k), vid(i, j + 1, k),
                                  vid(i, j, k + 1), vid(i + 1, j, k + 1), vid(i + 1, j + 1, k + 1),
                                  vid(i, j + 1, k + 1)])
    # one-cell faces in the order of obs's FaceTable (sorted vertex keys)
    local = TET_FACES if kind == "tet" else HEX_FACES
    count, first = {}, {}
    for c in cells:
        for lf in local:
            f = [c[a] for a in lf]
            key = tuple(sorted(f))
            count[key] = count.get(key, 0) + 1
            first.setdefault(key, f)
    tol = 1e-10 * max(u - l for u, l in zip(upper, lower))
    faces = []
    for key in sorted(k for k, m in count.items() if m == 1):
        f = first[key]
        centre = [sum(vertices[v][d] for v in f) / len(f) for d in range(3)]
        for side, (d, value) in enumerate([(0, lower[0]), (0, upper[0]), (2, lower[2]), (2, upper[2]),
                                           (1, lower[1]), (1, upper[1])]):
            if abs(centre[d] - value) <= tol:
                faces.append((f, side + 1))
                break
        else:
            raise RuntimeError("a boundary face off the box sides")
    return vertices, cells, faces


BODIES = [  # name, cell kind, blocks, lower, upper (data/scenes/twobody_patch.toml)
    ("lower", "tet", (3, 3, 3), (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)),
    ("upper", "hex", (5, 5, 2), (0.0, 0.0, 1.0), (1.0, 1.0, 2.0)),
]


def build():
    """Nodes (tag -> x), and per body its volume and surface entities with their elements."""
    nodes = []
    bodies = []
    for b, (name, kind, n, lo, up) in enumerate(BODIES):
        vertices, cells, faces = box(kind, n, lo, up)
        offset = len(nodes) + 1  # node tag of vertex 0
        nodes += vertices
        tags = list(range(offset, offset + len(vertices)))
        sides = [[[offset + v for v in f] for f, side in faces if side == s + 1] for s in range(6)]
        bodies.append({"name": name, "volume": b + 1, "kind": kind, "nodes": tags,
                       "cells": [[offset + v for v in c] for c in cells], "sides": sides})
    return nodes, bodies


def bbox(nodes, tags):
    xs = [nodes[t - 1] for t in tags]
    return [min(x[d] for x in xs) for d in range(3)] + [max(x[d] for x in xs) for d in range(3)]


def num(x):
    return repr(float(x))  # shortest round-trip form


def write41(path, nodes, bodies):
    out = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat", "$PhysicalNames", str(6 + len(bodies))]
    out += ['2 %d "%s"' % (s + 1, SIDES[s]) for s in range(6)]
    out += ['3 %d "%s"' % (b["volume"], b["name"]) for b in bodies]
    out += ["$EndPhysicalNames", "$Entities", "0 0 %d %d" % (6 * len(bodies), len(bodies))]
    for b in bodies:  # surface entity 6 * (volume - 1) + side, in physical surface side
        for s in range(6):
            tags = sorted({t for f in b["sides"][s] for t in f})
            out.append("%d %s 1 %d 0" % (6 * (b["volume"] - 1) + s + 1,
                                         " ".join(num(x) for x in bbox(nodes, tags)), s + 1))
    for b in bodies:
        surfaces = " ".join(str(6 * (b["volume"] - 1) + s + 1) for s in range(6))
        out.append("%d %s 1 %d 6 %s" % (b["volume"], " ".join(num(x) for x in bbox(nodes, b["nodes"])),
                                         b["volume"], surfaces))
    out += ["$EndEntities", "$Nodes", "%d %d 1 %d" % (len(bodies), len(nodes), len(nodes))]
    for b in bodies:  # all nodes of a body in its volume entity
        out.append("3 %d 0 %d" % (b["volume"], len(b["nodes"])))
        out += [str(t) for t in b["nodes"]]
        out += [" ".join(num(x) for x in nodes[t - 1]) for t in b["nodes"]]
    out.append("$EndNodes")
    blocks = []  # (entity dim, entity tag, element type, elements)
    for b in bodies:
        for s in range(6):
            blocks.append((2, 6 * (b["volume"] - 1) + s + 1, 2 if b["kind"] == "tet" else 3, b["sides"][s]))
    for b in bodies:
        blocks.append((3, b["volume"], 4 if b["kind"] == "tet" else 5, b["cells"]))
    total = sum(len(e) for *_, e in blocks)
    out += ["$Elements", "%d %d 1 %d" % (len(blocks), total, total)]
    tag = 0
    for dim, entity, etype, elements in blocks:
        out.append("%d %d %d %d" % (dim, entity, etype, len(elements)))
        for e in elements:
            tag += 1
            out.append(" ".join(str(x) for x in [tag] + e))
    out.append("$EndElements")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def write22(path, nodes, bodies):
    out = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$PhysicalNames", str(6 + len(bodies))]
    out += ['2 %d "%s"' % (s + 1, SIDES[s]) for s in range(6)]
    out += ['3 %d "%s"' % (b["volume"], b["name"]) for b in bodies]
    out += ["$EndPhysicalNames", "$Nodes", str(len(nodes))]
    out += ["%d %s" % (t + 1, " ".join(num(v) for v in x)) for t, x in enumerate(nodes)]
    out.append("$EndNodes")
    elements = []  # same order as the 4.1 file: "type physical elementary nodes"
    for b in bodies:
        for s in range(6):
            for f in b["sides"][s]:
                elements.append([2 if b["kind"] == "tet" else 3, s + 1, 6 * (b["volume"] - 1) + s + 1] + f)
    for b in bodies:
        for c in b["cells"]:
            elements.append([4 if b["kind"] == "tet" else 5, b["volume"], b["volume"]] + c)
    out += ["$Elements", str(len(elements))]
    for tag, e in enumerate(elements, 1):
        out.append(" ".join(str(x) for x in [tag, e[0], 2] + e[1:]))
    out.append("$EndElements")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    directory = sys.argv[1] if len(sys.argv) > 1 else "data/meshes"
    nodes, bodies = build()
    write41(os.path.join(directory, "two_blocks.msh"), nodes, bodies)
    write22(os.path.join(directory, "two_blocks_v22.msh"), nodes, bodies)
    for b in bodies:
        print("%s: %d nodes, %d cells, %d boundary faces" % (
            b["name"], len(b["nodes"]), len(b["cells"]), sum(len(s) for s in b["sides"])))


if __name__ == "__main__":
    main()
