"""Meshes: ffdkit.Mesh, read_mesh and write_mesh."""
from __future__ import annotations

import os
from typing import Any, Optional, Union

import numpy as np

from . import _ffd

PathLike = Union[str, "os.PathLike[str]"]


class Mesh(_ffd.Mesh):
    """A polygon mesh: ``Mesh(points, faces=None)`` or :func:`read_mesh`.

    points: (N, 3) numbers; faces: an (F, k) integer array or a list of index
    sequences (polygons of any size). ``points``, ``normals``, ``face_offsets`` and
    ``face_indices`` are read-only numpy views into the mesh (no copies);
    assigning ``mesh.points = P`` or calling :meth:`set_points` replaces the
    positions. A mesh read from a file keeps every byte it does not change, so
    :func:`write_mesh` in its own format is lossless.
    """

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
        return (f"<ffdkit.Mesh {self.vertex_count} vertices, {self.face_count} faces, "
                f"format {self.format!r}>")


def read_mesh(path: PathLike, format: Optional[str] = None) -> Mesh:
    """Reads a mesh (OBJ, PLY, OFF, STL, glTF/GLB) with the GIL released.

    format ('obj', 'ply', 'off', 'stl', 'gltf', 'glb') overrides the extension.
    Raises FileError (missing or unreadable file), ParseError (the message names
    the file and line or byte offset), RangeError, NonFiniteError.
    """
    return Mesh.read(path, format)


def write_mesh(mesh: _ffd.Mesh, path: PathLike, format: Optional[str] = None,
               encoding: Optional[str] = None) -> None:
    """Writes mesh to path atomically (the GIL released).

    In the mesh's own format every byte of a value that did not change is
    kept; format overrides the extension, encoding ('ascii', 'binary',
    'binary_little_endian', 'binary_big_endian') applies to PLY and STL.
    """
    if not isinstance(mesh, _ffd.Mesh):
        raise TypeError(f"mesh: expected an ffdkit.Mesh, got {type(mesh).__name__}")
    mesh.write(path, format, encoding)


