"""ffdkit.Deformer: the generic deformer of every method over numpy arrays:
bind, evaluate, jacobian, the controls view, move/set/reset, solve, the
linear map, report/rig/command, errors, no copies, refcounts and memory."""
import gc
import json
import os
import sys
import threading
import tracemalloc

import numpy as np
import pytest

import ffdkit
from ffdkit import _deformer
from conftest import EXAMPLES, sanitized

BUNNY = EXAMPLES / "lattice" / "bunny.obj"
BEND = EXAMPLES / "lattice" / "bend.json"
IDENTITY = {"version": 1, "deformer": "lattice", "resolution": [4, 4, 4], "box": "auto"}


@pytest.fixture
def bunny():
    return np.ascontiguousarray(ffdkit.read_mesh(BUNNY).points)


@pytest.fixture
def bend(bunny):
    return ffdkit.Rig.load(BEND).deformer(bunny)


def linear_deformers():
    """One deformer per linear method (lattice, PB-FFD, T-spline), on its example mesh."""
    for rig, mesh in [("lattice/bend.json", "lattice/bunny.obj"), ("pbffd/cow-drag.json", "pbffd/cow.off"),
                      ("tspline/bunny-ears.json", "tspline/bunny.obj")]:
        yield ffdkit.Rig.load(EXAMPLES / rig).deformer(ffdkit.read_mesh(EXAMPLES / mesh))


def gffd_deformer():
    doc = json.loads((EXAMPLES / "gffd" / "twist.json").read_text())
    doc.pop("resample")
    rig = ffdkit.Rig.load(doc, name=str(EXAMPLES / "gffd" / "twist.json"))
    return rig.deformer(ffdkit.read_mesh(EXAMPLES / "gffd" / "bunny.obj"))


def test_factory_and_properties(bunny):
    rig = ffdkit.Rig.load(BEND)
    d = ffdkit.Deformer(rig, bunny)
    assert isinstance(d, ffdkit.Deformer) and d.method == "lattice"
    assert d.point_count == len(bunny) and d.control_count == 125
    assert "lattice" in repr(d)

    class Mine(ffdkit.Deformer):
        pass

    saved = dict(_deformer.METHOD_CLASSES)
    try:
        _deformer.METHOD_CLASSES["lattice"] = Mine
        assert type(rig.deformer(bunny)) is Mine
        assert type(ffdkit.Deformer(rig, bunny)) is Mine
    finally:
        _deformer.METHOD_CLASSES.clear()
        _deformer.METHOD_CLASSES.update(saved)
    with pytest.raises(TypeError, match="rig"):
        ffdkit.Deformer("bend.json", bunny)
    with pytest.raises(ValueError, match="points"):
        ffdkit.Deformer(rig, bunny[:, :2])


def test_identity_at_rest_keeps_the_bits(bunny):
    d = ffdkit.Rig.load(IDENTITY).deformer(bunny)
    assert d.evaluate().tobytes() == bunny.tobytes()


def test_evaluate_equals_apply_and_out(bunny, bend):
    want = ffdkit.Rig.load(BEND).apply(bunny)
    got = bend.evaluate()
    assert got.tobytes() == want.tobytes()
    out = np.empty_like(bunny)
    r = bend.evaluate(out=out)
    assert r is out and np.shares_memory(r, out) and out.tobytes() == want.tobytes()
    for bad in (np.empty((len(bunny), 3), np.float32), np.empty((len(bunny) - 1, 3)),
                np.empty((3, len(bunny))).T, np.empty((len(bunny), 6))[:, ::2], [[0.0] * 3]):
        with pytest.raises(ValueError, match="out"):
            bend.evaluate(out=bad)
    with pytest.raises(ValueError, match="out"):
        bend.jacobian(out=np.empty((len(bunny), 9)))


