"""Each deformation method's own operations, as ``ffdkit.Deformer`` subclasses.

``rig.deformer(mesh)`` (and ``ffdkit.Deformer(rig, mesh)``) return the
subclass of the rig's method, registered here in
``ffdkit._deformer.METHOD_CLASSES``:

* :class:`LatticeDeformer` -- the lattice's resolution, box and basis, and the
  index of control point ``(i, j, k)``;
* :class:`TSplineDeformer` -- local refinement (Song & Yang §3.2-3.3), frozen
  points, the proxy mesh;
* :class:`PBFFDDeformer` -- the hierarchy level shown and edited (§3.4), the
  EBFs' frames (twist, stretch), deformation curves (§3.5);
* :class:`GFFDDeformer` -- skeleton primitives: add, change the radius,
  remove, transform;
* :class:`KelvinletDeformer` -- Kelvinlet brushes: add, remove.

Every operation is a thin layer over :meth:`ffdkit.Deformer.command`, the one
C entry point ``ffd_deformer_command``, with exactly the JSON bodies of the
editor's "Method operations" (docs/editor.md); what the methods report comes
from :meth:`ffdkit.Deformer.report` (``ffd_deformer_report``). An operation of
another method raises ``ffdkit.UnsupportedError``; a malformed body raises
``ffdkit.ParseError`` naming the key. The binding is kept across operations:
the next :meth:`~ffdkit.Deformer.evaluate` sees the change.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np

from ._deformer import METHOD_CLASSES, Deformer

if TYPE_CHECKING:
    from ._mesh import Mesh

ArrayLike3 = Union[Sequence[float], np.ndarray]
Ids = Union[int, Iterable[int], np.ndarray]

__all__ = ["LatticeDeformer", "TSplineDeformer", "PBFFDDeformer", "GFFDDeformer", "KelvinletDeformer"]


def _ids(ids: Ids) -> List[int]:
    """Control ids as a list of Python ints (one id or any iterable of them)."""
    if isinstance(ids, (int, np.integer)):
        return [int(ids)]
    return [int(i) for i in np.asarray(ids).reshape(-1)]


def _vec3(v: ArrayLike3, name: str) -> List[float]:
    """Three numbers as a JSON-ready list; ValueError naming ``name`` otherwise."""
    a = np.asarray(v, dtype=np.float64)
    if a.shape != (3,):
        raise ValueError(f"{name}: expected 3 numbers, got shape {a.shape}")
    return [float(x) for x in a]


# ---------------------------------------------------------------------------
# Lattice
# ---------------------------------------------------------------------------


class LatticeDeformer(Deformer):
    """A trivariate lattice (Sederberg-Parry Bernstein or uniform cubic
    B-spline; docs/rig.md "Lattice"). Control ``(i, j, k)`` is control
    ``(i*m + j)*n + k`` for a resolution ``(l, m, n)``; ``i`` runs along the
    box's first axis from its origin."""

    @property
    def resolution(self) -> Tuple[int, int, int]:
        """Control points per box axis ``(l, m, n)``."""
        r = self.report()["controls"]["resolution"]
        return (int(r[0]), int(r[1]), int(r[2]))

    @property
    def basis(self) -> str:
        """``"bspline"`` or ``"bernstein"``."""
        return str(self.report()["controls"]["basis"])

    @property
    def box(self) -> Tuple[np.ndarray, np.ndarray]:
        """The lattice's parallelepiped ``(origin (3,), axes (3,3))``: rest
        space ``x = origin + s*axes[0] + t*axes[1] + u*axes[2]`` for
        ``(s,t,u)`` in ``[0,1]^3`` (the rig's ``"box"``; ``"auto"`` resolved)."""
        box = self.rig()["box"]
        return (np.array(box["origin"], dtype=np.float64), np.array(box["axes"], dtype=np.float64))

    def control_index(self, i: int, j: int, k: int) -> int:
        """The control id of lattice point ``(i, j, k)``; IndexError out of range."""
        l, m, n = self.resolution
        for name, v, size in (("i", i, l), ("j", j, m), ("k", k, n)):
            if not 0 <= int(v) < size:
                raise IndexError(f"control_index: {name} = {v} out of range (resolution {l}x{m}x{n})")
        return (int(i) * m + int(j)) * n + int(k)

    def control_grid(self) -> np.ndarray:
        """The (root) lattice's controls as an ``(l, m, n, 3)`` array (a copy)."""
        l, m, n = self.resolution
        return np.array(self.controls[: l * m * n], dtype=np.float64).reshape(l, m, n, 3)

    @property
    def lattices(self) -> list:
        """A nested rig's lattices (``"children"``, docs/lattice-variants.md),
        root first, then depth-first: dicts ``{"first", "count", "depth",
        "parent", "resolution"}`` (controls ``first .. first+count-1``); a
        rig without children has the root alone."""
        lat = self.report()["controls"].get("lattices")
        if lat is None:
            l, m, n = self.resolution
            return [{"first": 0, "count": l * m * n, "depth": 0, "parent": -1, "resolution": [l, m, n]}]
        return lat


