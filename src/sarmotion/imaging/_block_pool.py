"""Large host arrays from reused blocks of memory: a pool, and the leases that return them.

Some memory is costly to obtain and cheap to reuse. Page-locked memory for GPU copies is
slow to lock (:mod:`._cuda_host`); fresh ordinary memory of tens of megabytes is zeroed by
the operating system page by page on first touch, which for a trace table costs a third of
building it (:mod:`._bp_table`). A :class:`BlockPool` hands out arrays that view blocks it
keeps, and takes each block back when the last array viewing it is gone.

Ownership: :meth:`BlockPool.empty` returns an array whose memory is owned by a small lease
object (``array.base``); every view of that array, a slice, a transpose, a ``.real``,
holds the lease through its ``base`` chain, so the lease dies with the last of them and a
:func:`weakref.finalize` on it puts the block back. The finalizer may run inside the
garbage collector, on any thread, even while the pool's lock is held: it appends the
block to a queue and drains the queue only if it gets the lock without waiting;
otherwise the next request does.

An array smaller than one block (:data:`BLOCK_GRANULE`) is ordinary memory. The pool holds
at most ``limit_bytes`` in blocks, idle and leased together; a request that would pass the
limit once the idle blocks are freed, or that the allocator refuses, gets ordinary memory.
At most ``idle_limit_bytes`` stay idle: past it, the blocks idle longest are freed as
others come back, so memory no array uses is not kept beyond that.
"""

from __future__ import annotations

import collections
import math
import threading
import weakref
from collections.abc import Callable

import numpy as np
from numpy.typing import DTypeLike, NDArray

#: Blocks are whole multiples of this many bytes (2 MiB, a large page), so arrays of
#: nearly the same size share blocks.
BLOCK_GRANULE = 2 << 20


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


class BlockPool:
    """Arrays from reused blocks (module docstring).

    Parameters
    ----------
    allocate : callable
        ``allocate(n_bytes)`` returns a new writeable ``(n_bytes,)`` uint8 block; any
        exception it raises means no block (the request gets ordinary memory).
    limit_bytes : int
        Most bytes held in blocks, idle and leased together.
    idle_limit_bytes : int, optional
        Most bytes kept in idle blocks (default ``limit_bytes``).
    """

    def __init__(
        self,
        allocate: Callable[[int], NDArray[np.uint8]],
        limit_bytes: int,
        idle_limit_bytes: int | None = None,
    ) -> None:
        self._allocate = allocate
        self.limit_bytes = int(limit_bytes)
        self.idle_limit_bytes = (
            self.limit_bytes if idle_limit_bytes is None else int(idle_limit_bytes)
        )
        self._lock = threading.Lock()
        self._idle: list[NDArray[np.uint8]] = []  # idle blocks, longest idle first
        self._returned: collections.deque = collections.deque()
        self.held_bytes = 0  # bytes of the blocks allocated and not freed

    def empty(self, shape: tuple[int, ...], dtype: DTypeLike) -> NDArray:
        """An uninitialised C-ordered array, in a block where the limit allows.

        Parameters
        ----------
        shape : tuple of int
            Array shape.
        dtype : dtype
            Element type.

        Returns
        -------
        ndarray
            ``shape``, ``dtype``; in a block (``base`` a lease) or, under
            :data:`BLOCK_GRANULE` bytes or past the limit, an ordinary array. Its contents
            are arbitrary: a reused block holds what its last array left there.
        """
        dtype = np.dtype(dtype)
        shape = tuple(int(s) for s in shape)
        nbytes = math.prod(shape) * dtype.itemsize
        if nbytes < BLOCK_GRANULE:
            return np.empty(shape, dtype)
        size = -(-nbytes // BLOCK_GRANULE) * BLOCK_GRANULE
        block = self._take(size)
        if block is None:
            return np.empty(shape, dtype)
        lease = _Lease(block, shape, dtype)
        weakref.finalize(lease, self._give_back, block)
        return np.asarray(lease)

    def _give_back(self, block: NDArray[np.uint8]) -> None:
        """A lease's finalizer: queue its block, and drain the queue if the lock is free."""
        self._returned.append(block)
        if self._lock.acquire(blocking=False):
            try:
                self._drain()
            finally:
                self._lock.release()

    def _drain(self) -> None:
        """Move the returned blocks to the idle ones, within the idle limit (lock held)."""
        while self._returned:
            self._idle.append(self._returned.popleft())
        idle = sum(b.nbytes for b in self._idle)
        while idle > self.idle_limit_bytes:
            block = self._idle.pop(0)
            idle -= block.nbytes
            self.held_bytes -= block.nbytes

    def _take(self, size: int) -> NDArray[np.uint8] | None:
        """An idle block of ``size`` bytes, a new one, or None past the limit."""
        with self._lock:
            self._drain()
            if self.held_bytes <= self.limit_bytes:
                for i in range(len(self._idle) - 1, -1, -1):  # the last returned first
                    if self._idle[i].nbytes == size:
                        return self._idle.pop(i)
            if self.held_bytes + size > self.limit_bytes:
                self._free_idle()
            if self.held_bytes + size > self.limit_bytes:
                return None
            try:
                block = self._allocate(size)
            except Exception:  # e.g. the driver refused to lock more pages
                return None
            self.held_bytes += size
            return block

    def _free_idle(self) -> None:
        """Release every idle block (the caller holds the lock)."""
        self.held_bytes -= sum(b.nbytes for b in self._idle)
        self._idle.clear()

    def idle_bytes(self) -> int:
        """Bytes held by blocks no array views (after the returned ones)."""
        with self._lock:
            self._drain()
            return sum(b.nbytes for b in self._idle)

    def release_idle(self) -> None:
        """Free every idle block now (memory the process no longer needs)."""
        with self._lock:
            self._drain()
            self._free_idle()
