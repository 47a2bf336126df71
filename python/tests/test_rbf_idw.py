"""RBF and IDW through the generic ffdkit.Deformer, against a numpy
transcription of PyGeM's formulas (pygem/rbf_factory.py, pygem/rbf.py
_get_weights and __call__, pygem/idw.py __call__), to 1e-10 relative."""
import numpy as np
import pytest
from scipy.spatial.distance import cdist

import ffdkit
from conftest import EXAMPLES

# --- PyGeM, written out with numpy (the same operations as PyGeM's) ---


def gaussian_spline(X, r, k=2):
    return np.exp(-(X * X) / (r * r))


def multi_quadratic_biharmonic_spline(X, r, k=2):
    return np.sqrt((X * X) + (r * r))


def inv_multi_quadratic_biharmonic_spline(X, r, k=2):
    return 1.0 / (np.sqrt((X * X) + (r * r)))


def thin_plate_spline(X, r, k=2):
    arg = X / r
    result = np.power(arg, k)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(arg > 0, result * np.log(arg), result)


def beckert_wendland_c2_basis(X, r, k=2):
    arg = X / r
    first = np.where((1 - arg) > 0, np.power((1 - arg), 4), 0)
    return first * ((4 * arg) + 1)


def polyharmonic_spline(X, r, k=2):
    r_sc = X / r
    if k & 1:
        return np.power(r_sc, k)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(r_sc < 1, np.power(r_sc, k - 1) * np.log(np.power(r_sc, r_sc)),
                        np.power(r_sc, k) * np.log(r_sc))


KERNELS = {f.__name__: f for f in (gaussian_spline, multi_quadratic_biharmonic_spline,
                                    inv_multi_quadratic_biharmonic_spline, thin_plate_spline,
                                    beckert_wendland_c2_basis, polyharmonic_spline)}


def pygem_rbf(original, deformed, kernel, radius, k, points):
    n = len(original)
    H = np.zeros((n + 4, n + 4))
    H[:n, :n] = KERNELS[kernel](cdist(original, original), radius, k)
    H[n, :n] = 1.0
    H[:n, n] = 1.0
    H[:n, -3:] = original
    H[-3:, :n] = original.T
    rhs = np.zeros((n + 4, 3))
    rhs[:n, :] = deformed
    weights = np.linalg.solve(H, rhs)
    A = np.zeros((len(points), n + 4))
    A[:, :n] = KERNELS[kernel](cdist(points, original), radius, k)
    A[:, n] = 1.0
    A[:, -3:] = points
    return A.dot(weights)


def pygem_idw(original, deformed, power, points):
    displ = deformed - original
    dist = cdist(points, original, lambda u, v: np.linalg.norm(u - v, ord=power))
    weights = np.zeros(dist.shape)
    for i, d in enumerate(dist):
        weights[i] = 1.0 / d if d.all() else np.where(d == 0.0, 1.0, 0.0)
    offset = np.array([np.sum(displ * wi[:, np.newaxis] / np.sum(wi), axis=0) for wi in weights])
    return points + offset


@pytest.fixture(scope="module")
def points():
    return np.ascontiguousarray(ffdkit.read_mesh(EXAMPLES / "lattice" / "bunny.obj").points[::5])


def control_set(points, count=20, seed=7):
    rng = np.random.default_rng(seed)
    lo, hi = points.min(0), points.max(0)
    original = lo + (hi - lo) * rng.random((count, 3))
    deformed = original + 0.3 * rng.standard_normal((count, 3))
    return original, deformed


def rel_error(got, want):
    return np.abs(got - want).max() / max(1.0, np.abs(want).max())


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("k", [2, 3])
def test_rbf_matches_pygem(points, kernel, k):
    original, deformed = control_set(points)
    radius = 4.0
    rig = ffdkit.Rig.load({"deformer": "rbf", "kernel": kernel, "radius": radius, "power": k,
                           "control_points": original.tolist(),
                           "deformed_control_points": deformed.tolist()})
    got = rig.deformer(points).evaluate()
    want = pygem_rbf(original, deformed, kernel, radius, k, points)
    assert rel_error(got, want) <= 1e-10, kernel


@pytest.mark.parametrize("power", [1, 2, 3])
def test_idw_matches_pygem(points, power):
    original, deformed = control_set(points, seed=power)
    original[0] = points[3]  # a point on a control point takes its displacement
    rig = ffdkit.Rig.load({"deformer": "idw", "power": power, "control_points": original.tolist(),
                           "deformed_control_points": deformed.tolist()})
    got = rig.deformer(points).evaluate()
    want = pygem_idw(original, deformed, power, points)
    assert rel_error(got, want) <= 1e-10
    np.testing.assert_array_equal(got[3], points[3] + (deformed[0] - original[0]))


@pytest.mark.parametrize("method", ["rbf", "idw"])
def test_identity_controls_and_solve(points, method):
    original, _ = control_set(points)
    d = ffdkit.Rig.load({"deformer": method, "control_points": original.tolist(),
                         **({"kernel": "thin_plate_spline", "radius": 3.0} if method == "rbf" else {})}
                        ).deformer(points)
    assert d.method == method and d.control_count == len(original)
    assert d.evaluate().tobytes() == points.tobytes()
    np.testing.assert_array_equal(d.controls, original)
    d.move([2], [[0.0, 0.5, 0.0]])
    assert not np.array_equal(d.evaluate(), points)
    target = points[[10, 40]] + [[0.2, 0.1, 0.0], [0.0, -0.3, 0.1]]
    result = d.solve([10, 40], target)
    assert result.max_residual <= 1e-9
    np.testing.assert_allclose(d.evaluate()[[10, 40]], target, atol=1e-9)
    W = d.sensitivities()
    assert W.shape == (len(points), len(original))
    d.reset()
    assert d.evaluate().tobytes() == points.tobytes()


def test_prm_files_read():
    for method, path in (("rbf", EXAMPLES / "rbf" / "cube.prm"), ("idw", EXAMPLES / "idw" / "cube.prm")):
        rig = ffdkit.Rig.load(path)
        out = rig.deformer(np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]])).evaluate()
        np.testing.assert_allclose(out[0], [1.5, 1.6, 1.7], atol=1e-12)
        assert rig.method == method
