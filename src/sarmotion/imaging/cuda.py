"""Exact backprojection on an NVIDIA GPU (numba.cuda): :func:`backproject_cuda`.

The same sum as :func:`sarmotion.imaging.backproject` (``eq:image``, ``eq:imagecompu``),

    I(rho) = sum_j D_j(dtau_j) exp(+i omega_o dtau_j),
    dtau_j = 2 (|r(s_j) - s_j u - rho| - |r(s_j) - rho_o|) / c,

with ``D_j`` the band-limited trace of pulse ``j``: the trigonometric interpolant of its
samples, ``D(t) = (1/n) sum_k P_k exp(2i pi (k - n//2) df t)``
(:mod:`sarmotion.core.spectral`). Its exact value is :func:`~sarmotion.imaging.point_response`.

Method
------
Per pulse, a table holds ``D`` and its derivative ``h D'`` on ``N`` points of step
``h = n dt / N <= dt / U`` over one period of ``D`` (``U = upsample``,
``N = table_samples(n, U)``, :func:`~._bp_common.table_samples`), built on the GPU from each
pulse's spectrum (:mod:`._cuda_table`: the trigonometric interpolant summed directly,
within ``2^-19`` of ``sum_k |P_k| / n``, then rounded to float32; :func:`hermite_table` is
the same table made on the host by zero-padded FFTs). ``D`` at a delay is the cubic
Hermite interpolant of the two table points around it. The table covers
``[-n/2, n/2) dt``, the fast-time window; a delay outside it contributes 0 (as on the
CPU).

Geometry: each GPU thread sums ``P`` pixels of one image column (``P`` in 1, 2, 4, 8: the
most that keeps the phase bound below and half the GPU's resident threads busy,
:func:`rows_per_thread`). Per pulse the range ``R_a`` to an anchor at the middle of the
``P`` pixels, its table position and its carrier phase (reduced exactly to
``[-1/2, 1/2]`` cycle) are computed in float64; each pixel's range offset from the
anchor, ``N / (R_a + sqrt(R_a^2 + N))`` with ``N = e (e + 2 (y_a - y_r))`` (``e`` its
offset along ``y``, ``|e| <= (P - 1) dy / 2``), in float32, as are the interpolation,
the phasor (``sin``/``cos`` of a reduced angle) and the sum over pulses.

Error bound
-----------
Each pixel's error is at most ``eps * sum_j S_j`` (:func:`error_bound`),
``S_j = sum_k |P_jk| / n >= max_t |D_j(t)|`` (``P_jk`` the spectrum of pulse ``j``),
``eps`` the sum of the per-term errors relative to ``S_j``:

- interpolation: ``D`` holds frequencies ``|f| <= 1 / (2 dt)``, so by Bernstein's
  inequality ``|D''''| <= (pi / dt)^4 max |D|``, and the cubic Hermite remainder is
  ``|D - H| <= max |D''''| h^4 tau^2 (1 - tau)^2 / 4! <= (pi / U)^4 / 384 max |D|`` per
  real component: ``eps_H = sqrt(2) (pi / U)^4 / 384`` (``U = 8``: 9.1e-5, -81 dB;
  reached only at the band edge half-way between table points: averaged over a flat
  band and over ``tau``, the error power is ``(pi / U)^8 / (9 * 576 * 630)`` of the
  signal's, -98 dB for ``U = 8``);
- phase: the float32 range offset is within ``8 u |e|`` of exact (``u = 2^-24``; six
  float32 operations, each rounded to ``u`` or, fast-math division and square root,
  ``2 u``), the phase sum rounds within ``2 u (2 nu_o / c) |e|`` cycles, so
  ``eps_phi = 2 pi (2 nu_o / c) 10 u (P - 1) dy / 2`` rad, and ``P`` is at most the
  largest value with ``eps_phi <= 1e-4`` rad (-80 dB; 4 at 0.25 m spacing, 8 at 0.1 m,
  X band). The float64 anchor adds ``2 pi (2 nu_o / c) 4 eps_64 R`` rad (1e-9 at
  ``R = 10`` km);
- the table: each value within ``2^-19 S_j`` (:func:`._cuda_table.entry_error`), each
  ``h D'`` within ``2^-19 (pi / U) S_j``; the Hermite weights sum to at most
  ``1 + 1/4`` of them: ``eps_T = 2^-19 (1 + pi / (4 U))`` (-113 dB);
- ``sin``/``cos`` of a reduced angle in ``[-pi, pi]`` (PTX ``sin.approx``,
  ``cos.approx``): ``2^-20.5``; float32 table values and table position: ``~u`` each
  (within the next term);
- the float32 sum over ``J`` pulses: ``J u``.

The bound holds pixel by pixel. For clutter, where terms and errors both add
incoherently, the signal-to-error ratio is set by the typical per-term error (the
averaged ``eps_H``, ``eps_phi / sqrt(3)``, ``sqrt(J) u``): above 90 dB at ``U = 8``.

Requirements
------------
The ``gpu`` extra (``pip install sarmotion[gpu]``: numba-cuda) and an NVIDIA GPU. numba's
CUDA simulator (``NUMBA_ENABLE_CUDASIM=1`` before numba is imported) runs the same
kernel on the CPU, slowly (the tests use it). numba-cuda 0.30 refers to ``np.row_stack``,
which numpy 2.5 removed: :mod:`._cuda_kernels` aliases it to :func:`numpy.vstack` where it
is missing, before importing :mod:`numba.cuda` (no version pin needed).

All quantities are SI: metres, seconds, hertz, m/s.
"""

