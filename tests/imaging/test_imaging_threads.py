"""Backprojection from many threads at once: the shared trace-table cache stays consistent.

Dask runs the sub-aperture images of ``track`` in worker threads that share
:data:`sarmotion.imaging._bp_table.TABLES`. Here many threads image different traces
objects concurrently while other threads' traces die (their weak-reference callbacks run
wherever the garbage collector does) and the cache, shrunk to a few tables, evicts on
every insertion. Every image must equal the one computed alone.
"""

from __future__ import annotations

import gc
import sys
import threading

import numpy as np
import pytest

from sarmotion.core import Trajectory
from sarmotion.imaging import ImageGrid, _bp_table, backproject
from sarmotion.simulation import PointTarget, Scene, simulate

N_THREADS = 8
ROUNDS = 4


@pytest.fixture(scope="module")
def traces():
    scene = Scene(name="threads", targets=[PointTarget(position_m=(2.0, -1.0))])
    trajectory = Trajectory.circular(aperture_deg=0.5)
    return simulate(scene, trajectory=trajectory).traces


def test_concurrent_backprojection_with_evictions(traces, monkeypatch, fast_switching):
    grid = ImageGrid.square(centre_m=(2.0, -1.0), size_m=4.0, spacing_m=0.5)
    alone = backproject(traces, grid).values
    table_bytes = _bp_table.TABLES.get(traces, 6).values.nbytes
    monkeypatch.setattr(_bp_table, "CACHE_BYTES", 3 * table_bytes)  # evict on every insertion
    _bp_table.TABLES.clear()
    errors: list[BaseException] = []
    start = threading.Barrier(N_THREADS)

    def work(k: int) -> None:
        try:
            start.wait()
            for r in range(ROUNDS):
                scale = complex(k + 1, r)
                tr = traces.with_data(traces.data * scale)  # a new traces object each round
                img = backproject(tr, grid).values
                # The scaled data round differently in the table (float16 c2, c3: up to
                # 7e-5 of the amplitude, module bound; complex64 c0, c1): the two images
                # agree within twice that of the coherent sum's peak, |scale| max|alone|.
                np.testing.assert_allclose(
                    img, scale * alone, rtol=0, atol=1.5e-4 * abs(scale) * abs(alone).max()
                )
                again = backproject(tr, grid).values  # the cached table, if still held
                np.testing.assert_array_equal(again, img)
                del tr  # its table's entry is queued for removal by the callback
                if r % 2 == k % 2:
                    gc.collect()
        except BaseException as exc:  # reported in the main thread
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(N_THREADS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors[0]


@pytest.fixture
def fast_switching():
    """Switch threads every microsecond (default 5 ms), so races show within a test."""
    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    yield
    sys.setswitchinterval(old)


def test_cache_stress_without_imaging(traces, monkeypatch, fast_switching):
    # The cache alone with small stand-in tables, many more operations from 16 threads:
    # get, drop, collect, clear, with ~400 entries held so that the eviction scan over
    # the entries is long. (An unlocked cache fails this with "OrderedDict mutated during
    # iteration".)
    monkeypatch.setattr(_bp_table, "CACHE_BYTES", 400 * 8000)
    monkeypatch.setattr(_bp_table, "make_table", lambda data, factor: _bp_table.TraceTable(
        values=np.zeros((1, 1000), np.uint64), upsample=factor, n_up=0))  # fmt: skip
    cache = _bp_table.TableCache()
    errors: list[BaseException] = []

    def work(k: int) -> None:
        try:
            for r in range(300):
                tr = traces.with_data(traces.data)
                assert cache.get(tr, 2).upsample == 2
                del tr
                if (r + k) % 17 == 0:
                    gc.collect()
                if (r + k) % 53 == 0:
                    cache.clear()
        except BaseException as exc:
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(16)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors[0]
    # Entries of collected traces are gone after the next call; the cache keeps its bound.
    gc.collect()
    cache.get(traces, 2)
    assert all(ref() is not None for ref, _, _ in cache._entries.values())
    assert len(cache._entries) <= 400
