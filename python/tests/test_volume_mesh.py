"""Volume meshes from Python: cells in and out, boundary faces, meshio both ways."""
import os

import numpy as np
import pytest

import ffdkit

DATA = os.path.join(os.path.dirname(__file__), "..", "..", "data")

CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                 [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1], [0.5, 0.5, 2]], float)


def test_cells_round_trip_and_boundary():
    m = ffdkit.Mesh(CUBE, cells=[("hexahedron", [[0, 1, 2, 3, 4, 5, 6, 7]]),
                                 ("pyramid", [[4, 5, 6, 7, 8]])])
    assert m.is_volume
    assert [(n, d.tolist()) for n, d in m.cells] == [("hexahedron", [[0, 1, 2, 3, 4, 5, 6, 7]]),
                                                     ("pyramid", [[4, 5, 6, 7, 8]])]
    assert m.cell_types.tolist() == [ffdkit.CELL_TYPES["hexahedron"], ffdkit.CELL_TYPES["pyramid"]]
    # the shared quad 4 5 6 7 is inside: 5 hex quads + 4 pyramid triangles
    assert m.face_count == 9
    assert sorted(np.diff(m.face_offsets).tolist()) == [3, 3, 3, 3, 4, 4, 4, 4, 4]
    assert m.face_cells.tolist() == [0] * 5 + [1] * 4
    # dict form and VTK ids give the same mesh
    m2 = ffdkit.Mesh(CUBE, cells={12: [[0, 1, 2, 3, 4, 5, 6, 7]], "pyramid": [[4, 5, 6, 7, 8]]})
    assert m2.cell_indices.tolist() == m.cell_indices.tolist()


def test_bad_cells_are_refused():
    with pytest.raises(ffdkit.RangeError, match="node 9 out of range"):
        ffdkit.Mesh(CUBE, cells=[("tetra", [[0, 1, 2, 9]])])
    with pytest.raises(ffdkit.ParseError, match="a tetra cell has 4 nodes, not 3"):
        ffdkit.Mesh(CUBE, cells=[("tetra", [[0, 1, 2]])])
    with pytest.raises(ValueError, match="unknown cell type 'tet'"):
        ffdkit.Mesh(CUBE, cells=[("tet", [[0, 1, 2, 3]])])
    with pytest.raises(ValueError, match="faces or cells, not both"):
        ffdkit.Mesh(CUBE, faces=[[0, 1, 2]], cells=[("tetra", [[0, 1, 2, 3]])])


def test_every_node_deformed():
    m = ffdkit.Mesh(CUBE, cells=[("hexahedron", [[0, 1, 2, 3, 4, 5, 6, 7]]),
                                 ("pyramid", [[4, 5, 6, 7, 8]])])
    rig = ffdkit.Rig.load({"deformer": "lattice", "resolution": [2, 2, 2],
                           "moves": [{"index": [1, 1, 1], "delta": [0.1, 0, 0]}]})
    expected = rig.apply(np.array(CUBE))
    report = rig.apply(m)
    assert np.array_equal(m.points, expected)
    assert any("volume mesh" in n for n in report["notes"])


def test_meshio_both_ways():
    meshio = pytest.importorskip("meshio")
    src = meshio.read(os.path.join(DATA, "volume", "hinge_tet.msh"))
    m = ffdkit.from_meshio(src)
    assert m.is_volume and m.vertex_count == len(src.points)
    # the boundary of the tetrahedra is the skin Gmsh wrote as triangles
    tris = np.concatenate([b.data for b in src.cells if b.type == "triangle"])
    faces = np.sort(np.asarray(m.faces).reshape(-1, 3), axis=1)
    assert sorted(map(tuple, faces)) == sorted(map(tuple, np.sort(tris, axis=1)))
    back = ffdkit.to_meshio(m)
    # the same cells in the same order (meshio splits blocks per Gmsh entity; ours are runs)
    def flat(mesh):
        return [(b.type, c) for b in mesh.cells for c in b.data.tolist()]
    assert flat(back) == flat(src)
