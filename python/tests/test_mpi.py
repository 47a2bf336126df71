"""ffdkit.mpi under MPI: run by every rank of

    timeout 120 mpirun --oversubscribe -np K /usr/bin/python3 -m pytest -q python/tests/test_mpi.py

for K = 1..4 (ctest python_mpi, tests/python/run_pytest_mpi.sh). Each rank holds a piece
of a real mesh's points (the bunny's, the cow's), with vertices shared between pieces;
the union of the ranks' results must equal the one-process result bit for bit, per
global id. Every test is collective: ranks run the same tests in the same order, and
each assertion is agreed over the ranks first (``agreed``), so that one rank's failure
fails every rank instead of leaving the others waiting in the next collective.
"""
import importlib.util
import pathlib

import numpy as np
import pytest

MPI = pytest.importorskip("mpi4py.MPI")

import ffdkit  # noqa: E402
import ffdkit.mpi  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
BUNNY = REPO / "examples" / "lattice" / "bunny.obj"
COW = REPO / "examples" / "pbffd" / "cow.off"

comm = MPI.COMM_WORLD
rank, size = comm.Get_rank(), comm.Get_size()


def named(r):
    """How an agreed error names the failing rank r: "rank r: " (nothing with one rank)."""
    return f"rank {r}: " if size > 1 else ""


def agreed(ok, what=""):
    """Asserts ok on every rank at once: each rank learns every rank's verdict."""
    verdicts = comm.allgather((bool(ok), f"rank {rank}: {what}"))
    bad = [w for o, w in verdicts if not o]
    assert not bad, "; ".join(bad)


def slices(n, overlap=7, empty_last=False):
    """Rank r's global ids: a contiguous slice, widened by `overlap` ids on each side
    (shared with the neighbours), listed in a shuffled order. empty_last: the last rank
    (of more than one) holds nothing."""
    parts = size - 1 if empty_last and size > 1 else size
    if rank >= parts:
        return np.empty(0, dtype=np.int64)
    bounds = np.linspace(0, n, parts + 1).astype(np.int64)
    ids = np.arange(max(0, bounds[rank] - overlap), min(n, bounds[rank + 1] + overlap))
    return np.random.default_rng(rank).permutation(ids)


def scattered(n, share=0.05):
    """Rank r's global ids: each vertex on a rank drawn at random (the same draw on
    every rank), 5% of them on a second rank too."""
    rng = np.random.default_rng(1234)
    owner = rng.integers(0, size, n)
    second = rng.integers(0, size, n)
    shared = rng.random(n) < share
    return np.flatnonzero((owner == rank) | (shared & (second == rank)))


def check_union(ids, got, ref, what):
    """got (this rank's rows, ids) equals ref[ids] bitwise, and the ranks together
    hold every id."""
    same = np.array_equal(got.view(np.uint64), ref[ids].view(np.uint64))
    bad = np.flatnonzero(np.any(got != ref[ids], axis=1))
    agreed(same, f"{what}: {len(bad)} of {len(ids)} points differ"
           + (f", first global id {ids[bad[0]]}: {got[bad[0]]} != {ref[ids[bad[0]]]}" if len(bad) else ""))
    held = np.minimum(np.bincount(ids, minlength=len(ref)), 1).astype(np.int64)
    comm.Allreduce(MPI.IN_PLACE, held, op=MPI.MAX)
    agreed(held.all(), f"{what}: the ranks hold {held.sum()} of {len(ref)} ids")


@pytest.fixture(scope="module")
def bunny():
    mesh = ffdkit.read_mesh(BUNNY)
    return np.array(mesh.points), np.array(mesh.faces, dtype=np.int64)


def lattice_rig():
    # a B-spline lattice with an auto box and vertex constraints on vertices that fall
    # on different ranks' slices for K = 2..4 (239, 553, 896, 1043, 1791 of 1839)
    return ffdkit.Rig.load(REPO / "examples" / "lattice" / "pins.json")


def rbf_rig():
    return ffdkit.Rig.load(REPO / "examples" / "rbf" / "bunny-pins.json")


# ---- points: every linear method's result is the one-process result, bit for bit ----