from __future__ import annotations

import contextlib
import math
import weakref
import zlib
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import C, ProgressCallback, Traces, to_fast_time, to_frequency
from ..core.geometry import _as_velocity
from ._bp_common import Setup, make_setup, table_samples
from ._cuda_host import pool_for
from .grid import Image, ImageGrid, all_finite, checked_values

__all__ = ["available", "backproject_cuda", "error_bound", "hermite_table", "rows_per_thread"]

#: The one-line error when no GPU path can run.
NEEDS = "device='cuda' needs the sarmotion[gpu] extra and an NVIDIA GPU"

#: Largest float32 phase error bound accepted when grouping pixels per thread (rad):
#: -80 dB.
_MAX_PHASE_ERROR_RAD = 1e-4

#: Thread rows per block (the block is 32 columns by this many rows of threads).
BLOCK_ROWS = 8

#: Most row bands of an exact image (:func:`row_bands`): each band's copy to host memory
#: runs while the next is computed, so only the last band's copy is not hidden.
MAX_BANDS = 8

#: Pixels per thread considered, most first.
_ROWS_PER_THREAD = (8, 4, 2)

#: float32 unit roundoff.
_U32 = 2.0**-24

#: Pulses per block of the table's FFTs (bounds the complex128 temporaries).
_FFT_BLOCK = 64


def _cuda() -> Any:
    """numba.cuda, imported on first use; RuntimeError (one line) when unusable."""
    try:  # numba.cuda through _cuda_kernels only: the numpy alias comes first there
        from ._cuda_kernels import cuda
    except Exception as err:  # ImportError, or numba-cuda failing at import
        raise RuntimeError(f"{NEEDS} ({type(err).__name__}: {err})".splitlines()[0]) from err
    return cuda


def available() -> bool:
    """Whether :func:`backproject_cuda` can run: numba.cuda imports and finds a GPU.

    True under numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``).
    """
    try:
        return bool(_cuda().is_available())
    except Exception:
        return False


