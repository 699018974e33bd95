"""The compiled backprojection kernels: float32 image tiles, and a float64 fallback.

Both evaluate ``sum_j D_j(dtau_j) exp(+i omega_o dtau_j)`` with ``D_j`` the cubic pieces of
:mod:`._bp_table` (the error analysis is in :mod:`.backprojection`).

- :func:`backproject_f32`, the default: image tiles of up to 32 x 64 pixels, one parallel
  task each; per pulse and tile the anchor pixel's range, table position and phase in
  float64, every other pixel as a float32 offset (:mod:`._simd`).
- :func:`run_numba_f64`: the same sum in float64, for geometries where :func:`tile_shape`
  finds no tile small enough (antenna within a few hundred metres of the image).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from ..core import ProgressCallback
from ..core.spectral import quarter_turns
from ._bp_common import KernelConstants, Setup, kernel_constants, table_samples
from ._bp_table import hermite_coefficients
from ._simd import LANES, tile_pulses
from .grid import ImageGrid

#: The version of :mod:`._simd`'s inner loop compiled into this module's kernels. numba's
#: on-disk cache keys on this file's contents, not on :mod:`._simd`'s: change this line
#: whenever the inner loop or its table layout changes, or a stale kernel is loaded.
SIMD_VERSION = "hermite-float32-planes-window-9-avx2-unmasked"

#: Memory bound of the float64 tables held by the float64 kernel at once (bytes).
_TABLE_BYTES = 128 * 2**20

#: Target number of progress steps (parallel regions) of the compiled kernels.
STEPS = 8

#: Image tile (rows, columns) of the float64 kernel, one parallel task.
_TILE = (64, 64)

#: Largest truncation error (m) of the degree-4 range series accepted for a tile size.
_SERIES_TOLERANCE_M = 2e-8
#: Largest carrier-phase offset from a tile's anchor (quarter cycles) accepted. Only the
#: series' terms beyond the linear one enter the phase in float32, but the range offset
#: feeds the float32 table position: at 4096 quarter cycles (about 16 m at X band) its
#: rounding stays below 1e-4 of an upsampled sample.
_MAX_QUARTER_CYCLES = 4096.0
#: Candidate tile shapes (rows, columns), preferred first; columns a multiple of LANES.
#: Wide, short tiles serve grids with coarse rows (the sub-images of :mod:`.ffbp`). The
#: largest, 32 x 64, keeps a tile's float32 accumulators (16 KiB) in a 32 KiB L1 data cache
#: beside the table rows it reads.
TILES = ((32, 64), (16, 64), (8, 64), (32, 32), (16, 32), (16, 16), (8, 16), (4, 16))


class Antennas(NamedTuple):
    """Per pulse, float64: antenna ``x``, ``y`` (m), ``z^2`` (m^2), reference range (m)."""

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    z2: NDArray[np.float64]
    ref: NDArray[np.float64]


class PixelLattice(NamedTuple):
    """A regular image lattice: pixel ``(iy, ix)`` at ``(x0 + ix dx, y0 + iy dy, 0)`` (m)."""

    x0: float
    dx: float
    nx: int
    y0: float
    dy: float
    ny: int


def antennas(positions: NDArray[np.float64], ref_ranges: NDArray[np.float64]) -> Antennas:
    return Antennas(
        np.ascontiguousarray(positions[:, 0], dtype=np.float64),
        np.ascontiguousarray(positions[:, 1], dtype=np.float64),
        np.ascontiguousarray(positions[:, 2] ** 2, dtype=np.float64),
        np.ascontiguousarray(ref_ranges, dtype=np.float64),
    )


# ===================================================================== float64 kernel
# Loops per (pulse, image row) of a tile: A (vectorised) range, table offset and weight,
# carrier phase; B (scalar) gather and evaluate the cubic piece; C (vectorised) accumulate.
# The phase phi = 2 pi (2 nu_o / c) d is reduced exactly to quarter cycles and evaluated by
# sarmotion.core.spectral.quarter_turns (error < 1e-14, vectorises).
# fastmath: contract (FMA), no reassociation: the order of the reduction is kept.
_FASTMATH = {"nnan", "ninf", "nsz", "arcp", "contract", "afn"}


@numba.njit(nogil=True, fastmath=_FASTMATH, cache=True)
def _row_geometry(xs, n, ax, c2, ref, consts, idx_max, base, obuf, wbuf, cbuf, sbuf):
    # pragma: no cover - compiled
    """Loop A: table offsets, weights and exp(i phi) along one tile row."""
    for k in range(n):
        dx = ax - xs[k]
        d = math.sqrt(dx * dx + c2) - ref
        q = d * consts.idx_scale + consts.idx_offset
        q = q if (q >= 1.0 and q < idx_max) else 0.0  # entry 0 of the table is zero
        fq = np.floor(q)
        obuf[k] = base + 8 * int(fq)
        wbuf[k] = q - fq
        cbuf[k], sbuf[k] = quarter_turns(d * consts.quarter_scale)


@numba.njit(nogil=True, fastmath=_FASTMATH, cache=True)
def _row_gather(table, n, obuf, wbuf, vre, vim):  # pragma: no cover - compiled
    """Loop B: the cubic piece at the offsets and weights of loop A."""
    for k in range(n):
        o = obuf[k]
        w = wbuf[k]
        vre[k] = table[o] + w * (table[o + 2] + w * (table[o + 4] + w * table[o + 6]))
        vim[k] = table[o + 1] + w * (table[o + 3] + w * (table[o + 5] + w * table[o + 7]))


@numba.njit(nogil=True, fastmath=_FASTMATH, cache=True)
def _row_accumulate(n, vre, vim, cbuf, sbuf, are, aim):  # pragma: no cover - compiled
    """Loop C: ``acc += sample * exp(i phi)``."""
    for k in range(n):
        c = cbuf[k]
        s = sbuf[k]
        are[k] += vre[k] * c - vim[k] * s
        aim[k] += vre[k] * s + vim[k] * c


@numba.njit(nogil=True, parallel=True, fastmath=_FASTMATH, cache=True)
def _accumulate_f64(table, pulse_stride, ant, x, y, consts, idx_max, out, ty0, ty1, tile):
    # pragma: no cover - compiled
    """Add the pulses of one block to tile rows ``ty0:ty1`` of ``out[0] + 1j out[1]``.

    ``table`` is the flat float64 view of :func:`~._bp_table.hermite_coefficients`
    (complex128), one row of ``pulse_stride`` floats per pulse; ``tile`` is (rows, cols).
    """
    tile_rows, tile_cols = tile
    ny = y.size
    nx = x.size
    n_tx = (nx + tile_cols - 1) // tile_cols
    n_pulses = ant.x.size
    for task in numba.prange((ty1 - ty0) * n_tx):
        ty = ty0 + task // n_tx
        tx = task % n_tx
        y0 = ty * tile_rows
        y1 = min(ny, y0 + tile_rows)
        x0 = tx * tile_cols
        x1 = min(nx, x0 + tile_cols)
        n = x1 - x0
        # Separate allocations, padded so that the buffers do not share 4 KiB offsets.
        stride = tile_cols + 8
        xs = x[x0:x1].copy()
        obuf = np.empty(tile_cols, np.int64)
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
                dy = ant.y[j] - y[iy]
                c2 = dy * dy + ant.z2[j]
                _row_geometry(xs, n, ant.x[j], c2, ant.ref[j], consts, idx_max, base, obuf,
                              wbuf, cbuf, sbuf)  # fmt: skip
                _row_gather(table, n, obuf, wbuf, vre, vim)
                off = (iy - y0) * stride
                _row_accumulate(n, vre, vim, cbuf, sbuf, are[off : off + n], aim[off : off + n])
        for iy in range(y0, y1):
            off = (iy - y0) * stride
            for k in range(n):
                out[0, iy, x0 + k] += are[off + k]
                out[1, iy, x0 + k] += aim[off + k]


def run_numba_f64(
    st: Setup, grid: ImageGrid, progress: ProgressCallback | None
) -> NDArray[np.complex128]:
    """The float64 compiled kernel (fallback of the float32 one)."""
    n_pulses, n = st.data.shape
    n_up = table_samples(n, st.upsample)
    consts = kernel_constants(st.sample_interval_s, st.carrier_hz, n, n_up)
    ny, nx = grid.shape
    out = np.zeros((2, ny, nx))
    x = np.ascontiguousarray(grid.x_m)
    y = np.ascontiguousarray(grid.y_m)
    # Pulse blocks whose tables fit in _TABLE_BYTES, each in a few groups of tile rows; one
    # parallel region per step (few barriers) and a progress report per step.
    per_block = max(1, min(n_pulses, _TABLE_BYTES // (64 * (n_up + 2))))
    blocks = [(j, min(j + per_block, n_pulses)) for j in range(0, n_pulses, per_block)]
    n_tile_rows = -(-ny // _TILE[0])
    n_groups = min(n_tile_rows, max(1, -(-STEPS // len(blocks))))
    groups = np.linspace(0, n_tile_rows, n_groups + 1).round().astype(int)
    total = len(blocks) * n_groups
    step = 0
    for j0, j1 in blocks:
        table = hermite_coefficients(st.data[j0:j1], st.upsample).reshape(-1).view(np.float64)
        ant = antennas(st.eff_positions[j0:j1], st.ref_ranges[j0:j1])
        for g0, g1 in zip(groups[:-1], groups[1:], strict=True):
            with numba.parallel_chunksize(1):  # tiles handed out one at a time
                _accumulate_f64(table, 8 * (n_up + 2), ant, x, y, consts, float(n_up), out,
                                int(g0), int(g1), _TILE)  # fmt: skip
            step += 1
            if progress is not None:
                progress("backprojection", step, total)
    return out[0] + 1j * out[1]


# ===================================================================== float32 kernel
@numba.njit(nogil=True, parallel=True, cache=True)
def _tile_kernel(tab, starts, stops, ant, lat, consts, n_up, tile, ty0, ty1, out, transposed):
    # pragma: no cover - compiled
    """Add pulses to the tiles of tile rows ``ty0:ty1`` of the complex128 images ``out``.

    The images ``out[i]`` on the lattice ``lat`` (``out[i, iy, ix]``, or ``out[i, ix, iy]``
    when ``transposed``) are cut in ``tile = (rows, cols)`` tiles;
    image ``i`` sums pulses ``starts[i]:stops[i]``; one parallel task per (image, tile).
    ``tab`` is :attr:`~._bp_table.TraceTable.values`, one row per pulse (the order of
    ``ant``). Per pulse and tile, the anchor quantities are float64 and the rest float32
    (:func:`~sarmotion.imaging._simd.tile_pulses`).
    """
    tile_rows, tile_cols = tile
    nx = lat.nx
    ny = lat.ny
    n_tx = (nx + tile_cols - 1) // tile_cols
    n_tiles = (ty1 - ty0) * n_tx
    hi = np.float32(n_up)
    for task in numba.prange(starts.size * n_tiles):
        item = task // n_tiles
        t = task % n_tiles
        ty = ty0 + t // n_tx
        r0 = ty * tile_rows
        c0 = (t % n_tx) * tile_cols
        nr = min(ny, r0 + tile_rows) - r0
        nc = min(nx, c0 + tile_cols) - c0
        ncp = (nc + LANES - 1) // LANES * LANES
        rc = r0 + nr // 2
        cc = c0 + nc // 2
        xc = lat.x0 + cc * lat.dx
        yc = lat.y0 + rc * lat.dy
        acc_re = np.zeros(nr * ncp, np.float32)
        acc_im = np.zeros(nr * ncp, np.float32)
        tile_pulses(
            tab, starts[item], stops[item], ant.x, ant.y, ant.z2, ant.ref, xc, yc, lat.dx,
            lat.dy, c0, cc, r0, rc, nr, ncp, consts.idx_scale, consts.idx_offset, hi,
            consts.quarter_scale, acc_re, acc_im,
        )  # fmt: skip
        if transposed:
            for k in range(nc):
                for r in range(nr):
                    v = complex(acc_re[r * ncp + k], acc_im[r * ncp + k])
                    out[item, c0 + k, r0 + r] += v
        else:
            for r in range(nr):
                for k in range(nc):
                    v = complex(acc_re[r * ncp + k], acc_im[r * ncp + k])
                    out[item, r0 + r, c0 + k] += v


def tile_shape(
    positions: NDArray[np.float64], x_m: NDArray, y_m: NDArray, quarter_scale: float
) -> tuple[int, int] | None:
    """Largest tile of :data:`TILES` whose range series and offsets stay in bounds.

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
    for rows, cols in TILES:
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


