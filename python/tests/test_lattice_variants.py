"""Lattice variants through the generic Deformer (docs/lattice-variants.md):
interpolation per axis, cylindrical and spherical lattices — load, identity,
the rig round trip, direct manipulation, the Jacobian against differences."""
import json

import numpy as np
import pytest

import ffdkit
from conftest import EXAMPLES

BUNNY = EXAMPLES / "lattice" / "bunny.obj"
VARIANTS = ["mixed.json", "cylinder.json", "sphere.json"]


@pytest.fixture(scope="module")
def bunny():
    return np.ascontiguousarray(ffdkit.read_mesh(BUNNY).points)


def at_rest(name):
    doc = json.loads((EXAMPLES / "lattice" / name).read_text())
    doc.pop("moves", None)
    doc.pop("constraints", None)
    return doc


@pytest.mark.parametrize("name", VARIANTS)
def test_matches_apply_and_round_trips(bunny, name):
    rig = ffdkit.Rig.load(EXAMPLES / "lattice" / name)
    d = rig.deformer(bunny)
    np.testing.assert_array_equal(d.evaluate(), rig.apply(bunny))
    again = ffdkit.Rig.load(d.rig()).deformer(bunny)
    np.testing.assert_allclose(again.evaluate(), d.evaluate(), atol=1e-12)


@pytest.mark.parametrize("name", VARIANTS)
def test_identity_is_bitwise(bunny, name):
    d = ffdkit.Rig.load(at_rest(name)).deformer(bunny)
    assert d.evaluate().tobytes() == bunny.tobytes()
    J = d.jacobian()
    assert np.array_equal(J.reshape(len(bunny), 9), np.tile(np.eye(3).ravel(), (len(bunny), 1)))


@pytest.mark.parametrize("name", VARIANTS)
def test_direct_manipulation_reaches_targets(bunny, name):
    d = ffdkit.Rig.load(at_rest(name)).deformer(bunny)
    ids = [553, 1043, 239]
    targets = bunny[ids] + np.array([[0.3, -0.2, 0.1], [-0.1, 0.2, 0.2], [0.0, 0.1, -0.3]])
    result = d.solve(ids, targets)
    assert result.max_residual < 1e-12
    np.testing.assert_allclose(d.evaluate()[ids], targets, atol=1e-12)


def test_linear_map_is_the_map(bunny):
    d = ffdkit.Rig.load(EXAMPLES / "lattice" / "cylinder.json").deformer(bunny)
    W = d.linear_map()
    rest = ffdkit.Rig.load(at_rest("cylinder.json")).deformer(bunny)
    x = d.evaluate() - bunny
    disp = np.asarray(d.controls) - np.asarray(rest.controls)
    np.testing.assert_allclose(W @ disp, x, atol=1e-12)


def test_periodic_bernstein_refused(bunny):
    doc = at_rest("cylinder.json")
    doc["basis"] = "bernstein"
    with pytest.raises(ffdkit.Error, match="bernstein cannot be periodic"):
        ffdkit.Rig.load(doc)