def test_bind_any_points(bunny, bend):
    rig = ffdkit.Rig.load(BEND)
    sub = bunny[::7]
    bend.bind(sub)
    assert bend.point_count == len(sub)
    np.testing.assert_array_equal(bend.evaluate(), rig.apply(bunny)[::7])
    bend.bind(sub.astype(np.float32))  # converted once
    bend.bind(sub.tolist())
    with pytest.raises(ValueError, match=r"points: expected an \(N, 3\) array, got shape \(3,\)"):
        bend.bind([1.0, 2.0, 3.0])
    with pytest.raises(TypeError, match="points"):
        bend.bind(np.array([["x", "y", "z"]]))
    with pytest.raises(TypeError):
        bend.bind(None)
    with pytest.raises(ffdkit.NonFiniteError):
        bend.bind(np.array([[np.inf, 0, 0]]))
    assert bend.point_count == len(sub)  # unchanged on error


def test_jacobian_against_finite_differences():
    meshes = {"lattice": BUNNY, "pbffd": EXAMPLES / "pbffd" / "cow.off", "tspline": EXAMPLES / "tspline" / "bunny.obj"}
    for d in linear_deformers():
        rest = np.ascontiguousarray(ffdkit.read_mesh(meshes[d.method]).points[::41])
        d.bind(rest)
        J = d.jacobian()
        assert J.shape == (len(rest), 3, 3)
        h = 1e-6 * max(1.0, float(np.abs(rest).max()))
        fd = np.empty_like(J)
        for k in range(3):
            e = np.zeros(3)
            e[k] = h
            d.bind(rest + e)
            plus = d.evaluate()
            d.bind(rest - e)
            minus = d.evaluate()
            fd[:, :, k] = (plus - minus) / (2 * h)
        err = np.abs(fd - J).max() / max(1.0, float(np.abs(J).max()))
        assert err < 1e-4, (d.method, err)
    with pytest.raises(ffdkit.UnsupportedError, match="Jacobian"):
        gffd_deformer().jacobian()


def test_linear_map_is_the_map(bunny):
    for d in linear_deformers():
        W = d.linear_map()
        import scipy.sparse

        assert scipy.sparse.isspmatrix_csr(W) and W.shape == (d.point_count, d.control_count)
        x0 = d.evaluate()
        c0 = np.array(d.controls)
        rng = np.random.default_rng(1)
        delta = rng.normal(scale=0.01, size=c0.shape)
        d.move(None, delta)
        x1 = d.evaluate()
        # x' = W controls + what does not depend on them
        np.testing.assert_allclose(x1 - x0, W @ delta, atol=1e-9, err_msg=d.method)
        if d.method != "pbffd":  # lattice and T-spline points are affine combinations of controls
            np.testing.assert_allclose(W @ np.array(d.controls), x1, atol=1e-9, err_msg=d.method)
    with pytest.raises(ffdkit.UnsupportedError):
        gffd_deformer().linear_map()


def test_solve_reaches_targets(bunny, bend):
    ids = [553, 1043, 1791]
    targets = bend.evaluate()[ids] + np.array([[0.2, 0.1, 0.0], [0.0, -0.1, 0.1], [0.05, 0.05, 0.05]])
    r = bend.solve(ids, targets)
    assert isinstance(r, ffdkit.SolveResult)
    assert r.residuals.shape == (3,) and r.reached.shape == (3, 3) and r.rank >= 3
    assert r.max_residual < 1e-9 and np.all(r.residuals < 1e-9)
    x = bend.evaluate()
    np.testing.assert_allclose(x[ids], targets, atol=1e-9)
    np.testing.assert_allclose(r.reached, x[ids], atol=1e-12)
    # one point with a (3,) target
    r1 = bend.solve(7, x[7] + 0.01)
    assert r1.max_residual < 1e-9
    with pytest.raises(ffdkit.RangeError, match="out of range"):
        bend.solve([len(bunny)], [[0, 0, 0]])
    with pytest.raises(ValueError, match="targets"):
        bend.solve([1, 2], [[0, 0, 0]])
    with pytest.raises(ValueError, match="points"):
        bend.solve([-1], [[0, 0, 0]])
    with pytest.raises(ffdkit.NonFiniteError):
        bend.solve([1], [[np.nan, 0, 0]])
    with pytest.raises(ValueError, match="rcond"):
        bend.solve([1], [[0, 0, 0]], rcond=-1)
    with pytest.raises(ffdkit.UnsupportedError):
        gffd_deformer().solve([0], [[0, 0, 0]])