def lane_spans(
    positions: NDArray[np.float64], x_m: NDArray, y_m: NDArray, idx_scale: float
) -> tuple[float, float]:
    """Table entries spanned by ``LANES`` neighbouring pixels along ``x`` and along ``y``.

    The range changes by ``dx |x - a_x| / R`` per pixel along ``x`` and ``dy |y - a_y| / R``
    along ``y`` (here at the grid's centre, averaged over the pulses), ``idx_scale`` table
    entries per metre. Neighbouring lanes read neighbouring table entries when the span is
    under ``LANES`` (:mod:`._simd`: a window of ``LANES`` entries is read without gathers).
    """
    nx, ny = x_m.size, y_m.size
    dx = abs(float(x_m[-1]) - float(x_m[0])) / max(nx - 1, 1)
    dy = abs(float(y_m[-1]) - float(y_m[0])) / max(ny - 1, 1)
    ex = 0.5 * (float(x_m[0]) + float(x_m[-1])) - positions[:, 0]
    ey = 0.5 * (float(y_m[0]) + float(y_m[-1])) - positions[:, 1]
    r = np.sqrt(ex * ex + ey * ey + positions[:, 2] ** 2)
    scale = (LANES - 1) * idx_scale
    return (scale * dx * float(np.mean(np.abs(ex) / r)),
            scale * dy * float(np.mean(np.abs(ey) / r)))  # fmt: skip


