"""The generic layers every method shares, through rigs (docs/constraints.md):
weights and strength, constrained FFD (volume, barycentre, linear
constraints) and the fold policy, checked from numpy."""
import json

import numpy as np
import pytest

import ffdkit
from conftest import EXAMPLES

BUNNY = EXAMPLES / "lattice" / "bunny.obj"
EARS = EXAMPLES / "lattice" / "ears.json"  # changes the volume
BEND = EXAMPLES / "lattice" / "bend.json"
RIGS = [("lattice/bend.json", "lattice/bunny.obj"), ("pbffd/cow-drag.json", "pbffd/cow.off"),
        ("tspline/bunny-ears.json", "tspline/bunny.obj")]


def rig_with(path, **extra):
    rig = json.loads(path.read_text())
    rig.update(extra)
    return ffdkit.Rig.load(rig)


def volume(points, faces):
    """The divergence theorem: sum over triangles of centroid . area normal / 3."""
    a, b, c = points[faces[:, 0]], points[faces[:, 1]], points[faces[:, 2]]
    normal = 0.5 * np.cross(b - a, c - a)
    return float(np.sum((a + b + c) / 3.0 * normal) / 3.0)


@pytest.mark.parametrize("rig,mesh", RIGS)
def test_weights_and_strength_scale_the_displacement(rig, mesh):
    m = ffdkit.read_mesh(EXAMPLES / mesh)
    points = np.ascontiguousarray(m.points)
    w = np.linspace(0.0, 1.0, len(points))
    plain = ffdkit.Rig.load(EXAMPLES / rig).deformer(m).evaluate()
    d = rig_with(EXAMPLES / rig, weights={"values": w.tolist()}, strength=0.5).deformer(m)
    got = d.evaluate()
    np.testing.assert_allclose(got, points + 0.5 * w[:, None] * (plain - points), rtol=0, atol=1e-12)
    assert got[0].tobytes() == points[0].tobytes()  # weight 0: the bits kept
    # the sensitivities' rows are scaled by s w_i
    W = ffdkit.Rig.load(EXAMPLES / rig).deformer(m).sensitivities()
    Ws = d.sensitivities()
    np.testing.assert_allclose(Ws.toarray(), (0.5 * w)[:, None] * W.toarray(), rtol=0, atol=1e-14)
    assert d.rig()["strength"] == 0.5 and "weights" in d.rig()


def test_strength_zero_is_the_identity():
    points = np.ascontiguousarray(ffdkit.read_mesh(BUNNY).points)
    d = rig_with(EARS, strength=0.0).deformer(points)
    assert d.evaluate().tobytes() == points.tobytes()
    J = d.jacobian()
    assert np.array_equal(J, np.broadcast_to(np.eye(3), J.shape))


def test_preserve_volume_and_barycentre():
    mesh = ffdkit.read_mesh(BUNNY)
    rest = np.ascontiguousarray(mesh.points)
    faces = np.asarray(mesh.faces)
    v0 = volume(rest, faces)
    plain = ffdkit.Rig.load(EARS).deformer(mesh).evaluate()
    assert abs(volume(plain, faces) - v0) > 1e-3 * abs(v0)
    d = rig_with(EARS, preserve=["volume", "barycentre"]).deformer(mesh)
    got = d.evaluate()
    layers = d.report()["layers"]["constraints"]
    assert layers["count"] == 4 and layers["max_residual"] <= 1e-12 and layers["change_norm"] > 0
    assert abs(volume(got, faces) - v0) <= 1e-12 * abs(v0)
    np.testing.assert_allclose(got.mean(axis=0), rest.mean(axis=0), rtol=0, atol=1e-12)


def test_linear_constraint_is_the_minimum_norm_projection():
    points = np.ascontiguousarray(ffdkit.read_mesh(BUNNY).points)
    plain = ffdkit.Rig.load(BEND).deformer(points)
    x = plain.evaluate()
    terms = [[5, 0, 1.0], [700, 2, -3.0]]
    d = rig_with(BEND, linear_constraints=[{"terms": terms, "value": 0.25}]).deformer(points)
    # closed form: P = P_req + (b - a.X) g / |g|^2, g = W^T a
    W = plain.sensitivities()
    a = np.zeros((len(points), 3))
    for i, axis, coef in terms:
        a[i, axis] = coef
    g = W.T @ a
    r = 0.25 - float(np.sum(a * x))
    want = np.asarray(plain.controls) + r * g / float(np.sum(g * g))
    np.testing.assert_allclose(np.asarray(d.controls), want, rtol=0, atol=1e-12)
    y = d.evaluate()
    assert abs(y[5, 0] - 3.0 * y[700, 2] - 0.25) <= 1e-12


def test_fold_policy():
    points = np.ascontiguousarray(ffdkit.read_mesh(BUNNY).points)
    big = 0.9 * float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    base = {"deformer": "lattice", "basis": "bspline", "resolution": [4, 4, 4],
            "moves": [{"index": [1, 1, 1], "delta": [big, 0, 0]}]}
    with pytest.raises(ffdkit.InvalidError, match="fold_policy"):
        ffdkit.Rig.load(dict(base, fold_policy="refuse")).deformer(points)
    d = ffdkit.Rig.load(dict(base, fold_policy="shorten")).deformer(points)
    assert d.report()["controls"]["count"] == 64
    rest = ffdkit.Rig.load(dict(base, moves=[])).deformer(points)
    moved = float(np.asarray(d.controls)[21, 0] - np.asarray(rest.controls)[21, 0])
    assert 0.05 * big < moved < big
    # a drag that would fold is shortened too
    d.move([42], [[-big, -big, 0.0]])
    assert float(np.abs(np.asarray(d.controls)[42] - np.asarray(rest.controls)[42]).max()) < big
