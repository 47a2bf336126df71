"""Meshes: ffdkit.Mesh, read_mesh and write_mesh."""
from __future__ import annotations

import os
from typing import Any, Optional, Union

import numpy as np

from . import _ffd

PathLike = Union[str, "os.PathLike[str]"]


CELL_TYPES = dict(_ffd.CELL_TYPES)  # {name: VTK id}, meshio's names
_CELL_NAMES = {v: k for k, v in CELL_TYPES.items()}


def _cell_arrays(cells):
    """(types uint8, offsets uint64, indices uint32) from meshio-style cell blocks:
    a list of (type, (k, n) array) pairs or of meshio.CellBlock, or a dict
    {type: (k, n) array}; type is a name ('tetra', 'hexahedron', ...) or a VTK id."""
    if isinstance(cells, dict):
        cells = list(cells.items())
    types, sizes, chunks = [], [], []
    for block in cells:
        if hasattr(block, "type") and hasattr(block, "data"):
            kind, data = block.type, block.data
        else:
            kind, data = block
        if isinstance(kind, str):
            if kind not in CELL_TYPES:
                raise ValueError(f"cells: unknown cell type {kind!r} (known: "
                                 f"{', '.join(sorted(CELL_TYPES))})")
            vtk = CELL_TYPES[kind]
        else:
            vtk = int(kind)
        if isinstance(data, list) and data and np.ndim(data[0]) == 1 and \
                len({len(c) for c in data}) > 1:
            rows = [np.asarray(c, dtype=np.int64) for c in data]  # cells of several sizes
        else:
            arr = np.asarray(data, dtype=np.int64)
            if arr.ndim != 2:
                raise ValueError(f"cells: a {kind!r} block must be a (k, n) array, got shape "
                                 f"{arr.shape}")
            rows = [arr]
        for r in rows:
            if r.size and (r.min() < 0 or r.max() > 0xFFFFFFFF):
                raise ValueError(f"cells: node ids of a {kind!r} cell out of range")
            k = r.shape[0] if r.ndim == 2 else 1
            n = r.shape[1] if r.ndim == 2 else r.size
            types.append(np.full(k, vtk, dtype=np.uint8))
            sizes.append(np.full(k, n, dtype=np.uint64))
            chunks.append(r.ravel())
    types = np.concatenate(types) if types else np.empty(0, np.uint8)
    sizes = np.concatenate(sizes) if sizes else np.empty(0, np.uint64)
    offsets = np.zeros(len(types) + 1, dtype=np.uint64)
    np.cumsum(sizes, out=offsets[1:])
    indices = (np.concatenate(chunks) if chunks else np.empty(0)).astype(np.uint32)
    return types, offsets, indices


class Mesh(_ffd.Mesh):
    """A polygon or volume mesh: ``Mesh(points, faces=None, cells=None)`` or :func:`read_mesh`.

    points: (N, 3) numbers; faces: an (F, k) integer array or a list of index
    sequences (polygons of any size); or cells (a volume mesh): meshio-style
    blocks, a list of (type, (k, n) array) pairs, meshio.CellBlock objects or a
    dict {type: array}, with VTK's node order and meshio's type names
    ('tetra', 'hexahedron', 'wedge', 'pyramid', 'triangle', ...; CELL_TYPES).
    A volume mesh's faces are its boundary surface. ``points``, ``normals``,
    ``face_offsets``, ``face_indices``, ``cell_types``, ``cell_offsets`` and
    ``cell_indices`` are read-only numpy views into the mesh (no copies);
    assigning ``mesh.points = P`` or calling :meth:`set_points` replaces the
    positions. A mesh read from a file keeps every byte it does not change, so
    :func:`write_mesh` in its own format is lossless.
    """

    def __new__(cls, points, faces=None, cells=None):
        if cells is None:
            return super().__new__(cls, points, faces)
        return super().__new__(cls, points, faces, _cell_arrays(cells))

    @property
    def cells(self) -> list:
        """The cells as meshio-style blocks: [(type name, (k, n) uint32 array), ...],
        one block per run of consecutive cells of one type and size."""
        types, off, idx = self.cell_types, self.cell_offsets, self.cell_indices
        blocks, c, C = [], 0, len(types)
        sizes = np.diff(off).astype(np.int64)
        while c < C:
            e = c + 1
            while e < C and types[e] == types[c] and sizes[e] == sizes[c]:
                e += 1
            n = int(sizes[c])
            data = idx[int(off[c]):int(off[e])].reshape(e - c, n)
            blocks.append((_CELL_NAMES.get(int(types[c]), str(int(types[c]))), data))
            c = e
        return blocks

    @property
    def point_data(self) -> dict:
        """The file's point data: {name: (N,) or (N, k) float64 array} (copies)."""
        return {n: (v[:, 0] if v.shape[1] == 1 else v)
                for n, a, v in self._fields() if a == "point"}

    @property
    def cell_data(self) -> dict:
        """The file's cell data (VTK cell data, gmsh:physical / gmsh:geometrical tags,
        su2:tag markers): {name: (C,) or (C, k) float64 array} over all cells (copies)."""
        return {n: (v[:, 0] if v.shape[1] == 1 else v)
                for n, a, v in self._fields() if a == "cell"}

    @property
    def faces(self) -> Union[np.ndarray, list]:
        """The faces: an (F, k) uint32 read-only array when every face has k
        corners, else a list of F uint32 arrays."""
        off = self.face_offsets
        idx = self.face_indices
        F = len(off) - 1
        if F == 0:
            return np.empty((0, 3), dtype=np.uint32)
        sizes = np.diff(off)
        if np.all(sizes == sizes[0]):
            return idx.reshape(F, int(sizes[0]))
        return [idx[off[f]:off[f + 1]] for f in range(F)]

    def __repr__(self) -> str:
        cells = f", {len(self.cell_types)} cells" if len(self.cell_types) else ""
        return (f"<ffdkit.Mesh {self.vertex_count} vertices, {self.face_count} faces{cells}, "
                f"format {self.format!r}>")


def read_mesh(path: PathLike, format: Optional[str] = None) -> Mesh:
    """Reads a mesh (OBJ, PLY, OFF, STL, glTF/GLB; volume meshes: VTK, VTU, Gmsh MSH,
    SU2; point sets: XYZ, CSV, NPY) with the GIL released.

    format ('obj', 'ply', 'off', 'stl', 'gltf', 'glb', 'vtk', 'vtu', 'msh', 'su2', 'xyz',
    'csv', 'npy') overrides the extension.
    Raises FileError (missing or unreadable file), ParseError (the message names
    the file and line or byte offset), RangeError, NonFiniteError.
    """
    return Mesh.read(path, format)


def write_mesh(mesh: _ffd.Mesh, path: PathLike, format: Optional[str] = None,
               encoding: Optional[str] = None, compress: bool = False) -> None:
    """Writes mesh to path atomically (the GIL released).

    In the mesh's own format every byte of a value that did not change is
    kept; format overrides the extension, encoding ('ascii', 'binary',
    'binary_little_endian', 'binary_big_endian'; VTU: 'ascii', 'base64', 'raw')
    applies to PLY, STL, VTK, VTU, MSH and NPY; compress: VTU's zlib compression.
    """
    if not isinstance(mesh, _ffd.Mesh):
        raise TypeError(f"mesh: expected an ffdkit.Mesh, got {type(mesh).__name__}")
    mesh.write(path, format, encoding, compress)


