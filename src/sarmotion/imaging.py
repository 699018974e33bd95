"""Backprojection imaging (paper ``sect:image``): ``eq:image`` and its motion-compensated form.

The image at a ground point ``rho`` (``z = 0``) superposes the traces at the differential
travel time of that point (``eq:image``); with a velocity estimate ``u`` the point is moved
along ``rho + s u`` over the aperture (``eq:imagecompu``)::

    I_u(rho) = sum_j D_r(s_j, dtau_j) exp(+i omega_o dtau_j),
    dtau_j   = tau(s_j, rho + s_j u) - tau(s_j, rho_o),   tau(s, p) = 2 |r(s) - p| / c.

``D_r`` are the complex-baseband traces of :class:`~sarmotion.traces.Traces`: a point at
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
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .constants import C
from .geometry import Trajectory, _as_velocity, as_point, look_geometry
from .radar import Radar
from .spectral import to_fast_time, to_frequency
from .traces import Traces

__all__ = [
    "ImageGrid",
    "Image",
    "Resolution",
    "backproject",
    "backproject_phase_history",
    "backproject_points",
    "resolution",
    "width_3db",
]

Kernel = Literal["numba", "numpy"]
ProgressCallback = Callable[[int, int], Any]

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


# =============================================================================== grid
def _axis(values: ArrayLike, name: str) -> NDArray[np.float64]:
    a = np.array(values, dtype=np.float64, copy=True)
    if a.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array (m), got shape {a.shape}")
    if a.size < 2:
        raise ValueError(f"{name} must hold at least 2 samples, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    step = np.diff(a)
    if np.any(step <= 0):
        raise ValueError(f"{name} must be strictly increasing")
    mean = (a[-1] - a[0]) / (a.size - 1)
    if np.max(np.abs(step - mean)) > 1e-6 * mean:
        raise ValueError(
            f"{name} must be uniformly spaced, got steps from {step.min():g} to {step.max():g} m"
        )
    a.setflags(write=False)
    return a


def _positive(value: float, name: str) -> float:
    v = float(value)
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a positive number, got {value!r}")
    return v


@dataclass(frozen=True, kw_only=True, eq=False)
class ImageGrid:
    """A uniform rectangular grid of image points on the ground ``z = 0``.

    Pixel ``(iy, ix)`` is the point ``(x_m[ix], y_m[iy], 0)``; images are ``(ny, nx)``
    arrays, row index along ``y``.

    Parameters
    ----------
    x_m : (nx,) array_like
        Increasing, uniformly spaced x coordinates (m), ``nx >= 2``.
    y_m : (ny,) array_like
        Increasing, uniformly spaced y coordinates (m), ``ny >= 2``.
    """

    x_m: NDArray[np.float64]
    y_m: NDArray[np.float64]

    def __post_init__(self) -> None:
        object.__setattr__(self, "x_m", _axis(self.x_m, "x_m"))
        object.__setattr__(self, "y_m", _axis(self.y_m, "y_m"))

    def __repr__(self) -> str:
        dx, dy = self.spacing_m
        return (
            f"ImageGrid(x: {self.x_m[0]:g}..{self.x_m[-1]:g} m step {dx:g}, "
            f"y: {self.y_m[0]:g}..{self.y_m[-1]:g} m step {dy:g}, shape {self.shape})"
        )

    # ---------------------------------------------------------- constructors
    @classmethod
    def square(
        cls,
        *,
        centre_m: ArrayLike = (0.0, 0.0),
        size_m: float = 100.0,
        spacing_m: float = 0.25,
    ) -> ImageGrid:
        """Square grid of ``n = round(size_m / spacing_m)`` points a side around a centre.

        Coordinates are ``centre + (k - n // 2) * spacing_m``, ``k = 0..n-1``, so the centre
        is a pixel (index ``n // 2``), as the fast-time axis puts ``t = 0`` at ``n // 2``.

        Parameters
        ----------
        centre_m : (2,) array_like
            Grid centre ``(x, y)`` (m).
        size_m : float
            Side length (m).
        spacing_m : float
            Pixel spacing (m).
        """
        c = np.asarray(centre_m, dtype=np.float64)
        if c.shape != (2,) or not np.all(np.isfinite(c)):
            raise ValueError(f"centre_m must be a finite (x, y) pair (m), got {centre_m!r}")
        size = _positive(size_m, "size_m")
        step = _positive(spacing_m, "spacing_m")
        n = int(round(size / step))
        if n < 2:
            raise ValueError(
                f"size_m / spacing_m must give at least 2 pixels a side, got {size / step:g}"
            )
        k = np.arange(n, dtype=np.float64) - n // 2
        return cls(x_m=c[0] + k * step, y_m=c[1] + k * step)

    @classmethod
    def from_extent(
        cls, *, x_range_m: ArrayLike, y_range_m: ArrayLike, spacing_m: float
    ) -> ImageGrid:
        """Grid from ``x0`` to ``x1`` and ``y0`` to ``y1`` in steps of ``spacing_m``.

        The first point of each axis is ``x0`` (``y0``); the last is the largest
        ``x0 + k * spacing_m <= x1`` (within 1e-9 of a step, so a divisible range includes
        both ends).

        Parameters
        ----------
        x_range_m, y_range_m : (2,) array_like
            ``(start, stop)`` of each axis (m), ``start < stop``.
        spacing_m : float
            Pixel spacing (m).
        """
        step = _positive(spacing_m, "spacing_m")
        axes = []
        for name, rng in (("x_range_m", x_range_m), ("y_range_m", y_range_m)):
            r = np.asarray(rng, dtype=np.float64)
            if r.shape != (2,) or not np.all(np.isfinite(r)) or not r[1] > r[0]:
                raise ValueError(f"{name} must be a finite (start, stop) with start < stop, "
                                 f"got {rng!r}")
            n = int(np.floor((r[1] - r[0]) / step + 1e-9)) + 1
            if n < 2:
                raise ValueError(
                    f"{name} spans less than one spacing_m ({step:g} m): got {r[1] - r[0]:g} m"
                )
            axes.append(r[0] + np.arange(n, dtype=np.float64) * step)
        return cls(x_m=axes[0], y_m=axes[1])

    # ----------------------------------------------------------------- props
    @property
    def shape(self) -> tuple[int, int]:
        """Image shape ``(ny, nx)``."""
        return (int(self.y_m.size), int(self.x_m.size))

    @property
    def spacing_m(self) -> tuple[float, float]:
        """Pixel spacing ``(dx, dy)`` (m)."""
        nx, ny = self.x_m.size, self.y_m.size
        return (
            float((self.x_m[-1] - self.x_m[0]) / (nx - 1)),
            float((self.y_m[-1] - self.y_m[0]) / (ny - 1)),
        )

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(left, right, bottom, top)`` pixel-edge bounds (m), for ``imshow(origin="lower")``."""
        dx, dy = self.spacing_m
        return (
            float(self.x_m[0] - dx / 2),
            float(self.x_m[-1] + dx / 2),
            float(self.y_m[0] - dy / 2),
            float(self.y_m[-1] + dy / 2),
        )

    def points_m(self) -> NDArray[np.float64]:
        """All pixel positions ``(x, y, 0)`` (m), shape (ny, nx, 3)."""
        ny, nx = self.shape
        p = np.zeros((ny, nx, 3))
        p[..., 0] = self.x_m[None, :]
        p[..., 1] = self.y_m[:, None]
        return p

    def nearest_index(self, point_m: ArrayLike) -> tuple[int, int]:
        """Index ``(iy, ix)`` of the pixel nearest to a ground point.

        Parameters
        ----------
        point_m : (2,) or (3,) array_like
            Point (m); ``z`` is ignored.

        Raises
        ------
        ValueError
            If the point lies outside :attr:`extent`.
        """
        p = as_point(point_m, name="point_m")
        left, right, bottom, top = self.extent
        if not (left <= p[0] <= right and bottom <= p[1] <= top):
            raise ValueError(
                f"point_m ({p[0]:g}, {p[1]:g}) lies outside the grid extent "
                f"x [{left:g}, {right:g}], y [{bottom:g}, {top:g}] m"
            )
        dx, dy = self.spacing_m
        ix = int(np.clip(np.rint((p[0] - self.x_m[0]) / dx), 0, self.x_m.size - 1))
        iy = int(np.clip(np.rint((p[1] - self.y_m[0]) / dy), 0, self.y_m.size - 1))
        return iy, ix

    def position(self, iy: float, ix: float) -> tuple[float, float]:
        """Ground position ``(x, y)`` (m) of pixel ``(iy, ix)``; fractional indices allowed."""
        dx, dy = self.spacing_m
        return (float(self.x_m[0] + ix * dx), float(self.y_m[0] + iy * dy))


# ============================================================================== image
@dataclass(frozen=True, kw_only=True, eq=False)
class Image:
    """A complex image on an :class:`ImageGrid`.

    Parameters
    ----------
    values : (ny, nx) array_like
        Complex image values (stored complex128).
    grid : ImageGrid
        The pixel positions; ``grid.shape`` must equal ``values.shape``.
    velocity_mps : (2,) array_like
        Ground velocity ``u`` (m/s) compensated in forming the image (``eq:imagecompu``);
        zeros for the stationary image ``eq:image``.
    metadata : dict
        Provenance (algorithm, kernel, upsampling, ...); JSON-serialisable values.
    """

    values: NDArray[np.complex128]
    grid: ImageGrid
    velocity_mps: NDArray[np.float64] = field(default_factory=lambda: np.zeros(2))
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.grid, ImageGrid):
            raise TypeError(f"grid must be an ImageGrid, got {type(self.grid).__name__}")
        v = np.asarray(self.values)
        if v.shape != self.grid.shape:
            raise ValueError(
                f"values must have the grid shape (ny, nx) = {self.grid.shape}, got {v.shape}"
            )
        v = v.astype(np.complex128)
        if not np.all(np.isfinite(v)):
            raise ValueError("values contains NaN or infinite entries")
        u = np.asarray(self.velocity_mps, dtype=np.float64)
        if u.shape != (2,) or not np.all(np.isfinite(u)):
            raise ValueError(f"velocity_mps must be a finite (ux, uy) pair (m/s), got {u}")
        object.__setattr__(self, "values", v)
        object.__setattr__(self, "velocity_mps", u)
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def magnitude(self) -> NDArray[np.float64]:
        """``|I|``, shape (ny, nx)."""
        return np.abs(self.values)

    def magnitude_db(self, *, floor_db: float = -120.0) -> NDArray[np.float64]:
        """``20 log10(|I| / max |I|)`` (dB), clipped below at ``floor_db``, shape (ny, nx)."""
        if not (np.isfinite(floor_db) and floor_db < 0):
            raise ValueError(f"floor_db must be a negative number (dB), got {floor_db!r}")
        mag = self.magnitude
        peak = float(mag.max())
        if peak == 0.0:
            return np.full(mag.shape, float(floor_db))
        with np.errstate(divide="ignore"):
            db = 20.0 * np.log10(mag / peak)
        return np.maximum(db, floor_db)

    def peak(self, *, refine: bool = False) -> tuple[float, float, complex]:
        """Brightest pixel: ``(x_m, y_m, value)``.

        Parameters
        ----------
        refine : bool
            Refine the position to sub-pixel accuracy by a parabola through ``|I|`` at the
            peak and its two neighbours, separately along x and y (no refinement at an
            edge). ``value`` is always the complex value at the brightest pixel.
        """
        mag = self.magnitude
        iy, ix = np.unravel_index(int(np.argmax(mag)), mag.shape)
        fy, fx = (_parabolic(mag, iy, ix) if refine else (float(iy), float(ix)))
        x, y = self.grid.position(fy, fx)
        return x, y, complex(self.values[iy, ix])

    def peaks(
        self, n: int, *, min_separation_m: float, refine: bool = False
    ) -> list[tuple[float, float, complex]]:
        """Up to ``n`` bright points, brightest first, at least ``min_separation_m`` apart.

        Candidates are the local maxima of ``|I|`` (not smaller than any of their 8
        neighbours); they are taken in decreasing ``|I|`` and kept when farther than
        ``min_separation_m`` from every point kept so far.

        Parameters
        ----------
        n : int
            Maximum number of points.
        min_separation_m : float
            Minimum distance between returned points (m).
        refine : bool
            Parabolic sub-pixel refinement, as in :meth:`peak`.

        Returns
        -------
        list of (x_m, y_m, value)
        """
        if not (isinstance(n, (int, np.integer)) and n >= 1):
            raise ValueError(f"n must be a positive integer, got {n!r}")
        if not (np.isfinite(min_separation_m) and min_separation_m >= 0):
            raise ValueError(f"min_separation_m must be >= 0 (m), got {min_separation_m!r}")
        from scipy.ndimage import maximum_filter

        mag = self.magnitude
        local = (mag == maximum_filter(mag, size=3, mode="nearest")) & (mag > 0)
        iy, ix = np.nonzero(local)
        order = np.argsort(-mag[iy, ix], kind="stable")
        kept: list[tuple[float, float, complex]] = []
        for k in order:
            fy, fx = (_parabolic(mag, iy[k], ix[k]) if refine else (float(iy[k]), float(ix[k])))
            x, y = self.grid.position(fy, fx)
            if all(math.hypot(x - a, y - b) >= min_separation_m for a, b, _ in kept):
                kept.append((x, y, complex(self.values[iy[k], ix[k]])))
                if len(kept) == n:
                    break
        return kept


def _parabolic(mag: NDArray[np.float64], iy: int, ix: int) -> tuple[float, float]:
    """Sub-pixel ``(iy, ix)`` of a maximum by 3-point parabolas along each axis."""

    def offset(a: float, b: float, c: float) -> float:
        den = a - 2.0 * b + c
        return 0.0 if den >= 0 else float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))

    ny, nx = mag.shape
    fy, fx = float(iy), float(ix)
    if 0 < ix < nx - 1:
        fx += offset(mag[iy, ix - 1], mag[iy, ix], mag[iy, ix + 1])
    if 0 < iy < ny - 1:
        fy += offset(mag[iy - 1, ix], mag[iy, ix], mag[iy + 1, ix])
    return fy, fx


