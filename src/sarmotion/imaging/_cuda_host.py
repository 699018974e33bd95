"""Page-locked host memory for the GPU's images: blocks kept in a pool and reused.

A copy from the device into page-locked (pinned) host memory runs at the bus's rate.
Into fresh pageable memory the driver stages it through a pinned buffer of its own and
the operating system maps every new page on first touch, far slower for an
image of hundreds of megabytes. Locking pages is itself slow (each page is locked, and
unlocked when freed), so blocks are allocated once and reused: an image's array views a
block, and the block returns to the pool when the last array that views it is gone.

Ownership: :meth:`PinnedPool.empty` returns an array whose memory is owned by a small
lease object (``array.base``); every view of that array, a slice, a transpose, a
``.real``, holds the lease through its ``base`` chain, so the lease dies with the last of
them and a :func:`weakref.finalize` on it puts the block back. The finalizer only appends
to a queue (it may run inside the garbage collector, on any thread); the queue is drained
under the pool's lock at the next request.

An array smaller than a block (:data:`BLOCK_GRANULE`) is ordinary memory: its copy is
short either way, and a block would lock far more than it holds.

Page-locked pages cannot be swapped, so the pool holds at most ``limit_bytes`` of them
(default :data:`PINNED_FRACTION` of the machine's physical memory). A request that would
pass the limit, once the idle blocks are freed, gets ordinary pageable memory, as does
one where the driver refuses to lock more pages.
"""

from __future__ import annotations

import collections
import math
import os
import threading
import weakref
from typing import Any

import numpy as np
from numpy.typing import DTypeLike, NDArray

#: Share of the machine's physical memory the pool may hold page-locked.
PINNED_FRACTION = 0.125

#: Blocks are whole multiples of this many bytes (2 MiB, a large page), so images of
#: nearly the same size share blocks.
BLOCK_GRANULE = 2 << 20


def physical_memory_bytes() -> int:
    """The machine's physical memory (bytes); 16 GiB where the system does not say."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return 16 << 30


class _Lease:
    """Owner of one array's memory: a view of ``block`` that numpy reads by its interface."""

    __slots__ = ("__array_interface__", "block", "__weakref__")

    def __init__(self, block: NDArray[np.uint8], shape: tuple[int, ...], dtype: np.dtype):
        self.block = block
        self.__array_interface__ = {
            "shape": shape,
            "typestr": dtype.str,
            "data": (block.ctypes.data, False),
            "version": 3,
        }


class PinnedPool:
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
        self._cuda = cuda
        self.limit_bytes = (
            int(PINNED_FRACTION * physical_memory_bytes()) if limit_bytes is None
            else int(limit_bytes)
        )  # fmt: skip
        self._lock = threading.Lock()
        self._idle: dict[int, list[NDArray[np.uint8]]] = {}
        self._returned: collections.deque = collections.deque()
        self.held_bytes = 0  # page-locked bytes allocated and not freed

    def empty(self, shape: tuple[int, ...], dtype: DTypeLike) -> NDArray:
        """An uninitialised C-ordered array, page-locked where the limit allows.

        Parameters
        ----------
        shape : tuple of int
            Array shape.
        dtype : dtype
            Element type.

        Returns
        -------
        ndarray
            ``shape``, ``dtype``; page-locked (``base`` a lease of a pool block) or, under
            :data:`BLOCK_GRANULE` bytes or past the limit, an ordinary array.
        """
        dtype = np.dtype(dtype)
        shape = tuple(int(s) for s in shape)
        nbytes = math.prod(shape) * dtype.itemsize
        if nbytes < BLOCK_GRANULE:  # the driver's own staging serves it; a block would waste
            return np.empty(shape, dtype)
        size = -(-nbytes // BLOCK_GRANULE) * BLOCK_GRANULE
        block = self._take(size)
        if block is None:
            return np.empty(shape, dtype)
        lease = _Lease(block, shape, dtype)
        weakref.finalize(lease, self._returned.append, block)
        return np.asarray(lease)

    def _take(self, size: int) -> NDArray[np.uint8] | None:
        """An idle block of ``size`` bytes, a new one, or None past the limit."""
        with self._lock:
            while self._returned:
                block = self._returned.popleft()
                self._idle.setdefault(block.nbytes, []).append(block)
            blocks = self._idle.get(size)
            if blocks and self.held_bytes <= self.limit_bytes:
                return blocks.pop()
            if self.held_bytes + size > self.limit_bytes:
                self._free_idle()
            if self.held_bytes + size > self.limit_bytes:
                return None
            try:
                block = self._cuda.pinned_array(size, np.uint8)
            except Exception:  # the driver refused to lock more pages
                return None
            self.held_bytes += size
            return block

    def _free_idle(self) -> None:
        """Release every idle block (the caller holds the lock)."""
        for blocks in self._idle.values():
            self.held_bytes -= sum(b.nbytes for b in blocks)
            blocks.clear()
        self._idle.clear()

    def idle_bytes(self) -> int:
        """Page-locked bytes held by blocks no array views (after the returned ones)."""
        with self._lock:
            while self._returned:
                block = self._returned.popleft()
                self._idle.setdefault(block.nbytes, []).append(block)
            return sum(b.nbytes for blocks in self._idle.values() for b in blocks)


_POOLS: dict[int, PinnedPool] = {}
_POOLS_LOCK = threading.Lock()


def pool_for(cuda: Any) -> PinnedPool:
    """The process's pool for this numba.cuda module (one per module: GPU or simulator)."""
    with _POOLS_LOCK:
        pool = _POOLS.get(id(cuda))
        if pool is None:
            pool = _POOLS[id(cuda)] = PinnedPool(cuda)
        return pool