def test_solve_takes_constraints_alone(bend):
    """solve({index: target}) and solve([(index, target), ...]) are solve(indices, targets)."""
    x = bend.evaluate()
    start = np.array(bend.controls)
    goal = {553: x[553] + (0.1, 0, 0), 1043: x[1043] + (0, 0.1, 0)}
    r = bend.solve(goal)
    assert r.max_residual < 1e-9
    moved = bend.evaluate()
    bend.controls = start
    r2 = bend.solve(list(goal.items()))
    assert r2.max_residual < 1e-9
    assert bend.evaluate().tobytes() == moved.tobytes()
    bend.controls = start
    bend.solve(list(goal), list(goal.values()))
    assert bend.evaluate().tobytes() == moved.tobytes()
    with pytest.raises(TypeError, match="constraints"):
        bend.solve([1, 2])


def test_controls_view_writes_through(bend):
    v = bend.controls
    assert isinstance(v, ffdkit.ControlsView) and v.shape == (125, 3) and v.dtype == np.float64
    rest = np.array(v)
    x0 = bend.evaluate()
    bend.controls[3] += (0, 0.1, 0)
    np.testing.assert_allclose(bend._get_controls()[3], rest[3] + (0, 0.1, 0))
    assert bend.controls is v  # the same view, refreshed
    assert not np.array_equal(bend.evaluate(), x0)
    bend.controls[:, 2] *= 2
    np.testing.assert_allclose(bend._get_controls()[:, 2], v[:, 2])
    v[0, 1] = 5.0
    assert bend._get_controls()[0, 1] == 5.0
    v += 1.0
    np.testing.assert_array_equal(bend._get_controls(), np.asarray(v))
    bend.controls = rest
    np.testing.assert_array_equal(bend._get_controls(), rest)
    np.testing.assert_array_equal(v, rest)  # refreshed
    np.testing.assert_array_equal(bend.evaluate(), x0)
    # writes the view does not see are pushed by assigning it back
    np.copyto(v, rest + 1.0)
    np.testing.assert_array_equal(bend._get_controls(), rest)
    bend.controls = v
    np.testing.assert_array_equal(bend._get_controls(), rest + 1.0)
    bend.controls = rest
    # derived arrays are copies, not written through
    w = v * 2
    w[0] = 0
    c = v.copy()
    c[1] = 0
    np.testing.assert_array_equal(bend._get_controls(), rest)
    # a bad value is refused and the view restored
    with pytest.raises(ffdkit.NonFiniteError):
        v[4] = (np.nan, 0, 0)
    np.testing.assert_array_equal(v, rest)
    # changes through the deformer refresh the view
    bend.move([5], [(1, 2, 3)])
    np.testing.assert_array_equal(v[5], rest[5] + (1, 2, 3))
    bend.set_controls([5, 6], [rest[5], (0, 0, 0)])
    np.testing.assert_array_equal(v[6], (0, 0, 0))
    bend.reset()
    np.testing.assert_array_equal(v, bend._get_controls())
    np.testing.assert_array_equal(bend.evaluate(), bunny_rest(bend))


def bunny_rest(d):
    """The bound points at rest (the controls reset: the lattice is the identity)."""
    return np.ascontiguousarray(ffdkit.read_mesh(BUNNY).points)


def test_move_and_set_errors(bend):
    with pytest.raises(ffdkit.RangeError, match="999"):
        bend.move([999], [[0, 0, 0]])
    with pytest.raises(ValueError, match="deltas"):
        bend.move([1, 2], [[0, 0, 0]])
    with pytest.raises(TypeError, match="ids"):
        bend.move([1.5], [[0, 0, 0]])
    with pytest.raises(ValueError, match="ids"):
        bend.set_controls([-3], [[0, 0, 0]])
    with pytest.raises(ValueError, match="positions"):
        bend.set_controls(None, np.zeros((3, 3)))
    with pytest.raises(TypeError, match="positions"):
        bend.set_controls([1], [["a", "b", "c"]])
    with pytest.raises(ffdkit.NonFiniteError):
        bend.move([1], [[np.inf, 0, 0]])
    bend.move(2, (0.5, 0, 0))  # one id, one delta