# ---------------------------------------------------------------------------
# T-spline volume (proxy T-spline FFD)
# ---------------------------------------------------------------------------


class TSplineDeformer(Deformer):
    """A cubic T-spline volume driven through its proxy mesh (docs/tspline.md).

    :meth:`refine` inserts edges, faces or cells (§3.2-3.3): the control count
    grows while the shape stays. Frozen points stay put in ARAP drags (the
    rig's ``deform`` steps and the editor)."""

    def refine(self, insertions: Union[Dict[str, Any], Sequence[Dict[str, Any]]]) -> None:
        """One refinement: the insertions of a rig's ``refine`` step (one
        dict or a list of them): ``{"cell": id}``, ``{"face": id}``,
        ``{"edge": id, "ratio": 0.5}``, ``{"cell": {"near": [x,y,z]}}`` (the
        element at a rest-space position; also for faces and edges) or
        ``{"cells": "proxy"}`` (every cell inside the proxy). The shape does
        not change; the control count grows. ParseError for a bad insertion
        (its key named), InvalidError when nothing is refined."""
        if isinstance(insertions, dict):
            insertions = [insertions]
        self.command("refine", insertions=[_json_ready(x) for x in insertions])

    def refine_cell(self, cell: int) -> None:
        """Refines one cell (by id)."""
        self.refine({"cell": int(cell)})

    def refine_face(self, face: int) -> None:
        """Refines one face (by id)."""
        self.refine({"face": int(face)})

    def refine_edge(self, edge: int, ratio: float = 0.5) -> None:
        """Splits one edge (by id) at ``ratio`` of its length."""
        self.refine({"edge": int(edge), "ratio": float(ratio)})

    def refine_near(self, point: ArrayLike3, element: str = "cell") -> None:
        """Refines the ``element`` (``"cell"``, ``"face"`` or ``"edge"``) at
        the rest-space position ``point``."""
        if element not in ("cell", "face", "edge"):
            raise ValueError(f"refine_near: element {element!r}: expected 'cell', 'face' or 'edge'")
        self.refine({element: {"near": _vec3(point, "point")}})

    def refine_proxy(self) -> None:
        """Refines every cell inside the proxy."""
        self.refine({"cells": "proxy"})

    def arap_sensitivity_product(self, handles: Ids, v: np.ndarray, soft: bool = False) -> np.ndarray:
        """dX/dq v for an ARAP drag of control points ``handles`` (k ids)
        begun from the current lattice: ``v`` (k, 3) target changes, result
        (M, 3) changes of the bound points. The derivative of one global
        step at fixed rotations (the identity here: a fresh drag), not of the
        rotation refit (ffd_tsv_arap_sensitivity_product; docs/sensitivities.md,
        "T-spline proxy handles"). Nothing changes. ``soft``: the handles are
        soft targets (eq. 4)."""
        return self._tspline_arap_product(_ids(handles), v, False, bool(soft))

    def arap_sensitivity_transpose_product(
        self, handles: Ids, w: np.ndarray, soft: bool = False
    ) -> np.ndarray:
        """(dX/dq)^T w, ``w`` (M, 3) (e.g. dJ/dX), result (k, 3): the adjoint of
        :meth:`arap_sensitivity_product`, one solve with the same factor."""
        return self._tspline_arap_product(_ids(handles), w, True, bool(soft))

    def freeze(self, ids: Ids, frozen: bool = True) -> None:
        """Freezes (or with ``frozen=False`` frees) control points: frozen
        points stay put in ARAP drags. All or nothing: RangeError for an id
        past the end, nothing changed."""
        self.command("freeze", points=_ids(ids), frozen=bool(frozen))

    @property
    def frozen(self) -> np.ndarray:
        """The frozen control ids (uint32, ascending)."""
        return np.array(self.report()["controls"]["frozen"], dtype=np.uint32)

    @property
    def cell_count(self) -> int:
        """Cells of the T-lattice."""
        return int(self.report()["controls"]["cells"])

    @property
    def face_count(self) -> int:
        """Faces of the T-lattice."""
        return int(self.report()["controls"]["faces"])

    @property
    def edge_count(self) -> int:
        """Edges of the T-lattice."""
        return int(self.report()["controls"]["edges_count"])

    @property
    def refinements(self) -> int:
        """Refinements made since the deformer was built (rig steps included)."""
        return int(self.report()["controls"]["refinements"])

    @property
    def max_weight_deviation(self) -> float:
        """max |W_v - 1| over the control points' rational weights W_v (the
        refinement's diagnostic, docs/tspline.md)."""
        return float(self.report()["controls"]["max_weight_deviation"])

    def proxy_arrays(self) -> Tuple[np.ndarray, List[List[int]], np.ndarray]:
        """The proxy as arrays ``(points (P,3), faces, point_controls (P,))``:
        a closed 2-manifold whose faces index ``points``; point ``p`` is
        control ``point_controls[p]`` (a control point where inside cells
        touch only along an edge or at a vertex appears once per sheet)."""
        proxy = self.report()["controls"]["proxy"]
        point_controls = np.array(proxy["point_controls"], dtype=np.uint32)
        points = np.array(self.controls, dtype=np.float64)[point_controls.astype(np.intp)]
        faces = [[int(i) for i in f] for f in proxy["face_points"]]
        return points, faces, point_controls

    def proxy(self) -> "Mesh":
        """The proxy mesh at the controls' current positions as an
        ``ffdkit.Mesh`` (see :meth:`proxy_arrays` for the point-to-control map)."""
        from . import Mesh

        points, faces, _ = self.proxy_arrays()
        return Mesh(points, faces)


