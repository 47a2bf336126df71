"""Distributed runs over mpi4py: each rank deforms its own partition of a mesh
with the same result, point for point and bit for bit, as one process
deforming the whole mesh (ffd.h "Distributed runs", docs/mpi.md).

    from mpi4py import MPI
    import ffdkit, ffdkit.mpi

    rig = ffdkit.Rig.load("rig.json")          # vertex ids in the rig are global ids
    moved = ffdkit.mpi.deform(MPI.COMM_WORLD, my_points, rig, global_ids=my_ids)

Every function here is collective: every rank of the communicator calls it,
with its own points (possibly none). An error on any rank is raised on every
rank with the failing rank's message ("rank 1: points[7]: non-finite ..."),
so no rank is left waiting. The compiled module links no MPI: the library's
few global steps (the extent for an auto box, the vertices the rig names, the
boundary surface for methods that read one, counts, agreeing on errors) call
back into this module, which runs them as mpi4py's Allreduce and Allgatherv.

mpi4py (Debian: python3-mpi4py) is imported when a function is first called
with an mpi4py communicator; ``import ffdkit.mpi`` works without it. Any
object with ``rank``, ``size``, ``allreduce(array, op)`` and
``allgatherv(mine, out, sizes)`` (see :class:`Reducer`) can stand for the
communicator: another runtime's, or a test's. docs/python.md "MPI (mpi4py)".
"""
from __future__ import annotations

from typing import Any, Dict, Mapping, Optional, Type

import numpy as np

from . import _ffd
from . import _deformer
from ._deformer import METHOD_CLASSES
from ._mesh import Mesh
from ._rig import _decode_report

__all__ = ["Deformer", "Reducer", "agree", "apply", "deform", "reducer"]

_MPI = None


def _mpi():
    """mpi4py's MPI module, imported on first use (it initialises MPI)."""
    global _MPI
    if _MPI is None:
        try:
            from mpi4py import MPI
        except ImportError as e:
            raise ImportError("ffdkit.mpi needs mpi4py for an MPI communicator "
                              "(Debian: apt install python3-mpi4py)") from e
        _MPI = MPI
    return _MPI


class Reducer:
    """The library's two collective callbacks over an mpi4py communicator.

    ``allreduce(array, op)`` reduces a float64 or uint64 array in place over
    every rank (``op``: 'sum', 'min', 'max', or 'or' bitwise on uint64):
    ``Allreduce(IN_PLACE, ...)``. ``allgatherv(mine, out, sizes)`` writes
    every rank's uint8 bytes into ``out`` in rank order (``sizes``: each
    rank's byte count, the same on every rank): ``Allgatherv``. The arrays
    are the library's memory, valid only during the call: a reducer must not
    keep them. Made by :func:`reducer`; a class of your own with these four
    members works as well.
    """

    def __init__(self, comm: Any):
        MPI = _mpi()
        if not isinstance(comm, MPI.Comm):
            raise TypeError(f"comm: expected an mpi4py communicator, got {type(comm).__name__}")
        if comm == MPI.COMM_NULL:
            raise ValueError("comm: MPI.COMM_NULL")
        self.comm = comm
        self.rank = comm.Get_rank()
        self.size = comm.Get_size()
        self._ops = {"sum": MPI.SUM, "min": MPI.MIN, "max": MPI.MAX, "or": MPI.BOR}
        self._in_place = MPI.IN_PLACE
        self._byte = MPI.BYTE

    def allreduce(self, array: np.ndarray, op: str) -> None:
        self.comm.Allreduce(self._in_place, array, op=self._ops[op])

    def allgatherv(self, mine: np.ndarray, out: np.ndarray, sizes: tuple) -> None:
        if len(out) > 0x7FFFFFFF:
            # MPI counts are C ints; mpi4py 3 has no large-count calls
            raise OverflowError(f"allgatherv: {len(out)} bytes in all exceed MPI's int counts "
                                f"(2^31 - 1); gather less (fewer surface faces) or use more ranks")
        displs = np.zeros(len(sizes), dtype=np.int64)
        if len(sizes) > 1:
            np.cumsum(sizes[:-1], out=displs[1:])
        self.comm.Allgatherv([mine, self._byte],
                             [out, (list(sizes), displs.tolist()), self._byte])


