#!/usr/bin/env python3
"""Writes the upper bodies of two readings of the thesis' Geometry B (docs/dynamics.md), Gmsh
format 2.2, one hexahedron each (the scenes refine it four times: 16^3 cells, as the thesis' "four
times uniformly refined"):

data/meshes/cube_on_corner.msh (data/scenes/dynamics_two_body_corner.toml): the unit cube [0, 1]^3
rotated so that its space diagonal points up (+z), with the corner (0, 0, 0) staying at the origin.
That corner is the cube's lowest point ("south pole"); the three faces that meet there rise from it
at slope sqrt(2) (their edges at slope 1/sqrt(2)), so a body below with its top face in the plane
z = 0 touches this cube at exactly one point. The rotation maps d = (1, 1, 1)/sqrt(3) to e_z: axis
(1, -1, 0)/sqrt(2) (d x e_z, normalised), angle arccos(1/sqrt(3)) (Rodrigues' formula).
Physical surfaces: 1 "corner", the three faces through the lowest corner (x = 0, y = 0, z = 0 of
the unrotated cube); 2 "free", the other three.

data/meshes/cube_on_edge.msh (data/scenes/dynamics_two_body_edge.toml): the cube
[-1/2, 1/2] x [0, 1]^2 rotated by 45 degrees about the x axis, so that its edge y = z = 0 is the
lowest line (on the x axis, z = 0) and the two faces through it rise at slope 1; it spans
y in [-1/sqrt(2), 1/sqrt(2)]. A flat body below touches it along one segment of length 1.
Physical surfaces: 1 "edge", the two faces through the lowest edge (y = 0 and z = 0 of the
unrotated cube); 2 "free", the other four.

The cell is physical volume 1 "cube". Coordinates are written with 17 significant digits; the
touching corner or edge lies exactly in z = 0.

    python3 scripts/make_geometry_b.py [output directory]     (default: data/meshes)
"""
import math
import os
import sys


def rotation():
    """Rotation matrix taking (1, 1, 1)/sqrt(3) to (0, 0, 1)."""
    k = (1 / math.sqrt(2), -1 / math.sqrt(2), 0.0)
    c = 1 / math.sqrt(3)          # cos of the angle between d and e_z
    s = math.sqrt(2.0 / 3.0)      # its sine
    kx, ky, kz = k
    K = [[0, -kz, ky], [kz, 0, -kx], [-ky, kx, 0]]
    KK = [[sum(K[i][m] * K[m][j] for m in range(3)) for j in range(3)] for i in range(3)]
    return [[(1.0 if i == j else 0.0) + s * K[i][j] + (1 - c) * KK[i][j] for j in range(3)]
            for i in range(3)]


# Gmsh hexahedron order: bottom face 0-3 counter-clockwise seen from above, then the top face.
UNIT = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
# outward vertex order of the faces of the unrotated cube
FACES = {"z0": (0, 3, 2, 1), "y0": (0, 1, 5, 4), "x0": (0, 4, 7, 3),
         "x1": (1, 2, 6, 5), "y1": (2, 3, 7, 6), "z1": (4, 5, 6, 7)}


def write(path, nodes, contact_name, contact_faces):
    free = [f for f in FACES if f not in contact_faces]
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$PhysicalNames", "3",
             f'2 1 "{contact_name}"', '2 2 "free"', '3 1 "cube"', "$EndPhysicalNames", "$Nodes", "8"]
    for i, n in enumerate(nodes):
        lines.append(f"{i + 1} " + " ".join(repr(float(v)) for v in n))
    lines += ["$EndNodes", "$Elements", "7"]
    e = 1
    for tag, faces in ((1, contact_faces), (2, free)):
        for f in faces:
            lines.append(f"{e} 3 2 {tag} {tag} " + " ".join(str(v + 1) for v in FACES[f]))
            e += 1
    lines.append(f"{e} 5 2 1 1 " + " ".join(str(v + 1) for v in range(8)))
    lines += ["$EndElements", ""]
    with open(path, "w") as f:
        f.write("\n".join(lines))
    print("wrote", os.path.normpath(path))


def rotate(R, p):
    q = [sum(R[i][j] * p[j] for j in range(3)) for i in range(3)]
    return [0.0 if abs(v) < 1e-15 else v for v in q]


def main():
    out_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "data", "meshes")
    R = rotation()
    nodes = [rotate(R, p) for p in UNIT]
    d = rotate(R, [1 / math.sqrt(3)] * 3)
    assert abs(d[0]) < 1e-15 and abs(d[1]) < 1e-15 and abs(d[2] - 1) < 1e-15, d
    assert min(n[2] for n in nodes) == 0.0 and nodes[0] == [0.0, 0.0, 0.0]
    write(os.path.join(out_dir, "cube_on_corner.msh"), nodes, "corner", ["z0", "y0", "x0"])

    c = s = math.sqrt(0.5)  # 45 degrees about the x axis: (y, z) -> (c y - s z, s y + c z)
    Rx = [[1, 0, 0], [0, c, -s], [0, s, c]]
    nodes = [rotate(Rx, (x - 0.5, y, z)) for x, y, z in UNIT]
    assert min(n[2] for n in nodes) == 0.0 and all(n[2] == 0.0 for n in nodes[:2])
    write(os.path.join(out_dir, "cube_on_edge.msh"), nodes, "edge", ["z0", "y0"])


if __name__ == "__main__":
    main()
