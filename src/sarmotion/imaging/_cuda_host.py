"""Page-locked host memory for the GPU's images: blocks kept in a pool and reused.

A copy from the device into page-locked (pinned) host memory runs at the bus's rate.
Into fresh pageable memory the driver stages it through a pinned buffer of its own and
the operating system maps every new page on first touch, far slower for an
image of hundreds of megabytes. Locking pages is itself slow (each page is locked, and
unlocked when freed), so blocks are allocated once and reused: an image's array views a
block, and the block returns to the pool when the last array that views it is gone
(:class:`~._block_pool.BlockPool`: the leases, the limit, the fall-back to ordinary
memory).

An array smaller than a block (:data:`~._block_pool.BLOCK_GRANULE`) is ordinary memory:
its copy is short either way (the driver's own staging serves it), and a block would lock
far more than it holds.

Page-locked pages cannot be swapped, so the pool holds at most ``limit_bytes`` of them
(default :data:`PINNED_FRACTION` of the machine's physical memory). A request that would
pass the limit, once the idle blocks are freed, gets ordinary pageable memory, as does
one where the driver refuses to lock more pages.
"""

from __future__ import annotations

import os
import threading
from typing import Any

import numpy as np

from ._block_pool import BLOCK_GRANULE, BlockPool

__all__ = ["BLOCK_GRANULE", "PINNED_FRACTION", "PinnedPool", "physical_memory_bytes", "pool_for"]

#: Share of the machine's physical memory the pool may hold page-locked.
PINNED_FRACTION = 0.125


def physical_memory_bytes() -> int:
    """The machine's physical memory (bytes); 16 GiB where the system does not say."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return 16 << 30


class PinnedPool(BlockPool):
    """Page-locked host arrays from reused blocks (module docstring).

    Parameters
    ----------
    cuda : module
        numba.cuda (or its simulator): ``cuda.pinned_array(n, np.uint8)`` allocates.
    limit_bytes : int, optional
        Most page-locked bytes held, idle and leased together; default
        :data:`PINNED_FRACTION` of :func:`physical_memory_bytes`.
    """

    def __init__(self, cuda: Any, limit_bytes: int | None = None) -> None:
        if limit_bytes is None:
            limit_bytes = int(PINNED_FRACTION * physical_memory_bytes())
        super().__init__(lambda size: cuda.pinned_array(size, np.uint8), limit_bytes)


_POOLS: dict[int, PinnedPool] = {}
_POOLS_LOCK = threading.Lock()


def pool_for(cuda: Any) -> PinnedPool:
    """The process's pool for this numba.cuda module (one per module: GPU or simulator)."""
    with _POOLS_LOCK:
        pool = _POOLS.get(id(cuda))
        if pool is None:
            pool = _POOLS[id(cuda)] = PinnedPool(cuda)
        return pool
