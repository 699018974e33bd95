"""Bright points of an image: one peak finder for every layer.

Candidates are local maxima of ``|I|`` within ``threshold_db`` of the brightest pixel,
brightest first, up to ``max_peaks``; a position may be refined to sub-pixel accuracy by
3-point parabolas of ``|I|`` along x and y. Two rules suppress the non-maxima:

``"distance"``
    maxima over the 8 neighbours, kept when farther than ``min_separation_m`` from every
    point kept so far (greedy, Euclidean): close distinct targets are all listed;
``"window"``
    maxima over a square of half-side ``min_separation_m``: a conservative rule that
    lists one point per resolution-sized square (the stationary candidates of the
    separation, where a sidelobe taken for a target costs a filter).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import maximum_filter

__all__ = ["find_peaks", "parabolic_peak"]


def find_peaks(
    values: ArrayLike,
    *,
    x_m: ArrayLike,
    y_m: ArrayLike,
    threshold_db: float = -25.0,
    min_separation_m: float = 1.0,
    max_peaks: int = 100,
    refine: bool = False,
    suppression: str = "distance",
) -> NDArray[np.float64]:
    """Local maxima of ``|values|`` above ``threshold_db`` re the image peak.

    Parameters
    ----------
    values : (ny, nx) array_like
        Complex or real image.
    x_m, y_m : (nx,), (ny,) array_like
        Pixel-centre coordinates (m), uniform and increasing.
    threshold_db : float
        Keep peaks within this many dB of the brightest (<= 0, dB; ``-inf`` keeps all).
    min_separation_m : float
        Least distance between two returned peaks (m); about one resolution cell.
    max_peaks : int
        Cap on the number of peaks returned (brightest first).
    refine : bool
        Refine each position by :func:`parabolic_peak` (no refinement at an edge).
    suppression : {"distance", "window"}
        Non-maximum suppression rule (module docstring).

    Returns
    -------
    (k, 3) ndarray
        Peak positions (m) with ``z = 0``, brightest first.
    """
    a = np.abs(np.asarray(values))
    x = np.asarray(x_m, dtype=np.float64)
    y = np.asarray(y_m, dtype=np.float64)
    if a.ndim != 2 or a.shape != (y.size, x.size):
        raise ValueError(f"values must have shape (ny, nx) = ({y.size}, {x.size}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("values contain NaN or infinite entries")
    if np.isnan(threshold_db) or threshold_db > 0:
        raise ValueError(f"threshold_db must be <= 0 (dB re the peak), got {threshold_db}")
    if not (np.isfinite(min_separation_m) and min_separation_m >= 0):
        raise ValueError(f"min_separation_m must be >= 0 (m), got {min_separation_m!r}")
    if isinstance(max_peaks, bool) or not isinstance(max_peaks, int | np.integer) or max_peaks < 1:
        raise ValueError(f"max_peaks must be a positive integer, got {max_peaks!r}")
    peak = a.max()
    if peak == 0:
        return np.zeros((0, 3))
    dx = (x[-1] - x[0]) / max(x.size - 1, 1)
    dy = (y[-1] - y[0]) / max(y.size - 1, 1)
    if suppression == "window":
        rx = max(1, int(round(min_separation_m / dx)))
        ry = max(1, int(round(min_separation_m / dy)))
        size, mode, min_sep = (2 * ry + 1, 2 * rx + 1), "constant", 0.0
    elif suppression == "distance":
        size, mode, min_sep = (3, 3), "nearest", min_separation_m
    else:
        raise ValueError(f"suppression must be 'distance' or 'window', got {suppression!r}")
    local = (a == maximum_filter(a, size=size, mode=mode)) & (
        a >= peak * 10.0 ** (threshold_db / 20.0)
    )
    iy, ix = np.nonzero(local)
    order = np.argsort(-a[iy, ix], kind="stable")
    kept: list[tuple[float, float]] = []
    for k in order:
        if refine:
            fy, fx = parabolic_peak(a, iy[k], ix[k])
            px, py = x[0] + fx * dx, y[0] + fy * dy
        else:
            px, py = float(x[ix[k]]), float(y[iy[k]])
        if all(math.hypot(px - qx, py - qy) >= min_sep for qx, qy in kept):
            kept.append((px, py))
            if len(kept) == max_peaks:
                break
    if not kept:
        return np.zeros((0, 3))
    xs, ys = np.array(kept).T
    return np.stack([xs, ys, np.zeros(len(kept))], axis=1)


def parabolic_peak(magnitude: NDArray[np.float64], iy: int, ix: int) -> tuple[float, float]:
    """Sub-pixel ``(iy, ix)`` of a maximum of ``magnitude`` by 3-point parabolas per axis.

    The offset along each axis is clipped to half a pixel; an edge pixel is not refined.
    """

    def offset(a: float, b: float, c: float) -> float:
        den = a - 2.0 * b + c
        return 0.0 if den >= 0 else float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))

    ny, nx = magnitude.shape
    fy, fx = float(iy), float(ix)
    if 0 < ix < nx - 1:
        fx += offset(magnitude[iy, ix - 1], magnitude[iy, ix], magnitude[iy, ix + 1])
    if 0 < iy < ny - 1:
        fy += offset(magnitude[iy - 1, ix], magnitude[iy, ix], magnitude[iy + 1, ix])
    return fy, fx
