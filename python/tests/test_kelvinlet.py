"""Kelvinlet brushes (docs/kelvinlet.md) through the generic ffdkit.Deformer:
a grab moves its center exactly, a twist is a rotation at its center, the
Jacobian against differences, the grab handles as controls, reset to the
identity bit for bit, constraints reaching their targets, the rig round
trip, and no linear map (a grab's response is a 3x3 block)."""
import json

import numpy as np
import pytest

import ffdkit
from conftest import EXAMPLES

BUNNY = EXAMPLES / "lattice" / "bunny.obj"


def kelvinlet(brushes, **keys):
    rig = {"version": 1, "deformer": "kelvinlet", "brushes": brushes}
    rig.update(keys)
    return ffdkit.Rig.load(rig)


@pytest.fixture(scope="module")
def bunny():
    return np.ascontiguousarray(ffdkit.read_mesh(BUNNY).points)


def test_grab_moves_its_center_exactly():
    center, d = [0.5, -1.0, 2.0], [0.3, 0.7, -0.2]
    for nu in (0.0, 0.3, 0.5):
        for ms in ("single", "biscale", "triscale"):
            rig = kelvinlet([{"type": "grab", "center": center, "radius": 0.8, "displacement": d}],
                            poisson_ratio=nu, multiscale=ms)
            moved = rig.deformer(np.array([center])).evaluate()[0]
            np.testing.assert_allclose(moved - center, d, rtol=0, atol=1e-14)


def test_twist_is_a_rotation_at_its_center():
    angle, axis = 0.4, np.array([0.0, 0.6, 0.8])
    rig = kelvinlet([{"type": "twist", "center": [0, 0, 0], "radius": 1.0, "axis": list(axis),
                      "angle": angle}])
    J = rig.deformer(np.zeros((1, 3))).jacobian()[0]
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    np.testing.assert_allclose(J - np.eye(3), angle * K, atol=1e-13)


def test_jacobian_against_differences(bunny):
    rig = ffdkit.Rig.load(EXAMPLES / "kelvinlet" / "bunny-brushes.json")
    pts = bunny[::97].copy()
    d = rig.deformer(pts)
    J = d.jacobian()
    h = 1e-6
    for b in range(3):
        e = np.zeros(3)
        e[b] = h
        d.bind(pts + e)
        plus = d.evaluate()
        d.bind(pts - e)
        minus = d.evaluate()
        np.testing.assert_allclose((plus - minus) / (2 * h), J[:, :, b], atol=1e-6)


def test_controls_are_grab_handles_and_reset_is_identity(bunny):
    rig = ffdkit.Rig.load(EXAMPLES / "kelvinlet" / "bunny-brushes.json")
    d = rig.deformer(bunny)
    assert d.method == "kelvinlet"
    assert d.controls.shape == (1, 3)
    brush = json.loads((EXAMPLES / "kelvinlet" / "bunny-brushes.json").read_text())["brushes"][0]
    np.testing.assert_allclose(d.controls[0], np.add(brush["center"], brush["displacement"]))
    d.move([0], [[0.0, 0.5, 0.0]])
    x = d.evaluate()
    i = int(np.argmin(np.linalg.norm(bunny - brush["center"], axis=1)))
    assert np.linalg.norm(x[i] - bunny[i]) > 0.1
    d.reset()
    assert np.array_equal(d.evaluate(), bunny)
    with pytest.raises(ffdkit.UnsupportedError):
        d.linear_map()


def test_constraints_reach_targets(bunny):
    rig_path = EXAMPLES / "kelvinlet" / "bunny-pins.json"
    rig = json.loads(rig_path.read_text())
    x = ffdkit.Rig.load(rig_path).deformer(bunny).evaluate()
    for c in rig["constraints"]:
        np.testing.assert_allclose(x[c["vertex"]], c["target"], atol=1e-9)


def test_rig_round_trip(bunny):
    d = ffdkit.Rig.load(EXAMPLES / "kelvinlet" / "bunny-stroke.json").deformer(bunny)
    again = ffdkit.Rig.load(d.rig()).deformer(bunny)
    assert np.array_equal(again.evaluate(), d.evaluate())
    assert d.report()["method"] == "kelvinlet"


def test_bad_poisson_ratio_names_the_range():
    with pytest.raises(ffdkit.Error) as e:
        kelvinlet([], poisson_ratio=0.6)
    assert "[0, 0.5]" in str(e.value)


def test_add_and_remove_brushes(bunny):
    from ffdkit.methods import KelvinletDeformer
    d = kelvinlet([]).deformer(bunny)
    assert isinstance(d, KelvinletDeformer) and d.controls.shape == (0, 3)
    d.add_brush("grab", bunny[553], 1.5, displacement=np.array([0.0, 1.0, 0.0]))
    np.testing.assert_allclose(d.evaluate()[553], bunny[553] + [0, 1, 0], atol=1e-12)
    d.add_brush("twist", [0, 8, -1], 1.0, axis=[0, 1, 0], angle=0.5)
    assert [b["type"] for b in d.brushes] == ["grab", "twist"] and d.controls.shape == (1, 3)
    with pytest.raises(ffdkit.RangeError):
        d.remove_brush(5)
    with pytest.raises(ffdkit.ParseError):
        d.add_brush("grab", [0, 0, 0], 1.0, angle=1.0)
    d.remove_brush(0)
    d.remove_brush(0)
    assert np.array_equal(d.evaluate(), bunny)
