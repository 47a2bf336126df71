#!/usr/bin/env python3
"""A tetrahedral volume mesh morphed with an ffdkit rig through meshio, written as .vtu.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/meshio_volume.py [IN_MESH] [OUT.vtu]

IN_MESH: any volume or surface mesh meshio reads (.vtu, .vtk, .msh, .inp, .med, ...); without
it, a beam of 6 x 2 x 2 hexahedra, each cut into six tetrahedra, is generated. The rig twists
the beam about its long axis and bends it (a B-spline lattice fitted to the mesh's nodes,
"box": "auto"). Cells, point data and cell data are kept; OUT.vtu defaults to
beam_morphed.vtu in the current directory.
"""

import sys

import numpy as np
import meshio

import ffdkit


def beam(nx=13, ny=5, nz=5):
    """A 6 x 1 x 1 beam of tetrahedra with a point field and a cell field."""
    x, y, z = np.meshgrid(np.linspace(0, 6, nx), np.linspace(0, 1, ny), np.linspace(0, 1, nz),
                          indexing="ij")
    points = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)

    def node(i, j, k):
        return (i * ny + j) * nz + k

    tets = []
    for i in range(nx - 1):
        for j in range(ny - 1):
            for k in range(nz - 1):
                c = [node(i + (v >> 2 & 1), j + (v >> 1 & 1), k + (v & 1)) for v in range(8)]
                for a, b in ((4, 6), (4, 5), (2, 6), (2, 3), (1, 5), (1, 3)):
                    tets.append([c[0], c[a], c[b], c[7]])
    tets = np.array(tets)
    return meshio.Mesh(points, [("tetra", tets)],
                       point_data={"distance": points[:, 0].copy()},
                       cell_data={"part": [(points[tets[:, 0], 0] > 3).astype(np.int32)]})


# Twist: the control points of the far end turn by 60 degrees about the beam's axis; bend:
# the middle layers rise. With "box": "auto" the lattice is fitted to the nodes; resolution 4
# along x puts control layers at 0, 1/3, 2/3 and 1 of the length.
def twist_rig():
    moves = []
    res = [4, 3, 3]
    for i in range(res[0]):
        angle = np.radians(60.0) * i / (res[0] - 1)
        lift = [0.0, 0.8, 0.8, 0.0][i]
        for j in range(res[1]):
            for k in range(res[2]):
                # rest control point in the unit square of the cross-section (margin 0.05)
                y = -0.05 + 1.1 * j / (res[1] - 1) - 0.5
                z = -0.05 + 1.1 * k / (res[2] - 1) - 0.5
                dy = y * np.cos(angle) - z * np.sin(angle) - y
                dz = y * np.sin(angle) + z * np.cos(angle) - z + lift
                moves.append({"index": [i, j, k], "delta": [0.0, dy, dz]})
    return {"version": 1, "deformer": "lattice", "basis": "bspline", "resolution": res,
            "box": "auto", "margin": 0.05, "moves": moves}


mesh = meshio.read(sys.argv[1]) if len(sys.argv) > 1 else beam()
out_path = sys.argv[2] if len(sys.argv) > 2 else "beam_morphed.vtu"
morphed = ffdkit.deform_meshio(mesh, twist_rig())
meshio.write(out_path, morphed)
moved = np.linalg.norm(morphed.points - mesh.points, axis=1)
print(f"{len(mesh.points)} nodes, {sum(len(c) for c in mesh.cells)} cells "
      f"({', '.join(c.type for c in mesh.cells)}); largest node displacement {moved.max():.3f}; "
      f"wrote {out_path}")