def hermite_table(data: ArrayLike, upsample: int) -> NDArray[np.float32]:
    """Trace values and derivatives on ``upsample`` points per sample, one period.

    Parameters
    ----------
    data : (n_pulses, n) array_like
        Complex baseband traces, ``t = 0`` at index ``n // 2``, sample interval ``dt``.
    upsample : int
        Table points per sample ``U`` (>= 1).

    Returns
    -------
    (n_pulses, N + 1, 4) ndarray
        float32 ``(Re V, Im V, Re D, Im D)`` at ``t_m = (m - N // 2) h``, ``h = n dt / N``,
        ``N = table_samples(n, U)`` (:func:`~._bp_common.table_samples`, ``h <= dt / U``):
        ``V = D(t_m)`` and ``D = h D'(t_m)`` of the band-limited trace; entry ``N`` is
        entry 0 (the trace has period ``n dt``).
    """
    d = np.asarray(data)
    m, n = d.shape
    big = table_samples(n, upsample)
    start = big // 2 - n // 2
    ramp = 2j * np.pi * (np.arange(n) - n // 2) / big  # h d/dt on bin k
    out = np.empty((m, big + 1, 4), dtype=np.float32)
    for j0 in range(0, m, _FFT_BLOCK):
        j1 = min(j0 + _FFT_BLOCK, m)
        spec = to_frequency(np.asarray(d[j0:j1], np.complex128))
        pad = np.zeros((j1 - j0, big), dtype=np.complex128)
        pad[:, start : start + n] = spec
        v = to_fast_time(pad) * (big / n)
        pad[:, start : start + n] = spec * ramp
        dv = to_fast_time(pad) * (big / n)
        out[j0:j1, :big, 0] = v.real
        out[j0:j1, :big, 1] = v.imag
        out[j0:j1, :big, 2] = dv.real
        out[j0:j1, :big, 3] = dv.imag
    out[:, big] = out[:, 0]
    return out


def rows_per_thread(
    carrier_hz: float, spacing_y_m: float, n_pixels: int = 0, min_threads: int = 0
) -> int:
    """Pixels per GPU thread ``P``: the largest of 8, 4, 2 that keeps both rules, else 1.

    - accuracy: the float32 phase bound (module docstring),
      ``2 pi (2 nu_o / c) 10 u (P - 1) dy / 2 <= 1e-4`` rad;
    - occupancy: at least ``min_threads`` threads, ``n_pixels / P >= min_threads``
      (more pixels per thread share one float64 anchor per pulse, but too few threads
      leave multiprocessors idle).

    Parameters
    ----------
    carrier_hz : float
        Carrier ``nu_o`` (Hz).
    spacing_y_m : float
        Pixel spacing along ``y`` (m), the direction of a thread's pixels.
    n_pixels : int
        Pixels of the image.
    min_threads : int
        Threads wanted at least (:func:`_min_threads`: half the device's resident threads).
    """
    per_m = 2.0 * math.pi * (2.0 * carrier_hz / C) * 10.0 * _U32
    for p in _ROWS_PER_THREAD:
        if per_m * 0.5 * (p - 1) * spacing_y_m <= _MAX_PHASE_ERROR_RAD and (
            n_pixels >= p * min_threads
        ):
            return p
    return 1


def error_bound(
    upsample: int,
    carrier_hz: float,
    spacing_y_m: float,
    rows_per_thread: int,
    n_pulses: int,
    range_m: float = 1e5,
) -> float:
    """Worst-case error of one pixel over ``sum_j sum_k |P_jk| / n`` (module docstring).

    ``eps_H + eps_T + eps_phi + eps_trig + J u``: cubic Hermite interpolation
    ``sqrt(2) (pi / U)^4 / 384``; the table built on the GPU ``2^-19 (1 + pi / (4 U))``;
    float32 range offsets and phase ``2 pi (2 nu_o / c) (10 u (P - 1) dy / 2 + 4 eps_64
    R)``; ``sin``/``cos`` ``2^-20.5`` (PTX ``sin.approx``/``cos.approx``); float32
    accumulation ``J u``.

    Parameters
    ----------
    upsample : int
        Table points per trace sample ``U``.
    carrier_hz : float
        Carrier ``nu_o`` (Hz).
    spacing_y_m : float
        Pixel spacing along ``y`` (m).
    rows_per_thread : int
        Pixels per thread ``P``.
    n_pulses : int
        Pulses ``J``.
    range_m : float
        Largest antenna-to-pixel range ``R`` (m).

    Returns
    -------
    float
        ``|I_gpu(rho) - I(rho)| / sum_j sum_k |P_jk| / n`` at most.
    """
    hermite = math.sqrt(2.0) * (math.pi / upsample) ** 4 / 384.0
    table = 2.0**-19 * (1.0 + math.pi / (4.0 * upsample))
    per_m = 2.0 * math.pi * (2.0 * carrier_hz / C)
    phase = per_m * (10.0 * _U32 * 0.5 * (rows_per_thread - 1) * spacing_y_m
                     + 4.0 * 2.0**-53 * range_m)  # fmt: skip
    return hermite + table + phase + 2.0**-20.5 + n_pulses * _U32


def _min_threads(cuda: Any) -> int:
    """Half the threads the current device holds at once (0 when it does not say)."""
    try:
        dev = cuda.get_current_device()
        return int(dev.MULTIPROCESSOR_COUNT) * int(dev.MAX_THREADS_PER_MULTIPROCESSOR) // 2
    except Exception:  # the simulator's device has no attributes
        return 0


class _DeviceTables:
    """The device table of the last traces imaged (one entry).

    Reused while the same traces object (by identity) is imaged at the same ``upsample``:
    other grids and velocities need no new table. Its data may have been changed in
    place since: the CRC-32 of the data tells, computed while the kernel runs (it reads
    every byte of the traces, as long as the kernel of a small image takes), and the
    image is then made again from a new table.
    """

    def __init__(self) -> None:
        self._key: tuple | None = None
        self._ref: weakref.ref | None = None
        self._crc: int | None = None
        self._table: Any = None

    def cached(self, traces: Traces, upsample: int) -> Any:
        """The table of this traces object if there is one, unverified; else None."""
        if self._key == (id(traces), upsample) and self._ref is not None:
            if self._ref() is traces:
                return self._table
        return None

    def verify(self, data: NDArray) -> bool:
        """Whether ``data`` still has the CRC-32 the cached table was built from."""
        return zlib.crc32(memoryview(data).cast("B")) == self._crc

    def build(self, cuda: Any, traces: Traces, data: NDArray, upsample: int) -> Any:
        self.clear()  # free the old table first
        from ._cuda_table import build_table, builds_on_device

        if builds_on_device():
            self._table = build_table(cuda, data, upsample)
        else:  # numba's simulator: the same table from the host's FFTs
            self._table = cuda.to_device(hermite_table(data, upsample).view(np.uint64).reshape(-1))
        self._crc = zlib.crc32(memoryview(data).cast("B"))
        self._key = (id(traces), upsample)
        self._ref = weakref.ref(traces)
        return self._table

    def clear(self) -> None:
        self._key = self._ref = self._crc = self._table = None


_TABLES = _DeviceTables()


def _antennas(st: Setup) -> NDArray[np.float64]:
    """``(n_pulses, 4)`` float64: effective antenna ``x``, ``y``, ``z**2`` and ``|r - rho_o|``."""
    pos = st.eff_positions
    return np.ascontiguousarray(
        np.stack([pos[:, 0], pos[:, 1], pos[:, 2] ** 2, st.ref_ranges], axis=1)
    )


def _launch_exact(
    cuda: Any,
    table: Any,
    n_table: int,
    ant: Any,
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    idx_scale: float,
    cycles_per_m: float,
    p: int,
    block_rows: int = BLOCK_ROWS,
) -> Any:
    """Launch the exact kernel on the pixels ``x`` x ``y`` (m); returns its launcher and args.

    ``ant`` the device copy of :func:`_antennas`, ``idx_scale`` table steps per metre of
    range offset, ``cycles_per_m = 2 nu_o / c``, ``p`` pixels per thread. The image is the
    last argument, a ``(ny, nx, 2)`` float64 device array; call ``kernel(table, *args)``.
    """
    from . import _cuda_kernels as kern

    ny, nx = y.size, x.size
    blocks = (-(-nx // kern.BLOCK_X), -(-ny // (block_rows * p)))
    out = cuda.device_array((ny, nx, 2), dtype=np.float64)
    kernel = kern.backprojection_kernel(p, block_rows)[blocks, (kern.BLOCK_X, block_rows)]
    args = (n_table, ant, cuda.to_device(np.ascontiguousarray(x)),
            cuda.to_device(np.ascontiguousarray(y)), idx_scale, float(n_table // 2),
            cycles_per_m, out)  # fmt: skip
    return kernel, args


def _image_on_device(
    cuda: Any,
    traces: Traces,
    grid: ImageGrid,
    u: NDArray[np.float64],
    upsample: int,
    pixels_per_thread: int | None = None,
    block_rows: int = BLOCK_ROWS,
) -> tuple[Any, int]:
    """Launch the kernel; returns the image as a (ny, nx, 2) float64 device array and P."""
    e = _exact_inputs(cuda, traces, grid, u, upsample, pixels_per_thread)
    kernel, args = _launch_exact(cuda, e.table, e.n_table, e.antennas, e.x, e.y, e.idx_scale,
                                 e.cycles_per_m, e.p, block_rows)  # fmt: skip
    kernel(e.table, *args)  # asynchronous: the check below runs while the GPU works
    if e.verify and not _TABLES.verify(e.data):  # data changed in place: new table, again
        kernel(_TABLES.build(cuda, traces, e.data, upsample), *args)
    return args[-1], e.p


class _ExactInputs(NamedTuple):
    """What an exact image needs on the device (:func:`_exact_inputs`)."""

    data: NDArray[np.complex128]  # the traces, C-ordered
    table: Any  # the device table (cached: ``verify`` it against ``data``)
    verify: bool
    n_table: int
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    p: int  # pixels per thread
    antennas: Any  # device (n_pulses, 4), :func:`_antennas`
    idx_scale: float  # table steps per metre of range offset
    cycles_per_m: float  # 2 nu_o / c


def _exact_inputs(
    cuda: Any,
    traces: Traces,
    grid: ImageGrid,
    u: NDArray[np.float64],
    upsample: int,
    pixels_per_thread: int | None,
) -> _ExactInputs:
    """The table (cached or built), axes, pixels per thread and antennas of an exact image."""
    carrier = float(traces.radar.carrier_hz)
    data = np.ascontiguousarray(traces.data)
    table = _TABLES.cached(traces, upsample)
    verify = table is not None
    if table is None:
        table = _TABLES.build(cuda, traces, data, upsample)
    n_table = table_samples(traces.n_samples, upsample)
    h = float(traces.radar.sample_interval_s) * traces.n_samples / n_table
    ny, nx = grid.shape
    x, y = np.ascontiguousarray(grid.x_m), np.ascontiguousarray(grid.y_m)
    dy = (float(y[-1]) - float(y[0])) / (ny - 1) if ny > 1 else 0.0
    p = pixels_per_thread or rows_per_thread(carrier, dy, nx * ny, _min_threads(cuda))
    ant = cuda.to_device(_antennas(make_setup(traces, u, upsample)))
    return _ExactInputs(data, table, verify, n_table, x, y, p, ant, 2.0 / (C * h),
                        2.0 * carrier / C)  # fmt: skip


def row_bands(ny: int, nx: int, p: int, block_rows: int, min_threads: int) -> list[tuple[int, int]]:
    """Row ranges ``[r0, r1)`` of an image computed and copied to host memory in turn.

    Each band is a whole number of thread blocks' rows (``block_rows * p``), so every
    thread sums the same pixels as in one launch (the same bits); each holds at least
    ``min_threads`` threads (half the GPU's, :func:`_min_threads`; 0: no minimum), at most
    :data:`MAX_BANDS` bands, as even as whole blocks allow; one band for a small image.
    """
    unit = block_rows * p
    units = -(-ny // unit)
    k = min(MAX_BANDS, units)
    while k > 1 and (units // k) * nx * block_rows < min_threads:  # the smallest band's
        k -= 1
    edges = [min(ny, (i * units // k) * unit) for i in range(k)] + [ny]
    return list(zip(edges[:-1], edges[1:], strict=True))


def _exact_to_host(
    cuda: Any,
    traces: Traces,
    grid: ImageGrid,
    u: NDArray[np.float64],
    upsample: int,
    pixels_per_thread: int | None = None,
    block_rows: int = BLOCK_ROWS,
) -> tuple[NDArray[np.complex128], int]:
    """The exact image in host memory, checked finite; returns it and ``P``.

    The image is computed in row bands (:func:`row_bands`) on one stream while another
    copies each finished band into a page-locked host block (:mod:`._cuda_host`), and
    the host checks each band as it arrives: the copies and the check run while the GPU
    computes the next bands.

    Raises
    ------
    ValueError
        When a value is not finite (a float32 sum overflowed).
    """
    from . import _cuda_kernels as kern

    e = _exact_inputs(cuda, traces, grid, u, upsample, pixels_per_thread)
    ny, nx = grid.shape
    host = pool_for(cuda).empty((ny, nx), np.complex128)
    parts = host.view(np.float64).reshape(ny, nx, 2)
    bands = row_bands(ny, nx, e.p, block_rows, _min_threads(cuda))
    compute, copier = cuda.stream(), cuda.stream()
    # Every band reads views of one copy of the axes and writes a view of one image.
    d_x, d_y = cuda.to_device(e.x), cuda.to_device(e.y)
    image = cuda.device_array((ny, nx, 2), dtype=np.float64)
    fn = kern.backprojection_kernel(e.p, block_rows)
    threads = (kern.BLOCK_X, block_rows)
    columns = -(-nx // kern.BLOCK_X)
    constants = (e.idx_scale, float(e.n_table // 2), e.cycles_per_m)

    def run(table: Any) -> list[Any]:
        copied = []
        for r0, r1 in bands:
            blocks = (columns, -(-(r1 - r0) // (block_rows * e.p)))
            fn[blocks, threads, compute](table, e.n_table, e.antennas, d_x, d_y[r0:r1],
                                         *constants, image[r0:r1])  # fmt: skip
            done = cuda.event()
            done.record(compute)
            done.wait(copier)
            image[r0:r1].copy_to_host(parts[r0:r1], stream=copier)
            arrived = cuda.event()
            arrived.record(copier)
            copied.append(arrived)
        return copied

    copied = run(e.table)  # asynchronous: the check below runs while the GPU works
    if e.verify and not _TABLES.verify(e.data):  # data changed in place: new table, again
        for arrived in copied:
            arrived.synchronize()
        copied = run(_TABLES.build(cuda, traces, e.data, upsample))
    finite = True
    for (r0, r1), arrived in zip(bands, copied, strict=True):
        arrived.synchronize()
        finite = finite and all_finite(host[r0:r1])
    if not finite:
        raise ValueError("values contains NaN or infinite entries")
    return host, e.p


def device_table(cuda: Any, traces: Traces, upsample: int) -> Any:
    """The device table of ``traces`` (:func:`hermite_table`, flat uint64), built if needed.

    The cached table of the same traces object is checked against the data first (CRC-32):
    data changed in place get a new table.
    """
    data = np.ascontiguousarray(traces.data)
    table = _TABLES.cached(traces, upsample)
    if table is None or not _TABLES.verify(data):
        table = _TABLES.build(cuda, traces, data, upsample)
    return table


def backproject_cuda(
    traces: Traces,
    grid: ImageGrid,
    *,
    velocity_mps: ArrayLike | None = None,
    upsample: int = 8,
    kernel: str = "numba",
    method: str = "exact",
    ffbp_oversampling: float | None = None,
    progress: ProgressCallback | None = None,
    pixels_per_thread: int | None = None,
) -> Image:
    """Backprojection image ``eq:image`` (``eq:imagecompu`` with a velocity) on the GPU.

    The keywords of :func:`sarmotion.imaging.backproject`; the module docstring gives the
    method and its error bound (>= 80 dB against the exact sum at ``upsample = 8``).

    Parameters
    ----------
    traces : Traces
        Range-compressed baseband traces with their geometry.
    grid : ImageGrid
        Image points on the ground ``z = 0``.
    velocity_mps : (2,) array_like, optional
        Ground velocity ``u`` (m/s) to compensate.
    upsample : int
        Table points per trace sample (1 to 64); the interpolation error bound falls as
        ``upsample**-4``.
    kernel : {"numba"}
        Accepted for the CPU signature: the GPU kernel is numba.cuda.
    method : {"exact", "ffbp"}
        ``"ffbp"``: fast factorised backprojection on the GPU (:mod:`.cuda_ffbp`, the CPU's
        plan and error budget), exact backprojection where it would not save work.
    ffbp_oversampling : float, optional
        ``method="ffbp"``: oversampling of each sub-image's band (as on the CPU).
    progress : callable, optional
        Called once, ``progress("backprojection", 1, 1)``, when the image is done.
    pixels_per_thread : {1, 2, 4, 8}, optional
        Pixels summed per GPU thread; default from the phase bound and the image size
        (:func:`rows_per_thread`).

    Returns
    -------
    Image
        Complex128 image, shape ``grid.shape``; ``metadata["kernel_variant"]`` is
        ``"cuda-hermite"`` (exact) or ``"cuda-ffbp"``; with ``method="ffbp"``,
        ``metadata["ffbp"]`` is the plan's information (:func:`.ffbp.ffbp_values`).

    Raises
    ------
    RuntimeError
        Without numba-cuda or a GPU (one line).
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    if not isinstance(grid, ImageGrid):
        raise TypeError(f"grid must be an ImageGrid, got {type(grid).__name__}")
    if isinstance(upsample, bool) or not isinstance(upsample, (int, np.integer)):
        raise TypeError(f"upsample must be an integer, got {type(upsample).__name__}")
    if not 1 <= int(upsample) <= 64:
        raise ValueError(f"upsample must be between 1 and 64, got {upsample}")
    if kernel != "numba":
        raise ValueError(
            f"device='cuda' runs the numba.cuda kernel: kernel must be 'numba', got {kernel!r}"
        )
    if method not in ("exact", "ffbp"):
        raise ValueError(f"method must be 'exact' or 'ffbp', got {method!r}")
    alpha = None if ffbp_oversampling is None else float(ffbp_oversampling)
    if alpha is not None and not (math.isfinite(alpha) and alpha > 1.0):
        raise ValueError(f"ffbp_oversampling must be a number > 1, got {ffbp_oversampling!r}")
    if pixels_per_thread is not None and pixels_per_thread not in (1, 2, 4, 8):
        raise ValueError(f"pixels_per_thread must be 1, 2, 4 or 8, got {pixels_per_thread!r}")
    u = np.zeros(3) if velocity_mps is None else _as_velocity(velocity_mps, name="velocity_mps")
    if u[2] != 0.0:
        raise ValueError(f"velocity_mps must be a ground velocity (uz = 0), got {u}")
    cuda = _cuda()
    if not cuda.is_available():
        raise RuntimeError(f"{NEEDS} (no CUDA device found)")
    values = None
    extra: dict = {}
    if method == "ffbp":
        from .cuda_ffbp import ffbp_cuda

        values, extra = ffbp_cuda(cuda, traces, grid.x_m, grid.y_m, u, int(upsample),
                                  alpha=alpha, progress=progress)  # fmt: skip
    p = 0
    checked = values is None  # the exact path checks its bands as they arrive
    if checked:
        values, p = _exact_to_host(cuda, traces, grid, u, int(upsample), pixels_per_thread)
        if progress is not None:
            progress("backprojection", 1, 1)
    carrier = float(traces.radar.carrier_hz)
    meta = {
        "algorithm": "backprojection",
        "equation": "eq:image" if velocity_mps is None else "eq:imagecompu",
        "kernel": "numba",
        "kernel_variant": "cuda-hermite" if extra.get("path", "exact") == "exact" else "cuda-ffbp",
        "method": method,
        "device": "cuda",
        "pixels_per_thread": p,
        "upsample": int(upsample),
        "n_pulses": traces.n_pulses,
        "reference_point_m": traces.reference_point_m.tolist(),
        "carrier_hz": carrier,
    }
    if extra:
        meta["ffbp"] = extra
    with checked_values() if checked else contextlib.nullcontext():
        return Image(values=values, grid=grid, velocity_mps=u[:2], metadata=meta)
