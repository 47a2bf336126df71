"""ffdkit.Rig: loading from paths, dicts and text; apply to points and meshes,
against the ffd command; out=; errors naming their line or key."""
import subprocess
import sys

import numpy as np
import pytest

import ffdkit
from conftest import EXAMPLES

BUNNY = EXAMPLES / "lattice" / "bunny.obj"
BEND = EXAMPLES / "lattice" / "bend.json"
IDENTITY = {"version": 1, "deformer": "lattice", "resolution": [4, 4, 4], "box": "auto"}


def test_load_sources():
    r = ffdkit.Rig.load(BEND)
    assert isinstance(r, ffdkit.Rig) and r.method == "lattice" and r.name.endswith("bend.json")
    assert ffdkit.Rig.load(str(BEND)).method == "lattice"
    assert ffdkit.Rig.load(BEND.read_text()).name == "<string>"
    assert ffdkit.Rig.load(IDENTITY).name == "<dict>"
    assert ffdkit.Rig.load(EXAMPLES / "lattice" / "pygem" / "ffd.prm").method == "lattice"
    assert ffdkit.Rig.load(EXAMPLES / "pbffd" / "cow-drag.json").method == "pbffd"
    assert ffdkit.Rig.load(EXAMPLES / "gffd" / "twist.json").method == "gffd"
    assert ffdkit.Rig.load(EXAMPLES / "tspline" / "bunny-ears.json").method == "tspline"
    with pytest.raises(TypeError):
        ffdkit.Rig()
    with pytest.raises(TypeError, match="source"):
        ffdkit.Rig.load(42)
    with pytest.raises(TypeError, match="bytes"):
        ffdkit.Rig.load(b"{}")