# ===================================================================== preparation
def _upsample_fast_time(data: ArrayLike, factor: int) -> NDArray[np.complex128]:
    """Exact band-limited upsampling of baseband traces by zero-padding their spectrum.

    The traces are ``D(t) = (1/n) sum_k P_k exp(2i pi (k - n//2) df t)`` sampled at
    ``t_l = (l - n//2) dt`` (:mod:`sarmotion.spectral`). The result samples the same
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
    xs, n, ax, c2, ref, idx_scale, idx_offset, idx_max, quarter_scale, base, obuf, wbuf, cbuf,
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
    table, pulse_stride, ant_x, ant_y, ant_z2, ref, x, y, idx_scale, idx_offset, idx_max,
    quarter_scale, out_re, out_im, ty0, ty1, tile_rows, tile_cols,
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
                _row_geometry(xs, n, ant_x[j], c2, ref[j], idx_scale, idx_offset, idx_max,
                              quarter_scale, base, obuf, wbuf, cbuf, sbuf)
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
    saves the shift copies of :mod:`sarmotion.spectral` (same result to rounding), and the
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
                progress(step, total)
    return out_re + 1j * out_im


def _run_numpy(
    st: _Setup, px: NDArray, py: NDArray, progress: ProgressCallback | None
) -> NDArray[np.complex128]:
    n_pulses = st.data.shape[0]
    out = np.zeros(px.shape, dtype=np.complex128)
    for j0, j1 in _blocks(n_pulses):
        _accumulate_numpy(st, j0, j1, px, py, out)
        if progress is not None:
            progress(j1, n_pulses)
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
        Called as ``progress(n_done, n_total)`` after each step of the computation (a
        block of pulses, or a band of image rows; ``n_total`` is fixed for the call).

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
    :func:`sarmotion.spectral.to_fast_time` (the carrier is the frequency of bin
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


# ===================================================================== resolution
@dataclass(frozen=True, kw_only=True, eq=False)
class Resolution:
    """Theoretical resolution of a stationary point (paper ``sect:scales``).

    Attributes
    ----------
    slant_range_m : float
        ``c / (2 B)`` (m).
    ground_range_m : float
        ``c / (2 B) / cos(elevation)`` (m), along :attr:`range_direction`.
    cross_range_m : float
        ``lambda_o L / (2 a)`` (m), along :attr:`cross_range_direction`.
    range_direction : (2,) ndarray
        Unit ground vector: the ground projection of ``m_o``, normalised.
    cross_range_direction : (2,) ndarray
        Unit ground vector perpendicular to :attr:`range_direction` (rotated +90 deg).
    elevation_rad : float
        Elevation of the antenna at ``s = 0`` seen from the point (rad).
    range_m : float
        ``L = |r(0) - rho|`` (m).
    aperture_m : float
        Aperture length ``a`` (m): the path flown from the first to the last pulse.
    wavelength_m : float
        ``lambda_o`` (m).
    """

    slant_range_m: float
    ground_range_m: float
    cross_range_m: float
    range_direction: NDArray[np.float64]
    cross_range_direction: NDArray[np.float64]
    elevation_rad: float
    range_m: float
    aperture_m: float
    wavelength_m: float


def resolution(traces: Traces, *, point_m: ArrayLike | None = None) -> Resolution:
    """Slant-range, ground-range and cross-range resolution of a stationary point.

    Parameters
    ----------
    traces : Traces
        The acquisition (radar bandwidth and carrier, trajectory).
    point_m : (2,) or (3,) array_like, optional
        The point ``rho`` (m); defaults to the reference point ``rho_o``.

    Returns
    -------
    Resolution
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    rho = traces.reference_point_m if point_m is None else as_point(point_m, name="point_m")
    geo = look_geometry(traces.trajectory, rho)
    b = geo.ground_m_o
    nb = float(np.linalg.norm(b))
    if nb < 1e-9:
        raise ValueError("the antenna is above the point (zenith look): ground range undefined")
    rng_dir = b / nb
    slant = float(traces.radar.range_resolution_m)
    a = traces.trajectory.aperture_length_m
    lam = float(traces.radar.wavelength_m)
    return Resolution(
        slant_range_m=slant,
        ground_range_m=slant / math.cos(geo.elevation_rad),
        cross_range_m=lam * geo.range_m / (2.0 * a),
        range_direction=rng_dir,
        cross_range_direction=np.array([-rng_dir[1], rng_dir[0]]),
        elevation_rad=geo.elevation_rad,
        range_m=geo.range_m,
        aperture_m=a,
        wavelength_m=lam,
    )


