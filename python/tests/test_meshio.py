"""ffdkit.deform_meshio on volume and surface meshes written and read back by meshio."""

import numpy as np
import pytest

import ffdkit

meshio = pytest.importorskip("meshio")

BEND = {
    "version": 1,
    "deformer": "lattice",
    "basis": "bernstein",
    "resolution": [3, 3, 3],
    "box": {"origin": [-0.1, -0.1, -0.1], "axes": [[1.2, 0, 0], [0, 1.2, 0], [0, 0, 1.2]]},
    "moves": [{"index": [2, 2, 2], "delta": [0.3, -0.2, 0.25]},
              {"index": [0, 1, 2], "delta": [0.0, 0.4, 0.0]}],
}


def tetra_cube(n=5):
    """A unit-cube volume of (n-1)^3 hexahedra, each cut into 6 tetrahedra (Kuhn split)."""
    g = np.linspace(0.0, 1.0, n)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    points = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)

    def node(i, j, k):
        return (i * n + j) * n + k

    tets = []
    for i in range(n - 1):
        for j in range(n - 1):
            for k in range(n - 1):
                c = [node(i + (v >> 2 & 1), j + (v >> 1 & 1), k + (v & 1)) for v in range(8)]
                # the six paths from corner 000 to 111 along the cube's edges
                for a, b in ((4, 6), (4, 5), (2, 6), (2, 3), (1, 5), (1, 3)):
                    tets.append([c[0], c[a], c[b], c[7]])
    tets = np.array(tets, dtype=np.int64)
    mesh = meshio.Mesh(
        points,
        [("tetra", tets)],
        point_data={"temperature": points[:, 0] * 10.0 + points[:, 2],
                    "velocity": np.stack([points[:, 1], -points[:, 0], points[:, 2]], axis=1)},
        cell_data={"material": [np.arange(len(tets), dtype=np.int32) % 3]},
        field_data={"steel": np.array([1, 3])},
    )
    return mesh


def assert_same_except_points(a, b):
    assert len(a.cells) == len(b.cells)
    for ca, cb in zip(a.cells, b.cells):
        assert ca.type == cb.type
        assert np.array_equal(ca.data, cb.data)
    assert a.point_data.keys() == b.point_data.keys()
    for k in a.point_data:
        assert np.array_equal(a.point_data[k], b.point_data[k])
    assert a.cell_data.keys() == b.cell_data.keys()
    for k in a.cell_data:
        for x, y in zip(a.cell_data[k], b.cell_data[k]):
            assert np.array_equal(x, y)
    assert a.field_data.keys() == b.field_data.keys()
    for k in a.field_data:
        assert np.array_equal(a.field_data[k], b.field_data[k])


@pytest.mark.parametrize("ext,fmt", [(".vtu", None), (".msh", "gmsh22"), (".msh", "gmsh")])
def test_volume_round_trip_through_files(tmp_path, ext, fmt):
    path = str(tmp_path / ("cube" + ext))
    mesh = tetra_cube()
    if fmt:  # a Gmsh file's physical and geometrical tags (its field_data names the physical)
        count = len(mesh.cells[0].data)
        mesh.cell_data["gmsh:physical"] = [np.ones(count, dtype=np.int32)]
        mesh.cell_data["gmsh:geometrical"] = [np.ones(count, dtype=np.int32)]
    meshio.write(path, mesh, file_format=fmt, **({"binary": False} if fmt else {}))
    mesh = meshio.read(path)
    rig = ffdkit.Rig.load(BEND)
    out = ffdkit.deform_meshio(mesh, rig)
    assert isinstance(out, meshio.Mesh)
    assert_same_except_points(out, mesh)
    assert np.array_equal(out.points, rig.apply(np.ascontiguousarray(mesh.points, dtype=float)))
    assert not np.array_equal(out.points, mesh.points)
    # the result can be written by meshio again
    meshio.write(str(tmp_path / ("out" + ext)), out, file_format=fmt)


def test_copies_not_aliases():
    mesh = tetra_cube(3)
    keep = meshio.Mesh(mesh.points.copy(), [(c.type, c.data.copy()) for c in mesh.cells],
                       point_data={k: v.copy() for k, v in mesh.point_data.items()})
    out = ffdkit.deform_meshio(mesh, BEND)
    assert not np.shares_memory(out.points, mesh.points)
    assert not np.shares_memory(out.cells[0].data, mesh.cells[0].data)
    for k in mesh.point_data:
        assert not np.shares_memory(out.point_data[k], mesh.point_data[k])
    assert not np.shares_memory(out.cell_data["material"][0], mesh.cell_data["material"][0])
    assert not np.shares_memory(out.field_data["steel"], mesh.field_data["steel"])
    out.point_data["temperature"][:] = -1
    out.cells[0].data[:] = 0
    assert np.array_equal(mesh.point_data["temperature"], keep.point_data["temperature"])
    assert np.array_equal(mesh.cells[0].data, keep.cells[0].data)
    assert np.array_equal(mesh.points, keep.points)


