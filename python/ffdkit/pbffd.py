"""PB-FFD automatic placement (Jin et al. §3.2.1): ``ffdkit.pbffd.place``.

``place(mesh, interior=60, exterior=60, ...)`` builds a PB-FFD deformer on a
mesh with its controls placed automatically -- a rig whose ``"controls"`` is
the object of placement options (docs/rig.md, "Controls") -- and returns the
deformer, the placed controls (the explicit form ``ffd pbffd place -o``
writes, ready for a rig's ``"controls"``) and the placement report.
"""

from __future__ import annotations

from typing import Any, Dict, List, NamedTuple, Union

import numpy as np

__all__ = ["place", "Placement", "PLACEMENT_OPTIONS", "DEFORMER_OPTIONS"]

#: Keys of the placement object (docs/rig.md, "Controls").
PLACEMENT_OPTIONS = ("interior", "exterior", "offset", "radius_factor", "surface", "voronoi_sites", "cover")
#: Keys of the PB-FFD rig that shape the deformer built on the placed controls.
DEFORMER_OPTIONS = ("levels", "sigma", "master")


class Placement(NamedTuple):
    """What :func:`place` returns."""

    #: the PB-FFD deformer bound to the mesh, controls at rest
    deformer: Any
    #: the placed EBF centres, (C, 3) float64 (a copy)
    centers: np.ndarray
    #: the placed controls as a rig's explicit ``"controls"`` list:
    #: ``[{"center", "radius", "frame", "enabled"}]``
    controls: List[Dict[str, Any]]
    #: the deformer's report (``ffd_deformer_report``): counts, levels, sigma, the EBFs
    report: Dict[str, Any]


def place(mesh: Any, *, limits: Any = None, **options: Any) -> Placement:
    """Places PB-FFD controls on ``mesh`` (an ``ffdkit.Mesh`` or a path) and
    builds the deformer. ``options`` are the placement options
    (:data:`PLACEMENT_OPTIONS`: ``interior``, ``exterior``, ``offset``,
    ``radius_factor``, ``surface``, ``voronoi_sites``, ``cover``) and the
    deformer's (:data:`DEFORMER_OPTIONS`: ``levels``, ``sigma``, ``master``);
    none given: 60 interior and 60 exterior points. Placement runs in the
    library with the GIL released. Raises TypeError for an unknown option;
    the library's errors (InvalidError: more points than the mesh offers, a
    mesh without normals; ParseError: a bad value, named) as
    ``ffdkit.Error`` subclasses."""
    from . import Mesh, Rig, read_mesh

    unknown = sorted(set(options) - set(PLACEMENT_OPTIONS) - set(DEFORMER_OPTIONS))
    if unknown:
        raise TypeError(
            f"place: unknown option {unknown[0]!r}; expected one of "
            + ", ".join(PLACEMENT_OPTIONS + DEFORMER_OPTIONS)
        )
    if isinstance(mesh, (str, bytes)) or hasattr(mesh, "__fspath__"):
        mesh = read_mesh(mesh)
    if not isinstance(mesh, Mesh):
        raise TypeError(f"place: expected an ffdkit.Mesh or a path, got {type(mesh).__name__}")
    placement = {k: v for k, v in options.items() if k in PLACEMENT_OPTIONS}
    rig: Dict[str, Union[int, str, Dict[str, Any]]] = {
        "version": 1,
        "deformer": "pbffd",
        "controls": placement if placement else "auto",
    }
    rig.update({k: v for k, v in options.items() if k in DEFORMER_OPTIONS})
    deformer = Rig.load(rig).deformer(mesh, limits=limits)
    controls = deformer.rig()["controls"]
    centers = np.array([c["center"] for c in controls], dtype=np.float64).reshape(len(controls), 3)
    return Placement(deformer, centers, controls, deformer.report())