def width_3db(
    image: Image,
    point_m: ArrayLike,
    direction: ArrayLike,
    *,
    traces: Traces | None = None,
    half_length_m: float | None = None,
    n_points: int = 801,
) -> float:
    """Half-power (-3 dB) width (m) of the main lobe of ``|I|`` along a ground direction.

    A profile of ``|I|`` is taken on the line ``point + l * direction``,
    ``|l| <= half_length_m``, at ``n_points`` points. With ``traces`` it is computed by
    backprojecting on the line itself (:func:`backproject_points`, same velocity and
    upsampling as the image: exact); without, by cubic-spline interpolation of ``|I|``
    between pixels (accurate when the pixels sample the main lobe finely, e.g. >= 4
    pixels per width).
    The width is the distance between the two points, on either side of the profile's
    maximum, where ``|I|`` falls to ``max / sqrt(2)``, located by linear interpolation.

    Parameters
    ----------
    image : Image
        The image (its grid, velocity and metadata are used).
    point_m : (2,) array_like
        A point on the line (m), near the peak.
    direction : (2,) array_like
        Ground direction (normalised internally).
    traces : Traces, optional
        The traces the image was formed from, for an exact profile.
    half_length_m : float, optional
        Half length of the profile (m); default twice the coarser theoretical resolution
        (:func:`resolution`) with ``traces``, else 20 pixels.
    n_points : int
        Profile samples.

    Returns
    -------
    float
        The -3 dB width (m).

    Raises
    ------
    ValueError
        If the profile does not fall below -3 dB on both sides of its maximum.
    """
    if not isinstance(image, Image):
        raise TypeError(f"image must be an Image, got {type(image).__name__}")
    p = as_point(point_m, name="point_m")[:2]
    d = np.asarray(direction, dtype=np.float64)
    if d.shape != (2,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
        raise ValueError(f"direction must be a finite non-zero (2,) vector, got {direction!r}")
    d = d / np.linalg.norm(d)
    if not (isinstance(n_points, (int, np.integer)) and n_points >= 11):
        raise ValueError(f"n_points must be an integer >= 11, got {n_points!r}")
    if half_length_m is None:
        if traces is not None:
            res = resolution(traces, point_m=p)
            half_length_m = 2.0 * max(res.ground_range_m, res.cross_range_m)
        else:
            half_length_m = 20.0 * max(image.grid.spacing_m)
    half = _positive(half_length_m, "half_length_m")
    ell = np.linspace(-half, half, int(n_points))
    line = p[None, :] + ell[:, None] * d[None, :]
    if traces is not None:
        prof = np.abs(
            backproject_points(
                traces,
                line,
                velocity_mps=image.velocity_mps,
                upsample=int(image.metadata.get("upsample", 8)),
            )
        )
    else:
        from scipy.ndimage import map_coordinates

        g = image.grid
        dx, dy = g.spacing_m
        coords = np.vstack([(line[:, 1] - g.y_m[0]) / dy, (line[:, 0] - g.x_m[0]) / dx])
        inside = (
            (coords[0] >= 0) & (coords[0] <= g.shape[0] - 1)
            & (coords[1] >= 0) & (coords[1] <= g.shape[1] - 1)
        )  # fmt: skip
        if not np.all(inside):
            raise ValueError("the profile leaves the image grid: reduce half_length_m")
        # |I|, not I: the complex image carries the carrier phase exp(2i k cos(el) range),
        # with a period (lambda / 2 / cos(el), ~2 cm) no pixel grid samples.
        prof = map_coordinates(image.magnitude, coords, order=3, mode="nearest")
    return _half_power_width(ell, prof)


def _half_power_width(ell: NDArray[np.float64], prof: NDArray[np.float64]) -> float:
    """Width between the ``max / sqrt(2)`` crossings around the maximum of ``prof``."""
    k = int(np.argmax(prof))
    level = prof[k] / math.sqrt(2.0)
    if prof[k] == 0:
        raise ValueError("the profile is identically zero")
    below = np.nonzero(prof[:k] < level)[0]
    above = np.nonzero(prof[k:] < level)[0]
    if below.size == 0 or above.size == 0:
        raise ValueError(
            "the profile does not fall to -3 dB on both sides of its maximum: "
            "increase half_length_m"
        )
    i0 = below[-1]  # prof[i0] < level <= prof[i0 + 1]
    i1 = k + above[0]  # prof[i1 - 1] >= level > prof[i1]
    left = ell[i0] + (level - prof[i0]) / (prof[i0 + 1] - prof[i0]) * (ell[i0 + 1] - ell[i0])
    right = ell[i1 - 1] + (prof[i1 - 1] - level) / (prof[i1 - 1] - prof[i1]) * (
        ell[i1] - ell[i1 - 1]
    )
    return float(right - left)