@pytest.mark.parametrize("rig_of", [lattice_rig, rbf_rig], ids=["lattice", "rbf"])
@pytest.mark.parametrize("split", ["slices", "scattered", "empty_last"])
def test_deform_points_bitwise(bunny, rig_of, split):
    points, _ = bunny
    rig = rig_of()
    ref = rig.apply(points)
    ids = {"slices": lambda: slices(len(points)), "scattered": lambda: scattered(len(points)),
           "empty_last": lambda: slices(len(points), empty_last=True)}[split]()
    got = ffdkit.mpi.deform(comm, points[ids], rig, global_ids=ids)
    agreed(got.shape == (len(ids), 3), f"shape {got.shape}")
    check_union(ids, got, ref, f"{rig.method} {split}")


@pytest.mark.parametrize("name", ["idw/bunny-pins.json", "kelvinlet/bunny-pins.json",
                                  "cage/bunny-drag.json"])
def test_deform_points_other_methods(bunny, name):
    """The examples' bunny rigs with vertex constraints of IDW, Kelvinlet and the cage."""
    points, _ = bunny
    rig = ffdkit.Rig.load(REPO / "examples" / name)
    ref = rig.apply(points)
    ids = scattered(len(points))
    got = ffdkit.mpi.deform(comm, points[ids], rig, global_ids=ids)
    check_union(ids, got, ref, name)


def test_deform_rank_major(bunny):
    """global_ids=None: rank r's points follow those of ranks 0 .. r-1."""
    points, _ = bunny
    rig = lattice_rig()
    ref = rig.apply(points)
    bounds = np.linspace(0, len(points), size + 1).astype(np.int64)
    ids = np.arange(bounds[rank], bounds[rank + 1])
    out = np.empty((len(ids), 3))
    got = ffdkit.mpi.deform(comm, points[ids], rig, out=out)
    agreed(got is out, "out= is returned")
    check_union(ids, got, ref, "rank-major")


def test_apply_mesh_pieces(bunny):
    """Each rank's piece is a Mesh of its faces: deformed in place like rig.apply of
    the whole mesh, and the report is the same on every rank."""
    points, faces = bunny
    rig = lattice_rig()
    whole = ffdkit.Mesh(points, faces)
    rig.apply(whole)
    ref = np.array(whole.points)
    mine = faces[np.array_split(np.arange(len(faces)), size)[rank]]
    ids = np.unique(mine)
    local = np.searchsorted(ids, mine)
    piece = ffdkit.Mesh(points[ids], local)
    report = ffdkit.mpi.apply(comm, piece, rig, global_ids=ids)
    check_union(ids, np.array(piece.points), ref, "mesh pieces")
    agreed(report["method"] == "lattice", f"report method {report['method']!r}")
    gathered = comm.allgather((report["residuals"].tobytes(), report["control_points"].tobytes(),
                               report["max_residual"]))
    agreed(all(g == gathered[0] for g in gathered), "the report differs between ranks")
    agreed(report["constraint_count"] == 6, f"constraint_count {report['constraint_count']}")


def test_pbffd_placement_surface():
    """PB-FFD placement reads the boundary surface, which the ranks gather in a canonical
    order (placement sums over the faces in that order in one process too): the
    pieces' union equals one process deforming the whole mesh through the same
    distributed path (COMM_SELF) and rig.apply of the whole mesh, bitwise."""
    mesh = ffdkit.read_mesh(COW)
    points, faces = np.array(mesh.points), np.array(mesh.faces, dtype=np.int64)
    rig = ffdkit.Rig.load(REPO / "examples" / "pbffd" / "cow-head.json")
    mine = faces[np.array_split(np.arange(len(faces)), size)[rank]]
    ids = np.unique(mine)
    got = ffdkit.mpi.deform(comm, points[ids], rig, global_ids=ids,
                            faces=np.searchsorted(ids, mine))
    one = ffdkit.mpi.deform(MPI.COMM_SELF, points, rig, global_ids=np.arange(len(points)),
                            faces=faces)
    check_union(ids, got, one, "pbffd placement vs one process")
    whole = ffdkit.Mesh(points, faces)
    rig.apply(whole)
    check_union(ids, got, np.array(whole.points), "pbffd placement vs rig.apply")


BOX = REPO / "data" / "volume" / "box_tet_binary.vtk"  # 354 nodes, 1151 tets, 580 boundary faces

SURFACE_RIGS = {
    "pbffd": {"version": 1, "deformer": "pbffd", "controls": {"interior": 12, "exterior": 12},
              "moves": [{"near": [2, 1, 1], "delta": [0.1, 0.05, 0]}]},
    "tspline": {"version": 1, "deformer": "tspline", "resolution": [4, 4, 4],
                "steps": [{"deform": {"handles": [{"box": {"min": [-9, -9, 0.6], "max": [9, 9, 9]},
                                                   "delta": [0.1, 0, 0.05]}]}}]},
}


