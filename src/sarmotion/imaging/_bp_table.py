"""Upsampled traces as cubic pieces: the tables every backprojection kernel reads.

A trace is ``D(t) = (1/n) sum_k P_k exp(2i pi (k - n//2) df t)``, sampled at
``t_l = (l - n//2) dt`` (:mod:`sarmotion.core.spectral`). Zero-padding its spectrum gives
``D`` and ``h D'`` exactly at ``t_m = (m - N//2) h`` over one period ``n dt``,
``h = n dt / N``, ``N = upsample n_fast`` (:func:`~._bp_common.table_samples`: ``n_fast``
the first length ``>= n`` of fast transforms, so ``h <= dt / upsample``; the derivative
multiplies bin ``k`` by ``2i pi k / N``). On the
interval ``[t_m, t_{m+1}]``, ``t = t_m + w h``, the cubic Hermite piece

    D(t) ~ c0 + w (c1 + w (c2 + w c3)),
    c0 = D_m,  c1 = h D'_m,  c2 = 3 (D_{m+1} - D_m) - 2 h D'_m - h D'_{m+1},
    c3 = 2 (D_m - D_{m+1}) + h D'_m + h D'_{m+1},

matches ``D`` and ``D'`` at both ends; its error bound is derived in
:mod:`.backprojection`. A table holds, per pulse, ``N + 2`` entries of the four
coefficients: entry ``p`` is the piece starting at upsampled sample ``p - 1``; entries 0
and ``N + 1`` are zero (read for delays outside the fast-time window, with ``w = 0``).

The float32 kernel's tables are packed in eight float32 planes (:class:`TraceTable`) and
kept in a small cache
(:data:`TABLES`) keyed by the traces object, with a copy of the data each table was built
from; the cache is locked, so threads (Dask workers) may image concurrently.

A table is built by blocks of pulses (:func:`make_table`): each block's transforms
(:func:`_polyphase`) and packing (:func:`_pack`) run in one thread while the block is in
that core's cache, the blocks shared out between threads, and every coefficient is the
float32 rounding of the complex128 one of :func:`hermite_coefficients`, bit for bit
whatever the blocks and threads. The packing runs eight pieces at a time
(:mod:`._pack_simd`), and a table's memory is a reused block of :data:`TABLE_BLOCKS`, so a
new table's pages are not zeroed again by the operating system.
"""

from __future__ import annotations

import os
import threading
import weakref
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np
import scipy.fft as sp_fft
from numpy.typing import ArrayLike, NDArray

from ..core import Traces, to_fast_time, to_frequency
from ._block_pool import BlockPool
from ._bp_common import table_samples
from ._pack_simd import WIDTH, pack_pieces

#: The version of :mod:`._pack_simd`'s IR compiled into :func:`_pack`. numba's on-disk
#: cache keys on this file's contents, not on :mod:`._pack_simd`'s: change this line
#: whenever that IR changes, or a stale packing is loaded.
PACK_VERSION = "pieces-float64-8-1"

#: Bytes of trace tables, and of the data they were built from, kept by the cache (least
#: recently used dropped first).
CACHE_BYTES = 512 * 2**20


def upsample_fast_time(data: ArrayLike, factor: int) -> NDArray[np.complex128]:
    """Exact band-limited upsampling of baseband traces by zero-padding their spectrum.

    The result samples ``D(t)`` at ``t'_m = (m - N//2) dt / factor``, ``m = 0..N-1``,
    ``N = factor * n``, so ``out[:, N//2 + factor * (l - n//2)] == data[:, l]`` for both
    parities of ``n``.

    Parameters
    ----------
    data : (n_pulses, n) array_like
        Complex baseband traces, ``t = 0`` at index ``n // 2``.
    factor : int
        Upsampling factor (>= 1).

    Returns
    -------
    (n_pulses, factor * n) ndarray
        complex128.
    """
    d = np.asarray(data, dtype=np.complex128)
    n = d.shape[-1]
    if factor == 1:
        return d.copy()
    big = factor * n
    spec = np.zeros(d.shape[:-1] + (big,), dtype=np.complex128)
    start = big // 2 - n // 2
    spec[..., start : start + n] = to_frequency(d)
    return to_fast_time(spec) * factor