# ---------------------------------------------------------------------------
# PB-FFD (point-based FFD with EBFs)
# ---------------------------------------------------------------------------


class PBFFDDeformer(Deformer):
    """Point-based FFD over ellipsoidal basis functions (Jin et al.;
    docs/pbffd.md). The controls are the EBF centres of the level shown (0 =
    finest) followed by the deformation curves' points; switching the level
    changes the control count. ``ffdkit.pbffd.place`` builds one with the
    controls placed automatically (§3.2.1)."""

    @property
    def level(self) -> int:
        """The hierarchy level shown and edited (§3.4; 0 = finest). Assign to
        switch (RangeError past the coarsest): the controls become that
        level's EBF centres."""
        return int(self.report()["controls"]["level"])

    @level.setter
    def level(self, k: int) -> None:
        self.set_level(k)

    def set_level(self, k: int) -> None:
        """Shows and edits level ``k`` (as assigning :attr:`level`)."""
        self.command("level", level=_json_int(k, "level"))

    @property
    def levels(self) -> int:
        """Levels of the hierarchy."""
        return int(self.report()["controls"]["levels"])

    @property
    def ebf_count(self) -> int:
        """EBFs of the level shown (the first controls; the curves' points follow)."""
        return len(self.report()["controls"]["ebfs"])

    @property
    def frames(self) -> np.ndarray:
        """The EBFs' frames of the level shown, ``(E, 3, 3)``: row ``a`` is
        the unit direction of semi-axis ``a`` (the matrix ``A`` of eq. 7
        normalised)."""
        ebfs = self.report()["controls"]["ebfs"]
        return np.array([e["frame"] for e in ebfs], dtype=np.float64).reshape(len(ebfs), 3, 3)

    @property
    def radii(self) -> np.ndarray:
        """The EBFs' ROI semi-axes of the level shown, ``(E, 3)``."""
        ebfs = self.report()["controls"]["ebfs"]
        return np.array([e["radius"] for e in ebfs], dtype=np.float64).reshape(len(ebfs), 3)

    @property
    def enabled(self) -> np.ndarray:
        """Whether each EBF of the level shown takes effect, ``(E,)`` bool."""
        return np.array([bool(e["enabled"]) for e in self.report()["controls"]["ebfs"]], dtype=bool)

    def set_frame(
        self,
        controls: Ids,
        *,
        axis: Optional[ArrayLike3] = None,
        angle: Optional[float] = None,
        scale: Optional[ArrayLike3] = None,
    ) -> None:
        """Rotates (``axis``, ``angle`` in radians) and/or scales (``scale``
        along the frame's own axes) the frames of EBFs ``controls`` of the
        level shown: the space around them twists or stretches. At least one
        of rotation or scale; InvalidError for a zero axis or scale or a
        curve point, RangeError for an id past the end."""
        body: Dict[str, Any] = {"points": _ids(controls)}
        if axis is not None:
            body["axis"] = _vec3(axis, "axis")
        if angle is not None:
            body["angle"] = float(angle)
        if scale is not None:
            body["scale"] = _vec3(scale, "scale")
        self.command("frame", **body)

    def frame_sensitivities(self, level: Optional[int] = None):
        """The bound points' derivatives with respect to the EBF frames of
        ``level`` (None: the level shown), a scipy.sparse.csr_matrix of shape
        ``(3 M, 6 E)``: row ``3 i + a`` is coordinate ``a`` of point ``i``;
        columns ``6 q .. 6 q + 2`` are the rotation vector (radians) turning
        EBF ``q``'s frame about its centre, ``6 q + 3 + m`` the scaling of its
        axis ``m`` (per unit of relative stretch), both at the current frame
        (ffd_pbffd_frame_sensitivities; docs/sensitivities.md, "PB-FFD
        frames"). The curves' samples are not included. ValueError when the
        deformer was bound to points other than the mesh's. Needs scipy."""
        try:
            import scipy.sparse
        except ImportError as e:  # pragma: no cover - depends on the machine
            raise ImportError("frame_sensitivities needs scipy (Debian: apt install python3-scipy)") from e
        k = self.level if level is None else _json_int(level, "level")
        indptr, indices, data, rows, cols = self._pbffd_frame_sensitivities_csr(k)
        return scipy.sparse.csr_matrix((data, indices, indptr), shape=(rows, cols))

    def rotate_frame(self, controls: Ids, axis: ArrayLike3, angle: float) -> None:
        """Twists: rotates the frames of EBFs ``controls`` about ``axis`` by ``angle`` radians."""
        self.set_frame(controls, axis=axis, angle=angle)

    def scale_frame(self, controls: Ids, scale: ArrayLike3) -> None:
        """Stretches: scales the frames of EBFs ``controls`` along their own axes."""
        self.set_frame(controls, scale=scale)

    def curve(
        self, points: ArrayLike3, radius: Optional[float] = None, samples: Optional[int] = None
    ) -> np.ndarray:
        """Adds a deformation curve (§3.5): a Catmull-Rom spline through
        ``points`` (k >= 2, (k,3)) discretised into ``samples`` EBFs (0 or
        None: automatic) of ROI radius ``radius`` (None: the default, a
        fraction of the diagonal). Returns the curve's control ids: move them
        (:meth:`move`, :attr:`controls`) and the enclosed part of the mesh
        follows."""
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"curve: points: expected a (k, 3) array, got shape {pts.shape}")
        body: Dict[str, Any] = {"points": pts.tolist()}
        if radius is not None:
            body["radius"] = float(radius)
        if samples is not None:
            body["samples"] = _json_int(samples, "samples")
        self.command("curve", **body)
        return self.curve_controls(-1)

    @property
    def curves(self) -> List[Dict[str, Any]]:
        """The curves: ``[{"offset": o, "count": n, "radius": r}]``; curve
        points are controls ``o .. o+n-1`` (after the EBFs)."""
        return [
            {"offset": int(c["offset"]), "count": int(c["count"]), "radius": float(c["radius"])}
            for c in self.report()["controls"]["curves"]
        ]

    def curve_controls(self, curve: int) -> np.ndarray:
        """The control ids of curve ``curve``'s points (negative: from the end)."""
        c = self.curves[curve]
        return np.arange(c["offset"], c["offset"] + c["count"], dtype=np.uint32)

    def move_curve(self, curve: int, index: Ids, delta: ArrayLike3) -> None:
        """Moves points ``index`` of curve ``curve`` by ``delta`` ((3,) or (k,3))."""
        ids = self.curve_controls(curve)
        idx = _ids(index)
        for i in idx:
            if not 0 <= i < len(ids):
                raise IndexError(f"move_curve: point {i} out of range (the curve has {len(ids)})")
        d = np.broadcast_to(np.asarray(delta, dtype=np.float64), (len(idx), 3))
        self.move(ids[idx], np.ascontiguousarray(d))


