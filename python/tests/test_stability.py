"""Reference counts and memory over 10,000 calls of each main function
(bind, evaluate, jacobian, controls, move, set_controls, solve, command,
report, read_mesh, Mesh), error paths too.

For every function: after a warm-up, 10,000 calls leave
* ``sys.getrefcount`` of every input (and of the deformer) unchanged;
* Python's traced memory (tracemalloc: objects and NumPy's array data) grown
  by at most TRACED_BOUND = 64 KiB, under 7 bytes a call: a leaked result
  array or exception would be >= 100 bytes a call;
* the resident set (/proc/self/statm) grown by at most RSS_BOUND = 16 MiB:
  the C-side buffers of one call on POINTS points are >= 12 KB (bind's copy,
  an evaluation), so one leaked per call would be >= 120 MB.
The whole file runs in well under a minute (release build; under ASan:
2,000 calls and no RSS bound, see ASAN below).
"""

import gc
import os
import sys
import tracemalloc

import numpy as np
import pytest

import ffdkit

def under_asan():
    with open("/proc/self/maps") as f:
        return "libasan" in f.read()


# Under AddressSanitizer (LD_PRELOAD=libasan, the FFD_SANITIZE build) freed
# blocks wait in ASan's quarantine (256 MB), so the resident set measures
# ASan, not us: the RSS bound is not checked there (LeakSanitizer is), and
# 2,000 calls keep the run short.
ASAN = under_asan()
CALLS = 2_000 if ASAN else 10_000
WARMUP = 200
TRACED_BOUND = 64 * 1024
RSS_BOUND = None if ASAN else 16 * 1024 * 1024
POINTS = 500


def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def cube():
    p = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
    return ffdkit.Mesh(p, [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])


@pytest.fixture(scope="module")
def points():
    return np.random.default_rng(3).random((POINTS, 3))


@pytest.fixture
def deformer(points):
    d = ffdkit.Rig.load({"version": 1, "deformer": "lattice", "resolution": [4, 4, 4]}).deformer(cube())
    d.bind(points)
    return d


def check_stable(call, *inputs, expect=None):
    """Runs call() CALLS times (expect: the exception every call raises) and
    checks the refcounts of inputs and the memory growth."""

    def run(n):
        for _ in range(n):
            if expect is None:
                call()
            else:
                try:
                    call()
                except expect:
                    pass
                else:
                    raise AssertionError(f"{call} did not raise {expect}")

    run(WARMUP)
    gc.collect()
    refs = [sys.getrefcount(x) for x in inputs]
    rss0 = rss()
    tracemalloc.start()
    try:
        traced0 = tracemalloc.get_traced_memory()[0]
        run(CALLS)
        gc.collect()
        traced = tracemalloc.get_traced_memory()[0] - traced0
    finally:
        tracemalloc.stop()
    grown = rss() - rss0
    assert [sys.getrefcount(x) for x in inputs] == refs
    assert traced <= TRACED_BOUND, f"traced memory grew by {traced} bytes over {CALLS} calls"
    if RSS_BOUND is not None:
        assert grown <= RSS_BOUND, f"RSS grew by {grown} bytes over {CALLS} calls"


def test_bind(deformer, points):
    check_stable(lambda: deformer.bind(points), deformer, points)


def test_bind_converting(deformer, points):
    as_f32 = points.astype(np.float32)
    as_list = points[:20].tolist()
    check_stable(lambda: deformer.bind(as_f32), deformer, as_f32)
    check_stable(lambda: deformer.bind(as_list), deformer, as_list)


def test_evaluate(deformer):
    out = np.empty((POINTS, 3))
    check_stable(deformer.evaluate, deformer)
    check_stable(lambda: deformer.evaluate(out=out), deformer, out)


def test_jacobian(deformer):
    out = np.empty((POINTS, 3, 3))
    check_stable(deformer.jacobian, deformer)
    check_stable(lambda: deformer.jacobian(out=out), deformer, out)


