"""Deformers: ffdkit.Deformer (every method behind one interface), its
controls view and direct manipulation."""
from __future__ import annotations

import json
import weakref
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Optional, Sequence, Type, Union

import numpy as np

from . import _ffd

#: method name -> Deformer subclass; Deformer(rig, ...) builds the class registered
#: for rig.method (ffdkit.methods registers each method's own class).
METHOD_CLASSES: Dict[str, Type["Deformer"]] = {}

Ids = Union[int, Sequence[int], np.ndarray, None]


@dataclass

class SolveResult:
    """What :meth:`Deformer.solve` reached: residuals (k,) = |reached - target|,
    reached (k, 3), the rank of the constraint matrix B S, max_residual, and
    the number of distinct controls the constraints touch."""

    residuals: np.ndarray
    reached: np.ndarray
    rank: int
    max_residual: float
    variables_used: int


_INPLACE_OPS = ("__iadd__", "__isub__", "__imul__", "__itruediv__", "__ifloordiv__", "__imod__",
                "__ipow__", "__imatmul__")


class ControlsView(np.ndarray):
    """The deformer's control positions (C, 3), float64, written through.

    Item assignment and augmented assignment on the view or on a slice of it
    (``d.controls[3] = p``, ``d.controls[3] += delta``, ``d.controls[:, 2] *= 2``,
    ``v = d.controls; v[0, 1] = 0.5; v += 1``) push the rows that changed to
    the deformer (ffd_deformer_set_controls), after which the view is
    refreshed from it. Other writes into its memory (np.copyto, a ufunc's
    out=) are not seen until an assignment: ``d.controls = v``. The same view
    object is refreshed after every change made through the deformer (move,
    set_controls, reset, solve, command); after a change of the control count
    (a refinement) ``d.controls`` is a new view and the old one is detached.
    Derived arrays (``d.controls * 2``, ``.copy()``) are plain copies.
    """

    def __array_finalize__(self, obj: Any) -> None:
        root = getattr(obj, "_root", None) if isinstance(obj, ControlsView) else None
        if root is not None and np.may_share_memory(self, root):
            self._root = root
        else:
            self._root = None
        self._deformer_ref = None

    def _push(self) -> None:
        root = self._root
        if root is None:
            return
        ref = root._deformer_ref
        d = ref() if ref is not None else None
        if d is None:
            return
        mine = root.view(np.ndarray)
        cur = d._get_controls()
        if cur.shape != mine.shape:
            raise RuntimeError("this controls view is detached: the control count changed; "
                               "read d.controls again")
        changed = np.flatnonzero(np.any(mine != cur, axis=1))
        try:
            if len(changed):
                _ffd.Deformer.set_controls(d, changed, mine[changed])
        finally:
            np.copyto(mine, d._get_controls())

    def __setitem__(self, key: Any, value: Any) -> None:
        np.ndarray.__setitem__(self, key, value)
        self._push()

    def __reduce__(self):  # pickles as a plain array
        return np.asarray(self).copy().__reduce__()


def _make_inplace(name: str):
    base = getattr(np.ndarray, name)

    def op(self, other):
        result = base(self, other)
        self._push()
        return result

    op.__name__ = name
    op.__doc__ = f"In-place {name[3:-2]}, written through to the deformer."
    return op


for _name in _INPLACE_OPS:
    setattr(ControlsView, _name, _make_inplace(_name))


