#!/usr/bin/env python3
"""Writes data/meshes/tibial_plateau.stl: a synthetic rigid surface shaped like the top of a tibia
(two shallow bowls, the condyles, separated by a raised ridge, the eminence), as a binary STL of
2 * N^2 triangles over [-0.25, 1.25]^2, ordered counterclockwise seen from above (outward normals
point up, towards a body pressed down onto it). The heights are chosen so that the highest point
under the unit square [0, 1]^2 is z = -0.005. Used by data/scenes/surface_obstacle.toml.

    python3 scripts/make_tibial_plateau.py [output.stl] [N]
"""
import math
import struct
import sys

LO, HI = -0.25, 1.25


def raw_height(x, y):
    medial = 0.05 * math.exp(-((x - 0.28) ** 2 + (y - 0.50) ** 2) / 0.040)
    lateral = 0.04 * math.exp(-((x - 0.72) ** 2 + (y - 0.45) ** 2) / 0.035)
    eminence = 0.025 * math.exp(-((x - 0.50) ** 2) / 0.003 - ((y - 0.50) ** 2) / 0.05)
    return -medial - lateral + eminence


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "data/meshes/tibial_plateau.stl"
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 32
    xs = [LO + (HI - LO) * i / n for i in range(n + 1)]
    # shift: highest grid vertex over the unit square at -0.005
    top = max(raw_height(x, y) for x in xs for y in xs if 0 <= x <= 1 and 0 <= y <= 1)
    z = {(i, j): raw_height(xs[i], xs[j]) - top - 0.005 for i in range(n + 1) for j in range(n + 1)}
    # each grid point once: the corners shared by neighbouring triangles are written bit-identically
    p = {k: (xs[k[0]], xs[k[1]], v) for k, v in z.items()}
    triangles = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = p[(i, j)], p[(i + 1, j)], p[(i + 1, j + 1)], p[(i, j + 1)]
            triangles += [(a, b, c), (a, c, d)]
    with open(out, "wb") as f:
        f.write(b"obs synthetic tibial plateau, scripts/make_tibial_plateau.py".ljust(80, b" "))
        f.write(struct.pack("<I", len(triangles)))
        for t in triangles:
            u = [t[1][k] - t[0][k] for k in range(3)]
            w = [t[2][k] - t[0][k] for k in range(3)]
            nrm = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
            length = math.sqrt(sum(c * c for c in nrm))
            f.write(struct.pack("<3f", *(c / length for c in nrm)))
            for v in t:
                f.write(struct.pack("<3f", *v))
            f.write(b"\0\0")
    print(f"{out}: {len(triangles)} triangles, {(n + 1) ** 2} vertices")


if __name__ == "__main__":
    main()
