#!/usr/bin/env python3
"""Shape optimisation with exact sensitivities: gradient descent on lattice control points.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/shape_optimisation.py [STEPS]

The target shape X* is the bunny (examples/lattice/bunny.obj) bent by examples/lattice/bend.json.
We start from the same 5x5x5 B-spline lattice at rest and move its control points P to minimise

    J(P) = 1/2 |X(P) - X*|^2,   with the gradient   dJ/dP = (dX/dP)^T (X - X*) = W^T (X - X*)

given by the adjoint product d.sensitivity_transpose_product (no finite differences, W never
formed). Since X is linear in P (X = X0 + W (P - P0)), J is a quadratic whose curvature is at most
L = the largest eigenvalue of W^T W: a step of 1/L never increases J. L comes from a few power
iterations that use both products (W v, then W^T (W v)). Prints J at every step: it falls.
docs/sensitivities.md explains W, the products and their cost.
"""

import os
import sys

import numpy as np

import ffdkit

HERE = os.path.dirname(os.path.abspath(__file__))
LATTICE = os.path.join(HERE, "..", "lattice")

steps = int(sys.argv[1]) if len(sys.argv) > 1 else 12
mesh = ffdkit.read_mesh(os.path.join(LATTICE, "bunny.obj"))
target = ffdkit.Rig.load(os.path.join(LATTICE, "bend.json")).deformer(mesh).evaluate()  # X*

d = ffdkit.Rig.load({"version": 1, "deformer": "lattice", "basis": "bspline",
                     "resolution": [5, 5, 5], "box": "auto", "margin": 0.05}).deformer(mesh)
print(f"{d.method}: {d.point_count} points, {d.control_count} control points")

# L = max eigenvalue of W^T W, by power iteration with the two products
v = np.random.default_rng(1).standard_normal((d.control_count, 3))
for _ in range(30):
    v = d.sensitivity_transpose_product(d.sensitivity_product(v))
    L = np.linalg.norm(v)
    v /= L
step = 1.0 / L

for k in range(steps + 1):
    r = d.evaluate() - target                   # dJ/dX = X - X*
    J = 0.5 * float(np.sum(r * r))
    g = d.sensitivity_transpose_product(r)      # dJ/dP = W^T (X - X*)
    print(f"step {k:2d}: J = {J:.6e}  |dJ/dP| = {np.linalg.norm(g):.3e}")
    if k < steps:
        d.controls = d.controls - step * g