def backproject_f32(
    table_values: NDArray[np.float32],
    positions: NDArray[np.float64],
    ref_ranges: NDArray[np.float64],
    x_m: NDArray[np.float64],
    y_m: NDArray[np.float64],
    constants: KernelConstants,
    n_up: int,
    tile: tuple[int, int],
    progress: ProgressCallback | None = None,
    steps: int = 1,
    pulse_ranges: NDArray[np.int64] | None = None,
) -> NDArray[np.complex128]:
    """Backprojection images of pulse ranges on the grid ``x_m`` x ``y_m``.

    ``table_values``, ``positions`` and ``ref_ranges`` have one row per pulse.
    ``pulse_ranges`` ``(n_images, 2)`` gives each image's pulses ``[start, stop)`` (default
    one image of every pulse). Returns the images, shape ``(n_images, y_m.size, x_m.size)``,
    complex128 (each tile's float32 sums, added in float64). ``steps`` parallel regions,
    each followed by a progress report. ``tile`` (rows, columns) is :func:`tile_shape`'s
    for this grid. When the lanes would span fewer table entries along ``y`` than along ``x``
    (:func:`lane_spans`), the sum runs on the grid mirrored about ``x = y`` (antennas
    too: every range is unchanged) with the tile :func:`tile_shape` gives there, each tile
    added to the images at its transposed place.
    """
    span_x, span_y = lane_spans(positions, x_m, y_m, constants[0])
    if y_m.size >= LANES and span_y < span_x:
        mirrored = np.ascontiguousarray(positions[:, [1, 0, 2]])
        tile_t = tile_shape(mirrored, y_m, x_m, constants[2])
        if tile_t is not None:
            return _backproject_f32(table_values, mirrored, ref_ranges, y_m, x_m, constants,
                                    n_up, tile_t, progress, steps, pulse_ranges,
                                    transposed=True)  # fmt: skip
    return _backproject_f32(table_values, positions, ref_ranges, x_m, y_m, constants, n_up, tile,
                            progress, steps, pulse_ranges)  # fmt: skip


