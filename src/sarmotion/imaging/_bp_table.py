"""Upsampled traces as cubic pieces: the tables every backprojection kernel reads.

A trace is ``D(t) = (1/n) sum_k P_k exp(2i pi (k - n//2) df t)``, sampled at
``t_l = (l - n//2) dt`` (:mod:`sarmotion.core.spectral`). Zero-padding its spectrum gives
``D`` and ``h D'`` exactly at ``t_m = (m - N//2) h``, ``h = dt / upsample``,
``N = upsample n`` (the derivative multiplies bin ``k`` by ``2i pi k / N``). On the
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
"""

from __future__ import annotations

import threading
import weakref
from collections import OrderedDict
from dataclasses import dataclass

import numba
import numpy as np
import scipy.fft as sp_fft
from numpy.typing import ArrayLike, NDArray

from ..core import Traces, to_fast_time, to_frequency

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


def _polyphase(data: ArrayLike, factor: int) -> NDArray[np.complex128]:
    """``D_m`` and ``h D'_m`` by phase: shape ``(2, factor, n_pulses, n)`` complex128.

    ``out[0, r, :, q]`` is ``D`` at upsampled sample ``m = q factor + r`` (time
    ``t_m = (m - N//2) h``), ``out[1, r, :, q]`` is ``h D'`` there. With the ``n`` bins
    ``F_kappa`` of the trace (signed offsets ``kappa``), ``D(t_m) = (1/n) sum_kappa F_kappa
    exp(2i pi kappa (m - N//2) / N)``, and ``m = q factor + r`` splits the phase into
    ``kappa q / n`` and ``kappa (r - N//2) / N``: each phase ``r`` is an ``n``-point
    inverse transform of ``F`` turned by the second (the derivative multiplies bin
    ``kappa`` by ``2i pi kappa / N``). The same values as the zero-padded ``N``-point
    transform, at the cost of ``2 factor`` transforms of the trace's own length (``N``
    often has the trace length's large prime factors, ``n`` no more), on every core
    (``scipy.fft``).
    """
    d = np.asarray(data, np.complex128)
    m, n = d.shape
    big = factor * n
    f = sp_fft.fft(np.fft.ifftshift(d, axes=-1), axis=-1, workers=-1)
    kappa = np.round(np.fft.fftfreq(n) * n)  # signed offsets, the bins' order
    r = np.arange(factor)[:, None]
    turn = np.exp(2j * np.pi * kappa[None, :] * (r - big // 2) / big)  # (factor, n)
    spec = np.empty((2, factor, m, n), np.complex128)
    np.multiply(f[None, :, :], turn[:, None, :], out=spec[0])
    np.multiply(spec[0], ((2j * np.pi / big) * kappa)[None, None, :], out=spec[1])
    return sp_fft.ifft(spec, axis=-1, workers=-1, overwrite_x=True)


def _interleave(phases: NDArray) -> NDArray:
    """``(factor, n_pulses, n)`` phases of :func:`_polyphase` as ``(n_pulses, factor n)``."""
    factor, m, n = phases.shape
    return np.ascontiguousarray(phases.transpose(1, 2, 0)).reshape(m, factor * n)


def hermite_coefficients(
    data: ArrayLike, factor: int, dtype: type = np.complex128
) -> NDArray[np.complexfloating]:
    """The table of cubic pieces (module docstring), shape ``(n_pulses, N + 2, 4)``.

    Computed in complex128 (:func:`_polyphase`), then cast to ``dtype``.
    """
    both = _polyphase(data, factor)
    y, hd = _interleave(both[0]), _interleave(both[1])
    m, big = y.shape
    y1 = np.roll(y, -1, axis=-1)
    hd1 = np.roll(hd, -1, axis=-1)
    out = np.zeros((m, big + 2, 4), dtype)
    out[:, 1:-1, 0] = y
    out[:, 1:-1, 1] = hd
    out[:, 1:-1, 2] = 3.0 * (y1 - y) - 2.0 * hd - hd1
    out[:, 1:-1, 3] = 2.0 * (y - y1) + hd + hd1
    return out


@numba.njit(nogil=True, parallel=True, cache=True)
def _pack(both, values, length):  # pragma: no cover - compiled
    """Write the cubic pieces of :func:`_polyphase`'s ``both`` into ``values``' planes.

    Entry ``p = j + 1`` of each of the eight float32 planes is the piece starting at
    upsampled sample ``j`` (its next sample circular, as :func:`hermite_coefficients`);
    entries 0 and ``N + 1`` and the padding stay as given (zero).
    """
    factor, m, n = both.shape[1], both.shape[2], both.shape[3]
    big = factor * n
    for i in numba.prange(m):
        row = values[i]
        a1 = both[0, 0, i, 0]  # sample 0 follows the last (circular)
        b1 = both[1, 0, i, 0]
        q, r = n - 1, factor - 1  # sample j = q factor + r, backwards from the last
        for j in range(big - 1, -1, -1):
            a = both[0, r, i, q]
            b = both[1, r, i, q]
            c2 = 3.0 * (a1 - a) - 2.0 * b - b1
            c3 = 2.0 * (a - a1) + b + b1
            p = j + 1
            row[p] = a.real
            row[length + p] = a.imag
            row[2 * length + p] = b.real
            row[3 * length + p] = b.imag
            row[4 * length + p] = c2.real
            row[5 * length + p] = c2.imag
            row[6 * length + p] = c3.real
            row[7 * length + p] = c3.imag
            a1, b1 = a, b
            if r > 0:
                r -= 1
            else:
                r, q = factor - 1, q - 1


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


def make_table(data: NDArray[np.complexfloating], factor: int) -> TraceTable:
    """:func:`hermite_coefficients` packed for the float32 kernel (:class:`TraceTable`)."""
    m, n = data.shape
    big = factor * n
    length = plane_length(big)
    values = np.zeros((m, 8 * length), np.float32)
    _pack(_polyphase(data, factor), values, length)
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
