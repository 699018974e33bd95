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

Interpolation in fast time. ``D_r(s_j, .)`` is band-limited: ``n`` frequency bins of
``df = 1 / (n dt)``, ``|f| <= 1 / (2 dt)``. Its samples and derivatives on a grid at least
``upsample`` times finer, ``h = n dt / N <= dt / upsample`` (``N`` from
:func:`~._bp_common.table_samples`: the spectrum padded to a length of fast transforms), come
exactly from the zero-padded spectrum, and ``D_r``
is read between them by the cubic Hermite piece matching ``D`` and ``D'`` at both ends
(:mod:`._bp_table`). Delays outside the table's span
(:func:`~sarmotion.imaging.exact_sum.fast_time_window`) contribute 0.

Error bound. On an interval, ``t = t_m + w h``, the Hermite remainder of each of ``Re D``
and ``Im D`` is ``D^(4)(xi) h^4 w^2 (1 - w)^2 / 4!``, and ``w^2 (1 - w)^2 <= 1/16``. By
Bernstein's inequality ``|D^(4)| <= (pi / dt)^4 A`` with ``A = (1/n) sum_k |P_k|`` (the
phase history's mean modulus), so, with ``h <= dt / upsample``,

    |error| <= (pi / upsample)^4 / 384 * A          (per real and imaginary part),

``1.96e-4 A`` (-74 dB) at the default ``upsample = 6`` (8: ``6.2e-5 A``, -84 dB). That is
the worst case: a tone at the band edge read half-way between samples. For a tone of
``theta = 2 pi f h`` the error is ``theta^4 w^2 (1 - w)^2 / 24`` to leading order, so with
the read positions ``w`` uniform and the spectrum flat over the band the mean-square
error relative to the signal's power is

    E|error|^2 / E|D|^2 = (pi / upsample)^8 / (9 * 576 * 630),

-87.6 dB at ``upsample = 6`` (4: -73.5; 5: -81.3; 8: -97.6). The errors of the pulses are
uncorrelated across pixels, so an image of a distributed scene has the same signal-to-
error ratio against :func:`~sarmotion.imaging.exact_sum.exact_sum` (the same sum without
interpolation); ``tests/imaging/test_backprojection_accuracy.py`` holds the kernels to
``accuracy_db(upsample) - 3 dB`` (:func:`accuracy_db`) on GOTCHA and on simulated points.

Kernels. ``"numpy"`` is a plain vectorised reference (one pulse at a time, float64
throughout, :mod:`._bp_reference`); ``"numba"`` the compiled, parallel kernels
(:mod:`._bp_kernels`). Geometry and phases are float64 in the reference: at ``L = 10`` km
the carrier phase is ``~4e6`` rad. The default compiled kernel works on image tiles (64 x
64 pixels at most): per pulse and tile it computes the range to the tile's anchor pixel,
the table position and the carrier phase there in float64, and expands the range of every
other pixel of the tile about the anchor,

    |r - rho| - |r - rho_c| = R0 (sqrt(1 + N / R0^2) - 1),   N = |r - rho|^2 - |r - rho_c|^2,

a degree-4 series in ``N = Nx[column] + Ny[row]``. The phase of the term linear in ``N`` is
formed per column and per row in float64 and reduced exactly to a quarter cycle; only the
series' higher terms (a few quarter cycles at most, float32 rounding ``~1e-7`` of them) and
the table position (a few hundred samples from the anchor, float32 rounding ``< 3e-5`` of a
sample, an error below ``(pi / upsample) 3e-5 A``) are float32. The table holds ``c0`` to
``c3`` as complex64 (``6e-8`` relative, :class:`~._bp_table.TraceTable`). Each of these
bounds lies under the
interpolation's, and they are uncorrelated with it and with each other, so they add in
power to a small fraction of it. Before each call the
truncation error of the series and the largest offsets are bounded from the geometry;
when the tiles cannot be made small enough (antenna within a few hundred metres of the
image), a float64 compiled kernel evaluates the same pieces.

All quantities are SI: metres, seconds, hertz, m/s.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import ProgressCallback, Radar, Traces, Trajectory
from ..core.geometry import _as_velocity
from ._bp_common import DEFAULT_UPSAMPLE, Setup, kernel_constants, make_setup
from ._bp_kernels import STEPS, TILES, backproject_f32, run_numba_f64, tile_shape
from ._bp_reference import run_numpy
from ._bp_table import TABLES
from .grid import Image, ImageGrid, outline_columns

