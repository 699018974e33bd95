"""What the data fix of a mover's position: its range, and its cross-range family in the scene.

Over a few degrees of aperture a mover's data fix its range history (range, range rate
and curvature at ``s = 0``), not its cross-range position: every motion of the family
``position + t a``, ``velocity + t b`` (:func:`sarmotion.motion.family_member`, tangent
``(a, b)`` per metre of cross-range offset ``t``) fits them as well
(:mod:`sarmotion.motion.aperture`). The estimate the analysis reports is the member
held at the reference point's cross range; this module states the rest:

* :func:`range_coordinate` -- the ground-range coordinate the data fix (m, along the
  ground range direction at the reference point, from the reference point);
* :func:`family_segment` -- the part of the family whose positions lie in the imaged
  scene, as members re-fitted to the same range history.

Pure functions: arrays in, arrays out. Positions in m (scene frame, ground ``z = 0``),
velocities in m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.acquisition import Acquisition
from ..core.traces import Traces
from ..imaging import resolution
from ..motion import family_member

__all__ = ["FamilySegment", "clip_family", "family_segment", "range_coordinate"]


@dataclass(frozen=True, kw_only=True)
class FamilySegment:
    """Members of a mover's cross-range family whose positions lie in a rectangle.

    The members are taken at evenly spaced cross-range offsets from one end of the part
    in the rectangle to the other (first and last rows: the end members).

    Attributes
    ----------
    cross_offsets_m : (n,) ndarray
        Cross-range offsets ``t`` of the members from the estimate (m, along the
        cross-range direction at the reference point), increasing; ``t[0] <= 0 <= t[-1]``
        when the estimate itself lies in the rectangle.
    positions_m : (n, 2) ndarray
        Their ground positions at ``s = 0`` (m).
    velocities_mps : (n, 2) ndarray
        Their ground velocities (m/s).
    rms_m : (n,) ndarray
        RMS difference between each member's range history and the estimate's over the
        acquisition (m): how well the family holds there (near zero over a degree).
    """

    cross_offsets_m: NDArray[np.float64]
    positions_m: NDArray[np.float64]
    velocities_mps: NDArray[np.float64]
    rms_m: NDArray[np.float64]


def range_coordinate(traces: Traces | Acquisition, position_m: ArrayLike) -> float:
    """Ground-range coordinate of a position: ``(rho - rho_o) . e_r`` (m).

    ``e_r`` is the unit ground range direction at the reference point ``rho_o``
    (:func:`sarmotion.imaging.resolution`), pointing away from the antenna; the
    coordinate is what a mover's data fix, whatever its cross-range position.
    """
    cells = resolution(traces)
    ref = (traces.acquisition if isinstance(traces, Traces) else traces).reference_point_m
    p = np.asarray(position_m, dtype=np.float64).reshape(-1)[:2]
    return float((p - ref[:2]) @ cells.range_direction)


def clip_family(
    position_m: ArrayLike,
    family_position_per_m: ArrayLike,
    extent_m: tuple[float, float, float, float],
) -> tuple[float, float] | None:
    """Cross-range offsets ``[t0, t1]`` for which ``position + t a`` lies in a rectangle.

    Liang–Barsky clipping of the tangent line of the family at the estimate.

    Parameters
    ----------
    position_m : (2,) or (3,) array_like
        The estimate's position (m).
    family_position_per_m : (2,) array_like
        ``a``: position change per metre of cross-range offset (m/m).
    extent_m : (x0, x1, y0, y1)
        The rectangle (m), ``x0 < x1``, ``y0 < y1``.

    Returns
    -------
    (float, float) or None
        ``(t0, t1)`` (m), or None when the line misses the rectangle.
    """
    p = np.asarray(position_m, dtype=np.float64).reshape(-1)[:2]
    a = np.asarray(family_position_per_m, dtype=np.float64).reshape(2)
    x0, x1, y0, y1 = (float(v) for v in extent_m)
    lo, hi = -np.inf, np.inf
    for pk, ak, low, high in ((p[0], a[0], x0, x1), (p[1], a[1], y0, y1)):
        if abs(ak) < 1e-12:  # parallel to this pair of sides: inside or never
            if not low <= pk <= high:
                return None
            continue
        ta, tb = (low - pk) / ak, (high - pk) / ak
        lo, hi = max(lo, min(ta, tb)), min(hi, max(ta, tb))
    if not np.isfinite(lo) or not np.isfinite(hi) or lo > hi:
        return None
    return float(lo), float(hi)


def family_segment(
    traces: Traces | Acquisition,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    family_position_per_m: ArrayLike,
    extent_m: tuple[float, float, float, float],
    *,
    n_members: int = 9,
) -> FamilySegment | None:
    """The part of a mover's family whose positions lie in ``extent_m``, as exact members.

    The end offsets come from the family's tangent line at the estimate
    (:func:`clip_family`); each member is :func:`sarmotion.motion.family_member` at its
    offset (the motion with the same range history over ``traces``, its ground range
    re-fitted), so positions follow the family's curvature (the range circle) and
    velocities are exact, not extrapolated along the tangent.

    Parameters
    ----------
    traces : Traces or Acquisition
        The acquisition whose ``s = 0`` is the time of ``position_m``.
    position_m : (2,) or (3,) array_like
        The estimate's position (m).
    velocity_mps : (2,) array_like
        Its ground velocity (m/s).
    family_position_per_m : (2,) array_like
        The family's tangent at the estimate (m/m).
    extent_m : (x0, x1, y0, y1)
        The scene (m).
    n_members : int
        Members from end to end (>= 2). The family curves with the range circle (radius
        ``R`` about the stand-off range): chords of length ``c`` between members depart
        from it by ``c**2 / (8 R)``, millimetres for nine members across a hundred metres
        at kilometres of range.

    Returns
    -------
    FamilySegment or None
        None when the tangent line misses the scene.
    """
    span = clip_family(position_m, family_position_per_m, extent_m)
    if span is None:
        return None
    offsets = np.linspace(span[0], span[1], max(2, int(n_members)))
    members = [family_member(traces, position_m, velocity_mps, float(t)) for t in offsets]
    return FamilySegment(
        cross_offsets_m=offsets,
        positions_m=np.array([m[0][:2] for m in members], dtype=np.float64),
        velocities_mps=np.array([m[1] for m in members], dtype=np.float64),
        rms_m=np.array([m[2] for m in members], dtype=np.float64),
    )
