"""The pool of page-locked host blocks for GPU images (:mod:`sarmotion.imaging._cuda_host`).

The pool's bookkeeping does not need a GPU: ``cuda.pinned_array`` is replaced by a
recording allocator of ordinary memory, so the tests see which requests were served from
a kept block, which from a new one and which from pageable memory.
"""

from __future__ import annotations

import gc

import numpy as np
import pytest

from sarmotion.imaging._cuda_host import BLOCK_GRANULE, PinnedPool


class RecordingCuda:
    """``pinned_array`` from ordinary memory, recording each allocation's size."""

    def __init__(self, refuse: bool = False) -> None:
        self.allocations: list[int] = []
        self.refuse = refuse

    def pinned_array(self, n: int, dtype) -> np.ndarray:
        if self.refuse:
            raise MemoryError("cuMemHostAlloc failed")
        self.allocations.append(int(n))
        return np.empty(n, dtype)


def _in_block(array: np.ndarray) -> bool:
    return type(array.base).__name__ == "_Lease"


#: A complex128 image of exactly one block.
ONE_BLOCK = (BLOCK_GRANULE // (16 * 512), 512)


def test_a_released_image_gives_its_block_to_the_next_one():
    cuda = RecordingCuda()
    pool = PinnedPool(cuda, limit_bytes=64 * BLOCK_GRANULE)
    a = pool.empty((300, 500), np.complex128)  # 2.4 MB: two blocks
    address = a.ctypes.data
    assert _in_block(a) and a.shape == (300, 500) and a.dtype == np.complex128
    assert a.flags.c_contiguous and a.flags.writeable
    del a
    b = pool.empty((300, 500), np.complex128)
    assert b.ctypes.data == address
    assert cuda.allocations == [2 * BLOCK_GRANULE]


def test_a_surviving_view_keeps_its_block():
    cuda = RecordingCuda()
    pool = PinnedPool(cuda, limit_bytes=64 * BLOCK_GRANULE)
    a = pool.empty(ONE_BLOCK, np.complex128)
    a[...] = np.arange(a.size).reshape(ONE_BLOCK) * (1 + 1j)
    views = [a.T[3:], a.real, a.view(np.float64)[::2]]
    expected = [v.copy() for v in views]
    del a
    gc.collect()
    for _ in range(3):  # each request finds the block still viewed: a new block, not it
        b = pool.empty(ONE_BLOCK, np.complex128)
        b[...] = -7.0
        for v, e in zip(views, expected, strict=True):
            np.testing.assert_array_equal(v, e)
        del b
    assert len(cuda.allocations) == 2  # the viewed block and one reused by the others
    del views, v
    assert pool.idle_bytes() == 2 * BLOCK_GRANULE


def test_past_the_limit_an_image_is_pageable():
    cuda = RecordingCuda()
    pool = PinnedPool(cuda, limit_bytes=2 * BLOCK_GRANULE)
    kept = pool.empty((BLOCK_GRANULE // 8,), np.float64)  # one block
    big = pool.empty((2 * BLOCK_GRANULE // 8,), np.float64)  # two more: over the limit
    assert _in_block(kept) and not _in_block(big)
    assert pool.held_bytes == BLOCK_GRANULE
    assert big.shape == (2 * BLOCK_GRANULE // 8,)


def test_idle_blocks_are_freed_to_make_room():
    cuda = RecordingCuda()
    pool = PinnedPool(cuda, limit_bytes=3 * BLOCK_GRANULE)
    small = pool.empty(ONE_BLOCK, np.complex128)
    del small  # idle: one block
    big = pool.empty((3 * BLOCK_GRANULE // 16,), np.complex128)  # needs the whole limit
    assert _in_block(big)
    assert pool.held_bytes == 3 * BLOCK_GRANULE
    assert pool.idle_bytes() == 0


def test_a_refusing_driver_gives_pageable_memory():
    pool = PinnedPool(RecordingCuda(refuse=True), limit_bytes=64 * BLOCK_GRANULE)
    a = pool.empty(ONE_BLOCK, np.complex128)
    assert not _in_block(a) and a.shape == ONE_BLOCK
    assert pool.held_bytes == 0


@pytest.mark.parametrize("shape", [(0, 5), (0,), (1, 1), (ONE_BLOCK[0] - 1, ONE_BLOCK[1])])
def test_an_array_smaller_than_a_block_takes_none(shape):
    cuda = RecordingCuda()
    pool = PinnedPool(cuda, limit_bytes=64 * BLOCK_GRANULE)
    a = pool.empty(shape, np.complex128)
    assert a.shape == shape and not _in_block(a) and cuda.allocations == []
    assert _in_block(pool.empty(ONE_BLOCK, np.complex128))  # one block: pooled