__all__ = ["accuracy_db", "backproject", "backproject_phase_history", "backproject_points"]


Kernel = Literal["numba", "numpy"]
Method = Literal["exact", "ffbp"]
Device = Literal["cpu", "cuda"]


def accuracy_db(upsample: int = DEFAULT_UPSAMPLE) -> float:
    """Signal-to-error ratio (dB) of the interpolation, flat band (module docstring).

    ``-10 log10((pi / upsample)^8 / (9 * 576 * 630))``.
    """
    return -10.0 * math.log10((math.pi / upsample) ** 8 / (9.0 * 576.0 * 630.0))


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


def _quarter_scale(st: Setup) -> float:
    return kernel_constants(st.sample_interval_s, st.carrier_hz, 1, 1).quarter_scale


def _run_numba(
    st: Setup, traces: Traces, grid: ImageGrid, progress: ProgressCallback | None
) -> tuple[NDArray[np.complex128], str]:
    """The compiled kernel: float32 tiles when the geometry allows, else float64."""
    tile = tile_shape(st.eff_positions, grid.x_m, grid.y_m, _quarter_scale(st))
    if tile is None:
        return run_numba_f64(st, grid, progress), "numba-float64"
    table = TABLES.get(traces, st.upsample)
    constants = kernel_constants(st.sample_interval_s, st.carrier_hz, traces.n_samples, table.n_up)
    # One parallel region unless progress is reported: each region ends in a barrier, and on
    # a busy machine a barrier waits for a descheduled thread.
    images = backproject_f32(
        table.values, st.eff_positions, st.ref_ranges, np.asarray(grid.x_m), np.asarray(grid.y_m),
        constants, table.n_up, tile, progress, STEPS if progress is not None else 1,
    )  # fmt: skip
    return images[0], "numba-float32"


def _run_ffbp(
    st: Setup,
    traces: Traces,
    grid: ImageGrid,
    alpha: float | None,
    progress: ProgressCallback | None,
    outline: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.complex128], str, dict]:
    """Fast factorised backprojection (:mod:`.ffbp`); ``outline``: pixels needed only there.

    Exact backprojection when the float32 kernel is out of bounds for this geometry or the
    factorisation would not save work. The float32 kernel on sub-grids (``exact_for``)
    computes the pixels the rotated path cannot resample.
    """
    from .ffbp import FfbpPulses, ffbp_values

    quarter_scale = _quarter_scale(st)
    if tile_shape(st.eff_positions, grid.x_m, grid.y_m, quarter_scale) is None:
        values, variant = _run_numba(st, traces, grid, progress)
        return values, variant, {}
    table = TABLES.get(traces, st.upsample)
    constants = kernel_constants(st.sample_interval_s, st.carrier_hz, traces.n_samples, table.n_up)

    def tile_for(pos: NDArray, u: NDArray, v: NDArray) -> tuple[int, int]:
        return tile_shape(pos, u, v, quarter_scale) or TILES[-1]

    def exact_for(x: NDArray, y: NDArray) -> NDArray[np.complex128]:
        return backproject_f32(
            table.values, st.eff_positions, st.ref_ranges, np.ascontiguousarray(x),
            np.ascontiguousarray(y), constants, table.n_up, tile_for(st.eff_positions, x, y),
            None, 1,
        )[0]  # fmt: skip

    pulses = FfbpPulses(
        table_values=table.values, positions=st.eff_positions, ref_ranges=st.ref_ranges,
        reference_point_m=traces.reference_point_m, constants=constants, n_up=table.n_up,
        carrier_hz=st.carrier_hz, bandwidth_hz=float(traces.radar.bandwidth_hz),
    )  # fmt: skip
    values, info = ffbp_values(
        pulses, np.asarray(grid.x_m), np.asarray(grid.y_m), tile_for=tile_for, alpha=alpha,
        progress=progress, exact_for=exact_for, outline_m=outline,
    )  # fmt: skip
    if values is None:
        values, variant = _run_numba(st, traces, grid, progress)
        return values, variant, info
    return values, "ffbp", info


