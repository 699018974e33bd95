"""Image grids and complex images: pixel axes in metres, magnitudes, peaks."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import positive as _positive
from ..core import C, Traces, as_point
from .peaks import find_peaks, parabolic_peak

__all__ = [
    "ImageGrid",
    "Image",
    "default_scene_size_m",
    "in_outline",
    "outline_columns",
    "scene_grid",
]


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
                raise ValueError(
                    f"{name} must be a finite (start, stop) with start < stop, got {rng!r}"
                )
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

    def window(
        self, box_m: tuple[float, float, float, float], *, pad: int = 0
    ) -> tuple[slice, slice]:
        """Row and column slices of the pixels within ``box_m`` ``(x0, y0, x1, y1)`` (m).

        Widened by ``pad`` pixels either side where the grid has them, and to at least
        two pixels a side (a grid's least): a box under two pixels, or beside the grid,
        gives the two nearest its centre.
        """
        x0, y0, x1, y1 = box_m

        def axis(v: NDArray[np.float64], lo: float, hi: float) -> slice:
            i = np.flatnonzero((v >= lo) & (v <= hi))
            if i.size == 0:
                j = int(np.clip(np.searchsorted(v, 0.5 * (lo + hi)), 1, v.size - 1))
                a, b = j - 1, j + 1
            else:
                a, b = max(0, int(i[0]) - pad), min(v.size, int(i[-1]) + 1 + pad)
            if b - a < 2:
                a, b = (a, a + 2) if a + 2 <= v.size else (b - 2, b)
            return slice(a, b)

        return axis(self.y_m, y0, y1), axis(self.x_m, x0, x1)


# ============================================================================== image
@numba.njit(parallel=True, cache=True)
def _all_finite(flat: NDArray[np.float64]) -> bool:  # pragma: no cover - compiled
    """Whether every entry is finite (``x - x`` is 0 for finite ``x``, NaN otherwise).

    One pass without temporaries, on the threads: an image's check costs a fraction of
    ``numpy.isfinite(v).all()`` (which writes a boolean image first).
    """
    bad = 0
    for i in numba.prange(flat.size):
        x = flat[i]
        if x - x != 0.0:
            bad += 1
    return bad == 0


def all_finite(values: NDArray) -> bool:
    """Whether every entry of a float or complex array is finite (one compiled pass)."""
    v = np.ascontiguousarray(values)
    if v.dtype.kind == "c":
        v = v.view(v.real.dtype)
    return bool(_all_finite(v.reshape(-1).astype(np.float64, copy=False)))


#: True while :func:`checked_values` is active: an :class:`Image` then takes its values
#: as already checked finite by their producer.
_CHECKED: ContextVar[bool] = ContextVar("sarmotion_image_values_checked", default=False)


@contextlib.contextmanager
def checked_values() -> Iterator[None]:
    """Images made inside skip the finite check of their values: the producer made it.

    For an image former that checks its values piece by piece while it forms them (the
    GPU's, band by band as each reaches host memory, :func:`all_finite`).
    """
    token = _CHECKED.set(True)
    try:
        yield
    finally:
        _CHECKED.reset(token)


@dataclass(frozen=True, kw_only=True, eq=False)
class Image:
    """A complex image on an :class:`ImageGrid`.

    Parameters
    ----------
    values : (ny, nx) array_like
        Complex image values, stored complex128: a complex128 array is kept as given, not
        copied (as :func:`numpy.asarray`).
    grid : ImageGrid
        The pixel positions; ``grid.shape`` must equal ``values.shape``.
    velocity_mps : (2,) array_like
        Ground velocity ``u`` (m/s) compensated in forming the image (``eq:imagecompu``);
        zeros for the stationary image ``eq:image``.
    metadata : dict
        Provenance (algorithm, kernel, upsampling, ...); JSON-serialisable values.

    Raises
    ------
    ValueError
        Values of another shape than the grid's, or not all finite (checked unless the
        image is made inside :func:`checked_values`, by a producer that checked them).
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
        v = np.asarray(v, dtype=np.complex128)  # not copied when complex128 already
        if not _CHECKED.get() and not all_finite(v):
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
        fy, fx = parabolic_peak(mag, iy, ix) if refine else (float(iy), float(ix))
        x, y = self.grid.position(fy, fx)
        return x, y, complex(self.values[iy, ix])

    def peaks(
        self, n: int, *, min_separation_m: float, refine: bool = False
    ) -> list[tuple[float, float, complex]]:
        """Up to ``n`` bright points, brightest first (:func:`~sarmotion.imaging.find_peaks`).

        Parameters
        ----------
        n : int
            Maximum number of points.
        min_separation_m : float
            Non-maximum suppression radius (m).
        refine : bool
            Parabolic sub-pixel refinement, as in :meth:`peak`.

        Returns
        -------
        list of (x_m, y_m, value)
            ``value`` is the complex value at the nearest pixel.
        """
        found = find_peaks(
            self.values,
            x_m=self.grid.x_m,
            y_m=self.grid.y_m,
            threshold_db=-np.inf,
            min_separation_m=min_separation_m,
            max_peaks=n,
            refine=refine,
        )
        out = []
        for x, y, _ in found:
            iy, ix = self.grid.nearest_index((x, y))
            out.append((float(x), float(y), complex(self.values[iy, ix])))
        return out


def default_scene_size_m(traces: Traces) -> float:
    """Side of the default square scene image (m): 0.6 of the ground-range window, <= 100 m.

    The fast-time window of the data covers ``c / (2 df)`` of slant range (``df`` the
    frequency step of the phase history); its ground projection bounds the unambiguous
    scene. The factor 0.6 keeps the image's half-diagonal inside it.
    """
    span = 0.5 * C / traces.radar.frequency_step_hz
    ground = span / np.cos(traces.geometry.elevation_rad)
    return float(min(100.0, 0.6 * ground))


def scene_grid(
    traces: Traces, *, size_m: float | None = None, spacing_m: float = 0.25
) -> ImageGrid:
    """Square grid around the reference point; ``size_m`` defaults to :func:`default_scene_size_m`.

    Raises ``ValueError`` when the grid would exceed 4096 pixels a side.
    """
    size = default_scene_size_m(traces) if size_m is None else _positive(size_m, "size_m")
    spacing = _positive(spacing_m, "spacing_m")
    if size / spacing > 4096:
        raise ValueError(
            f"size_m / spacing_m must give <= 4096 pixels a side, got {size} m / {spacing} m"
        )
    if size > 2e6:  # the inputs' range envelope: antennas within 1000 km of the scene
        raise ValueError(f"size_m must be at most 2e+06 m (1000 km either side), got {size:g} m")
    centre = tuple(float(v) for v in traces.reference_point_m[:2])
    return ImageGrid.square(centre_m=centre, size_m=size, spacing_m=spacing)


def in_outline(points_m: ArrayLike, outline_m: ArrayLike) -> NDArray[np.bool_]:
    """Whether ground points ``(..., 2)`` lie in the parallelogram ``outline_m`` (sides in)."""
    q = np.asarray(outline_m, dtype=np.float64)
    p = np.asarray(points_m, dtype=np.float64)[..., :2] - q[0]
    u, v = q[1] - q[0], q[3] - q[0]
    det = u[0] * v[1] - u[1] * v[0]
    a = (p[..., 0] * v[1] - p[..., 1] * v[0]) / det
    b = (u[0] * p[..., 1] - u[1] * p[..., 0]) / det
    tol = 1e-9
    return (a >= -tol) & (a <= 1.0 + tol) & (b >= -tol) & (b <= 1.0 + tol)


def outline_columns(
    grid: ImageGrid, outline_m: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each grid row's ``x`` interval ``[lo, hi]`` (m) within the parallelogram ``outline_m``.

    :func:`in_outline`'s test along each row: ``a`` and ``b`` are linear in ``x``, so each of
    ``0 <= a <= 1``, ``0 <= b <= 1`` bounds ``x`` on one side or holds for every ``x`` or
    none; an empty row has ``lo > hi``.
    """
    q = np.asarray(outline_m, dtype=np.float64)
    u, v = q[1] - q[0], q[3] - q[0]
    det = u[0] * v[1] - u[1] * v[0]
    dy = np.asarray(grid.y_m, np.float64) - q[0][1]
    lo = np.full(dy.shape, -np.inf)
    hi = np.full(dy.shape, np.inf)
    tol = 1e-9
    # a = (dx v1 - dy v0) / det, b = (u0 dy - u1 dx) / det: each c0 + c1 dx
    for c1, c0 in ((v[1] / det, -dy * v[0] / det), (-u[1] / det, u[0] * dy / det)):
        if c1 == 0.0:
            ok = (c0 >= -tol) & (c0 <= 1.0 + tol)
            lo = np.where(ok, lo, np.inf)
            continue
        x_a, x_b = (-tol - c0) / c1, (1.0 + tol - c0) / c1
        lo = np.maximum(lo, np.minimum(x_a, x_b))
        hi = np.minimum(hi, np.maximum(x_a, x_b))
    return lo + q[0][0], hi + q[0][0]
