"""Resolution theory of the SAR image: range and cross-range cells, 3 dB widths."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import positive as _positive
from ..core import Traces, as_point
from ..core.acquisition import Acquisition, Resolution
from ._bp_common import DEFAULT_UPSAMPLE
from .backprojection import backproject_points
from .grid import Image

__all__ = ["Resolution", "resolution", "width_3db"]


# ===================================================================== resolution
def resolution(traces: Traces | Acquisition, *, point_m: ArrayLike | None = None) -> Resolution:
    """Slant-range, ground-range and cross-range resolution of a stationary point.

    At the reference point it is the acquisition's, computed once
    (:attr:`~sarmotion.core.Acquisition.resolution`).

    Parameters
    ----------
    traces : Traces or Acquisition
        The acquisition (radar bandwidth and carrier, trajectory).
    point_m : (2,) or (3,) array_like, optional
        The point ``rho`` (m); defaults to the reference point ``rho_o``.

    Returns
    -------
    Resolution
    """
    if isinstance(traces, Traces):
        traces = traces.acquisition
    if not isinstance(traces, Acquisition):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    return traces.resolution if point_m is None else traces.resolution_at(point_m)


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
                upsample=int(image.metadata.get("upsample", DEFAULT_UPSAMPLE)),
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
