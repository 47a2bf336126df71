#!/usr/bin/env python3
"""ffdkit's PyGeM drop-in (ffdkit.pygem.FFD) against PyGeM's FFD formula in numpy, on the same points.

    PYTHONPATH=build/python /usr/bin/python3 bench/bench_python.py [--points N] [--rounds R]
        [--n 5] [--pygem PATH]

The reference is PyGeM's FFD.__call__ as PyGeM computes it (pygem/ffd.py, docs/pygem.md): psi
fitted by least squares from the box vertices, the inside mask, the three Bernstein tables
with np.power and binomials, then the triple loop over control points accumulating
b_i b_j b_k mu_ijk on all inside points, and psi^-1. --pygem PATH also times a local PyGeM
checkout (PATH is put first on sys.path; it must import as `pygem`). Rounds are interleaved
(ffdkit, reference, PyGeM, ffdkit, ...) so that load from other processes hits all alike;
the medians and their ratio are printed.
"""

import argparse
import math
import statistics
import sys
import time

import numpy as np

import ffdkit
from ffdkit.pygem import FFD


def rotation(angles_deg):
    ax, ay, az = np.radians(angles_deg)
    rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    rz = np.array([[np.cos(az), -np.sin(az), 0], [np.sin(az), np.cos(az), 0], [0, 0, 1]])
    return rx @ ry @ rz


def pygem_formula(points, length, origin, angles, mu_x, mu_y, mu_z):
    """PyGeM's FFD.__call__, computed the way PyGeM computes it."""
    m = rotation(angles) @ np.diag(length)
    # psi: an affine fit from the four box vertices to the reference frame (lstsq, as PyGeM)
    frame = np.vstack([np.zeros(3), m.T])
    ref = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    fit = np.linalg.lstsq(np.hstack([frame, np.ones((4, 1))]), ref, rcond=None)[0]
    y = np.hstack([points - origin, np.ones((len(points), 1))]) @ fit
    inside = np.all((y >= 0.0) & (y <= 1.0), axis=1)
    q = y[inside]
    count = q.shape[0]
    tables = []
    for a, dim in enumerate(mu_x.shape):
        b = np.zeros((dim, count))
        for i in range(dim):
            b[i] = math.comb(dim - 1, i) * np.power(1 - q[:, a], dim - 1 - i) * np.power(q[:, a], i)
        tables.append(b)
    bx, by, bz = tables
    sx = sy = sz = 0.0
    for j in range(mu_x.shape[1]):
        for k in range(mu_x.shape[2]):
            byz = by[j] * bz[k]
            for i in range(mu_x.shape[0]):
                w = bx[i] * byz
                sx = sx + w * mu_x[i, j, k]
                sy = sy + w * mu_y[i, j, k]
                sz = sz + w * mu_z[i, j, k]
    q = q + np.stack([sx, sy, sz], axis=1)
    out = points.copy()
    out[inside] = q @ m.T + origin
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--n", type=int, default=5, help="control points per axis")
    ap.add_argument("--pygem", metavar="PATH", help="a local PyGeM checkout to time as well")
    args = ap.parse_args()

    rng = np.random.default_rng(18)
    ffd = FFD([args.n] * 3)
    ffd.box_length = np.array([1.2, 0.9, 1.5])
    ffd.box_origin = np.array([-0.1, -0.05, -0.2])
    ffd.rot_angle = np.array([10.0, -5.0, 20.0])
    for a in (ffd.array_mu_x, ffd.array_mu_y, ffd.array_mu_z):
        a[...] = rng.uniform(-0.2, 0.2, size=a.shape)
    # inside the box, where PyGeM does its work (it returns outside points unchanged)
    points = ffd.box_origin + rng.uniform(0.0, 1.0, size=(args.points, 3)) @ (
        ffd.rotation_matrix @ np.diag(ffd.box_length)).T

    # the optimisation-loop form (docs/python.md "Speed"): bound once (not timed), new weights
    # set on the control points, evaluated into a reused array
    loop_ffd = FFD([args.n] * 3)
    for name in ("box_length", "box_origin", "rot_angle"):
        setattr(loop_ffd, name, getattr(ffd, name))
    t = time.perf_counter()
    bound = loop_ffd.rig().deformer(points)
    bind_s = time.perf_counter() - t
    rest = np.array(bound.controls)
    mu = np.stack([ffd.array_mu_x, ffd.array_mu_y, ffd.array_mu_z], axis=-1).reshape(-1, 3)
    m = ffd.rotation_matrix * ffd.box_length
    loop_out = np.empty_like(points)

    def bound_loop():
        bound.controls = rest + mu @ m.T
        return bound.evaluate(out=loop_out)

    runners = [("ffdkit.pygem.FFD", lambda: ffd(points)),
               ("bound deformer (loop)", bound_loop),
               ("numpy PyGeM formula", lambda: pygem_formula(
                   points, ffd.box_length, ffd.box_origin, ffd.rot_angle,
                   ffd.array_mu_x, ffd.array_mu_y, ffd.array_mu_z))]
    if args.pygem:
        sys.path.insert(0, args.pygem)
        import pygem

        theirs = pygem.FFD([args.n] * 3)
        for name in ("box_length", "box_origin", "rot_angle",
                     "array_mu_x", "array_mu_y", "array_mu_z"):
            setattr(theirs, name, np.array(getattr(ffd, name)))
        runners.append((f"PyGeM {getattr(pygem, '__version__', '?')}", lambda: theirs(points)))

    results = {name: None for name, _ in runners}
    times = {name: [] for name, _ in runners}
    for _ in range(args.rounds):
        for name, run in runners:
            t = time.perf_counter()
            results[name] = run()
            times[name].append(time.perf_counter() - t)

    mine = results[runners[0][0]]
    inside = np.count_nonzero(np.any(mine != points, axis=1))
    print(f"ffdkit {ffdkit.__version__}, numpy {np.__version__}; {args.points} points "
          f"({inside} moved), {args.n}^3 control points, {args.rounds} interleaved rounds; "
          f"the bound deformer's one-time creation: {bind_s * 1e3:.0f} ms")
    base = statistics.median(times[runners[0][0]])
    for name, _ in runners:
        med = statistics.median(times[name])
        err = float(np.max(np.abs(results[name] - mine)))
        print(f"  {name:24s} median {med * 1e3:9.1f} ms  {args.points / med / 1e6:7.2f} M points/s"
              f"  {med / base:6.1f}x ffdkit's time  max |diff| {err:.1e}")


if __name__ == "__main__":
    main()