_PROTOCOL = ("rank", "size", "allreduce", "allgatherv")


def reducer(comm: Any):
    """The reducer of comm: comm itself when it already has rank, size,
    allreduce and allgatherv (:class:`Reducer`'s protocol), else a
    :class:`Reducer` of an mpi4py communicator (ImportError without
    mpi4py, TypeError for anything else)."""
    if all(hasattr(comm, a) for a in _PROTOCOL) and callable(getattr(comm, "allgatherv")):
        return comm
    return Reducer(comm)


def agree(comm: Any, error: Optional[BaseException] = None) -> None:
    """Every rank learns whether any failed (ffd_comm_agree; collective): error
    is this rank's exception, or None. Returns None when no rank had one; else
    raises on every rank the lowest failing rank's error as an ffdkit.Error
    with the message "rank R: <message>" (an ffdkit.Error keeps its class;
    any other exception becomes InvalidError naming its type; on the failing
    rank the exception itself is the ``__cause__``). For a solver's own local
    steps before a collective one, e.g. reading its piece::

        try:
            piece = ffdkit.read_mesh(f"part_{rank}.vtu")
            error = None
        except Exception as e:
            error = e
        ffdkit.mpi.agree(comm, error)   # raises on every rank, or on none
    """
    _ffd.agree(reducer(comm), error)


def deform(comm: Any, points: Any, rig: _ffd.Rig, global_ids: Any = None, faces: Any = None,
           cells: Any = None, out: Optional[np.ndarray] = None,
           limits: Optional[Mapping[str, Any]] = None) -> np.ndarray:
    """Deforms this rank's points (N, 3) as the same vertices of the whole
    mesh would be by ``rig.apply`` (collective: every rank calls it).

    global_ids (N,): each point's id in the whole mesh, the numbering the
    rig's vertex ids use; a vertex held by several ranks has one id and the
    same position on each; None: rank-major (rank r's points follow those of
    ranks 0 .. r-1). faces or cells (as :class:`ffdkit.Mesh` takes them, over
    this rank's points): the piece's surface, for methods that read one
    (PB-FFD placement, the T-spline); faces of a volume's partition interface
    cancel. Returns the deformed points, a new (N, 3) array or out.
    RangeError for a rig vertex id no rank holds; UnsupportedError for GFFD
    resampling and the layers that read the whole mesh's per-vertex data.
    """
    r = reducer(comm)
    if faces is not None or cells is not None:
        mesh, error = None, None
        try:
            mesh = Mesh(points, faces, cells)
        except Exception as e:  # every rank must learn of it, or the others would wait
            error = e
        _ffd.agree(r, error)
        _ffd.apply_distributed(rig, mesh, r, global_ids, None, limits)
        moved = mesh.points
        if out is not None:
            np.copyto(out, moved)
            return out
        return np.array(moved)
    return _ffd.apply_distributed(rig, points, r, global_ids, out, limits)


def apply(comm: Any, mesh: _ffd.Mesh, rig: _ffd.Rig, global_ids: Any = None,
          limits: Optional[Mapping[str, Any]] = None) -> dict:
    """Deforms this rank's piece, a :class:`ffdkit.Mesh`, in place, as
    ``rig.apply(mesh)`` deforms the whole mesh (collective). Returns the
    report (a dict, as ``Rig.apply``), the same on every rank; its details
    hold "distributed" (ranks, points, what the global steps gathered). On
    error no piece changed. global_ids as :func:`deform` (None: rank-major)."""
    if not isinstance(mesh, _ffd.Mesh):
        raise TypeError(f"mesh: expected an ffdkit.Mesh, got {type(mesh).__name__} "
                        f"(points go to ffdkit.mpi.deform)")
    return _decode_report(_ffd.apply_distributed(rig, mesh, reducer(comm), global_ids, None, limits))


_CLASSES: Dict[type, type] = {}


