"""Plane polygons on the ground: validity, area, clipping, point tests.

The collection's region and its patches' cores are polygons on the ground of the scene
frame, ``(n, 2)`` arrays of vertices ``(x, y)`` (m), closed implicitly (the last vertex
joins the first). The declared image area of an input may be any simple polygon; a
patch core is a convex quadrilateral (a square turned to the look direction).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["polygon_area", "polygon_problem", "clip_convex", "inside_polygon", "inside_convex"]

#: Most vertices whose sides are tested pairwise for crossings (the test is quadratic).
MAX_CROSSING_TEST = 256
#: Shift of a parallelogram's sides in :func:`inside_convex`, as a fraction of a side
#: (1e-9: a micrometre on a kilometre, far above float64 rounding, far below a pixel).
SIDE_SHIFT = 1e-9


def polygon_area(xy: ArrayLike) -> float:
    """Signed area of a polygon ``(n, 2)`` (m²): positive counter-clockwise (shoelace)."""
    p = np.asarray(xy, dtype=np.float64)
    if p.shape[0] < 3:
        return 0.0
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def polygon_problem(xy: ArrayLike) -> str | None:
    """Why ``xy`` is not a simple polygon of positive area, or None.

    Refused: not ``(n, 2)`` finite numbers; fewer than 3 distinct vertices; two sides
    that cross (each pair of non-adjacent sides, for at most ``MAX_CROSSING_TEST``
    vertices); no area (below ``1e-9`` of the square of its extent: the vertices on a
    line).
    """
    try:
        p = np.asarray(xy, dtype=np.float64)
    except (TypeError, ValueError):
        return "the polygon's vertices must be (x, y) pairs of numbers"
    if p.ndim != 2 or p.shape[1] != 2 or not np.all(np.isfinite(p)):
        return "the polygon's vertices must be finite (x, y) pairs"
    distinct = np.unique(p, axis=0).shape[0]
    if distinct < 3:
        return f"a polygon needs 3 distinct vertices, got {distinct}"
    n = p.shape[0]
    if n <= MAX_CROSSING_TEST:
        q = np.roll(p, -1, axis=0)
        for i in range(n):
            for j in range(i + 2, n):
                if i == 0 and j == n - 1:
                    continue  # adjacent through the closing side
                if _cross(p[i], q[i], p[j], q[j]):
                    return f"the polygon's sides {i + 1} and {j + 1} cross"
    extent = float(np.max(np.ptp(p, axis=0)))
    if not abs(polygon_area(p)) > 1e-9 * extent**2:
        return f"the polygon has no area (its {n} vertices lie on a line)"
    return None


def _side(p: NDArray, q: NDArray, r: NDArray) -> float:
    return float((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))


def _cross(a: NDArray, b: NDArray, c: NDArray, d: NDArray) -> bool:
    """Whether segments ``ab`` and ``cd`` cross at a point inside both."""
    return _side(a, b, c) * _side(a, b, d) < 0.0 and _side(c, d, a) * _side(c, d, b) < 0.0


def clip_convex(subject: ArrayLike, clip: ArrayLike) -> NDArray[np.float64]:
    """The part of polygon ``subject`` inside the convex polygon ``clip`` (Sutherland–Hodgman).

    Parameters
    ----------
    subject : (n, 2) array_like
        Any simple polygon (m).
    clip : (k, 2) array_like
        A convex polygon (m), either orientation.

    Returns
    -------
    (m, 2) ndarray
        The clipped polygon (m = 0 when they do not overlap). Its area is the overlap's;
        a concave subject cut in two comes back joined by sides of no area.
    """
    out = np.asarray(subject, dtype=np.float64)
    c = np.asarray(clip, dtype=np.float64)
    if polygon_area(c) < 0:
        c = c[::-1]
    for a, b in zip(c, np.roll(c, -1, axis=0), strict=True):
        if out.shape[0] == 0:
            break
        edge = b - a
        side = edge[0] * (out[:, 1] - a[1]) - edge[1] * (out[:, 0] - a[0])  # >= 0: inside
        pts = []
        for i in range(out.shape[0]):
            j = (i + 1) % out.shape[0]
            p, q, sp, sq = out[i], out[j], side[i], side[j]
            if sp >= 0:
                pts.append(p)
            if (sp >= 0) != (sq >= 0):
                pts.append(p + (q - p) * (sp / (sp - sq)))
        out = np.array(pts, dtype=np.float64).reshape(-1, 2)
    return out


def inside_polygon(points: ArrayLike, xy: ArrayLike) -> NDArray[np.bool_]:
    """Whether each point ``(m, 2)`` lies inside the polygon ``(n, 2)`` (even-odd rule)."""
    pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
    p = np.asarray(xy, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    x, y = pts[:, 0:1], pts[:, 1:2]
    straddle = (p[None, :, 1] > y) != (q[None, :, 1] > y)
    dy = np.where(q[:, 1] == p[:, 1], 1.0, q[:, 1] - p[:, 1])
    at = p[None, :, 0] + (y - p[None, :, 1]) * (q[None, :, 0] - p[None, :, 0]) / dy[None, :]
    crossings = np.sum(straddle & (x < at), axis=1)
    return crossings % 2 == 1


def inside_convex(points: ArrayLike, quad: ArrayLike) -> NDArray[np.bool_]:
    """Whether points ``(m, 2)`` lie in a parallelogram ``(4, 2)``, lower sides included.

    ``quad`` is ``o, o + u, o + u + v, o + v``: a point ``o + a u + b v`` is inside for
    ``-e <= a < 1 - e`` and the same for ``b``, so parallelograms that tile the plane by
    shared sides hold each point once. The shift ``e = SIDE_SHIFT`` moves the sides off
    the shared lines themselves: a point on one (a target placed on a border) has ``a``
    within rounding of 0 in one tile and of 1 in the next, and would otherwise fall in
    neither when those roundings go the wrong way.
    """
    pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
    q = np.asarray(quad, dtype=np.float64)
    o, u, v = q[0], q[1] - q[0], q[3] - q[0]
    d = pts[:, :2] - o
    a = d @ u / float(u @ u)
    b = d @ v / float(v @ v)
    lo, hi = -SIDE_SHIFT, 1.0 - SIDE_SHIFT
    return (a >= lo) & (a < hi) & (b >= lo) & (b < hi)
