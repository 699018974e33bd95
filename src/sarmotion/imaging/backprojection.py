"""Backprojection imaging (paper ``sect:image``): ``eq:image`` and its motion-compensated form.

The image at a ground point ``rho`` (``z = 0``) superposes the traces at the differential
travel time of that point (``eq:image``); with a velocity estimate ``u`` the point is moved
along ``rho + s u`` over the aperture (``eq:imagecompu``)::

    I_u(rho) = sum_j D_r(s_j, dtau_j) exp(+i omega_o dtau_j),
    dtau_j   = tau(s_j, rho + s_j u) - tau(s_j, rho_o),   tau(s, p) = 2 |r(s) - p| / c.

``D_r`` are the complex-baseband traces of :class:`~sarmotion.core.traces.Traces`: a point at
``rho`` contributes ``p(t - dtau) exp(-i omega_o dtau)``, so the factor
``exp(+i omega_o dtau)`` restores the carrier phase the baseband removed and the sum is
coherent at the true position. The paper writes ``eq:image`` for real passband traces,
where the carrier is part of ``D_r``; on baseband data the factor is that same carrier.

Interpolation in fast time: each trace is upsampled exactly by zero-padding its spectrum
(the deramped phase history on ``radar.frequencies_hz``) by a factor ``upsample``, then
linearly interpolated. Delays outside the fast-time window contribute 0.

Two kernels compute the same sum: ``"numpy"``, a plain vectorised reference (one pulse at
a time, :func:`numpy.interp`, float64 throughout), and ``"numba"``, a compiled, parallel
kernel. Geometry and phases are float64 in the reference: at ``L = 10`` km the carrier
phase is ``~4e6`` rad. The compiled kernel works on image tiles (64 x 64 pixels at most):
per pulse and tile it computes the range to the tile's anchor pixel, the table position
and the carrier phase there in float64, folds the phase exactly to a quarter cycle, and
expands the range of every other pixel of the tile about the anchor,

    |r - rho| - |r - rho_c| = R0 (sqrt(1 + N / R0^2) - 1),   N = |r - rho|^2 - |r - rho_c|^2,

a degree-4 series in ``N`` evaluated in float32 (``N`` is exact to float32 rounding: it is
a sum of products of pixel offsets and anchor distances, never a difference of two
10 km ranges). Table position and phase offsets of a 16 m tile are then a few thousand
samples or quarter cycles, where float32 keeps ~1e-4 of a quarter cycle. The upsampled
traces are held as complex64 (``_TraceTable``, built once per traces object and kept in a
small cache) and read by 16-lane gathers (:mod:`sarmotion.imaging._simd`). It agrees
with the reference to 70-85 dB on the test scenes and on GOTCHA (spec: >= 60 dB). Before
each call the truncation error of the series and the largest phase offset are bounded
from the geometry; when the tiles cannot be made small enough (antenna within a few
hundred metres of the image), a float64 compiled kernel with an exact polynomial
sine/cosine is used instead.

All quantities are SI: metres, seconds, hertz, m/s.
"""

from __future__ import annotations

import math
import weakref
import zlib
from collections import OrderedDict
from dataclasses import dataclass
from typing import Literal

import numba
import numpy as np
import scipy.fft
from numpy.typing import ArrayLike, NDArray

from ..core import C, ProgressCallback, Radar, Traces, Trajectory, to_fast_time, to_frequency
from ..core.geometry import _as_velocity
from ..core.spectral import quarter_turns
from ._simd import LANES, tile_pulses
from .grid import Image, ImageGrid

__all__ = ["backproject", "backproject_phase_history", "backproject_points"]


Kernel = Literal["numba", "numpy"]
Method = Literal["exact", "ffbp"]


#: Pulses per block of the numpy reference (progress granularity) and of the FFTs.
_PULSE_BLOCK = 32


#: Memory bound of the upsampled traces held by the compiled kernel at once (bytes); a
#: 4-degree GOTCHA aperture at upsample 8 needs 25 MB.
_TABLE_BYTES = 128 * 2**20


#: Target number of progress steps (parallel regions) of the compiled kernel.
_STEPS = 8


#: Image tile (rows, columns), one parallel task of the compiled kernel: at 0.25 m spacing
#: 64 x 64 pixels span ~16 m, so the upsampled samples one pulse needs for a tile (~12 kB)
#: stay in the L1 cache while the tile's rows are swept.
_TILE = (64, 64)


