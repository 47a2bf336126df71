"""ffdkit.pygem.FFD against an independent transcription of PyGeM's FFD formula.

The reference below is written from the formula (docs/pygem.md "The deformation"), not from
ffdkit: the rotation comes from scipy's intrinsic x-y-z Euler angles, psi is a linear solve,
the Bernstein polynomials are binom(d, i) (1 - t)^(d - i) t^i with math.comb, and PyGeM's
closed-unit-cube inside test decides which points move.
"""

import math
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import ffdkit
from ffdkit.pygem import FFD

REPO = Path(__file__).resolve().parents[2]
PRM_EXAMPLE = REPO / "examples" / "lattice" / "pygem" / "ffd.prm"
BUNNY = REPO / "examples" / "lattice" / "bunny.obj"


def reference_rotation(angles_deg):
    from scipy.spatial.transform import Rotation

    # PyGeM: R = Rx(ax) Ry(ay) Rz(az) on column vectors = intrinsic rotations X, then Y, then Z
    return Rotation.from_euler("XYZ", angles_deg, degrees=True).as_matrix()


def bernstein(degree, t):
    return np.stack([math.comb(degree, i) * (1.0 - t) ** (degree - i) * t**i
                     for i in range(degree + 1)])


def reference_ffd(points, length, origin, angles, mu_x, mu_y, mu_z, extrapolate=False):
    """PyGeM's FFD.__call__ from the formula: psi, T, psi^-1; outside the closed unit cube the
    point is returned unchanged unless extrapolate."""
    m = reference_rotation(angles) @ np.diag(length)
    y = np.linalg.solve(m, (points - origin).T).T
    bx, by, bz = (bernstein(mu_x.shape[a] - 1, y[:, a]) for a in range(3))
    mu = np.stack([mu_x, mu_y, mu_z], axis=-1)
    shift = np.einsum("in,jn,kn,ijkc->nc", bx, by, bz, mu)
    deformed = origin + (y + shift) @ m.T
    if extrapolate:
        return deformed
    inside = np.all((y >= 0.0) & (y <= 1.0), axis=1)
    out = points.copy()
    out[inside] = deformed[inside]
    return out


def random_ffd(rng, outside="fixed", max_n=6):
    n = rng.integers(1, max_n + 1, size=3)
    ffd = FFD(n, outside=outside)
    ffd.box_length = rng.uniform(0.2, 5.0, size=3)
    ffd.box_origin = rng.uniform(-3.0, 3.0, size=3)
    ffd.rot_angle = rng.uniform(-180.0, 180.0, size=3)
    for a in (ffd.array_mu_x, ffd.array_mu_y, ffd.array_mu_z):
        a[...] = rng.uniform(-0.3, 0.3, size=a.shape)
    return ffd


def points_around(rng, ffd, count):
    """Points in and around the box: reference coordinates in [-0.5, 1.5]^3."""
    y = rng.uniform(-0.5, 1.5, size=(count, 3))
    m = reference_rotation(ffd.rot_angle) @ np.diag(ffd.box_length)
    return ffd.box_origin + y @ m.T


def assert_close(got, want):
    scale = max(1.0, float(np.max(np.abs(want))))
    err = float(np.max(np.abs(got - want))) / scale if len(want) else 0.0
    assert err <= 1e-12, f"max relative error {err:.3e}"


def reference_of(ffd, points, extrapolate=False):
    return reference_ffd(points, ffd.box_length, ffd.box_origin, ffd.rot_angle,
                         ffd.array_mu_x, ffd.array_mu_y, ffd.array_mu_z, extrapolate)


@pytest.mark.parametrize("seed", range(20))
def test_random_rotated_boxes_match_formula(seed):
    rng = np.random.default_rng(seed)
    ffd = random_ffd(rng)
    pts = points_around(rng, ffd, 2000)
    got = ffd(pts)
    want = reference_of(ffd, pts)
    assert got.shape == pts.shape and got.dtype == np.float64
    assert_close(got, want)
    m = reference_rotation(ffd.rot_angle) @ np.diag(ffd.box_length)
    y = np.linalg.solve(m, (pts - ffd.box_origin).T).T
    outside = np.any((y < -1e-9) | (y > 1 + 1e-9), axis=1)
    assert outside.sum() > 100 and (~outside).sum() > 100
    # PyGeM returns outside points unchanged: bit for bit
    assert np.array_equal(got[outside], pts[outside])
    assert not np.array_equal(got[~outside], pts[~outside])


@pytest.mark.parametrize("seed", range(10))
def test_extrapolate_continues_the_polynomials(seed):
    rng = np.random.default_rng(100 + seed)
    ffd = random_ffd(rng, outside="extrapolate")
    pts = points_around(rng, ffd, 2000)
    assert_close(ffd(pts), reference_of(ffd, pts, extrapolate=True))