def test_controls(deformer):
    p = deformer.controls.copy()
    ids = np.array([1, 5, 9], dtype=np.int64)
    deltas = np.full((3, 3), 1e-3)
    positions = p[ids]

    def assign():
        deformer.controls = p

    check_stable(lambda: deformer.controls, deformer)
    check_stable(assign, deformer, p)
    check_stable(lambda: deformer.move(ids, deltas), deformer, ids, deltas)
    check_stable(lambda: deformer.set_controls(ids, positions), deformer, ids, positions)
    check_stable(deformer.reset, deformer)


def test_solve(deformer, points):
    ids = np.array([0, 10, 20, 30])
    targets = points[ids] + 0.01
    check_stable(lambda: deformer.solve(ids, targets), deformer, ids, targets)


def test_report_rig(deformer):
    check_stable(deformer.report, deformer)
    check_stable(deformer.rig, deformer)


def test_command(cow_tspline):
    ids = [0, 1, 2]
    check_stable(lambda: cow_tspline.freeze(ids), cow_tspline, ids)
    check_stable(lambda: cow_tspline.command("freeze", points=ids, frozen=False), cow_tspline, ids)


@pytest.fixture
def cow_tspline(points):
    d = ffdkit.Rig.load({"version": 1, "deformer": "tspline", "resolution": [4, 4, 4]}).deformer(cube())
    d.bind(points)
    return d


def test_read_mesh(tmp_path):
    path = tmp_path / "cube.off"
    path.write_text("OFF\n8 6 0\n" + "".join(f"{x} {y} {z}\n" for x in (0, 1) for y in (0, 1) for z in (0, 1))
                    + "4 0 1 3 2\n4 4 6 7 5\n4 0 4 5 1\n4 2 3 7 6\n4 0 2 6 4\n4 1 5 7 3\n")
    name = str(path)
    check_stable(lambda: ffdkit.read_mesh(name), name)


def test_mesh_from_arrays():
    p = np.random.default_rng(5).random((POINTS, 3))
    faces = np.arange(POINTS - POINTS % 3, dtype=np.int64).reshape(-1, 3)
    check_stable(lambda: ffdkit.Mesh(p, faces).points, p, faces)


# ---------------------------------------------------------------------------
# error paths
# ---------------------------------------------------------------------------


def test_error_paths(deformer, points, tmp_path):
    bad_shape = np.zeros((4, 2))
    bad_out = np.empty((POINTS, 2))
    nan = points.copy()
    nan[3, 1] = np.nan
    far = np.array([10**6])
    target = np.zeros((1, 3))
    missing = str(tmp_path / "missing.off")
    garbage = tmp_path / "garbage.off"
    garbage.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n")
    garbage = str(garbage)
    check_stable(lambda: deformer.bind(bad_shape), deformer, bad_shape, expect=ValueError)
    check_stable(lambda: deformer.bind(nan), deformer, nan, expect=ffdkit.NonFiniteError)
    check_stable(lambda: deformer.evaluate(out=bad_out), deformer, bad_out, expect=(ValueError, TypeError))
    check_stable(lambda: deformer.move(far, target), deformer, far, target, expect=ffdkit.RangeError)
    check_stable(lambda: deformer.solve(far, target), deformer, far, target, expect=ffdkit.RangeError)
    check_stable(lambda: deformer.command("refine", insertions=[]), deformer, expect=ffdkit.UnsupportedError)
    check_stable(lambda: ffdkit.read_mesh(missing), missing, expect=ffdkit.FileError)
    check_stable(lambda: ffdkit.read_mesh(garbage), garbage, expect=ffdkit.ParseError)


def test_method_error_paths(cow_tspline):
    d = cow_tspline
    bad = [{"cel": 1}]
    check_stable(lambda: d.refine(bad), d, bad, expect=ffdkit.ParseError)
    check_stable(lambda: d.freeze([10**6]), d, expect=ffdkit.RangeError)
