#!/usr/bin/env python3
"""Direct manipulation in a loop: drag points of a mesh to targets, print the residuals.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/direct_manipulation.py [OUT.obj]

A B-spline lattice is fitted to the bunny (examples/lattice/bunny.obj); each step moves the tip
of an ear a little further back and up while the lowest vertex stays pinned, and d.solve finds
the smallest change of the control points that puts the bound points on their targets
(Hsu et al. 1992, minimum-norm least squares); the residuals say how far each point stayed from
its target (zero up to rounding when the lattice can reach them all). Writes the
deformed mesh to OUT.obj (bunny_dragged.obj in the current directory by default), keeping
everything in the file but the positions.
"""

import os
import sys

import numpy as np

import ffdkit

HERE = os.path.dirname(os.path.abspath(__file__))
BUNNY = os.path.join(HERE, "..", "lattice", "bunny.obj")

out_path = sys.argv[1] if len(sys.argv) > 1 else "bunny_dragged.obj"
mesh = ffdkit.read_mesh(BUNNY)
rest = np.array(mesh.points)  # a copy: mesh.points is a read-only view into the mesh

rig = ffdkit.Rig.load({"version": 1, "deformer": "lattice", "basis": "bspline",
                       "resolution": [5, 5, 5], "box": "auto"})
d = rig.deformer(mesh)
print(f"{d.method}: {d.point_count} bound points, {d.control_count} control points")

ear = int(np.argmax(rest[:, 1]))   # the highest vertex: an ear tip
base = int(np.argmin(rest[:, 1]))  # the lowest vertex: pinned where it is
ids = np.array([ear, base])
drag = np.array([1.0, 0.5, 0.0])   # back (+x) and up, per step

for step in range(1, 7):
    targets = np.array([rest[ear] + step * drag, rest[base]])
    r = d.solve(ids, targets)
    print(f"step {step}: ear target {np.round(targets[0], 3)}, reached {np.round(r.reached[0], 3)}; "
          f"residuals {np.array2string(r.residuals, precision=2)}, rank {r.rank}")

mesh.points = d.evaluate()
ffdkit.write_mesh(mesh, out_path)
print(f"wrote {out_path}")