def _backproject_f32(
    table_values, positions, ref_ranges, x_m, y_m, constants, n_up, tile, progress, steps,
    pulse_ranges, transposed=False,
):  # fmt: skip
    """:func:`backproject_f32` with the lanes along ``x``.

    The images are ``(n_images, y_m.size, x_m.size)``, or ``(n_images, x_m.size, y_m.size)``
    when ``transposed``.
    """
    ny, nx = y_m.size, x_m.size
    dx = (float(x_m[-1]) - float(x_m[0])) / (nx - 1) if nx > 1 else 1.0
    dy = (float(y_m[-1]) - float(y_m[0])) / (ny - 1) if ny > 1 else 1.0
    lat = PixelLattice(float(x_m[0]), dx, nx, float(y_m[0]), dy, ny)
    if pulse_ranges is None:
        pulse_ranges = np.array([[0, positions.shape[0]]], dtype=np.int64)
    ranges = np.ascontiguousarray(pulse_ranges, dtype=np.int64)
    out = np.zeros((ranges.shape[0], nx, ny) if transposed else (ranges.shape[0], ny, nx),
                   np.complex128)  # fmt: skip
    consts = KernelConstants(*(float(c) for c in constants))
    ant = antennas(positions, ref_ranges)
    n_tile_rows = -(-ny // tile[0])
    groups = np.linspace(0, n_tile_rows, min(n_tile_rows, max(1, steps)) + 1).round().astype(int)
    starts = np.ascontiguousarray(ranges[:, 0])
    stops = np.ascontiguousarray(ranges[:, 1])
    for step, (g0, g1) in enumerate(zip(groups[:-1], groups[1:], strict=True), start=1):
        with numba.parallel_chunksize(1):  # tiles handed out one at a time
            _tile_kernel(
                table_values, starts, stops, ant, lat, consts, n_up,
                (int(tile[0]), int(tile[1])), int(g0), int(g1), out, transposed,
            )  # fmt: skip
        if progress is not None:
            progress("backprojection", step, len(groups) - 1)
    return out