def _backproject_cuda(traces: Traces, grid: ImageGrid, **keywords) -> Image:
    """``device="cuda"``: :func:`sarmotion.imaging.cuda.backproject_cuda`, imported lazily."""
    try:
        from . import cuda
    except ImportError as exc:
        raise RuntimeError(
            "device='cuda' needs the sarmotion[gpu] extra and an NVIDIA GPU"
        ) from exc
    return cuda.backproject_cuda(traces, grid, **keywords)


# ========================================================================= public API
def backproject(
    traces: Traces,
    grid: ImageGrid,
    *,
    velocity_mps: ArrayLike | None = None,
    upsample: int = DEFAULT_UPSAMPLE,
    kernel: Kernel = "numba",
    method: Method = "exact",
    ffbp_oversampling: float | None = None,
    progress: ProgressCallback | None = None,
    device: Device = "cpu",
    outline_m: ArrayLike | None = None,
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
        Fast-time upsampling factor (exact, by zero-padding the spectrum) before cubic
        Hermite interpolation: error at most ``(pi / upsample)^4 / 384`` of the traces'
        mean spectral modulus, signal-to-error :func:`accuracy_db` (87.6 dB at 6) against
        the sum without interpolation (module docstring).
    kernel : {"numba", "numpy"}
        ``"numba"``: compiled, parallel (the first call compiles, ~10 s, then is cached on
        disk). ``"numpy"``: the plain reference, slow but obviously correct.
    method : {"exact", "ffbp"}
        ``"exact"``: the sum over every pulse at every pixel. ``"ffbp"``: fast factorised
        backprojection (:mod:`sarmotion.imaging.ffbp`), for large images, several times
        faster and less accurate (its error budget is in the module). Needs
        ``kernel="numba"``.
    ffbp_oversampling : float, optional
        ``method="ffbp"``: oversampling of each sub-image's cross-range band, > 1, with the
        interpolation taps the error budget gives it; default: the cheapest of
        :data:`sarmotion.imaging.ffbp.ALPHAS` by the factorisation's cost model.
    progress : callable, optional
        Called as ``progress("backprojection", n_done, n_total)`` after each step of the
        computation (a block of pulses, a band of image rows, or a level of the FFBP tree;
        ``n_total`` is fixed for the call).
    device : {"cpu", "cuda"}
        ``"cuda"`` hands the call, with the same keywords, to
        ``sarmotion.imaging.cuda.backproject_cuda`` (the ``sarmotion[gpu]`` extra).
    outline_m : (4, 2) array_like, optional
        A ground parallelogram ``o, o + u, o + u + v, o + v`` (m) beyond which the traces
        hold no echo (a collection patch's halo, :class:`~sarmotion.collection.Patch`):
        the image is formed on the grid's pixels within its bounding box (on the rotated
        FFBP path, within its box in the look's frame) and every pixel outside it is 0.
        Inside it the values are those of the same method without it (FFBP's to its
        error budget). Default: every pixel.

    Returns
    -------
    Image
        Complex image, shape ``grid.shape``, with ``velocity_mps`` and metadata.
    """
    if outline_m is not None:
        return _within_outline(
            traces, grid, _as_outline(outline_m),
            velocity_mps=velocity_mps, upsample=upsample, kernel=kernel, method=method,
            ffbp_oversampling=ffbp_oversampling, progress=progress, device=device,
        )  # fmt: skip
    return _backproject(
        traces, grid, velocity_mps=velocity_mps, upsample=upsample, kernel=kernel,
        method=method, ffbp_oversampling=ffbp_oversampling, progress=progress, device=device,
    )  # fmt: skip


def _as_outline(outline_m: ArrayLike) -> NDArray[np.float64]:
    q = np.asarray(outline_m, dtype=np.float64)
    if q.shape != (4, 2) or not np.all(np.isfinite(q)):
        raise ValueError(f"outline_m must be 4 finite ground corners (4, 2) (m), got {q.shape}")
    u, v = q[1] - q[0], q[3] - q[0]
    if not np.allclose(q[2], q[0] + u + v, atol=1e-6 * (1.0 + np.abs(q).max())):
        raise ValueError("outline_m must be a parallelogram o, o + u, o + u + v, o + v")
    if abs(u[0] * v[1] - u[1] * v[0]) <= 0.0:
        raise ValueError("outline_m must have a positive area")
    return q


def _within_outline(
    traces: Traces, grid: ImageGrid, outline: NDArray[np.float64], **keywords
) -> Image:
    """:func:`backproject` with ``outline_m``: the pixels of its box formed, the rest 0."""
    lo, hi = outline_columns(grid, outline)
    full = lo <= hi
    values = np.zeros(grid.shape, np.complex128)
    meta: dict = {}
    vel = np.zeros(2)
    if full.any():  # the outline's box on the grid and a pixel either side
        ys = grid.y_m[full]
        rows, cols = grid.window(
            (float(lo[full].min()), float(ys[0]), float(hi[full].max()), float(ys[-1])), pad=1
        )
        sub = ImageGrid(x_m=grid.x_m[cols], y_m=grid.y_m[rows])
        image = _backproject(traces, sub, outline=outline, **keywords)
        values[rows, cols] = image.values
        meta = dict(image.metadata)
        vel = image.velocity_mps
        del image
    elif keywords["velocity_mps"] is not None:
        vel = _as_velocity(keywords["velocity_mps"], name="velocity_mps")[:2]
    # every row's pixels outside its interval to 0, in slices (no pixel-sized temporaries)
    x = np.asarray(grid.x_m)
    first = np.searchsorted(x, lo, side="left")
    stop = np.searchsorted(x, hi, side="right")
    for r in range(grid.shape[0]):
        if first[r] >= stop[r]:
            values[r] = 0.0
            continue
        values[r, : first[r]] = 0.0
        values[r, stop[r] :] = 0.0
    meta["outline_m"] = outline.tolist()
    return Image(values=values, grid=grid, velocity_mps=vel, metadata=meta)


def _backproject(
    traces: Traces,
    grid: ImageGrid,
    *,
    velocity_mps: ArrayLike | None,
    upsample: int,
    kernel: Kernel,
    method: Method,
    ffbp_oversampling: float | None,
    progress: ProgressCallback | None,
    device: Device,
    outline: NDArray[np.float64] | None = None,
) -> Image:
    """:func:`backproject` on every pixel of ``grid`` (``outline``: FFBP's clip, if any)."""
    if device == "cuda":
        return _backproject_cuda(
            traces, grid, velocity_mps=velocity_mps, upsample=upsample, kernel=kernel,
            method=method, ffbp_oversampling=ffbp_oversampling, progress=progress,
        )  # fmt: skip
    if device != "cpu":
        raise ValueError(f"device must be 'cpu' or 'cuda', got {device!r}")
    _check_grid(grid)
    _check_kernel(kernel)
    _check_method(method, kernel)
    alpha = None if ffbp_oversampling is None else float(ffbp_oversampling)
    if alpha is not None and not (math.isfinite(alpha) and alpha > 1.0):
        raise ValueError(f"ffbp_oversampling must be a number > 1, got {ffbp_oversampling!r}")
    st = make_setup(traces, velocity_mps, upsample)
    extra: dict = {}
    if method == "ffbp":
        values, variant, extra = _run_ffbp(st, traces, grid, alpha, progress, outline)
    elif kernel == "numba":
        values, variant = _run_numba(st, traces, grid, progress)
    else:
        variant = "numpy"
        px = np.broadcast_to(grid.x_m[None, :], grid.shape)
        py = np.broadcast_to(grid.y_m[:, None], grid.shape)
        values = run_numpy(st, px, py, progress)
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
    upsample: int = DEFAULT_UPSAMPLE,
) -> NDArray[np.complex128]:
    """The backprojection sum of :func:`backproject` at arbitrary ground points.

    Uses the numpy reference kernel (the same interpolation); meant for a few hundred
    points (profiles, checks).

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
    st = make_setup(traces, velocity_mps, upsample)
    return run_numpy(st, p[..., 0], p[..., 1], None)


def backproject_phase_history(
    phase_history: ArrayLike,
    *,
    frequencies_hz: ArrayLike,
    positions_m: ArrayLike,
    slow_times_s: ArrayLike,
    reference_point_m: ArrayLike,
    grid: ImageGrid,
    velocity_mps: ArrayLike | None = None,
    upsample: int = DEFAULT_UPSAMPLE,
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