# ===================================================================== preparation
def _upsample_fast_time(data: ArrayLike, factor: int) -> NDArray[np.complex128]:
    """Exact band-limited upsampling of baseband traces by zero-padding their spectrum.

    The traces are ``D(t) = (1/n) sum_k P_k exp(2i pi (k - n//2) df t)`` sampled at
    ``t_l = (l - n//2) dt`` (:mod:`sarmotion.core.spectral`). The result samples the same
    ``D(t)`` at ``t'_m = (m - N//2) dt / factor``, ``m = 0..N-1``, ``N = factor * n``, so
    ``out[:, N//2 + factor * (l - n//2)] == data[:, l]`` for both parities of ``n``.

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


@dataclass(frozen=True)
class _Setup:
    """Everything the kernels need, float64, derived once from the traces."""

    data: NDArray[np.complexfloating]  # (n_pulses, n) traces
    eff_positions: NDArray[np.float64]  # (n_pulses, 3) r(s_j) - s_j u
    ref_ranges: NDArray[np.float64]  # (n_pulses,) |r(s_j) - rho_o|
    carrier_hz: float
    sample_interval_s: float  # dt of the traces
    upsample: int


def _setup(traces: Traces, velocity_mps: ArrayLike | None, upsample: int) -> _Setup:
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    if isinstance(upsample, bool) or not isinstance(upsample, (int, np.integer)):
        raise TypeError(f"upsample must be an integer, got {type(upsample).__name__}")
    if not 1 <= int(upsample) <= 64:
        raise ValueError(f"upsample must be between 1 and 64, got {upsample}")
    u = np.zeros(3) if velocity_mps is None else _as_velocity(velocity_mps, name="velocity_mps")
    if u[2] != 0.0:
        raise ValueError(f"velocity_mps must be a ground velocity (uz = 0), got {u}")
    pos = traces.positions_m
    s = traces.slow_times_s
    return _Setup(
        data=traces.data,
        eff_positions=pos - s[:, None] * u[None, :],
        ref_ranges=np.linalg.norm(pos - traces.reference_point_m[None, :], axis=1),
        carrier_hz=float(traces.radar.carrier_hz),
        sample_interval_s=float(traces.radar.sample_interval_s),
        upsample=int(upsample),
    )


def _check_kernel(kernel: str) -> None:
    if kernel not in ("numba", "numpy"):
        raise ValueError(f"kernel must be 'numba' or 'numpy', got {kernel!r}")


def _check_method(method: str, kernel: str) -> None:
    if method not in ("exact", "ffbp"):
        raise ValueError(f"method must be 'exact' or 'ffbp', got {method!r}")
    if method == "ffbp" and kernel != "numba":
        raise ValueError("method='ffbp' runs on the compiled kernel: use kernel='numba'")


def _check_grid(grid: ImageGrid) -> None:
    if not isinstance(grid, ImageGrid):
        raise TypeError(f"grid must be an ImageGrid, got {type(grid).__name__}")


def _blocks(n: int) -> list[tuple[int, int]]:
    return [(j, min(j + _PULSE_BLOCK, n)) for j in range(0, n, _PULSE_BLOCK)]


# =========================================================================== numpy
def _accumulate_numpy(
    st: _Setup, j0: int, j1: int, px: NDArray, py: NDArray, out: NDArray[np.complex128]
) -> None:
    """Reference: add pulses ``j0:j1`` of ``eq:imagecompu`` at points ``(px, py, 0)``."""
    up = _upsample_fast_time(st.data[j0:j1], st.upsample)
    big = up.shape[1]
    t_up = (np.arange(big) - big // 2) * (st.sample_interval_s / st.upsample)
    for k, j in enumerate(range(j0, j1)):
        r = st.eff_positions[j]
        dist = np.sqrt((r[0] - px) ** 2 + (r[1] - py) ** 2 + r[2] ** 2)  # |r - s u - rho|
        dtau = 2.0 * (dist - st.ref_ranges[j]) / C  # eq:DeltaTau, float64
        sample = np.interp(dtau, t_up, up[k].real, left=0.0, right=0.0) + 1j * np.interp(
            dtau, t_up, up[k].imag, left=0.0, right=0.0
        )
        cycles = st.carrier_hz * dtau  # omega_o dtau / (2 pi), up to ~1e4 cycles
        cycles -= np.round(cycles)  # exact reduction before exp
        out += sample * np.exp(2j * np.pi * cycles)


# =========================================================================== numba
# The compiled kernel runs three loops per (pulse, image row) of a tile:
#   A (vectorised): range, fast-time sample index and weight, carrier phase exp(i phi);
#   B (scalar): gather and linearly interpolate the upsampled trace (gathers are slower
#     than scalar loads on this CPU, and LLVM does not vectorise them here);
#   C (vectorised): accumulate sample * exp(i phi).
# The phase phi = 2 pi (2 nu_o / c) d, d = |r - s u - rho| - |r - rho_o|, is reduced exactly
# to quarter cycles, t = 4 (2 nu_o / c) d, k = rint(t), r = t - k in [-1/2, 1/2] (exact:
# Sterbenz), so exp(i phi) = i^k exp(i pi r / 2); two polynomials (minimax on
# |r| <= 1/2, sarmotion.core.spectral.quarter_turns) give cos and sin of pi r / 2 within
# 1e-14 and vectorise (no libm calls).
# fastmath: contract (FMA), no reassociation: the order of the reduction is kept.
_FASTMATH = {"nnan", "ninf", "nsz", "arcp", "contract", "afn"}


@numba.njit(fastmath=_FASTMATH, cache=True)
def _row_geometry(
    xs,
    n,
    ax,
    c2,
    ref,
    idx_scale,
    idx_offset,
    idx_max,
    quarter_scale,
    base,
    obuf,
    wbuf,
    cbuf,
    sbuf,
):  # pragma: no cover - compiled
    """Loop A: table offsets, interpolation weights and exp(i phi) along one tile row."""
    for k in range(n):
        dx = ax - xs[k]
        d = math.sqrt(dx * dx + c2) - ref
        q = d * idx_scale + idx_offset
        q = q if (q >= 1.0 and q <= idx_max) else 0.0  # entry 0 of the table is zero
        fq = np.floor(q)
        obuf[k] = base + 2 * int(fq)
        wbuf[k] = q - fq
        cbuf[k], sbuf[k] = quarter_turns(d * quarter_scale)


@numba.njit(fastmath=_FASTMATH, cache=True)
def _row_gather(table, n, obuf, wbuf, vre, vim):  # pragma: no cover - compiled
    """Loop B: linear interpolation between the table entries at the offsets of loop A."""
    one = numba.uint64(1)
    two = numba.uint64(2)
    three = numba.uint64(3)
    for k in range(n):
        o = obuf[k]
        w = wbuf[k]
        re0 = table[o]
        im0 = table[o + one]
        vre[k] = re0 + w * (table[o + two] - re0)
        vim[k] = im0 + w * (table[o + three] - im0)


@numba.njit(fastmath=_FASTMATH, cache=True)
def _row_accumulate(n, vre, vim, cbuf, sbuf, are, aim):  # pragma: no cover - compiled
    """Loop C: ``acc += sample * exp(i phi)``."""
    for k in range(n):
        c = cbuf[k]
        s = sbuf[k]
        are[k] += vre[k] * c - vim[k] * s
        aim[k] += vre[k] * s + vim[k] * c


@numba.njit(parallel=True, fastmath=_FASTMATH, cache=True)
def _accumulate_numba(
    table,
    pulse_stride,
    ant_x,
    ant_y,
    ant_z2,
    ref,
    x,
    y,
    idx_scale,
    idx_offset,
    idx_max,
    quarter_scale,
    out_re,
    out_im,
    ty0,
    ty1,
    tile_rows,
    tile_cols,
):  # pragma: no cover - compiled
    """Add the pulses of one block to tile rows ``ty0:ty1`` of ``out_re + 1j out_im``.

    The image (ny, nx) is cut in tiles of ``tile_rows x tile_cols`` pixels, one parallel
    task each.

    ``table`` holds, per pulse, ``n_up + 2`` complex entries as ``(re, im)`` pairs
    (:func:`_upsample_padded`): entry 0 and ``n_up + 1`` are zero, entry ``p`` is upsampled
    sample ``p - 1``; ``pulse_stride = 2 (n_up + 2)``.
    """
    ny = y.size
    nx = x.size
    n_tx = (nx + tile_cols - 1) // tile_cols
    n_pulses = ant_x.size
    for tile in numba.prange((ty1 - ty0) * n_tx):
        ty = ty0 + tile // n_tx
        tx = tile % n_tx
        y0 = ty * tile_rows
        y1 = min(ny, y0 + tile_rows)
        x0 = tx * tile_cols
        x1 = min(nx, x0 + tile_cols)
        n = x1 - x0
        # Separate allocations, padded so that the buffers do not share 4 KiB offsets.
        stride = tile_cols + 8
        xs = x[x0:x1].copy()
        obuf = np.empty(tile_cols, np.uint64)
        wbuf = np.empty(tile_cols + 8)
        cbuf = np.empty(tile_cols + 16)
        sbuf = np.empty(tile_cols + 24)
        vre = np.empty(tile_cols + 32)
        vim = np.empty(tile_cols + 40)
        are = np.zeros(tile_rows * stride + 3)
        aim = np.zeros(tile_rows * stride + 11)
        for j in range(n_pulses):
            base = j * pulse_stride
            for iy in range(y0, y1):
                dy = ant_y[j] - y[iy]
                c2 = dy * dy + ant_z2[j]
                _row_geometry(
                    xs,
                    n,
                    ant_x[j],
                    c2,
                    ref[j],
                    idx_scale,
                    idx_offset,
                    idx_max,
                    quarter_scale,
                    base,
                    obuf,
                    wbuf,
                    cbuf,
                    sbuf,
                )
                _row_gather(table, n, obuf, wbuf, vre, vim)
                off = (iy - y0) * stride
                _row_accumulate(n, vre, vim, cbuf, sbuf, are[off : off + n], aim[off : off + n])
        for iy in range(y0, y1):
            off = (iy - y0) * stride
            for k in range(n):
                out_re[iy, x0 + k] += are[off + k]
                out_im[iy, x0 + k] += aim[off + k]


def _upsample_padded(data: NDArray[np.complexfloating], factor: int) -> NDArray[np.float64]:
    """Traces upsampled as :func:`_upsample_fast_time`, padded with one zero sample each side.

    Returns the flat float64 view ``(re, im)`` of an ``(n_pulses, N + 2)`` complex128 array
    whose entry ``p`` is upsampled sample ``p - 1`` (``N = factor * n``); entries ``0`` and
    ``N + 1`` are zero. The spectrum is placed and the result rolled in FFT order, which
    saves the shift copies of :mod:`sarmotion.core.spectral` (same result to rounding), and the
    FFTs run on blocks of pulses that stay in cache.
    """
    m, n = data.shape
    big = factor * n
    lo = n - n // 2  # non-negative frequency offsets 0 .. lo-1 of the n bins
    h = big // 2
    out = np.empty((m, big + 2), dtype=np.complex128)
    out[:, 0] = 0.0
    out[:, -1] = 0.0
    spec = np.zeros((min(m, _PULSE_BLOCK), big), dtype=np.complex128)
    for j0 in range(0, m, _PULSE_BLOCK):
        j1 = min(j0 + _PULSE_BLOCK, m)
        b = j1 - j0
        f = np.fft.fft(np.fft.ifftshift(np.asarray(data[j0:j1], np.complex128), axes=-1))
        spec[:b, :lo] = f[:, :lo]  # the zero band in between is never written
        spec[:b, big - n // 2 :] = f[:, lo:]
        y = np.fft.ifft(spec[:b], axis=-1)
        np.multiply(y[:, : big - h], factor, out=out[j0:j1, 1 + h : 1 + big])  # t >= 0
        np.multiply(y[:, big - h :], factor, out=out[j0:j1, 1 : 1 + h])  # t < 0
    return out.reshape(-1).view(np.float64)


def _run_numba_f64(
    st: _Setup, grid: ImageGrid, progress: ProgressCallback | None
) -> NDArray[np.complex128]:
    """The float64 compiled kernel (fallback of :func:`_run_numba`)."""
    n_pulses = st.data.shape[0]
    n_up = st.upsample * st.data.shape[1]
    dt_up = st.sample_interval_s / st.upsample
    idx_scale = 2.0 / (C * dt_up)  # samples per metre of d = |r - rho| - |r - rho_o|
    idx_offset = float(n_up // 2 + 1)  # t = 0 is upsampled sample N//2, table entry N//2 + 1
    quarter_scale = 4.0 * 2.0 * st.carrier_hz / C  # quarter carrier cycles per metre of d
    ny, nx = grid.shape
    out_re = np.zeros((ny, nx))
    out_im = np.zeros((ny, nx))
    x = np.ascontiguousarray(grid.x_m)
    y = np.ascontiguousarray(grid.y_m)
    pos = st.eff_positions
    # Work split: pulse blocks whose upsampled traces fit in _TABLE_BYTES (one block for
    # GOTCHA-sized data), each in a few groups of tile rows. One parallel region per step:
    # few barriers (each costs a scheduler time slice on a loaded machine) and a progress
    # report per step.
    per_block = max(1, min(n_pulses, _TABLE_BYTES // (16 * (n_up + 2))))
    blocks = [(j, min(j + per_block, n_pulses)) for j in range(0, n_pulses, per_block)]
    n_tile_rows = -(-ny // _TILE[0])
    n_groups = min(n_tile_rows, max(1, -(-_STEPS // len(blocks))))
    groups = np.linspace(0, n_tile_rows, n_groups + 1).round().astype(int)
    total = len(blocks) * n_groups
    step = 0
    for j0, j1 in blocks:
        table = _upsample_padded(st.data[j0:j1], st.upsample)
        ant = (
            np.ascontiguousarray(pos[j0:j1, 0]),
            np.ascontiguousarray(pos[j0:j1, 1]),
            np.ascontiguousarray(pos[j0:j1, 2] ** 2),
            np.ascontiguousarray(st.ref_ranges[j0:j1]),
        )
        for g0, g1 in zip(groups[:-1], groups[1:], strict=True):
            with numba.parallel_chunksize(1):  # tiles handed out one at a time
                _accumulate_numba(
                    table, 2 * (n_up + 2), *ant, x, y, idx_scale, idx_offset, float(n_up),
                    quarter_scale, out_re, out_im, int(g0), int(g1), _TILE[0], _TILE[1],
                )  # fmt: skip
            step += 1
            if progress is not None:
                progress("backprojection", step, total)
    return out_re + 1j * out_im


# ===================================================================== float32 kernel
#: Largest truncation error (m) of the degree-4 range series accepted for a tile size.
_SERIES_TOLERANCE_M = 2e-8
#: Largest carrier-phase offset from a tile's anchor (quarter cycles) accepted: float32
#: keeps it to 2.4e-4 of a quarter cycle (4e-4 rad), 68 dB below the signal at worst.
_MAX_QUARTER_CYCLES = 4096.0
#: Candidate tile shapes (rows, columns), preferred first; columns a multiple of LANES.
#: Wide, short tiles serve grids with coarse rows (the sub-images of :mod:`.ffbp`).
_TILES = ((64, 64), (32, 64), (16, 64), (8, 64), (32, 32), (16, 32), (16, 16), (8, 16), (4, 16))
#: Bytes of complex64 trace tables kept by the cache (least recently used dropped first).
_CACHE_BYTES = 512 * 2**20


@dataclass(frozen=True, eq=False)
class _TraceTable:
    """Upsampled traces of one traces object as the float32 kernel reads them.

    ``values`` is the uint64 view of an ``(n_pulses, n_up + 2)`` complex64 array whose
    entry ``p`` is upsampled sample ``p - 1`` (:func:`_upsample_fast_time`); entries 0 and
    ``n_up + 1`` are zero.
    """

    values: NDArray[np.uint64]
    upsample: int
    n_up: int


def _make_table(data: NDArray[np.complexfloating], factor: int) -> _TraceTable:
    """Build the complex64 table by zero-padding the spectrum (FFTs in complex64).

    Same samples as :func:`_upsample_fast_time` to ~1e-7 relative (135 dB measured on
    GOTCHA), one FFT pair per pulse; 14 ms for 469 x 424 samples at ``factor = 8``.
    """
    m, n = data.shape
    big = factor * n
    lo = n - n // 2
    h = big // 2
    f = scipy.fft.fft(np.fft.ifftshift(np.asarray(data, np.complex64), axes=-1), axis=-1)
    spec = np.zeros((m, big), np.complex64)
    spec[:, :lo] = f[:, :lo]
    spec[:, big - n // 2 :] = f[:, lo:]
    y = scipy.fft.ifft(spec, axis=-1, overwrite_x=True)
    y *= factor
    out = np.zeros((m, big + 2), np.complex64)
    out[:, 1 + h : 1 + big] = y[:, : big - h]  # t >= 0
    out[:, 1 : 1 + h] = y[:, big - h :]  # t < 0
    return _TraceTable(values=out.view(np.uint64), upsample=factor, n_up=big)


class _TableCache:
    """Trace tables by traces object.

    Imaging the same traces again (other grids, other velocities) reuses the upsampling.
    An entry is dropped with its traces object, when ``traces.data`` no longer has the
    CRC-32 it was built from (0.7 ms for a 4-degree GOTCHA aperture), or when the cache
    holds more than :data:`_CACHE_BYTES`.
    """

    def __init__(self) -> None:
        self._entries: OrderedDict[tuple[int, int], tuple[weakref.ref, int, _TraceTable]] = (
            OrderedDict()
        )

    def get(self, traces: Traces, upsample: int) -> _TraceTable:
        data = np.ascontiguousarray(traces.data)
        crc = zlib.crc32(memoryview(data).cast("B"))
        key = (id(traces), upsample)
        entry = self._entries.get(key)
        if entry is not None and entry[0]() is traces and entry[1] == crc:
            self._entries.move_to_end(key)
            return entry[2]
        table = _make_table(data, upsample)
        entries = self._entries
        ref = weakref.ref(traces, lambda _, k=key: entries.pop(k, None))
        entries[key] = (ref, crc, table)
        total = sum(e[2].values.nbytes for e in entries.values())
        while total > _CACHE_BYTES and len(entries) > 1:
            _, (_, _, old) = entries.popitem(last=False)
            total -= old.values.nbytes
        return table

    def clear(self) -> None:
        self._entries.clear()


_TABLES = _TableCache()


@numba.njit(parallel=True, cache=True)
def _tile_kernel(
    tab, starts, stops, ant_x, ant_y, ant_z2, ref, x0, dx, nx, y0, dy, ny, idx_scale,
    idx_offset, n_up, quarter_scale, tile_rows, tile_cols, ty0, ty1, out_re, out_im,
):  # pragma: no cover - compiled  # fmt: skip
    """Add pulses to the tiles of tile rows ``ty0:ty1`` of ``out_re + 1j out_im``.

    The images ``out[i]``, ``(ny, nx)`` each, pixel ``(iy, ix)`` at
    ``(x0 + ix dx, y0 + iy dy, 0)``, are cut in ``tile_rows x tile_cols`` tiles; image
    ``i`` sums pulses ``starts[i]:stops[i]``; one parallel task per (image, tile). ``tab``
    is :attr:`_TraceTable.values`, one row per pulse (same order as ``ant_*`` and ``ref``).
    Per pulse and tile, the anchor quantities are float64 and the rest float32 (see the
    module docstring); :func:`~sarmotion.imaging._simd.tile_pulse` does the pixels.
    """
    n_tx = (nx + tile_cols - 1) // tile_cols
    n_tiles = (ty1 - ty0) * n_tx
    hi = np.float32(n_up)
    for task in numba.prange(starts.size * n_tiles):
        item = task // n_tiles
        tile = task % n_tiles
        ty = ty0 + tile // n_tx
        r0 = ty * tile_rows
        c0 = (tile % n_tx) * tile_cols
        nr = min(ny, r0 + tile_rows) - r0
        nc = min(nx, c0 + tile_cols) - c0
        ncp = (nc + LANES - 1) // LANES * LANES
        rc = r0 + nr // 2
        cc = c0 + nc // 2
        xc = x0 + cc * dx
        yc = y0 + rc * dy
        acc_re = np.zeros(nr * ncp, np.float32)
        acc_im = np.zeros(nr * ncp, np.float32)
        tile_pulses(
            tab, starts[item], stops[item], ant_x, ant_y, ant_z2, ref, xc, yc, dx, dy, c0, cc,
            r0, rc, nr, ncp, idx_scale, idx_offset, hi, quarter_scale, acc_re, acc_im,
        )  # fmt: skip
        for r in range(nr):
            for k in range(nc):
                out_re[item, r0 + r, c0 + k] += acc_re[r * ncp + k]
                out_im[item, r0 + r, c0 + k] += acc_im[r * ncp + k]


def _tile_shape(
    positions: NDArray[np.float64], x_m: NDArray, y_m: NDArray, quarter_scale: float
) -> tuple[int, int] | None:
    """Largest tile of :data:`_TILES` whose range series and phase offsets stay in bounds.

    With ``hx, hy`` the tile's half extents, ``Dx, Dy`` the largest antenna-to-pixel
    distances along x and y and ``R`` the smallest antenna-to-pixel distance,
    ``|N| <= hx (hx + 2 Dx) + hy (hy + 2 Dy)``, ``eps = |N| / R^2``; the series' truncation
    error is below ``R_max (7/256) eps^5 / (1 - eps)`` and the range offset below
    ``|N| / (2 R)``. ``None`` when even the smallest tile fails.
    """
    x0, x1 = float(x_m[0]), float(x_m[-1])
    y0, y1 = float(y_m[0]), float(y_m[-1])
    ax, ay, az = positions[:, 0], positions[:, 1], np.abs(positions[:, 2])
    dxmax = float(np.max(np.maximum(np.abs(ax - x0), np.abs(ax - x1))))
    dymax = float(np.max(np.maximum(np.abs(ay - y0), np.abs(ay - y1))))
    hx_near = np.maximum(np.maximum(x0 - ax, ax - x1), 0.0)  # 0 when above the grid
    hy_near = np.maximum(np.maximum(y0 - ay, ay - y1), 0.0)
    r_min = float(np.min(np.sqrt(hx_near**2 + hy_near**2 + az**2)))
    r_max = math.sqrt(dxmax**2 + dymax**2 + float(np.max(az)) ** 2)
    if r_min <= 0.0:
        return None
    dx = (x1 - x0) / max(x_m.size - 1, 1)
    dy = (y1 - y0) / max(y_m.size - 1, 1)
    for rows, cols in _TILES:
        hx = 0.5 * cols * dx
        hy = 0.5 * rows * dy
        n_max = hx * (hx + 2.0 * dxmax) + hy * (hy + 2.0 * dymax)
        eps = n_max / r_min**2
        if eps >= 0.5:
            continue
        truncation = r_max * 7.0 / 256.0 * eps**5 / (1.0 - eps)
        phase = quarter_scale * n_max / (2.0 * r_min)
        if truncation <= _SERIES_TOLERANCE_M and phase <= _MAX_QUARTER_CYCLES:
            return rows, cols
    return None


def _kernel_constants(
    radar_dt_s: float, carrier_hz: float, table: _TraceTable
) -> tuple[float, float, float]:
    """``(idx_scale, idx_offset, quarter_scale)`` of the float32 kernel.

    Table samples per metre of ``d = |r - rho| - |r - rho_o|``, table position of
    ``d = 0``, quarter carrier cycles per metre of ``d``.
    """
    dt_up = radar_dt_s / table.upsample
    return 2.0 / (C * dt_up), float(table.n_up // 2 + 1), 4.0 * 2.0 * carrier_hz / C


def _backproject_f32(
    table_values: NDArray[np.uint64],
    positions: NDArray[np.float64],
    ref_ranges: NDArray[np.float64],
    x_m: NDArray[np.float64],
    y_m: NDArray[np.float64],
    constants: tuple[float, float, float],
    n_up: int,
    tile: tuple[int, int],
    progress: ProgressCallback | None = None,
    steps: int = 1,
    pulse_ranges: NDArray[np.int64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Backprojection images of pulse ranges on the grid ``x_m`` x ``y_m``.

    ``table_values``, ``positions`` and ``ref_ranges`` have one row per pulse.
    ``pulse_ranges`` ``(n_images, 2)`` gives each image's pulses ``[start, stop)`` (default
    one image of every pulse). Returns ``(re, im)``, shape
    ``(n_images, y_m.size, x_m.size)``, float64. ``steps`` parallel regions, each followed
    by a progress report.
    """
    ny, nx = y_m.size, x_m.size
    dx = (float(x_m[-1]) - float(x_m[0])) / (nx - 1) if nx > 1 else 1.0
    dy = (float(y_m[-1]) - float(y_m[0])) / (ny - 1) if ny > 1 else 1.0
    if pulse_ranges is None:
        pulse_ranges = np.array([[0, positions.shape[0]]], dtype=np.int64)
    ranges = np.ascontiguousarray(pulse_ranges, dtype=np.int64)
    out_re = np.zeros((ranges.shape[0], ny, nx))
    out_im = np.zeros((ranges.shape[0], ny, nx))
    idx_scale, idx_offset, quarter_scale = constants
    ant = (
        np.ascontiguousarray(positions[:, 0]),
        np.ascontiguousarray(positions[:, 1]),
        np.ascontiguousarray(positions[:, 2] ** 2),
        np.ascontiguousarray(ref_ranges, dtype=np.float64),
    )
    n_tile_rows = -(-ny // tile[0])
    groups = np.linspace(0, n_tile_rows, min(n_tile_rows, max(1, steps)) + 1).round().astype(int)
    for step, (g0, g1) in enumerate(zip(groups[:-1], groups[1:], strict=True), start=1):
        with numba.parallel_chunksize(1):  # tiles handed out one at a time
            _tile_kernel(
                table_values, np.ascontiguousarray(ranges[:, 0]),
                np.ascontiguousarray(ranges[:, 1]), *ant, float(x_m[0]), dx, nx, float(y_m[0]),
                dy, ny, idx_scale, idx_offset, n_up, quarter_scale, tile[0], tile[1], int(g0),
                int(g1), out_re, out_im,
            )  # fmt: skip
        if progress is not None:
            progress("backprojection", step, len(groups) - 1)
    return out_re, out_im


def _run_numba(
    st: _Setup, traces: Traces, grid: ImageGrid, progress: ProgressCallback | None
) -> tuple[NDArray[np.complex128], str]:
    """The compiled kernel: float32 tiles when the geometry allows, else float64."""
    quarter_scale = 4.0 * 2.0 * st.carrier_hz / C
    tile = _tile_shape(st.eff_positions, grid.x_m, grid.y_m, quarter_scale)
    if tile is None:
        return _run_numba_f64(st, grid, progress), "numba-float64"
    table = _TABLES.get(traces, st.upsample)
    constants = _kernel_constants(st.sample_interval_s, st.carrier_hz, table)
    # One parallel region unless progress is reported: each region ends in a barrier, and on
    # a busy machine a barrier waits for a descheduled thread (128 x 128 GOTCHA image:
    # 18 ms in one region, 31 ms in eight, best of 20).
    re, im = _backproject_f32(
        table.values, st.eff_positions, st.ref_ranges, np.asarray(grid.x_m), np.asarray(grid.y_m),
        constants, table.n_up, tile, progress, _STEPS if progress is not None else 1,
    )  # fmt: skip
    return re[0] + 1j * im[0], "numba-float32"


def _run_ffbp(
    st: _Setup, traces: Traces, grid: ImageGrid, alpha: float, progress: ProgressCallback | None
) -> tuple[NDArray[np.complex128], str, dict]:
    """Fast factorised backprojection (:mod:`.ffbp`).

    Exact backprojection when the float32 kernel is out of bounds for this geometry or the
    factorisation would not save work. The float32 kernel on sub-grids (``exact_for``)
    computes the pixels the rotated path cannot resample.
    """
    from .ffbp import ffbp_values

    quarter_scale = 4.0 * 2.0 * st.carrier_hz / C
    if _tile_shape(st.eff_positions, grid.x_m, grid.y_m, quarter_scale) is None:
        values, variant = _run_numba(st, traces, grid, progress)
        return values, variant, {}
    table = _TABLES.get(traces, st.upsample)
    constants = _kernel_constants(st.sample_interval_s, st.carrier_hz, table)

    def tile_for(pos: NDArray, u: NDArray, v: NDArray) -> tuple[int, int]:
        return _tile_shape(pos, u, v, quarter_scale) or _TILES[-1]

    def exact_for(x: NDArray, y: NDArray) -> NDArray[np.complex128]:
        re, im = _backproject_f32(
            table.values, st.eff_positions, st.ref_ranges, np.ascontiguousarray(x),
            np.ascontiguousarray(y), constants, table.n_up, tile_for(st.eff_positions, x, y),
            None, 1,
        )  # fmt: skip
        return re[0] + 1j * im[0]

    values, info = ffbp_values(
        table.values, st.eff_positions, st.ref_ranges, traces.reference_point_m,
        np.asarray(grid.x_m), np.asarray(grid.y_m), constants=constants, n_up=table.n_up,
        carrier_hz=st.carrier_hz, bandwidth_hz=float(traces.radar.bandwidth_hz),
        tile_for=tile_for, alpha=alpha, progress=progress, exact_for=exact_for,
    )  # fmt: skip
    if values is None:
        values, variant = _run_numba(st, traces, grid, progress)
        return values, variant, info
    return values, "ffbp", info


def _run_numpy(
    st: _Setup, px: NDArray, py: NDArray, progress: ProgressCallback | None
) -> NDArray[np.complex128]:
    n_pulses = st.data.shape[0]
    out = np.zeros(px.shape, dtype=np.complex128)
    for j0, j1 in _blocks(n_pulses):
        _accumulate_numpy(st, j0, j1, px, py, out)
        if progress is not None:
            progress("backprojection", j1, n_pulses)
    return out


# ========================================================================= public API
def backproject(
    traces: Traces,
    grid: ImageGrid,
    *,
    velocity_mps: ArrayLike | None = None,
    upsample: int = 8,
    kernel: Kernel = "numba",
    method: Method = "exact",
    ffbp_oversampling: float = 1.4,
    progress: ProgressCallback | None = None,
) -> Image:
    """Backprojection image ``eq:image``, or ``eq:imagecompu`` with a velocity.

    ``I(rho) = sum_j D_r(s_j, dtau_j) exp(+i omega_o dtau_j)`` with
    ``dtau_j = tau(s_j, rho + s_j u) - tau(s_j, rho_o)`` at every grid point ``rho``.

    Parameters
    ----------
    traces : Traces
        Range-compressed baseband traces (complex64 or complex128) with their geometry.
    grid : ImageGrid
        Image points on the ground ``z = 0``.
    velocity_mps : (2,) array_like, optional
        Ground velocity ``u = (ux, uy)`` (m/s) to compensate; ``None`` images stationary
        targets (``u = 0``).
    upsample : int
        Fast-time upsampling factor (exact, by zero-padding the spectrum) before linear
        interpolation. The worst amplitude loss of linear interpolation, at the band edge
        and half-way between samples, is ``cos(pi / (2 upsample))``: -0.17 dB for 8.
    kernel : {"numba", "numpy"}
        ``"numba"``: compiled, parallel (the first call compiles, ~10 s, then is cached on
        disk). ``"numpy"``: the plain reference, slow but obviously correct.
    method : {"exact", "ffbp"}
        ``"exact"``: the sum over every pulse at every pixel. ``"ffbp"``: fast factorised
        backprojection (:mod:`sarmotion.imaging.ffbp`), for large images: 44 dB
        signal-to-error against ``"exact"`` on a 2048 x 2048 GOTCHA image, several times
        faster (see the module). Needs ``kernel="numba"``.
    ffbp_oversampling : float
        ``method="ffbp"``: oversampling of each sub-image's cross-range band, > 1; higher
        is more accurate and slower.
    progress : callable, optional
        Called as ``progress("backprojection", n_done, n_total)`` after each step of the
        computation (a block of pulses, a band of image rows, or a level of the FFBP tree;
        ``n_total`` is fixed for the call).

    Returns
    -------
    Image
        Complex image, shape ``grid.shape``, with ``velocity_mps`` and metadata.
    """
    _check_grid(grid)
    _check_kernel(kernel)
    _check_method(method, kernel)
    alpha = float(ffbp_oversampling)
    if not (math.isfinite(alpha) and alpha > 1.0):
        raise ValueError(f"ffbp_oversampling must be a number > 1, got {ffbp_oversampling!r}")
    st = _setup(traces, velocity_mps, upsample)
    extra: dict = {}
    if method == "ffbp":
        values, variant, extra = _run_ffbp(st, traces, grid, alpha, progress)
    elif kernel == "numba":
        values, variant = _run_numba(st, traces, grid, progress)
    else:
        variant = "numpy"
        px = np.broadcast_to(grid.x_m[None, :], grid.shape)
        py = np.broadcast_to(grid.y_m[:, None], grid.shape)
        values = _run_numpy(st, px, py, progress)
    u = np.zeros(2) if velocity_mps is None else _as_velocity(velocity_mps, name="velocity_mps")[:2]
    meta = {
        "algorithm": "backprojection",
        "equation": "eq:image" if velocity_mps is None else "eq:imagecompu",
        "kernel": kernel,
        "kernel_variant": variant,
        "method": method,
        "upsample": st.upsample,
        "n_pulses": traces.n_pulses,
        "reference_point_m": traces.reference_point_m.tolist(),
        "carrier_hz": st.carrier_hz,
    }
    if extra:
        meta["ffbp"] = extra
    return Image(values=values, grid=grid, velocity_mps=u, metadata=meta)


def backproject_points(
    traces: Traces,
    points_m: ArrayLike,
    *,
    velocity_mps: ArrayLike | None = None,
    upsample: int = 8,
) -> NDArray[np.complex128]:
    """The backprojection sum of :func:`backproject` at arbitrary ground points.

    Uses the numpy reference kernel; meant for a few hundred points (profiles, checks).

    Parameters
    ----------
    traces : Traces
        The traces.
    points_m : (..., 2) or (..., 3) array_like
        Ground points (m); a ``z`` column must be 0.
    velocity_mps : (2,) array_like, optional
        Compensated ground velocity (m/s).
    upsample : int
        Fast-time upsampling factor.

    Returns
    -------
    ndarray
        Complex values, shape ``points_m.shape[:-1]``.
    """
    p = np.asarray(points_m, dtype=np.float64)
    if p.ndim < 1 or p.shape[-1] not in (2, 3):
        raise ValueError(f"points_m must have shape (..., 2) or (..., 3) (m), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points_m must be finite")
    if p.shape[-1] == 3 and np.any(p[..., 2] != 0.0):
        raise ValueError("points_m must lie on the ground z = 0")
    st = _setup(traces, velocity_mps, upsample)
    return _run_numpy(st, p[..., 0], p[..., 1], None)


def backproject_phase_history(
    phase_history: ArrayLike,
    *,
    frequencies_hz: ArrayLike,
    positions_m: ArrayLike,
    slow_times_s: ArrayLike,
    reference_point_m: ArrayLike,
    grid: ImageGrid,
    velocity_mps: ArrayLike | None = None,
    upsample: int = 8,
    kernel: Kernel = "numba",
    progress: ProgressCallback | None = None,
) -> Image:
    """Backprojection image from a deramped phase history ``P(s_j, f_k)``.

    The phase history is converted to fast-time traces with
    :func:`sarmotion.core.spectral.to_fast_time` (the carrier is the frequency of bin
    ``n_freq // 2``), then imaged by :func:`backproject`.

    Parameters
    ----------
    phase_history : (n_pulses, n_freq) array_like
        Complex phase history, frequencies increasing along a row.
    frequencies_hz : (n_freq,) array_like
        Absolute frequencies (Hz), uniformly spaced and increasing.
    positions_m : (n_pulses, 3) array_like
        Antenna positions (m).
    slow_times_s : (n_pulses,) array_like
        Pulse times (s), increasing, ``s = 0`` at the aperture centre (the velocity
        compensation ``rho + s u`` is anchored there).
    reference_point_m : (2,) or (3,) array_like
        Range-compression (deramp) reference point ``rho_o`` (m).
    grid, velocity_mps, upsample, kernel, progress
        As in :func:`backproject`.

    Returns
    -------
    Image
    """
    ph = np.asarray(phase_history)
    if ph.ndim != 2:
        raise ValueError(f"phase_history must have shape (n_pulses, n_freq), got {ph.shape}")
    f = np.asarray(frequencies_hz, dtype=np.float64)
    if f.shape != (ph.shape[1],):
        raise ValueError(f"frequencies_hz must have shape ({ph.shape[1]},), got {f.shape}")
    if not np.all(np.isfinite(f)) or f.size < 2 or np.any(np.diff(f) <= 0):
        raise ValueError("frequencies_hz must be finite and strictly increasing")
    df = float(np.mean(np.diff(f)))
    if np.max(np.abs(np.diff(f) - df)) > 1e-6 * df:
        raise ValueError("frequencies_hz must be uniformly spaced")
    n = f.size
    radar = Radar(
        carrier_hz=float(f[n // 2]), bandwidth_hz=n * df, n_samples=n, frequency_step_hz=df
    )
    traj = Trajectory(positions_m=positions_m, slow_times_s=slow_times_s)
    traces = Traces.from_phase_history(
        ph, trajectory=traj, radar=radar, reference_point_m=reference_point_m
    )
    return backproject(
        traces, grid, velocity_mps=velocity_mps, upsample=upsample, kernel=kernel,
        progress=progress,
    )  # fmt: skip
