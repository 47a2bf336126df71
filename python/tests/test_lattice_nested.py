"""Nested lattices and the falloff outside the lattice through the generic
Deformer (docs/lattice-variants.md): the controls are the root's, then each
child's depth-first; solve() reaches targets in the parent's region and in a
child's; the rig round-trips; rigid motions of all controls move the points
rigidly; the falloff is continuous across the box and zero beyond its
distance; the sensitivities match differences of the evaluation."""

import json

import numpy as np

import ffdkit
from conftest import EXAMPLES

NESTED = EXAMPLES / "lattice" / "nested.json"
FALLOFF = EXAMPLES / "lattice" / "falloff.json"


def box_rig(extra):
    rig = {"version": 1, "deformer": "lattice", "resolution": [4, 4, 4],
           "box": {"origin": [0, 0, 0], "axes": [[4, 0, 0], [0, 4, 0], [0, 0, 4]]},
           "children": [{"box": {"origin": [1, 1, 1], "axes": [[2, 0, 0], [0, 2, 0], [0, 0, 2]]},
                         "resolution": [3, 4, 3],
                         "children": [{"box": {"origin": [1.5, 1.5, 1.5],
                                               "axes": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]},
                                       "basis": "bernstein", "resolution": [3, 3, 3]}]}]}
    rig.update(extra)
    return rig


def points():
    rng = np.random.default_rng(7)
    return np.ascontiguousarray(rng.uniform(-0.2, 4.2, size=(400, 3)))


def test_controls_order_and_identity():
    pts = points()
    d = ffdkit.Rig.load(box_rig({})).deformer(pts)
    assert d.control_count == 64 + 36 + 27
    assert d.evaluate().tobytes() == pts.tobytes()
    assert type(d).__name__ == "LatticeDeformer" and d.control_grid().shape == (4, 4, 4, 3)
    lattices = d.lattices
    assert [(l["first"], l["count"], l["depth"]) for l in lattices] == [(0, 64, 0), (64, 36, 1), (100, 27, 2)]


def test_solve_reaches_targets_in_parent_and_children():
    pts = points()
    d = ffdkit.Rig.load(box_rig({})).deformer(pts)
    inner = np.flatnonzero(np.all(np.abs(pts - 2.0) < 0.45, axis=1))[:2]  # in the grandchild
    middle = np.flatnonzero(np.all(np.abs(pts - 2.0) < 0.95, axis=1) & np.any(np.abs(pts - 2.0) > 0.55, axis=1))[:2]
    outer = np.flatnonzero(np.any(np.abs(pts - 2.0) > 1.1, axis=1) & np.all(np.abs(pts - 2.0) < 1.9, axis=1))[:2]
    ids = np.concatenate([inner, middle, outer])
    targets = pts[ids] + np.array([0.05, -0.04, 0.03])
    result = d.solve(ids, targets)
    assert result.max_residual < 1e-10
    np.testing.assert_allclose(d.evaluate()[ids], targets, atol=1e-10)


def test_rig_round_trip_and_rigid_motion():
    pts = points()
    d = ffdkit.Rig.load(NESTED).deformer(pts)
    again = ffdkit.Rig.load(d.rig()).deformer(pts)
    np.testing.assert_allclose(again.evaluate(), d.evaluate(), atol=1e-12)
    d.reset()
    c = np.array(d.controls)
    th = 0.4
    R = np.array([[np.cos(th), 0, np.sin(th)], [0, 1, 0], [-np.sin(th), 0, np.cos(th)]])
    d.controls = c @ R.T + [0.5, 1.0, -2.0]
    inside = np.all((pts >= [-5.5, -0.5, -4.3]) & (pts <= [5.5, 10.2, 4.3]), axis=1)
    np.testing.assert_allclose(d.evaluate()[inside], pts[inside] @ R.T + [0.5, 1.0, -2.0], atol=1e-11)


def test_sensitivities_match_differences():
    pts = points()
    d = ffdkit.Rig.load(box_rig({"outside": "falloff", "falloff": 0.5})).deformer(pts)
    W = d.sensitivities().toarray()
    base = d.evaluate()
    for j in (3, 70, 110):
        d.move([j], [[0.0, 0.01, 0.0]])
        np.testing.assert_allclose((d.evaluate() - base)[:, 1], 0.01 * W[:, j], atol=1e-13)
        d.move([j], [[0.0, -0.01, 0.0]])


def test_falloff_continuous_and_zero_beyond():
    rig = json.loads(FALLOFF.read_text())
    # across the box's lower face y = 6 and far below it
    pts = np.array([[-4.0, 6.0, 0.0], [-4.0, 6.0 - 1e-9, 0.0], [-4.0, 6.0 - 3.5, 0.0]])
    d = ffdkit.Rig.load(rig).deformer(pts)
    out = d.evaluate()
    assert np.abs(out[0] - pts[0]).max() > 1e-2
    np.testing.assert_allclose(out[1] - pts[1], out[0] - pts[0], atol=1e-7)
    assert out[2].tobytes() == pts[2].tobytes()


def test_move_of_all_controls_adds_to_the_variables():
    """move() of every control by a delta the linear map predicts: the
    children's deltas add to their own displacements, the root's carry them."""
    pts = points()
    d = ffdkit.Rig.load(box_rig({})).deformer(pts)
    W = d.sensitivities().toarray()
    base = d.evaluate()
    delta = np.random.default_rng(3).normal(scale=0.01, size=(d.control_count, 3))
    d.move(np.arange(d.control_count), delta)
    np.testing.assert_allclose(d.evaluate() - base, W @ delta, atol=1e-12)
