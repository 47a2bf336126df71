"""Issue 19's acceptance: a hexahedral box of 1M nodes (101^3; 51^3 under the
sanitizers) and the tetrahedral mesh of a real part (data/volume/hinge_tet.msh,
made by Gmsh) are deformed by every linear method, written to every volume
format and encoding, and read back by meshio (an independent reader) with
identical cells, points and data.

Formats see only coordinates, cells and data, never the method, so the box is
written to every format once (its lattice deformation) and each other
method's result to one format each; the hinge goes through every method and
every format."""
import os

import numpy as np
import pytest

import ffdkit

meshio = pytest.importorskip("meshio")

DATA = os.path.join(os.path.dirname(__file__), "..", "..", "data")
SANITIZED = "asan" in os.environ.get("LD_PRELOAD", "")

# (extension, encoding, compress, float32 points?)
TARGETS = [
    ("vtk", "ascii", False), ("vtk", "binary_big_endian", False),
    ("vtu", "ascii", False), ("vtu", "base64", False), ("vtu", "raw", False),
    ("vtu", "base64", True),
    ("msh", "ascii", False), ("msh", "binary", False),
    ("su2", "ascii", False),
]


def rigs(points):
    lo, hi = points.min(axis=0), points.max(axis=0)
    size = hi - lo
    centre = (lo + hi) / 2
    return {
        "lattice": {"deformer": "lattice", "resolution": [4, 4, 4],
                    "moves": [{"index": [2, 2, 3], "delta": (0.1 * size).tolist()},
                              {"index": [1, 3, 1], "delta": [0.0, 0.05 * size[1], 0.0]}]},
        "bernstein": {"deformer": "lattice", "basis": "bernstein", "resolution": [3, 3, 3],
                      "moves": [{"index": [1, 1, 2], "delta": (0.08 * size).tolist()}]},
        "pbffd": {"deformer": "pbffd",
                  "controls": [{"center": (lo + f * size).tolist(), "radius": (0.6 * size).tolist()}
                               for f in (np.array([0.3, 0.3, 0.3]), np.array([0.7, 0.6, 0.5]),
                                         np.array([0.5, 0.7, 0.8]))],
                  "moves": [{"control": 1, "delta": (0.05 * size).tolist()}]},
        "tspline": {"deformer": "tspline", "resolution": [4, 4, 4],
                    "steps": [{"deform": {"handles": [
                        {"box": {"min": (centre + 0.2 * size).tolist(),
                                 "max": (hi + size).tolist()},
                         "delta": (0.05 * size).tolist()}]}}]},
    }


def box(n):
    """An n^3 grid of hexahedra on [0, 1]^3 with (n + 1)^3 nodes (VTK order)."""
    g = np.linspace(0.0, 1.0, n + 1)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    a = (i + (n + 1) * (j + (n + 1) * k)).ravel()  # i runs along x
    s, t = 1, n + 1
    u = (n + 1) ** 2
    hexes = np.column_stack([a, a + s, a + s + t, a + t, a + u, a + s + u, a + s + t + u, a + t + u])
    return ffdkit.Mesh(points, cells=[("hexahedron", hexes)])


def flat_cells(m):
    return [(b.type, tuple(c)) for b in m.cells for c in b.data.tolist()]


def our_cells(mesh):
    return [(name, tuple(c)) for name, data in mesh.cells for c in data.tolist()]


DIMENSION = {"vertex": 0, "line": 1, "triangle": 2, "quad": 2, "polygon": 2}


def write_and_check(mesh, path, ext, encoding, compress, expected_data=None):
    ffdkit.write_mesh(mesh, path, encoding=encoding, compress=compress)
    back = meshio.read(path)
    assert np.array_equal(np.asarray(back.points, dtype=np.float64), mesh.points), path
    expected = our_cells(mesh)
    if ext == "su2":  # SU2 holds the volume elements, then the markers' boundary elements
        expected = ([c for c in expected if DIMENSION.get(c[0], 3) == 3] +
                    [c for c in expected if DIMENSION.get(c[0], 3) == 2])
    assert flat_cells(back) == expected, path
    again = ffdkit.read_mesh(path)  # and our own reader agrees
    assert np.array_equal(again.points, mesh.points)
    assert our_cells(again) == expected
    for name, values in (expected_data or {}).items():
        got = np.concatenate(back.cell_data[name]) if name in back.cell_data else None
        assert got is not None and np.array_equal(got.ravel(), values.ravel()), (path, name)
    return back


def deform(mesh, rig):
    r = ffdkit.Rig.load(rig)
    expected = r.deformer(np.array(mesh.points)).evaluate()  # the points alone, independently
    r.apply(mesh)
    assert np.array_equal(mesh.points, expected)


def test_box(tmp_path):
    n = 50 if SANITIZED else 100
    methods = list(rigs(np.zeros((1, 3))))
    for m_i, method in enumerate(methods):
        mesh = box(n)
        assert mesh.vertex_count == (n + 1) ** 3
        assert mesh.face_count == 6 * n * n
        rest = np.array(mesh.points)
        deform(mesh, rigs(rest)[method])
        assert not np.array_equal(mesh.points, rest)
        targets = TARGETS if method == "lattice" else [TARGETS[m_i % len(TARGETS)]]
        for ext, enc, z in targets:
            write_and_check(mesh, str(tmp_path / f"box_{method}_{enc}{'_z' if z else ''}.{ext}"),
                            ext, enc, z)
        # point sets: the nodes alone
        ffdkit.write_mesh(mesh, str(tmp_path / "box.npy"))
        assert np.array_equal(np.load(tmp_path / "box.npy"), mesh.points)


def test_hinge_every_method_every_format(tmp_path):
    src = os.path.join(DATA, "volume", "hinge_tet.msh")
    source = meshio.read(src)
    physical = np.concatenate(source.cell_data["gmsh:physical"])
    for method, rig in rigs(np.asarray(source.points)).items():
        mesh = ffdkit.read_mesh(src)
        assert mesh.is_volume and len(mesh.cell_types) == sum(len(b.data) for b in source.cells)
        rest = np.array(mesh.points)
        deform(mesh, rig)
        assert not np.array_equal(mesh.points, rest)
        # back to its own format: only coordinates change, meshio reads the same cells and tags
        out = str(tmp_path / f"hinge_{method}.msh")
        ffdkit.write_mesh(mesh, out)
        back = meshio.read(out)
        assert flat_cells(back) == flat_cells(source)
        assert np.array_equal(np.concatenate(back.cell_data["gmsh:physical"]), physical)
        assert np.allclose(back.points, mesh.points, rtol=0, atol=0)
        for ext, enc, z in TARGETS:
            data = {"gmsh:physical": physical} if ext in ("vtu", "vtk", "msh") else None
            write_and_check(mesh, str(tmp_path / f"hinge_{method}_{enc}{'_z' if z else ''}.{ext}"),
                            ext, enc, z, data)
