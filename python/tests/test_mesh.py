"""ffdkit.Mesh, read_mesh, write_mesh: views without copies, losslessness, errors."""
import os
import sys

import numpy as np
import pytest

import ffdkit
from conftest import DATA, EXAMPLES

BUNNY = EXAMPLES / "lattice" / "bunny.obj"


def test_read_mesh_counts_and_views():
    m = ffdkit.read_mesh(BUNNY)
    assert isinstance(m, ffdkit.Mesh)
    assert m.format == "obj"
    assert m.points.shape == (m.vertex_count, 3) and m.points.dtype == np.float64
    assert m.points.flags.c_contiguous and not m.points.flags.writeable
    # the same memory every time: a view, not a copy
    assert np.shares_memory(m.points, m.points)
    with pytest.raises(ValueError):
        m.points[0, 0] = 1.0
    assert m.face_offsets.dtype == np.uint32 and len(m.face_offsets) == m.face_count + 1
    assert m.face_indices.dtype == np.uint32 and len(m.face_indices) == m.face_offsets[-1]
    assert m.faces.shape == (m.face_count, 3)
    info = m.info()
    assert info["vertex_count"] == m.vertex_count and info["closed"] is True
    np.testing.assert_array_equal(info["bbox_min"], m.points.min(axis=0))


def test_view_keeps_mesh_alive():
    p = ffdkit.read_mesh(BUNNY).points
    q = p.copy()
    import gc

    gc.collect()
    np.testing.assert_array_equal(p, q)


def test_mesh_from_arrays_and_faces():
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
    m = ffdkit.Mesh(pts, [[0, 1, 2, 3], [0, 1, 4]])
    assert m.format is None and m.vertex_count == 5 and m.face_count == 2
    np.testing.assert_array_equal(m.face_offsets, [0, 4, 7])
    faces = m.faces
    assert isinstance(faces, list) and [list(f) for f in faces] == [[0, 1, 2, 3], [0, 1, 4]]
    m2 = ffdkit.Mesh(pts, np.array([[0, 1, 2], [0, 2, 3]]))
    assert m2.faces.shape == (2, 3)
    assert ffdkit.Mesh(np.zeros((0, 3))).vertex_count == 0
    assert ffdkit.Mesh(pts).faces.shape == (0, 3)


def test_mesh_bad_inputs():
    with pytest.raises(ValueError, match=r"points: expected an \(N, 3\) array, got shape \(4, 2\)"):
        ffdkit.Mesh(np.zeros((4, 2)))
    with pytest.raises(TypeError, match="points"):
        ffdkit.Mesh([["a", "b", "c"]])
    with pytest.raises(TypeError):
        ffdkit.Mesh(None)
    with pytest.raises(IndexError, match=r"faces\[1\]\[2\]: vertex 9"):
        ffdkit.Mesh(np.zeros((3, 3)), [[0, 1, 2], [0, 1, 9]])
    with pytest.raises(TypeError, match="faces"):
        ffdkit.Mesh(np.zeros((3, 3)), [[0.5, 1, 2]])
    with pytest.raises(ValueError, match="faces"):
        ffdkit.Mesh(np.zeros((3, 3)), [[0, -1, 2]])
    with pytest.raises(ffdkit.NonFiniteError) as e:
        ffdkit.Mesh(np.array([[0, 0, np.nan]]))
    assert e.value.status == "non-finite number"


def test_read_errors_are_mapped(tmp_path):
    with pytest.raises(ffdkit.FileError) as e:
        ffdkit.read_mesh(tmp_path / "missing.obj")
    assert isinstance(e.value, OSError) and isinstance(e.value, ffdkit.Error)
    assert "missing.obj" in str(e.value) and e.value.status == "i/o error"
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(ffdkit.RangeError, match="bad.obj:4"):
        ffdkit.read_mesh(bad)
    bad.write_text("v 0 0 0\nv 1 zero 0\n")
    with pytest.raises(ffdkit.ParseError, match="bad.obj:2") as e:
        ffdkit.read_mesh(bad)
    assert isinstance(e.value, ValueError)
    with pytest.raises(ffdkit.FileError):
        ffdkit.read_mesh(tmp_path / "missing.obj", format="obj")
    with pytest.raises(ValueError, match="format"):
        ffdkit.read_mesh(BUNNY, format="fbx")


def test_write_is_lossless_and_atomic(tmp_path):
    for src in (BUNNY, DATA / "cow.off", DATA / "hinge.stl", DATA / "teapot.obj"):
        m = ffdkit.read_mesh(src)
        out = tmp_path / ("copy" + src.suffix)
        ffdkit.write_mesh(m, out)
        assert out.read_bytes() == src.read_bytes(), src
        assert m.to_bytes() == src.read_bytes()
    m = ffdkit.read_mesh(BUNNY)
    with pytest.raises(ffdkit.FileError):
        ffdkit.write_mesh(m, tmp_path / "no" / "such" / "dir.obj")
    with pytest.raises(TypeError):
        ffdkit.write_mesh(m.points, tmp_path / "x.obj")


def test_format_conversion_and_from_bytes(tmp_path):
    m = ffdkit.read_mesh(BUNNY)
    ply = m.to_bytes("ply", "binary")
    m2 = ffdkit.Mesh.from_bytes(ply, "ply", "bunny.ply")
    np.testing.assert_array_equal(m2.points, m.points)
    np.testing.assert_array_equal(m2.face_indices, m.face_indices)
    with pytest.raises(ValueError, match="format"):
        ffdkit.Mesh(m.points).to_bytes()
    with pytest.raises(ffdkit.ParseError, match="junk"):
        ffdkit.Mesh.from_bytes(b"ply\nformat nonsense\n", "ply", "junk")


def test_set_points_and_normals(tmp_path):
    m = ffdkit.read_mesh(BUNNY)
    view = m.points
    p = m.points.copy()
    m.points = p * 2.0
    np.testing.assert_array_equal(view, p * 2.0)  # the view sees the change
    m.set_points(p, jacobians=np.tile(np.eye(3), (len(p), 1, 1)))
    np.testing.assert_array_equal(m.points, p)
    with pytest.raises(ValueError, match=r"points: expected shape \(1839, 3\)"):
        m.points = p[:10]
    with pytest.raises(ValueError, match="jacobians"):
        m.set_points(p, jacobians=np.zeros((len(p), 4)))
    bad = p.copy()
    bad[5, 1] = np.inf
    with pytest.raises(ffdkit.NonFiniteError):
        m.points = bad
    np.testing.assert_array_equal(m.points, p)  # nothing changed
    with pytest.raises(AttributeError):
        del m.points


def test_refcounts_stable():
    m = ffdkit.read_mesh(BUNNY)
    before = sys.getrefcount(m)
    views = [m.points for _ in range(100)]
    assert sys.getrefcount(m) == before  # views hold the store, not the mesh
    del views
    p = np.ascontiguousarray(m.points)
    r0 = sys.getrefcount(p)
    for _ in range(10000):
        ffdkit.Mesh(p)
    assert sys.getrefcount(p) == r0
