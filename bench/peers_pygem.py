# PyGeM's side of bench/peers.sh: PyGeM's FFD (Bernstein, Sederberg-Parry) on
# the points of bench_peers gen, a 5^3 lattice on the unit cube whose control
# (i, j, k) moves by the same delta as ffdkit's (array_mu is the displacement
# divided by the box length, here 1).
#   python3 bench/peers_pygem.py PYGEM_CHECKOUT DIR ROUNDS
# Prints "ffd_call MS" (median over ROUNDS of ffd(points): PyGeM maps the
# points into the box and evaluates every time, i.e. bind + evaluate) and the
# first deformed point.
import sys
import time

import numpy

checkout, directory, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3])
sys.path.insert(0, checkout)
from pygem import FFD  # noqa: E402  (from the checkout given on the command line)

points = numpy.fromfile(directory + "/points.f64", dtype="<f8").reshape(-1, 3)
deltas = numpy.fromfile(directory + "/deltas.f64", dtype="<f8").reshape(5, 5, 5, 3)
ffd = FFD([5, 5, 5])
ffd.box_origin = numpy.array([0.0, 0.0, 0.0])
ffd.box_length = numpy.array([1.0, 1.0, 1.0])
ffd.array_mu_x = deltas[..., 0].copy()
ffd.array_mu_y = deltas[..., 1].copy()
ffd.array_mu_z = deltas[..., 2].copy()
times = []
for r in range(rounds):
    t0 = time.perf_counter()
    out = ffd(points)
    times.append(time.perf_counter() - t0)
times.sort()
print("ffd_call %.3f first %.6f %.6f %.6f" % (1e3 * times[len(times) // 2], *out[0]))