def test_T_psi_compose_to_the_map():
    rng = np.random.default_rng(7)
    ffd = random_ffd(rng)
    y = rng.uniform(-0.5, 1.5, size=(500, 3))
    pts = ffd.inverse_psi(y) + ffd.box_origin
    assert_close(ffd.psi(pts - ffd.box_origin), y)
    # T has no inside test (PyGeM's T deforms whatever it is given)
    assert_close(ffd.inverse_psi(ffd.T(y)) + ffd.box_origin, reference_of(ffd, pts, True))


def test_rotation_and_vertices_pinned_to_pygem_tests():
    # pygem tests/test_ffd.py: parameters_sphere.prm angles (20.3, 11, 0)
    ffd = FFD()
    ffd.rot_angle = np.array([20.3, 11.0, 0.0])
    want = np.array([[0.98162718, 0.0, 0.190809],
                     [0.06619844, 0.93788893, -0.34056147],
                     [-0.17895765, 0.34693565, 0.92065727]])
    np.testing.assert_allclose(ffd.rotation_matrix, want, atol=1e-8)
    ffd.box_origin = np.array([1.0, 2.0, 3.0])
    ffd.box_length = np.array([2.0, 3.0, 4.0])
    pv = ffd.position_vertices
    np.testing.assert_array_equal(pv[0], ffd.box_origin)
    np.testing.assert_allclose(pv[1:], ffd.box_origin + (want * ffd.box_length).T, atol=1e-7)


def test_identity_returns_the_same_bits():
    rng = np.random.default_rng(3)
    ffd = random_ffd(rng)
    ffd.reset_weights()
    pts = points_around(rng, ffd, 1000)
    got = ffd(pts)
    assert np.array_equal(got.view(np.uint64), pts.view(np.uint64))
    assert not np.shares_memory(got, pts)


def test_input_is_not_modified_and_dtypes_convert():
    rng = np.random.default_rng(4)
    ffd = random_ffd(rng)
    pts = points_around(rng, ffd, 300)
    before = pts.copy()
    want = ffd(pts)
    assert np.array_equal(pts, before)
    assert np.array_equal(ffd(np.asfortranarray(pts)), want)
    assert np.array_equal(ffd(pts.tolist()), want)
    assert np.array_equal(ffd(pts.astype(np.float32)), ffd(pts.astype(np.float32).astype(float)))
    ints = np.array([[0, 0, 0], [1, 1, 1]])
    assert ffd(ints).dtype == np.float64
    assert ffd(np.zeros((0, 3))).shape == (0, 3)


def test_attribute_changes_are_seen():
    rng = np.random.default_rng(5)
    ffd = random_ffd(rng)
    pts = points_around(rng, ffd, 200)
    first = ffd(pts)
    ffd.array_mu_y[0, 0, 0] += 0.25
    assert_close(ffd(pts), reference_of(ffd, pts))
    assert not np.array_equal(ffd(pts), first)
    ffd.box_origin = ffd.box_origin + 0.1
    assert_close(ffd(pts), reference_of(ffd, pts))


def test_control_points():
    rng = np.random.default_rng(6)
    ffd = random_ffd(rng)
    n = ffd.n_control_points
    rot = reference_rotation(ffd.rot_angle)
    rest = ffd.control_points(deformed=False)
    moved = ffd.control_points()
    for i in range(n[0]):
        for j in range(n[1]):
            for k in range(n[2]):
                row = (i * n[1] + j) * n[2] + k
                t = np.array([i / max(n[0] - 1, 1), j / max(n[1] - 1, 1), k / max(n[2] - 1, 1)])
                mu = np.array([ffd.array_mu_x[i, j, k], ffd.array_mu_y[i, j, k],
                               ffd.array_mu_z[i, j, k]])
                np.testing.assert_allclose(rest[row], ffd.box_origin + rot @ (t * ffd.box_length),
                                           atol=1e-12)
                np.testing.assert_allclose(moved[row],
                                           ffd.box_origin + rot @ ((t + mu) * ffd.box_length),
                                           atol=1e-12)


