"""Deformer.sensitivities, sensitivity_product, sensitivity_transpose_product
(docs/sensitivities.md): W against central differences of evaluate, the
products against W and against each other, --expand's Kronecker form, out=,
and GFFD refused."""

import numpy as np
import pytest

import ffdkit
from test_deformer import gffd_deformer, linear_deformers

scipy_sparse = pytest.importorskip("scipy.sparse")


def test_matches_central_differences():
    for d in linear_deformers():
        W = d.sensitivities()
        assert isinstance(W, scipy_sparse.csr_matrix)
        assert W.shape == (d.point_count, d.control_count)
        assert W.has_sorted_indices
        P = np.array(d.controls)
        h = 1e-3 * np.linalg.norm(np.ptp(P, axis=0))
        dense = W.toarray()
        for j in np.unique(W.indices[:: max(1, W.nnz // 6)]):
            for a in range(3):
                Pp, Pm = P.copy(), P.copy()
                Pp[j, a] += h
                Pm[j, a] -= h
                d.controls = Pp
                xp = d.evaluate()
                d.controls = Pm
                xm = d.evaluate()
                d.controls = P
                fd = (xp - xm) / (2 * h)
                want = np.zeros_like(fd)
                want[:, a] = dense[:, j]
                np.testing.assert_allclose(fd, want, rtol=0, atol=1e-8, err_msg=d.method)


def test_products_and_expand():
    rng = np.random.default_rng(3)
    for d in linear_deformers():
        W = d.sensitivities()
        v = rng.standard_normal((d.control_count, 3))
        w = rng.standard_normal((d.point_count, 3))
        Wv = d.sensitivity_product(v)
        Wtw = d.sensitivity_transpose_product(w)
        assert Wv.shape == (d.point_count, 3) and Wtw.shape == (d.control_count, 3)
        np.testing.assert_allclose(Wv, W @ v, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(Wtw, W.T @ w, rtol=1e-12, atol=1e-10)
        assert abs(np.sum(Wv * w) - np.sum(v * Wtw)) <= 1e-10 * np.sum(np.abs(W) @ np.abs(v) * np.abs(w))
        E = d.sensitivities(expand=True)
        assert E.shape == (3 * d.point_count, 3 * d.control_count) and E.nnz == 3 * W.nnz
        np.testing.assert_allclose(E @ v.ravel(), (W @ v).ravel(), rtol=1e-12, atol=1e-12)
        # out=: written in place and returned
        out = np.empty((d.point_count, 3))
        assert d.sensitivity_product(v, out=out) is out
        np.testing.assert_array_equal(out, Wv)
        tout = np.empty((d.control_count, 3))
        assert d.sensitivity_transpose_product(w=w, out=tout) is tout
        np.testing.assert_array_equal(tout, Wtw)
        with pytest.raises(ValueError):
            d.sensitivity_product(v[:-1])
        with pytest.raises(ValueError):
            d.sensitivity_transpose_product(w, out=np.empty((d.control_count, 2)))


def test_follows_the_binding():
    d = next(linear_deformers())
    pts = np.array(d.evaluate())[:7] * 0.9
    d.bind(pts)
    W = d.sensitivities()
    assert W.shape == (7, d.control_count)
    np.testing.assert_allclose(W.sum(axis=1), 1, atol=1e-12)  # partition of unity inside


def test_gffd_refused():
    d = gffd_deformer()
    with pytest.raises(ffdkit.UnsupportedError, match="gffd"):
        d.sensitivities()
    with pytest.raises(ffdkit.UnsupportedError, match="gffd"):
        d.sensitivity_product(np.zeros((d.control_count, 3)))
    with pytest.raises(ffdkit.UnsupportedError, match="gffd"):
        d.sensitivity_transpose_product(np.zeros((d.point_count, 3)))