class Deformer(_ffd.Deformer):
    """A deformer of any method, built from a rig for a Mesh or (N, 3) points.

    ``Deformer(rig, target, limits=None)`` (or ``rig.deformer(target)``) replays
    the rig exactly as applying it does and binds target's points; it returns
    an instance of the method's subclass (METHOD_CLASSES). Not thread-safe by
    itself: each deformer has a lock, so calls from several threads run one
    after another; the long calls release the GIL.
    """

    def __new__(cls, rig: _ffd.Rig, target: Any, limits: Optional[Mapping[str, Any]] = None):
        if not isinstance(rig, _ffd.Rig):
            raise TypeError(f"rig: expected an ffdkit.Rig, got {type(rig).__name__}")
        if cls is Deformer:
            cls = METHOD_CLASSES.get(rig.method, Deformer)
        return super().__new__(cls, rig, target, limits)

    def __init__(self, rig: _ffd.Rig, target: Any, limits: Optional[Mapping[str, Any]] = None):
        pass

    # ---- controls ----

    def _refresh(self) -> None:
        v = self.__dict__.get("_controls_view")
        if v is None:
            return
        cur = self._get_controls()
        if cur.shape == v.shape:
            np.copyto(v.view(np.ndarray), cur)
        else:
            v._root = None
            del self.__dict__["_controls_view"]

    @property
    def controls(self) -> ControlsView:
        """(C, 3) view of the control positions you can assign to (see ControlsView)."""
        cur = self._get_controls()
        v = self.__dict__.get("_controls_view")
        if v is None or v.shape != cur.shape:
            if v is not None:
                v._root = None
            v = cur.view(ControlsView)
            v._root = v
            v._deformer_ref = weakref.ref(self)
            self.__dict__["_controls_view"] = v
        else:
            np.copyto(v.view(np.ndarray), cur)
        return v

    @controls.setter
    def controls(self, positions: Any) -> None:
        v = self.__dict__.get("_controls_view")
        if positions is v and v is not None:
            # the view itself (after `d.controls += x`, or writes the view did
            # not see, e.g. np.copyto): push the rows that differ
            v._push()
            return
        self.set_controls(None, positions)

    def set_controls(self, ids: Ids, positions: Any) -> None:
        """Sets controls ids (None: all, in order) to positions (k, 3);
        RangeError for an id, NonFiniteError; on error nothing changed."""
        try:
            super().set_controls(ids, positions)
        finally:
            self._refresh()

    def move(self, ids: Ids, deltas: Any) -> None:
        """Moves controls ids (None: all) by deltas (k, 3)."""
        try:
            super().move(ids, deltas)
        finally:
            self._refresh()

    def reset(self) -> None:
        """Puts every control back at rest."""
        try:
            super().reset()
        finally:
            self._refresh()

    # ---- direct manipulation, the linear map ----

    def solve(self, points: Any, targets: Any = None, rcond: float = 1e-10) -> SolveResult:
        """Direct manipulation (Hsu et al. 1992): moves the controls by the
        minimum-norm change that takes bound points ``points`` (k indices) to
        ``targets`` (k, 3) in the least-squares sense (ffd_manip_solve; the
        GIL released). The constraints may also come alone, as ``points``:
        a dict {point index: target} or a sequence of (index, target) pairs.
        UnsupportedError for a method without a linear map (GFFD); RangeError
        for a point index."""
        if targets is None:
            points, targets = _constraint_pairs(points)
        try:
            residuals, reached, rank, max_residual, used = self._solve(points, targets, rcond)
        finally:
            self._refresh()
        return SolveResult(residuals, reached, rank, max_residual, used)

    def linear_map(self):
        """The bound points' deformed positions as a linear map of the controls:
        a scipy.sparse.csr_matrix W (M, C) with x' = W @ controls + what does
        not depend on them (ffd_deformer_linear_map; columns through the tie to
        control ids, duplicates summed). UnsupportedError for GFFD. Needs scipy
        (Debian: python3-scipy)."""
        try:
            import scipy.sparse
        except ImportError as e:  # pragma: no cover - depends on the machine
            raise ImportError("Deformer.linear_map needs scipy (Debian: apt install python3-scipy)") from e
        indptr, indices, data, M, C = self._linear_map_csr()
        W = scipy.sparse.csr_matrix((data, indices, indptr), shape=(M, C))
        W.sum_duplicates()
        return W

    def sensitivities(self, expand: bool = False):
        """W = dX/dP of the bound points (ffd_deformer_sensitivities,
        docs/sensitivities.md): a scipy.sparse.csr_matrix (M, C), rows the
        bound points, columns the controls (ties merged, columns sorted), with
        dX/dP = W (x) I3: d x[i, a] / d controls[j, b] = W[i, j] if a == b.
        expand=True gives that (3M, 3C) matrix itself (row 3i+a, column
        3j+b). Exact (no finite differences). UnsupportedError for GFFD. Needs
        scipy (Debian: python3-scipy)."""
        try:
            import scipy.sparse
        except ImportError as e:  # pragma: no cover - depends on the machine
            raise ImportError("Deformer.sensitivities needs scipy (Debian: apt install python3-scipy)") from e
        indptr, indices, data, M, C = self._sensitivities_csr()
        W = scipy.sparse.csr_matrix((data, indices, indptr), shape=(M, C))
        if expand:
            W = scipy.sparse.kron(W, scipy.sparse.identity(3, format="csr"), format="csr")
        return W

    # ---- reports, rigs, method operations ----

    def report(self) -> dict:
        """The method's report: {"method", "points", "controls": {"count", ...}, "params": {...}}."""
        return json.loads(self._report_json())

    def rig(self) -> dict:
        """The deformer's state as a rig (a dict): Rig.load of it on the same
        mesh builds the same deformer, its controls where they are now."""
        return json.loads(self._rig_json())

    def command(self, op: str, **body: Any) -> None:
        """Runs the method's own operation op with body as its JSON body,
        exactly as the editor's operation of that name (docs/editor.md "Method
        operations"); the binding is kept. UnsupportedError for an op the method
        does not have, ParseError for a wrong key."""
        try:
            self._command_json(op, json.dumps(body, allow_nan=False) if body else None)
        finally:
            self._refresh()

    def __repr__(self) -> str:
        return (f"<ffdkit.{type(self).__name__} {self.method}: {self.point_count} points, "
                f"{self.control_count} controls>")


def _constraint_pairs(constraints: Any):
    """(indices, targets) of constraints given as {index: target} or [(index, target), ...]."""
    items = constraints.items() if isinstance(constraints, dict) else constraints
    try:
        pairs = [(index, target) for index, target in items]
    except (TypeError, ValueError):
        raise TypeError("solve: constraints must be {point index: target} or "
                        "[(point index, target), ...] when no targets are given") from None
    return [p[0] for p in pairs], [p[1] for p in pairs]