def test_prm_round_trip(tmp_path):
    rng = np.random.default_rng(8)
    ffd = random_ffd(rng)
    path = str(tmp_path / "p.prm")
    ffd.write_parameters(path)
    back = FFD()
    back.read_parameters(path)
    for name in ("n_control_points", "box_length", "box_origin", "rot_angle",
                 "array_mu_x", "array_mu_y", "array_mu_z"):
        assert np.array_equal(getattr(back, name), getattr(ffd, name)), name
    pts = points_around(rng, ffd, 200)
    assert np.array_equal(back(pts), ffd(pts))
    # PyGeM reads any file name, not only *.prm
    other = str(tmp_path / "parameters.txt")
    ffd.write_parameters(other)
    back = FFD()
    back.read_parameters(other)
    assert np.array_equal(back.array_mu_z, ffd.array_mu_z)
    # the file ffdkit's own .prm reader applies gives the same map (for n >= 2 on every axis)
    ffd2 = random_ffd(rng)
    ffd2.n_control_points = [3, 4, 2]
    ffd2.array_mu_z[1, 2, 1] = 0.2
    ffd2.write_parameters(path)
    pts = points_around(rng, ffd2, 300)
    assert_close(ffdkit.Rig.load(path).apply(pts), ffd2(pts))


def test_read_missing_file_writes_defaults(tmp_path):
    path = tmp_path / "parameters.prm"
    ffd = FFD([3, 2, 2])
    ffd.read_parameters(str(path))  # PyGeM: a missing file is written with the current values
    assert path.is_file()
    back = FFD()
    back.read_parameters(str(path))
    assert back.n_control_points.tolist() == [3, 2, 2]


def find_ffd_cli():
    env = os.environ.get("FFD_BIN")
    if env:
        return env
    here = Path(os.path.abspath(ffdkit.__file__))
    for parent in here.parents:
        if (parent / "ffd").is_file() and os.access(parent / "ffd", os.X_OK):
            return str(parent / "ffd")
    return shutil.which("ffd")


def test_example_prm_gives_what_ffd_deform_gives(tmp_path):
    ffd = FFD()
    ffd.read_parameters(str(PRM_EXAMPLE))
    assert ffd.n_control_points.tolist() != [2, 2, 2] or np.any(ffd.array_mu_x)
    mesh = ffdkit.read_mesh(str(BUNNY))
    pts = np.array(mesh.points)
    got = ffd(pts)
    assert_close(got, reference_of(ffd, pts))
    cli = find_ffd_cli()
    if cli is None:
        pytest.skip("the ffd command is not built (set FFD_BIN)")
    out = tmp_path / "out.obj"
    subprocess.run([cli, "deform", str(BUNNY), "-o", str(out), "--rig", str(PRM_EXAMPLE)],
                   check=True, capture_output=True)
    # ffd deform writes shortest round-trip decimals: the same doubles
    assert np.array_equal(np.array(ffdkit.read_mesh(str(out)).points), got)


def test_single_control_point_axis_is_a_constant_shift():
    ffd = FFD([1, 3, 2])
    ffd.array_mu_x[0, 1, 0] = 0.3
    ffd.array_mu_z[0, 2, 1] = -0.2
    rng = np.random.default_rng(9)
    pts = points_around(rng, ffd, 500)
    assert_close(ffd(pts), reference_of(ffd, pts))


def test_reflect():
    rng = np.random.default_rng(10)
    for axis in range(3):
        ffd = random_ffd(rng, max_n=4)
        ffd.n_control_points = [3, 3, 3]
        for a in (ffd.array_mu_x, ffd.array_mu_y, ffd.array_mu_z):
            a[...] = rng.uniform(-0.2, 0.2, size=a.shape)
        plane = [slice(None)] * 3
        plane[axis] = -1
        (ffd.array_mu_x, ffd.array_mu_y, ffd.array_mu_z)[axis][tuple(plane)] = 0.0
        mus = [a.copy() for a in (ffd.array_mu_x, ffd.array_mu_y, ffd.array_mu_z)]
        length = ffd.box_length.copy()
        r = ffd.reflect(axis, in_place=False)
        assert ffd.n_control_points.tolist() == [3, 3, 3]
        assert r.n_control_points[axis] == 5 and r.box_length[axis] == 2 * length[axis]
        for c, name in enumerate(("array_mu_x", "array_mu_y", "array_mu_z")):
            got = getattr(r, name)
            for idx in np.ndindex(*got.shape):
                src = list(idx)
                sign = 1.0
                if idx[axis] > 2:
                    src[axis] = 4 - idx[axis]
                    sign = -1.0 if c == axis else 1.0
                assert got[idx] == sign * mus[c][tuple(src)]
        pts = points_around(rng, r, 300)
        assert_close(r(pts), reference_of(r, pts))
        assert ffd.reflect(axis) is None and ffd.n_control_points[axis] == 5
    bad = FFD([2, 2, 2])
    bad.array_mu_x[-1, 0, 0] = 0.1
    with pytest.raises(RuntimeError):
        bad.reflect(0)
    with pytest.raises(ValueError):
        bad.reflect(3)


def test_str_lists_the_parameters():
    s = str(FFD([2, 3, 4]))
    for word in ("n_control_points", "box_length", "box_origin", "rot_angle", "array_mu_x",
                 "rotation_matrix", "position_vertices"):
        assert word in s


