"""The methods' own design variables (docs/sensitivities.md): PB-FFD frame
sensitivities against central differences of the frame edits, T-spline ARAP
drag products (adjoint identity, translations reproduced)."""

from pathlib import Path

import numpy as np
import pytest

import ffdkit

scipy = pytest.importorskip("scipy.sparse")

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


@pytest.fixture(scope="module")
def cow():
    return ffdkit.read_mesh(str(EXAMPLES / "tspline" / "cow.off"))


@pytest.fixture(scope="module")
def placement(cow):
    return ffdkit.pbffd.place(cow, interior=6, exterior=6, levels=2)


@pytest.fixture
def pbffd(cow, placement):
    rig = {"version": 1, "deformer": "pbffd", "controls": placement.controls, "levels": 2}
    return ffdkit.Rig.load(rig).deformer(cow)


def fd_column(d, q, k, h):
    """Central difference of the points for frame variable k of EBF q."""
    out = []
    for s in (h, -h):
        if k < 3:
            axis = np.zeros(3)
            axis[k] = 1.0
            d.rotate_frame([q], axis, s)
        else:
            scale = np.ones(3)
            scale[k - 3] = 1.0 + s
            d.scale_frame([q], scale)
        out.append(d.evaluate())
        d.reset()
    return ((out[0] - out[1]) / (2 * h)).reshape(-1)


@pytest.mark.parametrize("level", [0, 1])
def test_pbffd_frame_sensitivities_match_central_differences(pbffd, level):
    d = pbffd
    d.level = level
    W = d.frame_sensitivities()
    M, E = d.point_count, d.ebf_count
    assert isinstance(W, scipy.csr_matrix) and W.shape == (3 * M, 6 * E)
    worst = 0.0
    for q in range(0, E, max(1, E // 4)):
        for k in range(6):
            col = W[:, 6 * q + k].toarray().reshape(-1)
            fd = fd_column(d, q, k, 1e-4)
            scale = max(np.abs(col).max(), np.abs(fd).max(), 1e-300)
            worst = max(worst, np.abs(col - fd).max() / scale)
    assert worst <= 1e-8
    # another level than the one shown
    other = d.frame_sensitivities(1 - level)
    assert other.shape[0] == 3 * M


def test_pbffd_frame_sensitivities_errors(pbffd):
    with pytest.raises(ffdkit.RangeError):
        pbffd.frame_sensitivities(5)


@pytest.fixture
def tspline(cow):
    return ffdkit.Rig.load({"version": 1, "deformer": "tspline", "resolution": [5, 5, 5]}).deformer(cow)


@pytest.mark.parametrize("soft", [False, True])
def test_tspline_arap_products_are_adjoint(tspline, soft):
    d = tspline
    _, _, point_controls = d.proxy_arrays()
    handles = np.unique(point_controls)[::7][:6]
    rng = np.random.default_rng(3)
    v = rng.standard_normal((len(handles), 3))
    w = rng.standard_normal((d.point_count, 3))
    Wv = d.arap_sensitivity_product(handles, v, soft=soft)
    Wtw = d.arap_sensitivity_transpose_product(handles, w, soft=soft)
    assert Wv.shape == (d.point_count, 3) and Wtw.shape == (len(handles), 3)
    assert np.abs(Wv).max() > 0
    assert np.isclose(np.vdot(Wv, w), np.vdot(v, Wtw), rtol=1e-10, atol=1e-12)
    rest = d.evaluate()
    assert np.array_equal(d.evaluate(), rest)  # nothing moved


def test_tspline_arap_translation(tspline):
    d = tspline
    _, _, point_controls = d.proxy_arrays()
    handles = np.unique(point_controls)
    v = np.tile([0.5, -1.0, 2.0], (len(handles), 1))
    Wv = d.arap_sensitivity_product(handles, v)
    assert np.allclose(Wv, [0.5, -1.0, 2.0], atol=1e-9)


def test_tspline_arap_errors(tspline):
    with pytest.raises(ffdkit.RangeError):
        tspline.arap_sensitivity_product([10**6], np.zeros((1, 3)))
    with pytest.raises(ValueError):
        tspline.arap_sensitivity_product([0, 1], np.zeros((3, 3)))
