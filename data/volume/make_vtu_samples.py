#!/usr/bin/python3
"""Makes the VTU samples of data/volume/ (docs in data/SOURCES.md).

mixed_*.vtu: a 2x1x1 block of one hexahedron, two wedges, a pyramid and a
tetrahedron (shared nodes), with point data (a scalar and a vector) and cell
data, written by meshio (ascii, inline base64, inline base64 + zlib) and by
hand (raw appended data, little- and big-endian, UInt32 headers; base64
appended data), the layouts meshio cannot write."""
import base64, struct, sys, zlib
import numpy as np
import meshio

pts = np.array([
    [0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
    [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1],
    [2, 0, 0], [2, 1, 0], [2, 0, 1], [2, 1, 1],
    [1.5, 0.5, 1.8], [0.5, 0.5, 1.9]], dtype=np.float64)
cells = [
    ("hexahedron", np.array([[0, 1, 2, 3, 4, 5, 6, 7]])),
    ("wedge", np.array([[1, 8, 9, 5, 10, 11], [1, 9, 2, 5, 11, 6]])),
    ("pyramid", np.array([[5, 10, 11, 6, 12]])),
    ("tetra", np.array([[4, 5, 6, 13]])),
]
point_data = {"temperature": np.linspace(0.25, 3.5, len(pts)),
              "velocity": np.arange(3 * len(pts), dtype=np.float32).reshape(-1, 3) / 8}
cell_data = {"material": [np.array([1], np.int32), np.array([2, 2], np.int32),
                          np.array([3], np.int32), np.array([4], np.int32)]}
mesh = meshio.Mesh(pts, cells, point_data=point_data, cell_data=cell_data)
out = sys.argv[1] if len(sys.argv) > 1 else "."
meshio.write(f"{out}/mixed_ascii.vtu", mesh, binary=False)
meshio.write(f"{out}/mixed_base64.vtu", mesh, binary=True, compression=None)
meshio.write(f"{out}/mixed_zlib.vtu", mesh, binary=True, compression="zlib")

# by hand: appended data
conn = np.concatenate([c.ravel() for _, c in cells]).astype(np.int64)
offs = np.cumsum([len(c) for _, cs in cells for c in cs]).astype(np.int64)
types = np.array([12, 13, 13, 14, 10], np.uint8)
mat = np.array([1, 2, 2, 3, 4], np.int32)


def appended(path, order, header, encoding, compress=False):
    e = "<" if order == "LittleEndian" else ">"
    h = e + ("I" if header == "UInt32" else "Q")
    arrays = [("Points", "Float32", 3, pts.astype(np.float32)),
              ("connectivity", "Int64", 1, conn), ("offsets", "Int64", 1, offs),
              ("types", "UInt8", 1, types),
              ("temperature", "Float64", 1, point_data["temperature"]),
              ("material", "Int32", 1, mat)]
    blob = b""
    tags = []
    for name, t, nc, a in arrays:
        data = a.astype(a.dtype.newbyteorder(e)).tobytes()
        if compress:
            z = zlib.compress(data)
            packed = struct.pack(e + h[1] * 4, 1, len(data), len(data), len(z)) + z
        else:
            packed = struct.pack(h, len(data)) + data
        if encoding == "base64":
            if compress:
                n = 4 * struct.calcsize(h)
                packed = base64.b64encode(packed[:n]) + base64.b64encode(packed[n:])
            else:
                packed = base64.b64encode(packed[:struct.calcsize(h)]) + \
                    base64.b64encode(packed[struct.calcsize(h):])
        tags.append((name, t, nc, len(blob)))
        blob += packed
    x = lambda name: next(f'<DataArray type="{t}" Name="{n}" NumberOfComponents="{nc}" format="appended" offset="{o}"/>'
                          for n, t, nc, o in tags if n == name)
    comp = ' compressor="vtkZLibDataCompressor"' if compress else ""
    head = f'''<?xml version="1.0"?>
<!-- written by data/volume/make_vtu_samples.py -->
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="{order}" header_type="{header}"{comp}>
  <UnstructuredGrid>
    <Piece NumberOfPoints="{len(pts)}" NumberOfCells="{len(types)}">
      <PointData Scalars="temperature">
        {x("temperature")}
      </PointData>
      <CellData>
        {x("material")}
      </CellData>
      <Points>
        {x("Points")}
      </Points>
      <Cells>
        {x("connectivity")}
        {x("offsets")}
        {x("types")}
      </Cells>
    </Piece>
  </UnstructuredGrid>
  <AppendedData encoding="{encoding}">
   _'''
    with open(path, "wb") as f:
        f.write(head.encode() + blob + b"\n  </AppendedData>\n</VTKFile>\n")


appended(f"{out}/mixed_raw.vtu", "LittleEndian", "UInt64", "raw")
appended(f"{out}/mixed_raw_be32.vtu", "BigEndian", "UInt32", "raw")
appended(f"{out}/mixed_raw_zlib.vtu", "LittleEndian", "UInt32", "raw", compress=True)
appended(f"{out}/mixed_appended_base64.vtu", "LittleEndian", "UInt64", "base64")