def test_load_errors_name_line_and_key(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{\n  "deformer": "lattice",\n  "resolution": [4, 4,\n}\n')
    with pytest.raises(ffdkit.ParseError, match=r"bad\.json:4") as e:
        ffdkit.Rig.load(bad)
    assert e.value.status == "parse error" and isinstance(e.value, ValueError)
    with pytest.raises(ffdkit.ParseError, match=r"<dict>: moves\[0\]"):
        ffdkit.Rig.load({"deformer": "lattice", "resolution": [3, 3, 3],
                         "moves": [{"index": [0, 0, 0], "delta": [1, 2]}]})
    with pytest.raises(ffdkit.ParseError, match="nosuchkey"):
        ffdkit.Rig.load('{"deformer": "lattice", "nosuchkey": 1}', name="mine.json")
    with pytest.raises(ffdkit.FileError, match="missing.json"):
        ffdkit.Rig.load(tmp_path / "missing.json")
    with pytest.raises(ValueError):  # NaN is not JSON
        ffdkit.Rig.load({"deformer": "lattice", "margin": float("nan")})


def test_identity_keeps_the_bits():
    m = ffdkit.read_mesh(BUNNY)
    rig = ffdkit.Rig.load(IDENTITY)
    out = rig.apply(m.points)
    assert out.tobytes() == m.points.tobytes()
    before = m.to_bytes()
    rep = rig.apply(m)
    assert m.to_bytes() == before and rep["method"] == "lattice"


def test_apply_points_equals_ffd_deform(tmp_path, ffd_cli):
    out = tmp_path / "bent.obj"
    subprocess.run([str(ffd_cli), "deform", str(BUNNY), "-o", str(out), "--rig", str(BEND)], check=True,
                   capture_output=True)
    want = ffdkit.read_mesh(out).points
    rig = ffdkit.Rig.load(BEND)
    mesh = ffdkit.read_mesh(BUNNY)
    got = rig.apply(mesh.points)
    assert got.tobytes() == want.tobytes()
    # a Mesh is deformed in place; writing it gives the command's file
    rep = rig.apply(mesh)
    assert mesh.points.tobytes() == want.tobytes()
    ffdkit.write_mesh(mesh, tmp_path / "again.obj")
    assert (tmp_path / "again.obj").read_bytes() == out.read_bytes()
    assert set(rep) >= {"method", "residuals", "reached", "rank", "max_residual", "outside_count",
                        "timings", "control_points", "resolution", "notes", "details"}
    assert rep["control_points"].shape == (125, 3)


def test_apply_constraints_report(tmp_path):
    rig = ffdkit.Rig.load(EXAMPLES / "lattice" / "pins.json")
    mesh = ffdkit.read_mesh(BUNNY)
    rep = rig.apply(mesh)
    assert rep["constraint_count"] == 6 and rep["residuals"].shape == (6,)
    assert rep["reached"].shape == (6, 3) and rep["max_residual"] < 1e-6
    np.testing.assert_allclose(mesh.points[553], [2.0, 8.4, -1.0], atol=1e-6)


def test_apply_out_and_conversions():
    rig = ffdkit.Rig.load(BEND)
    p = np.ascontiguousarray(ffdkit.read_mesh(BUNNY).points)
    want = rig.apply(p)
    out = np.empty_like(p)
    r = rig.apply(p, out=out)
    assert r is out and np.shares_memory(r, out) and out.tobytes() == want.tobytes()
    # other dtypes and layouts are converted once
    np.testing.assert_array_equal(rig.apply(np.asfortranarray(p)), want)
    np.testing.assert_array_equal(rig.apply(p.tolist()), want)
    np.testing.assert_allclose(rig.apply(p.astype(np.float32)), rig.apply(p.astype(np.float32).astype(float)))
    for bad in (np.empty((len(p), 3), np.float32), np.empty((len(p) + 1, 3)), np.empty((3, len(p))).T,
                np.empty((len(p), 3))[:, :], [[0.0] * 3] * len(p)):
        if isinstance(bad, np.ndarray) and bad.flags.c_contiguous and bad.dtype == np.float64 \
                and bad.shape == p.shape:
            continue
        with pytest.raises(ValueError, match="out"):
            rig.apply(p, out=bad)
    ro = np.empty_like(p)
    ro.flags.writeable = False
    with pytest.raises(ValueError, match="read-only"):
        rig.apply(p, out=ro)
    with pytest.raises(ValueError, match="out"):
        rig.apply(ffdkit.read_mesh(BUNNY), out=np.empty_like(p))
    with pytest.raises(ValueError, match=r"points: expected an \(N, 3\) array, got shape \(5,\)"):
        rig.apply(np.zeros(5))
    with pytest.raises(TypeError, match="points"):
        rig.apply(np.array([["a", "b", "c"]]))
    with pytest.raises(TypeError):
        rig.apply(None)
    with pytest.raises(ffdkit.NonFiniteError):
        rig.apply(np.array([[0, 0, np.nan]]))


def test_apply_limits():
    rig = ffdkit.Rig.load(BEND)
    p = ffdkit.read_mesh(BUNNY).points
    with pytest.raises(ffdkit.InvalidError, match="limit"):
        rig.apply(p, limits={"max_work": 1})
    np.testing.assert_array_equal(rig.apply(p, limits={"unlimited": True}), rig.apply(p))
    with pytest.raises(ValueError, match="limits"):
        rig.apply(p, limits={"speed": 1})
    with pytest.raises(TypeError, match="limits"):
        rig.apply(p, limits=3)


def test_apply_to_mesh_with_live_views_is_safe():
    """A rig that replaces the mesh (GFFD resampling) while views are alive."""
    mesh = ffdkit.read_mesh(EXAMPLES / "gffd" / "elephant.off")
    view = mesh.points
    kept = view.copy()
    faces = mesh.face_indices
    rig = ffdkit.Rig.load(EXAMPLES / "gffd" / "bend.json")
    rig.apply(mesh)
    assert mesh.vertex_count > len(kept)  # resampled: more vertices
    np.testing.assert_array_equal(view, kept)  # the old view is still readable memory
    assert faces.sum() >= 0
    # without views the mesh changes in place
    m2 = ffdkit.read_mesh(EXAMPLES / "gffd" / "elephant.off")
    rig.apply(m2)
    np.testing.assert_array_equal(m2.points, mesh.points)


def test_apply_points_refuses_a_refining_rig():
    rig = ffdkit.Rig.load(EXAMPLES / "gffd" / "bend.json")
    pts = ffdkit.read_mesh(EXAMPLES / "gffd" / "elephant.off").points
    try:
        out = rig.apply(pts)
    except ffdkit.Error as e:
        assert isinstance(e, (ffdkit.UnsupportedError, ffdkit.InvalidError)), e
    else:
        assert out.shape == pts.shape


def gffd_rig_without_resampling(rig_path):
    """A GFFD example rig without "resample" (which a deformer cannot replay)."""
    import json

    doc = json.loads((EXAMPLES / rig_path).read_text())
    doc.pop("resample", None)
    return ffdkit.Rig.load(doc, name=str(EXAMPLES / rig_path))


def test_every_method_apply_equals_deformer(tmp_path):
    for rig_path, mesh_path in [("pbffd/cow-drag.json", "pbffd/cow.off"),
                                ("tspline/bunny-ears.json", "tspline/bunny.obj"),
                                ("gffd/twist.json", "gffd/bunny.obj")]:
        rig = ffdkit.Rig.load(EXAMPLES / rig_path)
        if rig.method == "gffd":
            rig = gffd_rig_without_resampling(rig_path)
        mesh = ffdkit.read_mesh(EXAMPLES / mesh_path)
        d = rig.deformer(mesh)
        got = d.evaluate()
        rig.apply(mesh)  # in place
        np.testing.assert_allclose(got, mesh.points, atol=1e-9, err_msg=rig_path)


def test_apply_refcounts():
    rig = ffdkit.Rig.load(BEND)
    p = np.ascontiguousarray(ffdkit.read_mesh(BUNNY).points[:50])
    out = np.empty_like(p)
    rp, ro, rr = sys.getrefcount(p), sys.getrefcount(out), sys.getrefcount(rig)
    for _ in range(2000):
        rig.apply(p, out=out)
    assert (sys.getrefcount(p), sys.getrefcount(out), sys.getrefcount(rig)) == (rp, ro, rr)