def volume_piece(mesh):
    """This rank's cells (cut by their centroids' x into one block per rank), their
    nodes' global ids and the cells over the piece's own nodes."""
    (kind, tets), = mesh.cells
    tets = np.asarray(tets, dtype=np.int64)
    order = np.argsort(np.asarray(mesh.points)[tets].mean(axis=1)[:, 0], kind="stable")
    mine = tets[np.array_split(order, size)[rank]]
    ids = np.unique(mine)
    return ids, [(kind, np.searchsorted(ids, mine))]


@pytest.mark.parametrize("method", ["pbffd", "tspline"])
def test_volume_pieces_surface_methods(method):
    """A tetrahedral volume cut between the ranks: each piece's boundary includes the
    partition's interface, whose faces cancel in the gathered surface. PB-FFD placement
    and the T-spline (which read the surface) equal one process running the same call
    on the whole volume (MPI.COMM_SELF) and rig.apply, bitwise."""
    mesh = ffdkit.read_mesh(BOX)
    points = np.array(mesh.points)
    rig = ffdkit.Rig.load(SURFACE_RIGS[method])
    ids, cells = volume_piece(mesh)
    got = ffdkit.mpi.deform(comm, points[ids], rig, global_ids=ids, cells=cells)
    one = ffdkit.mpi.deform(MPI.COMM_SELF, points, rig, cells=mesh.cells)
    agreed(np.max(np.abs(one - points)) > 0.01, f"{method}: the rig moves the volume")
    check_union(ids, got, one, f"{method} volume pieces vs one process")
    whole = ffdkit.read_mesh(BOX)
    rig.apply(whole)
    check_union(ids, got, np.array(whole.points), f"{method} volume pieces vs rig.apply")


# ---- the deformer a solver keeps ----

def test_deformer_design_loop(bunny):
    """ffdkit.mpi.Deformer: controls set the same on every rank give the one-process
    deformer's points bitwise; the transpose product is summed over the ranks."""
    points, _ = bunny
    rig = lattice_rig()
    ids = slices(len(points))
    d = ffdkit.mpi.Deformer(comm, points[ids], rig, global_ids=ids)
    ref = rig.deformer(points)
    agreed(isinstance(d, ffdkit.mpi.Deformer) and isinstance(d, type(ref)),
           f"class {type(d).__mro__}")
    agreed(np.array_equal(d.controls, ref.controls), "the controls differ from one process's")
    rng = np.random.default_rng(7)
    for _ in range(3):  # a design loop: the same move on every rank
        delta = rng.normal(scale=0.05, size=(d.control_count, 3))
        d.controls += delta
        ref.controls += delta
        check_union(ids, d.evaluate(), ref.evaluate(), "design step")
    # W^T w: each shared point's share of w on its lowest rank only
    w_all = rng.normal(size=(len(points), 3))
    first = np.where(np.bincount(ids, minlength=len(points)) > 0, rank, size).astype(np.int64)
    comm.Allreduce(MPI.IN_PLACE, first, op=MPI.MIN)
    w = np.where((first[ids] == rank)[:, None], w_all[ids], 0.0)
    g = d.sensitivity_transpose_product(w)
    g_ref = ref.sensitivity_transpose_product(w_all)
    agreed(np.allclose(g, g_ref, rtol=1e-12, atol=1e-12 * np.abs(g_ref).max()),
           f"W^T w off by {np.abs(g - g_ref).max():g}")
    same = comm.allgather(g.tobytes())
    agreed(all(s == same[0] for s in same), "W^T w differs between ranks")
    local = d.local_sensitivity_transpose_product(w)
    comm.Allreduce(MPI.IN_PLACE, local, op=MPI.SUM)
    agreed(np.allclose(local, g), "local product")
    with pytest.raises(ffdkit.UnsupportedError, match="constraints in the rig"):
        d.solve([0], [[0.0, 0.0, 0.0]])


# ---- errors: every rank raises the same error, nobody waits ----

def test_error_bad_vertex_id(bunny):
    points, _ = bunny
    rig = ffdkit.Rig.load({"version": 1, "deformer": "lattice", "resolution": [3, 3, 3],
                           "box": "auto",
                           "constraints": [{"vertex": 99999, "target": [0, 0, 0]}]})
    ids = slices(len(points))
    with pytest.raises(ffdkit.RangeError) as e:
        ffdkit.mpi.deform(comm, points[ids], rig, global_ids=ids)
    msgs = comm.allgather(str(e.value))
    agreed(all(m == msgs[0] for m in msgs), f"messages differ: {msgs}")
    agreed("99999" in msgs[0], msgs[0])