# ---------------------------------------------------------------------------
# GFFD (generalized FFD over a skeleton)
# ---------------------------------------------------------------------------


class GFFDDeformer(Deformer):
    """Generalized FFD driven by a skeleton of primitives (points, polylines,
    triangle meshes; docs/gffd.md). The controls are the skeleton's vertices,
    primitive after primitive. GFFD's map is not linear in the controls:
    :meth:`linear_map` and :meth:`solve` raise UnsupportedError.

    A skeleton edit (:meth:`primitive`, :meth:`add_primitive`,
    :meth:`set_radius`, :meth:`remove_primitive`) re-binds the mesh at its
    current shape's rest; the control count changes with it."""

    @property
    def skeleton(self) -> List[Dict[str, Any]]:
        """The primitives: ``{"type", "radius", "offset", "count", "faces",
        "vertices"}``; the primitive's vertices are controls ``offset ..
        offset+count-1`` (``vertices``: their current positions, a copy)."""
        prims = self.report()["controls"]["primitives"]
        controls = np.array(self.controls, dtype=np.float64)
        out = []
        for p in prims:
            o, n = int(p["offset"]), int(p["count"])
            out.append(
                {
                    "type": str(p["type"]),
                    "radius": float(p["radius"]),
                    "offset": o,
                    "count": n,
                    "faces": p.get("faces", []),
                    "vertices": controls[o : o + n].copy(),
                }
            )
        return out

    @property
    def influenced(self) -> int:
        """Mesh vertices inside some primitive's influence region."""
        return int(self.report()["controls"]["influenced"])

    def primitive(self, **body: Any) -> None:
        """The editor's ``primitive`` op with its body: ``add={primitive as in
        rigs}``, ``index=i, radius=r`` or ``remove=i`` (exactly one).
        ParseError for a bad body, RangeError for an index past the end."""
        self.command("primitive", **{k: _json_ready(v) for k, v in body.items()})

    def add_primitive(self, primitive: Optional[Dict[str, Any]] = None, **fields: Any) -> int:
        """Adds a primitive given as in rigs (``{"type": "point", "position":
        [..], "radius": r}``, ``{"type": "polyline", "vertices": [[..], ..],
        "radius": r}``, ...; a dict or keywords). Returns its index."""
        prim = dict(primitive or {})
        prim.update(fields)
        self.primitive(add=prim)
        return len(self.report()["controls"]["primitives"]) - 1

    def set_radius(self, index: int, radius: float) -> None:
        """Sets primitive ``index``'s influence radius ``r_s > 0``."""
        self.primitive(index=_json_int(index, "index"), radius=float(radius))

    def remove_primitive(self, index: int) -> None:
        """Removes primitive ``index`` (InvalidError for the only one)."""
        self.primitive(remove=_json_int(index, "remove"))

    def primitive_controls(self, index: int) -> np.ndarray:
        """The control ids of primitive ``index``'s vertices."""
        prims = self.report()["controls"]["primitives"]
        if not -len(prims) <= index < len(prims):
            raise IndexError(f"primitive_controls: {index} out of range ({len(prims)} primitives)")
        p = prims[index]
        return np.arange(int(p["offset"]), int(p["offset"]) + int(p["count"]), dtype=np.uint32)

    def transform_primitive(
        self,
        index: int,
        matrix: Optional[np.ndarray] = None,
        *,
        translate: Optional[ArrayLike3] = None,
        axis: Optional[ArrayLike3] = None,
        angle: float = 0.0,
        center: Optional[ArrayLike3] = None,
    ) -> None:
        """Moves primitive ``index`` rigidly or affinely: its vertices ``v``
        become ``M (v - c) + c + t`` with ``M`` = ``matrix`` (3x3) or the
        rotation about ``axis`` by ``angle`` (default identity), ``c`` =
        ``center`` (default: the vertices' centroid), ``t`` = ``translate``.
        The mesh vertices it influences follow (a control edit)."""
        ids = self.primitive_controls(index)
        v = np.array(self.controls, dtype=np.float64)[ids.astype(np.intp)]
        if matrix is not None and axis is not None:
            raise ValueError("transform_primitive: give matrix or axis/angle, not both")
        if matrix is not None:
            m = np.asarray(matrix, dtype=np.float64)
            if m.shape != (3, 3):
                raise ValueError(f"transform_primitive: matrix: expected (3, 3), got {m.shape}")
        elif axis is not None:
            m = _rotation(_vec3(axis, "axis"), float(angle))
        else:
            m = np.eye(3)
        c = v.mean(axis=0) if center is None else np.array(_vec3(center, "center"))
        t = np.zeros(3) if translate is None else np.array(_vec3(translate, "translate"))
        self.set_controls(ids, np.ascontiguousarray((v - c) @ m.T + c + t))