def _distributed_class(base: Type[_deformer.Deformer]) -> type:
    """Deformer (this module's) mixed into the method's class, once per class."""
    if base is _deformer.Deformer:
        return Deformer
    cls = _CLASSES.get(base)
    if cls is None:
        cls = type(base.__name__, (Deformer, base), {"__module__": __name__,
                                                     "__doc__": Deformer.__doc__})
        _CLASSES[base] = cls
    return cls


class Deformer(_deformer.Deformer):
    """The deformer a solver keeps across design iterations, over this rank's
    points: ``ffdkit.mpi.Deformer(comm, mesh_or_points, rig, global_ids=None)``
    (collective), an instance of the method's class like ``rig.deformer``.

    Built once by the library's distributed construction: every rank gets the
    same controls (rank 0's bits) and its points deform exactly as the same
    vertices of the whole mesh would. Afterwards everything is local to the
    rank and needs no communication: ``controls``, ``move``, ``set_controls``,
    ``evaluate``, ``jacobian``, ``sensitivities`` (this rank's rows) and
    ``sensitivity_product`` (W v for this rank's points). Change the controls
    identically on every rank (the same design variables), or the ranks'
    pieces stop fitting together.

    ``sensitivity_transpose_product(w)`` is the one sum over ranks: Wᵀw of
    the whole mesh is the sum of every rank's Wᵀw over its points, so it
    runs the local product and an Allreduce SUM (collective; the result is
    the same on every rank). A point held by several ranks must have its
    share of w on one of them only (zero elsewhere), or it counts twice.
    ``local_sensitivity_transpose_product`` is the rank's term alone.

    ``solve`` (direct manipulation of bound points) is refused: put the
    constraints in the rig, where vertex ids are global.
    """

    def __new__(cls, comm: Any, target: Any, rig: _ffd.Rig, global_ids: Any = None,
                limits: Optional[Mapping[str, Any]] = None):
        if not isinstance(rig, _ffd.Rig):
            raise TypeError(f"rig: expected an ffdkit.Rig, got {type(rig).__name__}")
        if cls is Deformer:
            cls = _distributed_class(METHOD_CLASSES.get(rig.method, _deformer.Deformer))
        r = reducer(comm)
        d = _ffd.deformer_distributed(cls, rig, target, r, global_ids, limits)
        d.__dict__["_reducer"] = r
        return d

    def __init__(self, comm: Any, target: Any, rig: _ffd.Rig, global_ids: Any = None,
                 limits: Optional[Mapping[str, Any]] = None):
        pass

    @property
    def comm(self) -> Any:
        """The communicator (an mpi4py one: its Reducer's ``comm``) or reducer given."""
        r = self.__dict__["_reducer"]
        return r.comm if isinstance(r, Reducer) else r

    def local_sensitivity_transpose_product(self, w: Any, out: Optional[np.ndarray] = None) -> np.ndarray:
        """Wᵀw over this rank's points only (C, 3), without the sum over ranks."""
        return _ffd.Deformer.sensitivity_transpose_product(self, w, out)

    def sensitivity_transpose_product(self, w: Any, out: Optional[np.ndarray] = None) -> np.ndarray:
        """Wᵀw of the whole mesh (C, 3), the adjoint product dJ/dP: this rank's
        product summed over ranks (an Allreduce SUM; collective, the same on
        every rank). w (M, 3): dJ/dX of this rank's points, each shared point's
        share on one rank only. The sum's rounding depends on the MPI
        reduction's order, not on this library."""
        g = self.local_sensitivity_transpose_product(w, out)
        self.__dict__["_reducer"].allreduce(g.reshape(-1), "sum")
        return g

    def solve(self, points: Any, targets: Any = None, rcond: float = 1e-10):
        """Refused on a distributed deformer: each rank would move the controls
        its own way. Put the constraints in the rig (global vertex ids)."""
        raise _ffd.UnsupportedError(
            "solve: a distributed deformer's ranks would each move the controls by their own "
            "points; give the constraints in the rig (vertex ids are global ids)")

    def __repr__(self) -> str:
        r = self.__dict__.get("_reducer")
        where = f" rank {r.rank} of {r.size}" if r is not None else ""
        return (f"<ffdkit.mpi.{type(self).__name__} {self.method}{where}: {self.point_count} "
                f"points, {self.control_count} controls>")