# ---------------------------------------------------------------------- bad input

def test_bad_point_shapes_and_types():
    ffd = FFD()
    for shape in [(3,), (4, 2), (2, 4), (1, 3, 1)]:
        with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
            ffd(np.zeros(shape))
    with pytest.raises(TypeError):
        ffd(np.array([["a", "b", "c"]]))
    with pytest.raises(TypeError):
        ffd(np.zeros((2, 3), dtype=complex))


def test_bad_attributes():
    ffd = FFD()
    ffd.array_mu_x = np.zeros((3, 2, 2))
    with pytest.raises(ValueError, match="array_mu_x"):
        ffd(np.zeros((1, 3)))
    ffd = FFD()
    ffd.box_length = [1.0, 2.0]
    with pytest.raises(ValueError, match="box_length"):
        ffd(np.zeros((1, 3)))
    ffd = FFD()
    ffd.box_length = [1.0, 0.0, 1.0]
    with pytest.raises(ffdkit.InvalidError):
        ffd(np.zeros((1, 3)))
    ffd = FFD()
    ffd.rot_angle = [np.nan, 0, 0]
    with pytest.raises(ValueError, match="rot_angle"):
        ffd(np.zeros((1, 3)))
    for n in ([2, 2], [0, 2, 2], [2.5, 2, 2]):
        with pytest.raises(ValueError):
            FFD(n)
    with pytest.raises(ValueError):
        FFD(outside="clamp")
    with pytest.raises(TypeError):
        FFD().read_parameters(3)
    with pytest.raises(TypeError):
        FFD().write_parameters(None)


def test_malformed_prm_names_the_line(tmp_path):
    text = PRM_EXAMPLE.read_text().splitlines()
    line = next(i for i, t in enumerate(text) if t.lower().startswith("box length y"))
    text[line] = "box length y: one"
    path = tmp_path / "bad.prm"
    path.write_text("\n".join(text) + "\n")
    ffd = FFD()
    before = str(ffd)
    with pytest.raises(ffdkit.ParseError) as e:
        ffd.read_parameters(str(path))
    assert f"bad.prm:{line + 1}:" in str(e.value)
    assert e.value.status == "parse error"
    assert str(ffd) == before  # nothing read on failure

    path.write_text("[Box info]\nn control points x: 2\n")
    with pytest.raises(ffdkit.Error):
        FFD().read_parameters(str(path))


def test_bound_deformer_loop_as_documented():
    # docs/python.md, "Speed": the drop-in's rig, bound once, driven by new weights
    rng = np.random.default_rng(11)
    ffd = random_ffd(rng)
    ffd.n_control_points = [4, 3, 5]
    pts = points_around(rng, ffd, 1000)
    ffd.reset_weights()
    d = ffd.rig().deformer(pts)
    rest = np.array(d.controls)
    M = ffd.rotation_matrix * ffd.box_length
    new_points = np.empty_like(pts)
    for _ in range(3):
        mu = rng.uniform(-0.3, 0.3, size=(4, 3, 5, 3))
        d.controls = rest + mu.reshape(-1, 3) @ M.T
        d.evaluate(out=new_points)
        ffd.array_mu_x, ffd.array_mu_y, ffd.array_mu_z = (mu[..., a].copy() for a in range(3))
        assert_close(new_points, reference_of(ffd, pts))
        assert_close(new_points, ffd(pts))


def test_repeated_calls_give_the_rig_apply_bits():
    """__call__ keeps its lattice and binding between calls; every call still gives
    exactly rig().apply's bits: new weights, points changed in place (a -0.0 for a
    0.0 included), other points, a changed box, the other outside rule."""
    rng = np.random.default_rng(11)
    for outside in ("fixed", "extrapolate"):
        ffd = random_ffd(rng, outside=outside)
        pts = points_around(rng, ffd, 500)
        pts[0] = 0.0
        for step in range(7):
            if step == 1:
                ffd.array_mu_x[...] = rng.uniform(-0.3, 0.3, size=ffd.array_mu_x.shape)
            elif step == 2:
                pts[0] = -0.0  # equal as numbers, not as bits: must rebind
            elif step == 3:
                pts[7] += 0.01
            elif step == 4:
                pts = points_around(rng, ffd, 300)
            elif step == 5:
                ffd.box_length = ffd.box_length * 1.1
            elif step == 6:
                ffd.array_mu_z[...] = 0.0
                ffd.array_mu_x[...] = 0.0
                ffd.array_mu_y[...] = 0.0
            got = ffd(pts)
            want = ffd.rig().apply(pts)
            assert got.view(np.uint64).tolist() == want.view(np.uint64).tolist(), (outside, step)
        assert got.view(np.uint64).tolist() == pts.view(np.uint64).tolist()  # identity: same bits
