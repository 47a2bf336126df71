"""meshio interop: deform a ``meshio.Mesh`` (any format meshio reads) with an ffdkit rig.

meshio (Debian: python3-meshio) is imported only when a function here is called.
"""

from __future__ import annotations

import copy
import os

import numpy as np

__all__ = ["deform_meshio", "from_meshio", "to_meshio"]


def _meshio():
    try:
        import meshio
    except ImportError as e:  # pragma: no cover - depends on the machine
        raise ImportError("ffdkit.deform_meshio needs meshio: apt-get install python3-meshio "
                          "(or pip install meshio)") from e
    return meshio


def _rig(rig):
    from . import Rig

    if isinstance(rig, Rig):
        return rig
    if isinstance(rig, (dict, str, os.PathLike)):
        return Rig.load(os.fspath(rig) if isinstance(rig, os.PathLike) else rig)
    raise TypeError(f"deform_meshio: rig must be an ffdkit.Rig, a dict, a path or JSON text, "
                    f"got {type(rig).__name__}")


def deform_meshio(mesh, rig):
    """Deform a ``meshio.Mesh`` with a rig and return a new ``meshio.Mesh``.

    :param mesh: a ``meshio.Mesh``: a surface or a volume (tetra, hexahedron, wedge, pyramid,
        ... cells); ffdkit deforms its points only, so every cell type works.
    :param rig: an ``ffdkit.Rig``, a rig as a dict, a path (.json or PyGeM .prm) or JSON text.
        A rig with ``"box": "auto"`` fits the box to all the mesh's points (a volume's
        interior nodes included); vertex constraints index ``mesh.points``.
    :returns: a new ``meshio.Mesh`` with the deformed points and copies (not views) of the
        cells, point_data, cell_data, field_data, point_sets, cell_sets, gmsh_periodic and info.
        ``mesh`` is not modified.

    2D points ((N, 2), as some formats read planar meshes) are deformed in the plane z = 0 and
    returned as (N, 2); a rig that moves any of them off that plane raises ValueError
    (returning 2D points would drop the z it computed).
    """
    meshio = _meshio()
    if not isinstance(mesh, meshio.Mesh):
        raise TypeError(f"deform_meshio: expected a meshio.Mesh, got {type(mesh).__name__}")
    rig = _rig(rig)
    points = np.asarray(mesh.points)
    if points.dtype.kind not in "biuf":
        raise TypeError(f"deform_meshio: mesh.points must be numbers, got dtype {points.dtype}")
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise ValueError(f"deform_meshio: mesh.points must have shape (N, 3) or (N, 2), "
                         f"got {points.shape}")
    planar = points.shape[1] == 2
    xyz = np.zeros((points.shape[0], 3))
    xyz[:, : points.shape[1]] = points
    deformed = rig.apply(xyz) if points.shape[0] else xyz
    if planar:
        off = np.flatnonzero(deformed[:, 2] != 0.0)
        if off.size:
            i = int(off[0])
            raise ValueError(f"deform_meshio: the mesh has 2D points but the rig moves point {i} "
                             f"off the plane z = 0 (z = {deformed[i, 2]!r}; {off.size} points in "
                             f"all); give the mesh 3D points to keep z")
        deformed = np.ascontiguousarray(deformed[:, :2])

    # deepcopy, not np.array: polyhedron blocks hold a list of ragged arrays
    cells = [meshio.CellBlock(block.type, copy.deepcopy(block.data),
                              *([copy.deepcopy(block.tags)] if hasattr(block, "tags") else []))
             for block in mesh.cells]
    out = meshio.Mesh(
        deformed,
        cells,
        point_data=copy.deepcopy(mesh.point_data),
        cell_data=copy.deepcopy(mesh.cell_data),
        field_data=copy.deepcopy(mesh.field_data),
        point_sets=copy.deepcopy(mesh.point_sets),
        cell_sets=copy.deepcopy(mesh.cell_sets),
        gmsh_periodic=copy.deepcopy(mesh.gmsh_periodic),
        info=copy.deepcopy(mesh.info),
    )
    return out


def to_meshio(mesh):
    """An ``ffdkit.Mesh`` as a ``meshio.Mesh``: its points (a copy), its cells as
    meshio cell blocks (a surface mesh without cells: its faces as triangle / quad /
    polygon blocks) and its point and cell data."""
    meshio = _meshio()
    points = np.array(mesh.points)
    if len(mesh.cell_types):
        blocks = [(name, np.array(data, dtype=np.int64)) for name, data in mesh.cells]
        sizes = [len(data) for _, data in blocks]
        cell_data = {}
        for name, values in mesh.cell_data.items():
            parts, at = [], 0
            for n in sizes:
                parts.append(values[at:at + n])
                at += n
            cell_data[name] = parts
    else:
        faces = mesh.faces
        if isinstance(faces, list):
            blocks = [("polygon", np.array(f, dtype=np.int64)[None, :]) for f in faces]
        elif len(faces):
            k = faces.shape[1]
            blocks = [({3: "triangle", 4: "quad"}.get(k, "polygon"), np.array(faces, np.int64))]
        else:
            blocks = []
        cell_data = {}
    return meshio.Mesh(points, blocks, point_data=mesh.point_data, cell_data=cell_data)


def from_meshio(m):
    """A ``meshio.Mesh`` as an ``ffdkit.Mesh`` with its cells (VTK node order, as meshio's);
    point and cell data are not carried (write the ffdkit mesh and they are not
    there: deform a meshio mesh with :func:`deform_meshio` to keep them)."""
    from . import Mesh

    meshio = _meshio()
    if not isinstance(m, meshio.Mesh):
        raise TypeError(f"from_meshio: expected a meshio.Mesh, got {type(m).__name__}")
    points = np.asarray(m.points, dtype=np.float64)
    if points.ndim == 2 and points.shape[1] == 2:
        points = np.hstack([points, np.zeros((len(points), 1))])
    return Mesh(np.ascontiguousarray(points), cells=[(b.type, b.data) for b in m.cells])
