"""Makes the legacy VTK samples of data/volume/ with meshio (Debian's
python3-meshio) and gmsh (Debian's gmsh): run with /usr/bin/python3 from this
directory. data/SOURCES.md says what each file is."""
import subprocess

import meshio
import numpy as np

# A mixed mesh: a unit hexahedron, a wedge on its top, a pyramid on its +x
# face and a tetrahedron under it, every cell positively oriented (VTK order).
points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                   [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1],
                   [0.5, 0, 1.8], [0.5, 1, 1.8], [2, 0.5, 0.5], [0.5, 0.5, -1]], float)
cells = [("hexahedron", np.array([[0, 1, 2, 3, 4, 5, 6, 7]])),
         ("wedge", np.array([[4, 5, 8, 7, 6, 9]])),
         ("pyramid", np.array([[1, 2, 6, 5, 10]])),
         ("tetra", np.array([[0, 2, 1, 11]]))]
mixed = meshio.Mesh(
    points, cells,
    point_data={"temperature": np.linspace(0.5, 6, 12),
                "velocity": np.array([[i, 0.25 * i, -1.5] for i in range(12)], float)},
    cell_data={"material": [np.array([c], dtype=np.int32) for c in (1, 2, 3, 4)]})
meshio.vtk.write("mixed_51_ascii.vtk", mixed, fmt_version="5.1", binary=False)
meshio.vtk.write("mixed_51_binary.vtk", mixed, fmt_version="5.1", binary=True)
meshio.vtk.write("mixed_42_ascii.vtk", mixed, fmt_version="4.2", binary=False)
meshio.vtk.write("mixed_42_binary.vtk", mixed, fmt_version="4.2", binary=True)

# A tetrahedral box from Gmsh (float32 points in the binary file).
subprocess.run(["gmsh", "-3", "-setnumber", "Mesh.MeshSizeMax", "0.3", "-format", "msh22",
                "-o", "/tmp/box_tet.msh", "box.geo"], check=True, capture_output=True)
box = meshio.read("/tmp/box_tet.msh")
box = meshio.Mesh(box.points.astype(np.float32), [c for c in box.cells if c.type == "tetra"])
meshio.vtk.write("box_tet_binary.vtk", box, fmt_version="4.2", binary=True)

# Binary polydata in the 5.1 layout (OFFSETS / CONNECTIVITY per section, as
# VTK 9 writes it), with a binary string array (vtkDataWriter's length
# prefixes), a bit array and a METADATA block; meshio cannot write polydata,
# so it is put together here byte by byte.
def be(fmt, values):
    return np.asarray(values, dtype=fmt).tobytes()


def vtk_string(s):
    b = s.encode()
    return bytes([0xC0 | len(b)]) + b


pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1],
                [0, 1, 1], [0.5, 0.5, 1.5], [2, 2, 2]])
out = b"# vtk DataFile Version 5.1\nbinary polydata put together by make_vtk_samples.py\nBINARY\n"
out += b"DATASET POLYDATA\nPOINTS 10 double\n" + be(">f8", pts) + b"\n"
out += b"METADATA\nINFORMATION 0\n\n"
out += b"VERTICES 2 1\nOFFSETS vtktypeint64\n" + be(">i8", [0, 1]) + b"\n"
out += b"CONNECTIVITY vtktypeint64\n" + be(">i8", [9]) + b"\n"
out += b"POLYGONS 4 12\nOFFSETS vtktypeint32\n" + be(">i4", [0, 3, 7, 12]) + b"\n"
out += b"CONNECTIVITY vtktypeint32\n" + be(">i4", [4, 5, 8, 0, 3, 2, 1, 4, 5, 6, 7, 8]) + b"\n"
out += b"CELL_DATA 4\nSCALARS flag bit 1\nLOOKUP_TABLE default\n" + bytes([0b1010_0000]) + b"\n"
out += b"FIELD FieldData 2\nname 1 4 string\n"
out += b"".join(vtk_string(s) for s in ("vertex", "triangle", "quad", "pentagon")) + b"\n"
out += b"weight 1 4 float\n" + be(">f4", [0.5, 1, 1.5, 2]) + b"\n"
out += b"POINT_DATA 10\nVECTORS displacement float\n" + be(">f4", pts * 0.1) + b"\n"
with open("polydata_binary.vtk", "wb") as f:
    f.write(out)