def test_report_rig_command(bunny, bend):
    bend.move([10], [[0.3, 0, 0]])
    rep = bend.report()
    assert rep["method"] == "lattice" and rep["controls"]["count"] == 125
    rig = bend.rig()
    assert rig["deformer"] == "lattice"
    again = ffdkit.Rig.load(rig).deformer(bunny)
    np.testing.assert_allclose(again.evaluate(), bend.evaluate(), atol=1e-12)
    with pytest.raises(ffdkit.UnsupportedError):
        bend.command("refine", region={})
    t = ffdkit.Rig.load(EXAMPLES / "tspline" / "bunny-ears.json").deformer(bunny)
    with pytest.raises(ffdkit.ParseError):
        t.command("refine", nosuchkey=1)


def test_deformer_refcounts_and_memory(bunny, bend):
    bend.bind(bunny[:100])
    out = np.empty_like(bunny[:100])
    ids = np.array([1, 2])
    deltas = np.zeros((2, 3))
    refs = (sys.getrefcount(out), sys.getrefcount(bend), sys.getrefcount(ids), sys.getrefcount(deltas))
    for _ in range(200):  # warm up numpy's caches
        bend.evaluate(out=out)
    gc.collect()
    tracemalloc.start()
    snap0 = tracemalloc.take_snapshot()
    for _ in range(10000):
        bend.evaluate(out=out)
        bend.move(ids, deltas)
        bend.controls
    gc.collect()
    snap1 = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in snap1.compare_to(snap0, "filename"))
    assert grown < 64 * 1024, grown
    assert (sys.getrefcount(out), sys.getrefcount(bend), sys.getrefcount(ids),
            sys.getrefcount(deltas)) == refs


def test_new_arrays_do_not_leak(bunny, bend):
    small = bunny[:100]
    bend.bind(small)
    gc.collect()
    tracemalloc.start()
    for _ in range(500):
        bend.evaluate()
        bend.jacobian()
    snap0 = tracemalloc.take_snapshot()
    for _ in range(3000):
        bend.evaluate()
        bend.jacobian()
        bend.solve([0], [[0.0, 0.0, 0.0]])
    snap1 = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in snap1.compare_to(snap0, "filename"))
    assert grown < 64 * 1024, grown


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.skipif(sanitized() or not os.path.exists("/proc/self/statm"),
                    reason="ASan's quarantine grows the resident set; needs /proc")
def test_library_memory_stable_over_2000_deformers(bunny):
    """The C side (libffd's handles, meshes, rigs) frees what it allocates."""
    pts = bunny[:64]
    rig = ffdkit.Rig.load(BEND)

    def cycle(n):
        for _ in range(n):
            d = ffdkit.Rig.load(IDENTITY).deformer(pts)
            d.evaluate()
            d.solve([0], [[0.0, 0.0, 0.0]])
            d.linear_map()
            d.report()
            rig.apply(pts)
            ffdkit.Mesh(pts, [[0, 1, 2]]).to_bytes("ply")
            del d

    cycle(300)
    gc.collect()
    before = rss_bytes()
    cycle(2000)
    gc.collect()
    grown = rss_bytes() - before
    assert grown < 8 * 1024 * 1024, grown


def test_one_thread_at_a_time_per_deformer(bunny):
    d = ffdkit.Rig.load(BEND).deformer(np.tile(bunny, (50, 1)))
    errors = []

    def work():
        try:
            for _ in range(5):
                d.evaluate()
                d.move([0], [[1e-3, 0, 0]])
        except Exception as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=work) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    np.testing.assert_allclose(d._get_controls()[0] - ffdkit.Rig.load(BEND).deformer(bunny)._get_controls()[0],
                               (0.02, 0, 0), atol=1e-12)


def test_one_id_does_not_leak(bend):
    """A single id (not a sequence) is reshaped to (1,) without leaking the shape."""
    delta = np.zeros(3)
    for _ in range(200):
        bend.move(4, delta)
    gc.collect()
    tracemalloc.start()
    snap0 = tracemalloc.take_snapshot()
    for _ in range(10000):
        bend.move(4, delta)
    gc.collect()
    snap1 = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in snap1.compare_to(snap0, "filename"))
    assert grown < 64 * 1024, grown
