#!/usr/bin/env python3
"""A PyGeM FFD tutorial script, ported to ffdkit by changing one import line.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/pygem_port.py [OUT_DIR]

Everything below the import is PyGeM code as a PyGeM user writes it (in the style of PyGeM's
tutorial 1, "Free Form Deformation on a sphere"): a point cloud on a sphere, a 3x3x3 lattice on
a rotated box, a few weights, the deformation, the parameters saved as a .prm file. It writes
OUT_DIR/sphere.obj, OUT_DIR/sphere_deformed.obj and OUT_DIR/parameters.prm (OUT_DIR: the current
directory by default).
"""

import os
import sys

import numpy as np

# from pygem import FFD
from ffdkit.pygem import FFD


def mesh_points(num_pts=20000):
    """Points spread evenly over the unit sphere (a Fibonacci spiral)."""
    indices = np.arange(0, num_pts, dtype=float) + 0.5
    phi = np.arccos(1 - 2 * indices / num_pts)
    theta = np.pi * (1 + 5**0.5) * indices
    return np.array([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)]).T


def write_obj(path, points):
    with open(path, "w") as f:
        f.write("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in points.tolist()))


out_dir = sys.argv[1] if len(sys.argv) > 1 else "."
mesh = mesh_points()

ffd = FFD([3, 3, 3])
ffd.box_origin = np.array([-1.1, -1.1, -1.1])
ffd.box_length = np.array([2.2, 2.2, 2.2])
ffd.rot_angle = np.array([0.0, 0.0, 10.0])
ffd.array_mu_x[2, 1, 1] = 0.4   # pull the +x side out
ffd.array_mu_z[1, 1, 2] = 0.3   # and the top up
ffd.array_mu_y[1, 0, 1] = -0.2  # and the -y side out
print(ffd)

new_mesh = ffd(mesh)

write_obj(os.path.join(out_dir, "sphere.obj"), mesh)
write_obj(os.path.join(out_dir, "sphere_deformed.obj"), new_mesh)
ffd.write_parameters(os.path.join(out_dir, "parameters.prm"))
print(f"{len(mesh)} points, largest displacement {np.max(np.linalg.norm(new_mesh - mesh, axis=1)):.3f}")