def _rotation(axis: List[float], angle: float) -> np.ndarray:
    """Rodrigues' rotation matrix about a nonzero axis."""
    a = np.asarray(axis, dtype=np.float64)
    n = np.linalg.norm(a)
    if not n > 0:
        raise ValueError("axis: the zero vector is no axis")
    x, y, z = a / n
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


# ---------------------------------------------------------------------------
# Kelvinlet brushes
# ---------------------------------------------------------------------------


class KelvinletDeformer(Deformer):
    """Kelvinlet brushes (de Goes & James 2017; docs/kelvinlet.md). The
    controls are the grab brushes' handles (center + displacement); there is
    no linear map (a grab's response is a 3x3 block)."""

    @property
    def brushes(self) -> List[Dict[str, Any]]:
        """The brushes as in rigs (each grab with its ``control`` id)."""
        return list(self.report()["controls"].get("brushes", []))

    def add_brush(self, type: str, center: ArrayLike3, radius: float, **keys: Any) -> None:
        """Adds a brush: ``type`` "grab", "twist", "scale" or "pinch", its
        ``center`` and ``radius``, and its type's keys (``displacement``;
        ``axis`` and ``angle``; ``factor``; ``pinch``)."""
        brush = {"type": type, "center": _vec3(center, "center"), "radius": float(radius)}
        brush.update(_json_ready(keys))
        self.command("brush", add=brush)

    def remove_brush(self, index: int) -> None:
        """Removes brush ``index`` (RangeError past the end)."""
        self.command("brush", remove=_json_int(index, "remove"))


def _json_int(v: Any, name: str) -> Any:
    """A numpy integer as a Python int for a JSON body; anything else passes
    unchanged so that the library refuses it by name (ParseError naming
    ``name``'s key)."""
    if isinstance(v, (bool, np.bool_)):
        return v
    if isinstance(v, (int, np.integer)):
        return int(v)
    return v


def _json_ready(v: Any) -> Any:
    """numpy arrays and scalars inside a body as plain JSON values."""
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, dict):
        return {k: _json_ready(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_ready(x) for x in v]
    return v


METHOD_CLASSES.update(
    {
        "lattice": LatticeDeformer,
        "tspline": TSplineDeformer,
        "pbffd": PBFFDDeformer,
        "gffd": GFFDDeformer,
        "kelvinlet": KelvinletDeformer,
    }
)

# ffdkit.pbffd (automatic placement) is reached as an attribute of the package
from . import pbffd  # noqa: E402,F401