def test_error_nan_point_on_one_rank(bunny):
    points, _ = bunny
    ids = slices(len(points))
    mine = points[ids].copy()
    bad_rank = min(1, size - 1)
    if rank == bad_rank:
        mine[5, 1] = np.nan
    with pytest.raises(ffdkit.NonFiniteError) as e:
        ffdkit.mpi.deform(comm, mine, lattice_rig(), global_ids=ids)
    msgs = comm.allgather(str(e.value))
    agreed(all(m == msgs[0] for m in msgs), f"messages differ: {msgs}")
    agreed(msgs[0].startswith(f"{named(bad_rank)}points[5]: non-finite"), msgs[0])


def test_error_argument_on_one_rank(bunny):
    """A Python-level argument error on one rank (wrong global_ids length) is agreed:
    every rank raises InvalidError naming it; on that rank the ValueError is the cause."""
    points, _ = bunny
    ids = slices(len(points))
    given = ids[:-1] if rank == size - 1 else ids
    with pytest.raises(ffdkit.InvalidError) as e:
        ffdkit.mpi.deform(comm, points[ids], lattice_rig(), global_ids=given)
    msg = str(e.value)
    agreed(msg.startswith(f"{named(size - 1)}ValueError: global_ids: expected"), msg)
    agreed(isinstance(e.value.__cause__, ValueError) == (rank == size - 1), "cause")


def test_error_bad_faces_on_one_rank(bunny):
    points, faces = bunny
    ids = np.arange(len(points))
    mine = faces.copy()
    if rank == 0:
        mine[0, 0] = len(points) + 5
    with pytest.raises(ffdkit.Error) as e:
        ffdkit.mpi.deform(comm, points, lattice_rig(), global_ids=ids, faces=mine)
    agreed(str(e.value).startswith(f"{named(0)}IndexError: faces[0][0]: vertex"), str(e.value))


class Failing(ffdkit.mpi.Reducer):
    """The mpi4py reducer, failing its n-th callback on every rank alike."""

    class Boom(Exception):
        pass

    def __init__(self, comm, fail_at):
        super().__init__(comm)
        self.calls, self.fail_at = 0, fail_at

    def allreduce(self, array, op):
        self.calls += 1
        if self.calls == self.fail_at:
            raise Failing.Boom(f"allreduce call {self.calls}")
        super().allreduce(array, op)

    def allgatherv(self, mine, out, sizes):
        self.calls += 1
        if self.calls == self.fail_at:
            raise Failing.Boom(f"allgatherv call {self.calls}")
        super().allgatherv(mine, out, sizes)


@pytest.mark.parametrize("fail_at", [1, 2, 3])
def test_callback_exception_is_raised(bunny, fail_at):
    points, _ = bunny
    ids = slices(len(points))
    r = Failing(comm, fail_at)
    with pytest.raises(Failing.Boom, match=f"call {fail_at}$"):
        ffdkit.mpi.deform(r, points[ids], lattice_rig(), global_ids=ids)


def test_reducer_must_not_keep_buffers(bunny):
    points, _ = bunny
    ids = slices(len(points))
    kept = []

    class Keeping(ffdkit.mpi.Reducer):
        def allreduce(self, array, op):
            super().allreduce(array, op)
            kept.append(array)

    with pytest.raises(RuntimeError, match="kept a reference"):
        ffdkit.mpi.deform(Keeping(comm), points[ids], lattice_rig(), global_ids=ids)
    kept.clear()


# ---- the worked example ----

def test_example_mpi_morph(tmp_path):
    spec = importlib.util.spec_from_file_location("mpi_morph", REPO / "examples" / "python" / "mpi_morph.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    out = tmp_path / "morphed.obj" if rank == 0 else None
    history = example.main(comm, steps=4, out=out)
    agreed(len(history) == 4 and history[-1] < history[0], f"objective {history}")
    agreed(comm.allgather(history) == [history] * size, "objective differs between ranks")
    alone = example.main(MPI.COMM_SELF, steps=4)  # one process, the whole mesh
    agreed(np.allclose(history, alone, rtol=1e-10, atol=0), f"{history} != one process's {alone}")
    if rank == 0:
        agreed(out.exists(), "the morphed mesh was written")
    else:
        agreed(True)
