"""Reused blocks of host memory (:mod:`sarmotion.imaging._block_pool`).

The pool's own rules with an allocator of ordinary memory that records its requests; the
page-locked pool built on it is tested in ``test_cuda_host.py``, the trace tables that use
it in ``test_fast_imaging.py``.
"""

from __future__ import annotations

import numpy as np

from sarmotion.imaging._block_pool import BLOCK_GRANULE, BlockPool

ONE_BLOCK = (BLOCK_GRANULE // 4,)  # float32


def _recording_pool(**limits) -> tuple[BlockPool, list[int]]:
    sizes: list[int] = []

    def allocate(n: int) -> np.ndarray:
        sizes.append(n)
        return np.empty(n, np.uint8)

    return BlockPool(allocate, **limits), sizes


def test_idle_blocks_beyond_the_idle_limit_are_freed_as_they_come_back():
    pool, sizes = _recording_pool(
        limit_bytes=16 * BLOCK_GRANULE, idle_limit_bytes=2 * BLOCK_GRANULE
    )
    arrays = [pool.empty(ONE_BLOCK, np.float32) for _ in range(4)]
    last = arrays[-1].ctypes.data
    assert pool.held_bytes == 4 * BLOCK_GRANULE and len(sizes) == 4
    while arrays:  # back in order, without another request: the lock was free, so each
        arrays.pop(0)  # finalizer drained the queue
    assert pool.held_bytes == 2 * BLOCK_GRANULE
    assert pool.idle_bytes() == 2 * BLOCK_GRANULE
    again = pool.empty(ONE_BLOCK, np.float32)  # the last one back is the first handed out
    assert again.ctypes.data == last and len(sizes) == 4


def test_a_block_is_handed_out_only_for_its_own_size():
    pool, sizes = _recording_pool(limit_bytes=16 * BLOCK_GRANULE)
    a = pool.empty((2 * BLOCK_GRANULE // 4,), np.float32)  # two granules
    del a
    b = pool.empty(ONE_BLOCK, np.float32)  # one granule: a new block, the idle one kept
    assert sizes == [2 * BLOCK_GRANULE, BLOCK_GRANULE]
    assert pool.idle_bytes() == 2 * BLOCK_GRANULE
    c = pool.empty((2 * BLOCK_GRANULE // 4 - 7,), np.float32)  # rounds up to two granules
    assert len(sizes) == 2 and c.shape == (2 * BLOCK_GRANULE // 4 - 7,)
    assert b.base is not None and c.base is not None


def test_release_idle_frees_every_idle_block():
    pool, _ = _recording_pool(limit_bytes=16 * BLOCK_GRANULE)
    kept = pool.empty(ONE_BLOCK, np.float32)
    dropped = [pool.empty(ONE_BLOCK, np.float32) for _ in range(3)]
    del dropped
    pool.release_idle()
    assert pool.idle_bytes() == 0 and pool.held_bytes == BLOCK_GRANULE
    kept[...] = 1.0  # a leased block is untouched
    assert float(kept.sum()) == ONE_BLOCK[0]
