"""Threads, the GIL and asyncio (docs/python-methods.md, "Threads, the GIL, reference counts").

* The GIL is released during binding and evaluation: a second Python thread
  runs while the C call does. The harness is deterministic where it must
  fail: the switch interval is raised to 10 s, so a thread that holds the GIL
  is never made to hand it over (within 10 s) and the helper thread cannot
  run between the two reads of its counter around the call unless the call
  releases the GIL; ``test_harness_sees_a_held_gil`` runs the same harness
  on a C call that holds the GIL (``sum(range(...))``) and sees no progress.
  The helper does one step per wake-up and then waits again, so it never
  holds the GIL long enough to stall the main thread.
* Two threads with a deformer each give bitwise the results of a sequential
  run.
* Two threads on ONE deformer are serialised or refused with RuntimeError,
  never a crash or a torn result.
* ``loop.run_in_executor`` runs a deformer's calls off the event loop.
"""

import asyncio
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import ffdkit

BIG = 1_500_000  # points of the long calls (1.5 M: about 36 MB per (N,3) array)

LATTICE = {"version": 1, "deformer": "lattice", "resolution": [6, 6, 6], "outside": "clamp"}


def cube_mesh():
    return ffdkit.Mesh(
        np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)]),
        [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]],
    )


def lattice(points=None):
    d = ffdkit.Rig.load(LATTICE).deformer(cube_mesh())
    if points is not None:
        d.bind(points)
    return d


@pytest.fixture(scope="module")
def big_points():
    rng = np.random.default_rng(18)
    return rng.random((BIG, 3))


@contextmanager
def long_switch_interval():
    old = sys.getswitchinterval()
    sys.setswitchinterval(10.0)
    try:
        yield
    finally:
        sys.setswitchinterval(old)


class Helper:
    """A second Python thread that takes one step (counter += 1) each time it
    is woken and then blocks again (releasing the GIL while it waits)."""

    def __init__(self):
        self.counter = 0
        self.wake = threading.Semaphore(0)
        self.stop = False
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        while True:
            self.wake.acquire()
            if self.stop:
                return
            self.counter += 1

    def close(self):
        self.stop = True
        self.wake.release()
        self.thread.join(timeout=30)


def progressed_during(call, tries=5):
    """True when the helper took a step between just before and just after
    call() in some try (a GIL-releasing call gives it the chance; a call that
    holds the GIL does not, with the 10 s switch interval)."""
    helper = Helper()
    try:
        with long_switch_interval():
            for _ in range(tries):
                helper.wake.release()  # the helper now wants the GIL
                before = helper.counter
                call()
                after = helper.counter
                if after > before:
                    return True
                # let it take its pending step before the next try
                while helper.counter == before:
                    helper.thread.join(timeout=0.001)
        return False
    finally:
        helper.close()


def test_harness_sees_a_held_gil():
    # the negative control: a long C call that keeps the GIL
    assert not progressed_during(lambda: sum(range(20_000_000)), tries=2)


def test_gil_released_during_evaluate(big_points):
    d = lattice(big_points)
    d.move([100], [[0.1, 0.0, 0.0]])
    out = np.empty((BIG, 3))
    assert progressed_during(lambda: d.evaluate(out=out))
    assert np.array_equal(out, d.evaluate())


def test_gil_released_during_bind(big_points):
    d = lattice()
    assert progressed_during(lambda: d.bind(big_points))
    assert d.point_count == BIG