def _phase_turns(
    n: int, n_fast: int, factor: int
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """The factors :func:`_polyphase` multiplies a padded spectrum by, flat.

    Returns
    -------
    turn : (n_fast factor,) ndarray
        At ``kappa_i factor + r``: ``(n_fast / n) exp(2i pi kappa (r - N//2) / N)`` for bin
        ``kappa`` of the ``n_fast``-point layout (signed offsets, the bins' order, ``i`` its
        index) and phase ``r``, ``N = factor n_fast``, complex128 (``n_fast / n`` turns the
        inverse transform's ``1 / n_fast`` into the trace's ``1 / n``).
    slope : (n_fast factor,) ndarray
        At ``kappa_i factor + r``: ``2i pi kappa / N``, the derivative's factor (``h D'``),
        complex128.
    """
    big = factor * n_fast
    kappa = np.round(np.fft.fftfreq(n_fast) * n_fast)  # signed offsets, the bins' order
    r = np.arange(factor)[None, :]
    turn = (n_fast / n) * np.exp(2j * np.pi * kappa[:, None] * (r - big // 2) / big)
    return turn.reshape(big), np.repeat((2j * np.pi / big) * kappa, factor)


def _polyphase(
    d: NDArray[np.complex128],
    turn: NDArray[np.complex128],
    slope: NDArray[np.complex128],
    factor: int,
    work: NDArray[np.complex128],
    workers: int = 1,
) -> NDArray[np.complex128]:
    """``D_m`` and ``h D'_m`` of every upsampled sample, in order: ``(2, n_pulses, N)``.

    ``out[0, i, m]`` is ``D`` of pulse ``i`` at upsampled sample ``m`` (time
    ``t_m = (m - N//2) h``, ``h = n dt / N``), ``out[1, i, m]`` is ``h D'`` there. With the
    ``n`` bins ``F_kappa`` of the trace (signed offsets ``kappa``), ``D(t_m) = (1/n)
    sum_kappa F_kappa exp(2i pi kappa (m - N//2) / N)``. The bins are laid out as ``n_fast
    = N / factor`` bins (the same signed offsets, zeros beyond them), and ``m = q factor +
    r`` splits the phase into ``kappa q / n_fast`` and ``kappa (r - N//2) / N``: each phase
    ``r`` is an ``n_fast``-point inverse transform of the padded bins turned by the second
    (``turn``; the derivative multiplies bin ``kappa`` by ``2i pi kappa / N``, ``slope``).
    The same values as the zero-padded ``N``-point transform, at the cost of ``2 factor``
    transforms of length ``n_fast`` (``N`` often has the trace length's large prime
    factors, ``n_fast`` none). The spectra are laid out ``(2, n_pulses, n_fast, factor)``
    in ``work`` and transformed along the bins in place, so the samples come out in order
    (``m = q factor + r``).

    Parameters
    ----------
    d : (n_pulses, n) ndarray
        complex128 traces, ``t = 0`` at index ``n // 2``.
    turn, slope : (N,) ndarray
        :func:`_phase_turns`.
    factor : int
        Phases per bin, ``N / n_fast``.
    work : (2 n_pulses N,) ndarray
        complex128 scratch, or longer (its start is used); overwritten, and the result is
        normally a view of it.
    workers : int
        Threads of each ``scipy.fft`` call (-1: every core).
    """
    m, n = d.shape
    big = turn.shape[0]
    n_fast = big // factor
    spec = work[: 2 * m * big].reshape(2, m, big)
    f = sp_fft.fft(np.fft.ifftshift(d, axes=-1), axis=-1, workers=workers)
    _spread(f, turn, slope, factor, spec)
    out = sp_fft.ifft(spec.reshape(2, m, n_fast, factor), axis=2, workers=workers,
                      overwrite_x=True)  # fmt: skip
    return out.reshape(2, m, big)


@numba.njit(nogil=True, cache=True)
def _spread(f, turn, slope, factor, spec):  # pragma: no cover - compiled
    """The turned spectra of :func:`_polyphase`: ``spec[0]`` for ``D``, ``spec[1]`` for ``h D'``.

    ``f`` ``(n_pulses, n)`` holds the bins in transform order (offsets ``0 .. (n - 1) // 2``,
    then the negative ones); bin ``i`` of the ``n_fast = N / factor``-point layout is the
    bin of the same signed offset, zero where the trace has none. Entry ``i factor + r`` of
    a row is that bin times ``turn[i factor + r]`` (complex128 products), and of
    ``spec[1]`` that product times ``slope[i factor + r]``.
    """
    m, n = f.shape
    big = turn.shape[0]
    n_fast = big // factor
    positive = (n + 1) // 2
    first_negative = n_fast - (n - positive)  # where the negative offsets start
    for i in range(m):
        for b in range(n_fast):
            if b < positive:
                value = f[i, b]
            elif b >= first_negative:
                value = f[i, b - (n_fast - n)]
            else:
                value = 0j
            for r in range(factor):
                k = b * factor + r
                v = value * turn[k]
                spec[0, i, k] = v
                spec[1, i, k] = v * slope[k]


def hermite_coefficients(
    data: ArrayLike, factor: int, dtype: type = np.complex128
) -> NDArray[np.complexfloating]:
    """The table of cubic pieces (module docstring), shape ``(n_pulses, N + 2, 4)``.

    Computed in complex128 (:func:`_polyphase`, every pulse at once), then cast to
    ``dtype``.
    """
    d = np.asarray(data, np.complex128)
    m, n = d.shape
    turn, slope = _phase_turns(n, table_samples(n, factor) // factor, factor)
    work = np.empty(2 * m * turn.size, np.complex128)
    y, hd = _polyphase(d, turn, slope, factor, work, workers=-1)
    big = y.shape[1]
    y1 = np.roll(y, -1, axis=-1)
    hd1 = np.roll(hd, -1, axis=-1)
    out = np.zeros((m, big + 2, 4), dtype)
    out[:, 1:-1, 0] = y
    out[:, 1:-1, 1] = hd
    out[:, 1:-1, 2] = 3.0 * (y1 - y) - 2.0 * hd - hd1
    out[:, 1:-1, 3] = 2.0 * (y - y1) + hd + hd1
    return out


@numba.njit(nogil=True, inline="always", cache=True)
def _put_piece(row, length, p, ar, ai, br, bi, a1r, a1i, b1r, b1i):  # pragma: no cover
    """Entry ``p`` of the eight planes: one cubic piece, from float64 real and imaginary parts.

    The piece runs from ``a = D_m``, ``b = h D'_m`` to ``a1 = D_{m+1}``, ``b1 = h D'_{m+1}``.
    ``c2 = 3 (a1 - a) - 2 b - b1`` and ``c3 = 2 (a - a1) + b + b1`` are evaluated in the
    order of the complex128 expressions of :func:`hermite_coefficients`, a real ``s`` times
    a complex ``x`` as the complex product ``(s + 0i) x`` (real part ``s x_re - 0 x_im``,
    imaginary part ``s x_im + 0 x_re``; the zero products change at most the sign of a
    zero), so each float32 stored is the rounding of the same float64.
    """
    xr = a1r - ar
    xi = a1i - ai
    c2r = ((3.0 * xr - 0.0 * xi) - (2.0 * br - 0.0 * bi)) - b1r
    c2i = ((3.0 * xi + 0.0 * xr) - (2.0 * bi + 0.0 * br)) - b1i
    yr = ar - a1r
    yi = ai - a1i
    c3r = ((2.0 * yr - 0.0 * yi) + br) + b1r
    c3i = ((2.0 * yi + 0.0 * yr) + bi) + b1i
    row[p] = ar
    row[length + p] = ai
    row[2 * length + p] = br
    row[3 * length + p] = bi
    row[4 * length + p] = c2r
    row[5 * length + p] = c2i
    row[6 * length + p] = c3r
    row[7 * length + p] = c3i


@numba.njit(nogil=True, cache=True)
def _pack(both, values, length):  # pragma: no cover - compiled
    """Write the cubic pieces of :func:`_polyphase`'s samples into ``values``' planes.

    ``both`` is the ``(2, n_pulses, 2 N)`` float64 view of the samples (real and imaginary
    parts alternating). Entry ``p = j + 1`` of each of the eight float32 planes is the
    piece starting at upsampled sample ``j`` (its next sample circular, as
    :func:`hermite_coefficients`); entries 0 and ``N + 1`` and the padding are written zero
    (``values`` may hold anything). One thread (the caller's blocks run in threads,
    :func:`make_table`).
    """
    m, big = both.shape[1], both.shape[2] // 2
    for i in range(m):
        y = both[0, i]
        d = both[1, i]
        row = values[i]
        for plane in range(8):
            row[plane * length] = 0.0
            for p in range(big + 1, length):
                row[plane * length + p] = 0.0
        vector = (big - 1) // WIDTH * WIDTH
        pack_pieces(y, d, row, vector, length)
        for j in range(vector, big - 1):
            k = 2 * j
            _put_piece(
                row, length, j + 1, y[k], y[k + 1], d[k], d[k + 1],
                y[k + 2], y[k + 3], d[k + 2], d[k + 3],
            )  # fmt: skip
        k = 2 * (big - 1)  # the last sample's next is sample 0
        _put_piece(row, length, big, y[k], y[k + 1], d[k], d[k + 1], y[0], y[1], d[0], d[1])


#: Entries after each plane of a :class:`TraceTable` row: a window of 32 entries read from
#: any entry stays inside the row.
PLANE_PAD = 32


def plane_length(n_up: int) -> int:
    """Floats per plane of a :class:`TraceTable` row: ``n_up + 2`` entries and the padding."""
    return n_up + 2 + PLANE_PAD


@dataclass(frozen=True, eq=False)
class TraceTable:
    """The cubic pieces of one traces object, packed as the float32 kernel reads them.

    ``values`` is ``(n_pulses, 8 L)`` float32, ``L = plane_length(n_up)``: per pulse, eight
    planes of ``L`` floats, the real and imaginary parts of ``c0``, ``c1``, ``c2``, ``c3`` of
    :func:`hermite_coefficients` (entry ``p`` at float ``p`` of each plane), the last
    :data:`PLANE_PAD` floats of a plane zero. The entries of neighbouring pixels are
    contiguous in each plane (:mod:`._simd`). Rounding: ``6e-8`` relative for each
    coefficient.
    """

    values: NDArray[np.float32]
    upsample: int
    n_up: int


#: Bytes of table memory kept idle for the next tables once their tables are gone: three
#: tables of the four GOTCHA degrees at x6 (39 MB each; one analysis builds two).
IDLE_TABLE_BYTES = 128 * 2**20

#: Memory of the tables' values, reused (:class:`~._block_pool.BlockPool`): a fresh
#: table's tens of megabytes would otherwise be zeroed by the operating system page by page
#: as they are first written. Holds at most :data:`CACHE_BYTES`, the cache's own bound, of
#: which at most :data:`IDLE_TABLE_BYTES` idle.
TABLE_BLOCKS = BlockPool(
    lambda size: np.empty(size, np.uint8), CACHE_BYTES, idle_limit_bytes=IDLE_TABLE_BYTES
)

#: Pulses per block of :func:`make_table`: a block's spectra and samples,
#: ``2 x 16 x N x 16`` bytes (1.3 MB at ``N = 2592``), stay in one core's cache between the
#: transforms and the packing.
BLOCK_PULSES = 16

_POOL_LOCK = threading.Lock()
#: The threads :func:`_run_in_threads` adds, by the process that started them (a forked
#: child has none of its parent's threads, so it starts its own).
_POOLS: dict[int, ThreadPoolExecutor] = {}


def _run_in_threads(work: Callable[[], None], n_threads: int) -> None:
    """Run ``work`` in ``n_threads`` threads, the caller's one of them, and wait for all.

    The others come from one pool shared by every caller (created on first use, as many
    threads as cores); an exception is raised after every thread has returned.
    """
    futures = []
    if n_threads > 1:
        with _POOL_LOCK:
            pool = _POOLS.get(os.getpid())
            if pool is None:
                pool = _POOLS[os.getpid()] = ThreadPoolExecutor(
                    os.cpu_count() or 1, "sarmotion-table"
                )
        futures = [pool.submit(work) for _ in range(n_threads - 1)]
    try:
        work()
    finally:
        errors = [f.exception() for f in futures]
    for e in errors:
        if e is not None:
            raise e


def make_table(data: NDArray[np.complexfloating], factor: int) -> TraceTable:
    """:func:`hermite_coefficients` packed for the float32 kernel (:class:`TraceTable`).

    Built by blocks of :data:`BLOCK_PULSES` pulses, each transformed (:func:`_polyphase`)
    and packed (:func:`_pack`) by one thread while it is in that core's cache; the blocks
    are shared out as the threads ask for them (``numba.get_num_threads()`` threads, the
    caller's included). Every pulse's values do not depend on the blocks: each
    coefficient is the float32 rounding of :func:`hermite_coefficients`' float64 one. The
    values' memory comes from :data:`TABLE_BLOCKS`.
    """
    d = np.asarray(data, np.complex128)
    m, n = d.shape
    big = table_samples(n, factor)
    length = plane_length(big)
    values = TABLE_BLOCKS.empty((m, 8 * length), np.float32)  # every float written by _pack
    turn, slope = _phase_turns(n, big // factor, factor)
    starts = iter(range(0, m, BLOCK_PULSES))
    lock = threading.Lock()

    def work() -> None:
        scratch = np.empty(2 * BLOCK_PULSES * big, np.complex128)
        while True:
            with lock:
                i0 = next(starts, None)
            if i0 is None:
                return
            i1 = min(i0 + BLOCK_PULSES, m)
            both = _polyphase(d[i0:i1], turn, slope, factor, scratch)
            _pack(both.view(np.float64), values[i0:i1], length)

    n_blocks = -(-m // BLOCK_PULSES)
    _run_in_threads(work, min(numba.get_num_threads(), n_blocks))
    return TraceTable(values=values, upsample=factor, n_up=big)


def unpack_table(table: TraceTable) -> NDArray[np.complex128]:
    """The coefficients a :class:`TraceTable` holds, ``(n_pulses, n_up + 2, 4)`` complex128."""
    m = table.values.shape[0]
    n = table.n_up + 2
    planes = table.values.reshape(m, 8, plane_length(table.n_up))[:, :, :n].astype(np.float64)
    return np.stack([planes[:, 2 * k] + 1j * planes[:, 2 * k + 1] for k in range(4)], axis=-1)


class TableCache:
    """Trace tables by traces object, safe to share between threads.

    Imaging the same traces again (other grids, other velocities) reuses the upsampling.
    An entry is dropped after its traces object is collected, when ``traces.data`` is no
    longer, bit for bit, the data it was built from (a change in place; the entry keeps a
    copy: comparing 64-bit words reads the data once, several times faster than a
    checksum of it), or when the cache holds more than :data:`CACHE_BYTES`. Every read
    and change of the entries holds one lock. The
    weak-reference callback, which the garbage collector may run in any thread and in the
    middle of a locked section, only queues the key (a list append is atomic); queued keys
    are removed under the lock by the next call. Tables are built outside the lock, so
    two threads may each build the same table once.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._dead: list[tuple[int, int]] = []
        self._entries: OrderedDict[tuple[int, int], tuple[weakref.ref, NDArray, TraceTable]] = (
            OrderedDict()
        )

    def _purge(self) -> None:
        """Remove the entries of collected traces (lock held)."""
        while self._dead:
            key = self._dead.pop()
            entry = self._entries.get(key)
            if entry is not None and entry[0]() is None:
                del self._entries[key]

    def get(self, traces: Traces, upsample: int) -> TraceTable:
        data = np.ascontiguousarray(traces.data)
        key = (id(traces), upsample)
        with self._lock:
            self._purge()
            entry = self._entries.get(key)
            if entry is not None and entry[0]() is traces and _same_bits(entry[1], data):
                self._entries.move_to_end(key)
                return entry[2]
        built_from = data.copy()
        table = make_table(built_from, upsample)
        ref = weakref.ref(traces, lambda _, k=key, dead=self._dead: dead.append(k))
        with self._lock:
            self._purge()
            entries = self._entries
            entries[key] = (ref, built_from, table)
            entries.move_to_end(key)
            total = sum(e[1].nbytes + e[2].values.nbytes for e in list(entries.values()))
            while total > CACHE_BYTES and len(entries) > 1:
                _, (_, old_data, old) = entries.popitem(last=False)
                total -= old_data.nbytes + old.values.nbytes
        return table

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()
            self._dead.clear()


TABLES = TableCache()


def _same_bits(a: NDArray, b: NDArray) -> bool:
    """Whether two C-contiguous arrays hold the same dtype, shape and bytes."""
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    word = np.uint64 if a.nbytes % 8 == 0 else np.uint8
    return bool(np.array_equal(a.reshape(-1).view(word), b.reshape(-1).view(word)))
