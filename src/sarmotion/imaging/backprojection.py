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
kernel. Geometry and phases are float64 in both: at ``L = 10`` km the carrier phase is
``~4e6`` rad and float32 would destroy the image. The compiled kernel folds the phase
exactly (``t - rint(t)`` on quarter cycles) before a float64 polynomial sine/cosine
accurate to ``~1e-14``, and agrees with the reference to far better than 60 dB.

All quantities are SI: metres, seconds, hertz, m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import C, ProgressCallback, Radar, Traces, Trajectory, to_fast_time, to_frequency
from ..core.geometry import _as_velocity
from .grid import Image, ImageGrid

__all__ = ["backproject", "backproject_phase_history", "backproject_points"]


Kernel = Literal["numba", "numpy"]


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
# Sterbenz), so exp(i phi) = i^k exp(i pi r / 2); the two polynomials below (minimax on
# |r| <= 1/2) give cos and sin of pi r / 2 within 6e-15 and vectorise (no libm calls).
# fastmath: contract (FMA), no reassociation: the order of the reduction is kept.
_FASTMATH = {"nnan", "ninf", "nsz", "arcp", "contract", "afn"}


_S0, _S1, _S2, _S3, _S4, _S5 = (
    1.57079632679489,
    -0.6459640975043288,
    0.07969262615641214,
    -0.0046817525994714984,
    0.00016042930460199835,
    -3.5564543255214174e-06,
)


_C0, _C1, _C2, _C3, _C4, _C5, _C6 = (
    0.9999999999999951,
    -1.2337005501361604,
    0.2536695079002106,
    -0.02086348074043811,
    0.0009192599906072516,
    -2.5200275027694737e-05,
    4.657112551982875e-07,
)


@numba.njit(fastmath=_FASTMATH, cache=True)
def _sincos_quarter(r: float) -> tuple[float, float]:
    """``(cos(pi r / 2), sin(pi r / 2))`` for ``|r| <= 1/2``, error < 6e-15."""
    z = r * r
    s = r * (_S0 + z * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * _S5)))))
    c = _C0 + z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    return c, s


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
        t = d * quarter_scale
        kq = np.rint(t)
        c, s = _sincos_quarter(t - kq)
        quadrant = int(kq) & 3
        swap = (quadrant & 1) == 1
        cs = s if swap else c
        sn = c if swap else s
        cbuf[k] = -cs if (quadrant == 1 or quadrant == 2) else cs
        sbuf[k] = -sn if quadrant >= 2 else sn


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


def _run_numba(
    st: _Setup, grid: ImageGrid, progress: ProgressCallback | None
) -> NDArray[np.complex128]:
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
    progress : callable, optional
        Called as ``progress("backprojection", n_done, n_total)`` after each step of the
        computation (a block of pulses, or a band of image rows; ``n_total`` is fixed for
        the call).

    Returns
    -------
    Image
        Complex image, shape ``grid.shape``, with ``velocity_mps`` and metadata.
    """
    _check_grid(grid)
    _check_kernel(kernel)
    st = _setup(traces, velocity_mps, upsample)
    if kernel == "numba":
        values = _run_numba(st, grid, progress)
    else:
        px = np.broadcast_to(grid.x_m[None, :], grid.shape)
        py = np.broadcast_to(grid.y_m[:, None], grid.shape)
        values = _run_numpy(st, px, py, progress)
    u = np.zeros(2) if velocity_mps is None else _as_velocity(velocity_mps, name="velocity_mps")[:2]
    meta = {
        "algorithm": "backprojection",
        "equation": "eq:image" if velocity_mps is None else "eq:imagecompu",
        "kernel": kernel,
        "upsample": st.upsample,
        "n_pulses": traces.n_pulses,
        "reference_point_m": traces.reference_point_m.tolist(),
        "carrier_hz": st.carrier_hz,
    }
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
