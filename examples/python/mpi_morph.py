#!/usr/bin/env python3
"""A solver's design loop over MPI: each rank morphs only its own partition.

    mpirun -np 4 env PYTHONPATH=build/python /usr/bin/python3 examples/python/mpi_morph.py [STEPS] [OUT.obj]

(as root: mpirun --allow-run-as-root; more ranks than cores: --oversubscribe.)

A CFD solver's Python driver holds its partition of the mesh: this rank's points and
their global ids (a VTU's GlobalNodeID, Gmsh's node tags). Here the partition is made
from the bunny (examples/lattice/bunny.obj) by cutting its faces into one contiguous
block per rank; the vertices on a cut are held by both ranks, as in a solver's halo.

The design loop is shape_optimisation.py's, distributed: gradient descent on a 5x5x5
B-spline lattice's control points P towards a target shape X* (the bunny bent by
examples/lattice/bend.json), minimising J = 1/2 |X(P) - X*|^2 with

    dJ/dP = W^T (X - X*) = sum over ranks of W_r^T (X_r - X*_r)

  * the deformer is built once, collectively (ffdkit.mpi.Deformer): every rank gets the
    same lattice (the auto box is the whole mesh's) and the same controls;
  * each step, every rank evaluates its own points (no communication), sums its share
    of J with one allreduce and gets dJ/dP from sensitivity_transpose_product, which
    sums the ranks' products (one Allreduce of 3C doubles): the same gradient on every
    rank, so every rank moves the controls alike and the pieces stay one mesh;
  * a shared vertex counts once: its share of J and of dJ/dX is on the lowest rank
    holding it (`owned`).

Prints J at each step (rank 0); with OUT, rank 0 gathers the pieces and writes the
morphed mesh. main(comm, steps, out) is what python/tests/test_mpi.py runs.
"""

import os
import sys

import numpy as np

import ffdkit
import ffdkit.mpi

HERE = os.path.dirname(os.path.abspath(__file__))
LATTICE = os.path.join(HERE, "..", "lattice")


def partition(comm, mesh):
    """This rank's piece: (global ids, points, local faces). A solver has these already."""
    faces = np.asarray(mesh.faces, dtype=np.int64)
    mine = faces[np.array_split(np.arange(len(faces)), comm.Get_size())[comm.Get_rank()]]
    ids = np.unique(mine)
    return ids, np.array(mesh.points)[ids], np.searchsorted(ids, mine)


def main(comm=None, steps=12, out=None):
    from mpi4py import MPI  # Debian: python3-mpi4py

    if comm is None:
        comm = MPI.COMM_WORLD
    rank = comm.Get_rank()
    whole = ffdkit.read_mesh(os.path.join(LATTICE, "bunny.obj"))  # only to make the pieces
    ids, points, faces = partition(comm, whole)

    # the lowest rank holding a vertex owns it (its share of J and of dJ/dX)
    n = comm.allreduce(int(ids.max()) + 1 if len(ids) else 0, op=MPI.MAX)
    holder = np.full(n, comm.Get_size(), dtype=np.int64)
    holder[ids] = rank
    comm.Allreduce(MPI.IN_PLACE, holder, op=MPI.MIN)
    owned = holder[ids] == rank

    # the target shape of this rank's points: the bend rig, applied to the distributed mesh
    target = ffdkit.mpi.deform(comm, points, ffdkit.Rig.load(os.path.join(LATTICE, "bend.json")),
                               global_ids=ids)
    rig = ffdkit.Rig.load({"version": 1, "deformer": "lattice", "basis": "bspline",
                           "resolution": [5, 5, 5], "box": "auto", "margin": 0.05})
    d = ffdkit.mpi.Deformer(comm, points, rig, global_ids=ids)
    if rank == 0:
        print(f"{comm.Get_size()} ranks, {n} vertices, {d.method}: {d.control_count} control points")

    # the step 1/L, L = max eigenvalue of W^T W (power iteration; both products distributed)
    v = np.random.default_rng(1).standard_normal((d.control_count, 3))
    for _ in range(30):
        v = d.sensitivity_transpose_product(d.sensitivity_product(v) * owned[:, None])
        L = np.linalg.norm(v)
        v /= L
    step = 1.0 / L

    history = []
    for k in range(steps):
        r = (d.evaluate() - target) * owned[:, None]   # dJ/dX of the points this rank owns
        J = comm.allreduce(0.5 * float(np.sum(r * r)), op=MPI.SUM)
        g = d.sensitivity_transpose_product(r)       # dJ/dP, summed over the ranks
        history.append(J)
        if rank == 0:
            print(f"step {k:2d}: J = {J:.6e}  |dJ/dP| = {np.linalg.norm(g):.3e}")
        d.controls = d.controls - step * g           # the same move on every rank

    moved = comm.gather((ids, d.evaluate()), root=0)
    if rank == 0 and out is not None:
        P = np.array(whole.points)
        for i, x in moved:
            P[i] = x
        whole.points = P
        ffdkit.write_mesh(whole, str(out))
        print(f"wrote {out}")
    return history


if __name__ == "__main__":
    main(steps=int(sys.argv[1]) if len(sys.argv) > 1 else 12,
         out=sys.argv[2] if len(sys.argv) > 2 else None)
