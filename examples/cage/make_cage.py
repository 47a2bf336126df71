#!/usr/bin/env python3
"""Writes examples/cage/bunny-cage.obj: a cage around examples/cage/bunny.obj.

An icosphere subdivided once (42 vertices, 80 triangles) about the centre of
the bunny's bounding box, each vertex pushed along its direction d to the
bunny's support distance max_v (v - c) . d, times 1.25: a closed, outward,
star-shaped triangle cage that holds every vertex of the bunny (ffd deform
with "outside": "fixed" reports none outside). Run from the repository root:
    /usr/bin/python3 examples/cage/make_cage.py
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def read_obj_vertices(path):
    with open(path) as f:
        return [tuple(map(float, line.split()[1:4])) for line in f if line.startswith("v ")]


def icosphere():
    t = (1 + math.sqrt(5)) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    mid = {}

    def midpoint(a, b):
        key = (min(a, b), max(a, b))
        if key not in mid:
            p = [(v[a][k] + v[b][k]) / 2 for k in range(3)]
            n = math.sqrt(sum(x * x for x in p))
            v.append(tuple(x / n for x in p))
            mid[key] = len(v) - 1
        return mid[key]

    g = []
    for a, b, c in f:
        ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
        g += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    return v, g


def main():
    pts = read_obj_vertices(os.path.join(HERE, "bunny.obj"))
    lo = [min(p[k] for p in pts) for k in range(3)]
    hi = [max(p[k] for p in pts) for k in range(3)]
    c = [(lo[k] + hi[k]) / 2 for k in range(3)]
    dirs, faces = icosphere()
    out = []
    for d in dirs:
        s = max(sum((p[k] - c[k]) * d[k] for k in range(3)) for p in pts)
        out.append(tuple(c[k] + 1.25 * s * d[k] for k in range(3)))
    with open(os.path.join(HERE, "bunny-cage.obj"), "w") as f:
        f.write("# cage around bunny.obj: examples/cage/make_cage.py (icosphere, 42 vertices)\n")
        for p in out:
            f.write("v %.6f %.6f %.6f\n" % p)
        for a, b, cc in faces:
            f.write("f %d %d %d\n" % (a + 1, b + 1, cc + 1))


if __name__ == "__main__":
    main()