def test_rig_forms_dict_json_path_prm(tmp_path):
    import json

    mesh = tetra_cube(3)
    want = ffdkit.deform_meshio(mesh, ffdkit.Rig.load(BEND)).points
    assert np.array_equal(ffdkit.deform_meshio(mesh, BEND).points, want)
    assert np.array_equal(ffdkit.deform_meshio(mesh, json.dumps(BEND)).points, want)
    path = tmp_path / "bend.json"
    path.write_text(json.dumps(BEND))
    assert np.array_equal(ffdkit.deform_meshio(mesh, str(path)).points, want)
    assert np.array_equal(ffdkit.deform_meshio(mesh, path).points, want)
    from ffdkit.pygem import FFD

    ffd = FFD([2, 2, 2])
    ffd.box_origin = np.array([-0.1, -0.1, -0.1])
    ffd.box_length = np.array([1.2, 1.2, 1.2])
    ffd.array_mu_z[1, 1, 1] = 0.2
    prm = str(tmp_path / "p.prm")
    ffd.write_parameters(prm)
    got = ffdkit.deform_meshio(mesh, prm).points
    np.testing.assert_allclose(got, ffd(mesh.points), rtol=0, atol=1e-14)


def test_auto_box_uses_every_node():
    mesh = tetra_cube(4)
    # an extra node outside the cells (meshio keeps unused points): the box must reach it
    mesh.points = np.vstack([mesh.points, [[2.0, 0.5, 0.5]]])
    mesh.point_data = {}
    auto = {"version": 1, "basis": "bernstein", "resolution": [2, 2, 2], "box": "auto",
            "margin": 0.0, "moves": [{"index": [1, 1, 1], "delta": [0.0, 0.0, 0.5]}]}
    explicit = dict(auto, box={"origin": [0.0, 0.0, 0.0],
                               "axes": [[2.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]})
    out = ffdkit.deform_meshio(mesh, auto)
    np.testing.assert_allclose(out.points, ffdkit.deform_meshio(mesh, explicit).points,
                               rtol=0, atol=1e-14)
    # without the extra node the box is the unit cube, and the cube's corner moves by 0.5
    assert out.points[63, 2] < 1.5 - 1e-3


def test_surface_mixed_cells_and_sets(tmp_path):
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1.0],
                       [0, 0, 1], [1, 0, 1]], dtype=float)
    cells = [("triangle", np.array([[0, 1, 4], [1, 2, 4]])),
             ("quad", np.array([[0, 1, 2, 3]])),
             ("wedge", np.array([[0, 1, 4, 5, 6, 4]]))]
    mesh = meshio.Mesh(points, cells, cell_data={"id": [np.array([1, 2]), np.array([3]),
                                                        np.array([4])]},
                       point_sets={"base": np.array([0, 1, 2, 3])})
    out = ffdkit.deform_meshio(mesh, BEND)
    assert np.array_equal(out.point_sets["base"], mesh.point_sets["base"])
    assert not np.shares_memory(out.point_sets["base"], mesh.point_sets["base"])
    path = str(tmp_path / "mixed.vtu")
    meshio.write(path, mesh)  # (meshio's VTU writer turns point_sets into point_data in place)
    back = meshio.read(path)
    out = ffdkit.deform_meshio(back, BEND)
    assert [c.type for c in out.cells] == ["triangle", "quad", "wedge"]
    assert_same_except_points(out, back)


def test_2d_points():
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.3, 0.6]], dtype=float)
    mesh = meshio.Mesh(pts, [("triangle", np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4]]))])
    planar = {"version": 1, "basis": "bernstein", "resolution": [2, 2, 2],
              "box": {"origin": [-0.1, -0.1, -1], "axes": [[1.2, 0, 0], [0, 1.2, 0], [0, 0, 2]]},
              "moves": [{"index": [1, 1, 0], "delta": [0.2, 0.1, 0]},
                        {"index": [1, 1, 1], "delta": [0.2, 0.1, 0]}]}
    out = ffdkit.deform_meshio(mesh, planar)
    assert out.points.shape == (5, 2)
    xyz = np.hstack([pts, np.zeros((5, 1))])
    assert np.array_equal(out.points, ffdkit.Rig.load(planar).apply(xyz)[:, :2])
    with pytest.raises(ValueError, match="off the plane z = 0"):
        ffdkit.deform_meshio(mesh, BEND)


def test_bad_arguments():
    mesh = tetra_cube(2)
    with pytest.raises(TypeError, match="meshio.Mesh"):
        ffdkit.deform_meshio(mesh.points, BEND)
    with pytest.raises(TypeError, match="rig"):
        ffdkit.deform_meshio(mesh, 42)
    with pytest.raises(ffdkit.ParseError):
        ffdkit.deform_meshio(mesh, "{not json")
    bad = tetra_cube(2)
    bad.points = np.zeros((8, 4))
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        ffdkit.deform_meshio(bad, BEND)
