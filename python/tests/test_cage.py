"""The cage method ("deformer": "cage", docs/cage.md) through the generic
Deformer: mean value and harmonic coordinates of the bunny's cage, the
identity at rest, translations, the linear map against the evaluation,
direct manipulation reaching its targets, the rig round trip, and a bad cage."""
import json

import numpy as np
import pytest

import ffdkit
from conftest import EXAMPLES

BUNNY = EXAMPLES / "cage" / "bunny.obj"
CAGE = str(EXAMPLES / "cage" / "bunny-cage.obj")


def cage_rig(**keys):
    doc = {"version": 1, "deformer": "cage", "cage": CAGE}
    doc.update(keys)
    return ffdkit.Rig.load(doc)


@pytest.fixture(scope="module")
def bunny():
    return np.ascontiguousarray(ffdkit.read_mesh(BUNNY).points)


@pytest.mark.parametrize("keys", [{}, {"coordinates": "harmonic", "resolution": 12}])
def test_identity_translation_and_map(bunny, keys):
    d = cage_rig(**keys).deformer(bunny)
    assert d.method == "cage" and d.control_count == 42
    assert d.evaluate().tobytes() == bunny.tobytes()  # a cage at rest: bitwise
    t = np.array([0.5, -1.0, 2.0])
    d.move(None, np.tile(t, (42, 1)))
    np.testing.assert_allclose(d.evaluate(), bunny + t, atol=1e-12)  # partition of unity
    W = d.linear_map()
    assert W.shape == (len(bunny), 42)
    np.testing.assert_allclose(W @ np.asarray(d.controls) - W @ (np.asarray(d.controls) - t),
                               np.tile(t, (len(bunny), 1)), atol=1e-12)
    d.reset()
    rng = np.random.default_rng(3)
    dv = rng.normal(scale=0.3, size=(42, 3))
    d.move(None, dv)
    np.testing.assert_allclose(d.evaluate(), bunny + W @ dv, atol=1e-12)


def test_mean_value_linear_precision(bunny):
    d = cage_rig().deformer(bunny)
    W = d.linear_map().toarray()
    rest = np.asarray(d.controls)
    np.testing.assert_allclose(W.sum(axis=1), 1, atol=1e-12)
    np.testing.assert_allclose(W @ rest, bunny, atol=1e-10 * np.ptp(bunny))


def test_direct_manipulation_reaches_targets(bunny):
    for keys in ({}, {"coordinates": "harmonic", "resolution": 12}):
        d = cage_rig(**keys).deformer(bunny)
        targets = {553: [2.0, 8.4, -1.0], 1791: bunny[1791].tolist(), 896: [4.9, 2.0, 0.9]}
        r = d.solve(targets)
        assert r.max_residual < 1e-9
        got = d.evaluate()
        for i, t in targets.items():
            np.testing.assert_allclose(got[i], t, atol=1e-9)
        # the deformer's rig replays to the same positions
        again = ffdkit.Rig.load(d.rig()).apply(bunny)
        np.testing.assert_allclose(again, got, atol=1e-12)


def test_bad_cage(tmp_path, bunny):
    bad = tmp_path / "open.obj"
    # the octahedron without its last face
    bad.write_text("v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
                   "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\n")
    with pytest.raises(ffdkit.Error, match="open.obj: cage: edge .* is on no other face: the cage is not closed"):
        ffdkit.Rig.load({"version": 1, "deformer": "cage", "cage": str(bad)}).deformer(bunny)