def test_gil_released_during_jacobian(big_points):
    d = lattice(big_points[: BIG // 3])
    assert progressed_during(d.jacobian)


def test_gil_released_during_read_mesh(tmp_path):
    # a 300k-vertex OFF file (about 12 MB)
    n = 300_000
    p = np.random.default_rng(1).random((n, 3))
    path = tmp_path / "cloud.off"
    with open(path, "w") as f:
        f.write(f"OFF\n{n} 0 0\n")
        np.savetxt(f, p, fmt="%.17g")
    assert progressed_during(lambda: ffdkit.read_mesh(str(path)))


def test_gil_released_during_placement():
    cow = ffdkit.read_mesh(str(Path(__file__).resolve().parents[2] / "examples" / "pbffd" / "cow.off"))
    assert progressed_during(lambda: ffdkit.pbffd.place(cow, interior=30, exterior=30), tries=3)


def test_gil_released_during_solve(big_points):
    d = lattice(big_points[:400_000])
    ids = np.arange(0, 400_000, 40_000)
    targets = big_points[ids] + 0.01
    assert progressed_during(lambda: d.solve(ids, targets))


# ---------------------------------------------------------------------------
# two deformers in two threads
# ---------------------------------------------------------------------------


def job(seed, points):
    """Bind, move, evaluate, jacobian: the results of one deformer."""
    rng = np.random.default_rng(seed)
    d = lattice(points)
    results = []
    for _ in range(4):
        ids = rng.choice(d.control_count, size=5, replace=False)
        d.move(ids, rng.normal(scale=0.05, size=(5, 3)))
        results.append(d.evaluate().copy())
    results.append(d.jacobian().copy())
    return results


def test_two_deformers_in_two_threads_equal_sequential(big_points):
    points = [big_points[:200_000], big_points[200_000:400_000]]
    sequential = [job(7, points[0]), job(8, points[1])]
    with ThreadPoolExecutor(max_workers=2) as pool:
        for _ in range(2):
            futures = [pool.submit(job, 7, points[0]), pool.submit(job, 8, points[1])]
            concurrent = [f.result(timeout=300) for f in futures]
            for seq, con in zip(sequential, concurrent):
                assert all(np.array_equal(a, b) for a, b in zip(seq, con))


# ---------------------------------------------------------------------------
# one deformer, two threads: serialised or refused, never torn
# ---------------------------------------------------------------------------


def test_one_deformer_two_threads_serialised_or_refused(big_points):
    points = big_points[:300_000]
    d = lattice(points)
    rest = d.controls.copy()
    moved = rest.copy()
    moved[:, 1] += 0.05 * np.sin(3 * rest[:, 0])
    d.controls = moved
    at_moved = d.evaluate().copy()
    d.controls = rest
    at_rest = d.evaluate().copy()
    refused = []
    torn = []
    stop = threading.Event()

    def writer():
        k = 0
        while not stop.is_set():
            try:
                d.controls = moved if k % 2 else rest
                k += 1
            except RuntimeError as e:
                refused.append(str(e))

    def reader():
        for _ in range(25):
            try:
                x = d.evaluate()
            except RuntimeError as e:
                refused.append(str(e))
                continue
            if not (np.array_equal(x, at_rest) or np.array_equal(x, at_moved)):
                torn.append(float(np.abs(x - at_rest).max()))

    t1, t2 = threading.Thread(target=writer), threading.Thread(target=reader)
    t1.start()
    t2.start()
    t2.join(timeout=300)
    stop.set()
    t1.join(timeout=300)
    assert not t1.is_alive() and not t2.is_alive()
    assert not torn, f"an evaluation saw a half-written control set: {torn[:3]}"
    # the deformer still works after the contention
    d.controls = rest
    assert np.array_equal(d.evaluate(), at_rest)


def test_one_deformer_concurrent_binds(big_points):
    a, b = big_points[:250_000], big_points[250_000:600_000]
    d = lattice(a)
    d.move([50], [[0.0, 0.2, 0.0]])
    expect = {len(a): d.evaluate().copy()}
    d.bind(b)
    expect[len(b)] = d.evaluate().copy()
    errors = []

    def binder(points):
        for _ in range(4):
            try:
                d.bind(points)
            except RuntimeError as e:
                errors.append(e)

    threads = [threading.Thread(target=binder, args=(p,)) for p in (a, b)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=300)
    x = d.evaluate()
    assert d.point_count in expect and np.array_equal(x, expect[d.point_count])


# ---------------------------------------------------------------------------
# asyncio
# ---------------------------------------------------------------------------


def test_asyncio_run_in_executor(big_points):
    d = lattice(big_points[:500_000])
    d.move([10, 20], [[0.1, 0, 0], [0, 0.1, 0]])
    expect = d.evaluate().copy()

    async def main():
        loop = asyncio.get_running_loop()
        ticks = 0
        fut = loop.run_in_executor(None, d.evaluate)
        while not fut.done():
            ticks += 1
            await asyncio.sleep(0)
        bound = await loop.run_in_executor(None, d.bind, big_points[:1000])
        return await fut, ticks, bound

    result, ticks, bound = asyncio.run(main())
    assert ticks > 0 and bound is None
    assert np.array_equal(result, expect)
    assert d.point_count == 1000
