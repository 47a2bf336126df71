"""ffdkit.mpi without MPI (the ordinary suite; test_mpi.py runs under mpirun): the
package imports without mpi4py, and the library's collective steps run over any
object with the reducer protocol, here ranks that are threads of one process."""
import os
import pathlib
import subprocess
import sys
import threading

import numpy as np
import pytest

import ffdkit
import ffdkit.mpi

REPO = pathlib.Path(__file__).resolve().parents[2]
BUNNY = REPO / "examples" / "lattice" / "bunny.obj"
PINS = REPO / "examples" / "lattice" / "pins.json"


class Threads:
    """size ranks as threads: the reducer protocol over shared memory and a barrier."""

    def __init__(self, size):
        self.size = size
        self.barrier = threading.Barrier(size, timeout=60)
        self.slots = [None] * size

    def rank(self, r):
        threads = self

        class Rank:
            rank, size = r, threads.size

            def allreduce(self, array, op):
                threads.slots[r] = array.copy()
                threads.barrier.wait()
                f = {"sum": np.sum, "min": np.min, "max": np.max,
                     "or": lambda a, axis: np.bitwise_or.reduce(a, axis=axis)}[op]
                result = f(np.stack(threads.slots), axis=0)
                threads.barrier.wait()
                array[...] = result

            def allgatherv(self, mine, out, sizes):
                assert len(mine) == sizes[r] and len(out) == sum(sizes)
                threads.slots[r] = bytes(mine)
                threads.barrier.wait()
                out[...] = np.frombuffer(b"".join(threads.slots), dtype=np.uint8)
                threads.barrier.wait()

        return Rank()

    def run(self, fn):
        """fn(reducer, rank) on every rank at once; returns the results (or exceptions)."""
        results = [None] * self.size

        def body(r):
            try:
                results[r] = fn(self.rank(r), r)
            except BaseException as e:  # noqa: BLE001 - handed to the test
                results[r] = e

        ts = [threading.Thread(target=body, args=(r,)) for r in range(self.size)]
        for t in ts:
            t.start()
        for t in ts:
            t.join(90)
        assert not any(t.is_alive() for t in ts), "a rank is still waiting"
        return results


@pytest.fixture(scope="module")
def bunny():
    return np.array(ffdkit.read_mesh(BUNNY).points)


def test_threads_as_ranks_bitwise(bunny):
    """Three thread ranks, vertices shared between neighbours: the one-process result,
    bitwise (the GIL is released in the library and taken back in each callback)."""
    rig = ffdkit.Rig.load(PINS)
    ref = rig.apply(bunny)
    bounds = np.linspace(0, len(bunny), 4).astype(int)
    pieces = [np.arange(max(0, bounds[r] - 5), min(len(bunny), bounds[r + 1] + 5)) for r in range(3)]
    res = Threads(3).run(lambda red, r: ffdkit.mpi.deform(red, bunny[pieces[r]], rig,
                                                           global_ids=pieces[r]))
    for r in range(3):
        assert not isinstance(res[r], BaseException), res[r]
        assert np.array_equal(res[r], ref[pieces[r]])


def test_threads_deformer_transpose_product_summed(bunny):
    rig = ffdkit.Rig.load(PINS)
    ref = rig.deformer(bunny)
    halves = np.array_split(np.arange(len(bunny)), 2)
    w = np.random.default_rng(3).normal(size=bunny.shape)

    def rank(red, r):
        d = ffdkit.mpi.Deformer(red, bunny[halves[r]], rig, global_ids=halves[r])
        return d.sensitivity_transpose_product(w[halves[r]]), repr(d)

    res = Threads(2).run(rank)
    g_ref = ref.sensitivity_transpose_product(w)
    for g, text in res:
        assert np.allclose(g, g_ref, rtol=1e-12, atol=1e-12 * np.abs(g_ref).max())
        assert "rank" in text and "of 2" in text


def test_one_rank_protocol_is_one_process(bunny):
    """A reducer of one rank (no MPI at all) gives rig.apply's result bitwise."""
    rig = ffdkit.Rig.load(PINS)
    (got,) = Threads(1).run(lambda red, r: ffdkit.mpi.deform(red, bunny, rig))
    assert np.array_equal(got, rig.apply(bunny))


def test_error_on_one_thread_rank_is_everyones(bunny):
    rig = ffdkit.Rig.load(PINS)
    mine = [bunny[:900].copy(), bunny[900:].copy()]
    mine[1][3, 0] = np.inf
    res = Threads(2).run(lambda red, r: ffdkit.mpi.deform(red, mine[r], rig))
    assert all(isinstance(e, ffdkit.NonFiniteError) for e in res), res
    assert str(res[0]) == str(res[1]) and str(res[0]).startswith("rank 1: points[3]")


def test_agree(bunny):
    res = Threads(2).run(lambda red, r: ffdkit.mpi.agree(red, KeyError("x") if r == 1 else None))
    assert all(isinstance(e, ffdkit.InvalidError) for e in res)
    assert str(res[0]) == "rank 1: KeyError: 'x'"
    assert isinstance(res[1].__cause__, KeyError) and res[0].__cause__ is None
    assert Threads(2).run(lambda red, r: ffdkit.mpi.agree(red)) == [None, None]


def test_reducer_protocol_checked(bunny):
    rig = ffdkit.Rig.load(PINS)
    with pytest.raises(TypeError, match="mpi4py communicator"):
        ffdkit.mpi.deform(object(), bunny, rig)

    class Bad:
        rank, size = 2, 2

        def allreduce(self, a, op):
            pass

        def allgatherv(self, mine, out, sizes):
            pass

    with pytest.raises(ValueError, match="rank 2 of size 2"):
        ffdkit.mpi.deform(Bad(), bunny, rig)


def test_imports_without_mpi4py(tmp_path):
    """import ffdkit.mpi works without mpi4py; using it with a communicator raises an
    ImportError naming Debian's package."""
    import ffdkit as pkg

    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(pathlib.Path(os.path.abspath(pkg.__file__)).parents[1])] +
        ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else [])))
    code = ("import sys; sys.modules['mpi4py'] = None\n"
            "import numpy as np, ffdkit, ffdkit.mpi\n"
            "rig = ffdkit.Rig.load({'version': 1, 'deformer': 'lattice', 'box': 'auto'})\n"
            "try:\n"
            "    ffdkit.mpi.deform(object(), np.zeros((3, 3)), rig)\n"
            "except ImportError as e:\n"
            "    print('ImportError:', e)\n")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    assert "python3-mpi4py" in done.stdout
