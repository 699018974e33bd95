"""Road-constrained positions: the member of a mover's cross-range family on a road.

Over a few degrees the data fix a mover's range history, not its cross-range position:
the estimate is one point of a line of positions ``p + t a`` (``a`` the family's
position tangent, about the cross-range direction), each with its velocity ``v + t b``
(:mod:`sarmotion.motion.aperture`). A vehicle is on a road: where the family line
crosses the nearest road is its position. The fix is as good as the angle ``theta``
between the line and the road allows: an error ``sigma_r`` across the family (ground
range) and ``sigma_w`` across the road (the vehicle's offset from the centre line)
combine into a point whose covariance is the inverse of the two lines' information
``n_f n_f^T / sigma_r^2 + n_w n_w^T / sigma_w^2`` (``n`` the unit normals); along the
road it is about ``sigma_w / sin(theta)``. A road parallel to the family (``theta``
-> 0) fixes no single point: :func:`road_fix` says so when that standard deviation
exceeds ``max_std_m``.

Roads are polylines in the scene's ground coordinates (m); reading them from GeoJSON
is :func:`sarmotion.documents.read_roads`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Road", "RoadFix", "road_fix", "road_misses"]


@dataclass(frozen=True, kw_only=True, eq=False)
class Road:
    """A road centre line: a polyline on the ground.

    Parameters
    ----------
    points_m : (n_points, 2) array_like
        Vertices ``(x, y)`` in the scene's ground coordinates (m), ``n_points >= 2``.
    name : str
        Optional name.
    """

    points_m: NDArray[np.float64]
    name: str = ""

    def __post_init__(self) -> None:
        p = np.asarray(self.points_m, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 2:
            raise ValueError(f"points_m must have shape (n_points >= 2, 2), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError("points_m must be finite")
        object.__setattr__(self, "points_m", p)


@dataclass(frozen=True, kw_only=True, eq=False)
class RoadFix:
    """Where a cross-range family meets a road.

    Attributes
    ----------
    road : int
        Index of the road in the sequence given to :func:`road_fix`.
    offset_m : float
        Family offset ``t`` of the crossing (m along the family's cross-range coordinate).
    position_m : (2,) ndarray
        The crossing ``p + t a`` (m).
    covariance_m2 : (2, 2) ndarray
        Its covariance (m^2), see the module notes.
    angle_deg : float
        Angle between the family line and the road segment (degrees, 0..90).
    fixed : bool
        False when the road runs (nearly) parallel to the family: its standard deviation
        along the road exceeds ``max_std_m`` and no single point is fixed.
    """

    road: int
    offset_m: float
    position_m: NDArray[np.float64]
    covariance_m2: NDArray[np.float64]
    angle_deg: float
    fixed: bool

    @property
    def std_m(self) -> float:
        """Largest standard deviation of the fixed position (m)."""
        return float(np.sqrt(np.linalg.eigvalsh(self.covariance_m2)[-1]))


def road_fix(
    position_m: ArrayLike,
    family_position_per_m: ArrayLike,
    roads: Sequence[Road],
    *,
    velocity_mps: ArrayLike | None = None,
    family_velocity_per_m: ArrayLike | None = None,
    max_cross_speed_mps: float = np.inf,
    near_m: ArrayLike | None = None,
    max_offset_m: float = np.inf,
    range_std_m: float,
    road_std_m: float = 0.5,
    max_std_m: float = 5.0,
) -> RoadFix | None:
    """The family member of a detection that lies on the nearest road.

    Every crossing of the family line ``position + t a`` with a road segment within
    ``|t| <= max_offset_m`` is a candidate, unless the member's velocity ``velocity +
    t b`` crosses the road faster than ``max_cross_speed_mps`` (a vehicle moves along
    its road: this tells apart the roads a family line crosses); the candidate nearest
    ``near_m`` (e.g. the track's predicted position; default the detection itself) is
    returned. A segment
    parallel to the line within ``1e-9`` rad never crosses it; one at a small angle
    gives a candidate with ``fixed=False`` (module notes).

    Parameters
    ----------
    position_m : (2,) array_like
        The detection's ground position (m).
    family_position_per_m : (2,) array_like
        Its family's position tangent ``a`` (m/m; cross-range component 1).
    roads : sequence of Road
        Road centre lines.
    velocity_mps : (2,) array_like, optional
        The detection's ground velocity (m/s); with ``family_velocity_per_m`` (``b``,
        (m/s)/m) and ``max_cross_speed_mps`` (m/s), the along-road test above.
    family_velocity_per_m : (2,) array_like, optional
        The family's velocity tangent ``b`` ((m/s)/m).
    max_cross_speed_mps : float
        Largest speed across a road of a vehicle on it (m/s); default no test.
    near_m : (2,) array_like, optional
        Point the chosen crossing is nearest to (m).
    max_offset_m : float
        Largest family offset considered (m).
    range_std_m : float
        Standard deviation of the detection across the family line (m, > 0).
    road_std_m : float
        Standard deviation of a vehicle's offset from the road's centre line (m, > 0).
        Default 0.5 m, about a car's offset within its lane.
    max_std_m : float
        Largest standard deviation along the road for a fix (m). Default 5 m, four
        GOTCHA cross-range cells: beyond it the road says little more than the family.

    Returns
    -------
    RoadFix or None
        None if the family line crosses no road within ``max_offset_m``.
    """
    p = np.asarray(position_m, dtype=np.float64).reshape(2)
    a = np.asarray(family_position_per_m, dtype=np.float64).reshape(2)
    for name, v in (("range_std_m", range_std_m), ("road_std_m", road_std_m)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be positive (m), got {v!r}")
    if not np.all(np.isfinite(a)) or np.hypot(*a) == 0:
        raise ValueError(f"family_position_per_m must be a finite non-zero vector, got {a}")
    ref = p if near_m is None else np.asarray(near_m, dtype=np.float64).reshape(2)
    a_len = float(np.hypot(*a))
    e_f = a / a_len
    n_f = np.array([-e_f[1], e_f[0]])
    best: tuple[float, RoadFix] | None = None
    for k, road in enumerate(roads):
        q0, q1 = road.points_m[:-1], road.points_m[1:]
        for s0, s1 in zip(q0, q1, strict=True):
            d = s1 - s0
            length = float(np.hypot(*d))
            if length == 0.0:
                continue
            e_w = d / length
            sin = float(e_f[0] * e_w[1] - e_f[1] * e_w[0])
            if abs(sin) < 1e-9:
                continue
            # p + t a = s0 + r d: solve the 2x2 system for (t, r).
            t, r = np.linalg.solve(np.column_stack([a, -d]), s0 - p)
            if not (-1e-12 <= r <= 1.0 + 1e-12) or abs(t) > max_offset_m:
                continue
            point = p + t * a
            n_w = np.array([-e_w[1], e_w[0]])
            if velocity_mps is not None:
                v = np.asarray(velocity_mps, dtype=np.float64).reshape(2)
                if family_velocity_per_m is not None:
                    v = v + t * np.asarray(family_velocity_per_m, dtype=np.float64).reshape(2)
                if abs(float(v @ n_w)) > max_cross_speed_mps:
                    continue
            info = np.outer(n_f, n_f) / range_std_m**2 + np.outer(n_w, n_w) / road_std_m**2
            cov = np.linalg.inv(info)
            fix = RoadFix(
                road=k,
                offset_m=float(t),
                position_m=point,
                covariance_m2=cov,
                angle_deg=float(np.degrees(np.arcsin(min(1.0, abs(sin))))),
                fixed=bool(np.sqrt(np.linalg.eigvalsh(cov)[-1]) <= max_std_m),
            )
            distance = float(np.hypot(*(point - ref)))
            if best is None or distance < best[0]:
                best = (distance, fix)
    return None if best is None else best[1]


def road_misses(
    position_m: ArrayLike,
    family_position_per_m: ArrayLike,
    roads: Sequence[Road],
    *,
    velocity_mps: ArrayLike | None = None,
    family_velocity_per_m: ArrayLike | None = None,
    max_cross_speed_mps: float = np.inf,
    max_offset_m: float = np.inf,
) -> tuple[str, ...]:
    """Why each road gives no candidate to :func:`road_fix`: one sentence per road.

    The tests of :func:`road_fix`, road by road, and the first one every segment of the
    road fails, in this order: the family line ``position + t a`` does not cross the
    road (or runs parallel to it); it crosses it only beyond ``|t| <= max_offset_m``;
    the family member there would cross the road faster than ``max_cross_speed_mps``
    (it does not move along it). A road that gives a candidate gets the empty string.

    Parameters are those of :func:`road_fix`.

    Returns
    -------
    tuple of str
        One reason per road, in the order of ``roads``; ``""`` for a road with a candidate.
    """
    p = np.asarray(position_m, dtype=np.float64).reshape(2)
    a = np.asarray(family_position_per_m, dtype=np.float64).reshape(2)
    if not np.all(np.isfinite(a)) or np.hypot(*a) == 0:
        raise ValueError(f"family_position_per_m must be a finite non-zero vector, got {a}")
    e_f = a / float(np.hypot(*a))
    reasons = []
    for road in roads:
        offsets: list[float] = []  # |t| of the crossings (m)
        across: list[float] = []  # speed across the road of the crossings within reach
        for s0, s1 in zip(road.points_m[:-1], road.points_m[1:], strict=True):
            d = s1 - s0
            length = float(np.hypot(*d))
            if length == 0.0:
                continue
            e_w = d / length
            if abs(float(e_f[0] * e_w[1] - e_f[1] * e_w[0])) < 1e-9:
                continue
            t, r = np.linalg.solve(np.column_stack([a, -d]), s0 - p)
            if not -1e-12 <= r <= 1.0 + 1e-12:
                continue
            offsets.append(abs(float(t)))
            if abs(t) > max_offset_m:
                continue
            if velocity_mps is None:
                across.append(0.0)
                continue
            v = np.asarray(velocity_mps, dtype=np.float64).reshape(2)
            if family_velocity_per_m is not None:
                v = v + t * np.asarray(family_velocity_per_m, dtype=np.float64).reshape(2)
            across.append(abs(float(v @ np.array([-e_w[1], e_w[0]]))))
        if not offsets:
            reasons.append("the mover's cross-range family line does not cross it")
        elif not across:
            reasons.append(
                f"it crosses the family line {min(offsets):.1f} m from the detection, beyond "
                f"the {max_offset_m:.1f} m the data allow"
            )
        elif min(across) > max_cross_speed_mps:
            reasons.append(
                f"a mover on it would cross it at {min(across):.1f} m/s, more than "
                f"{max_cross_speed_mps:.1f} m/s: it does not move along this road"
            )
        else:
            reasons.append("")
    return tuple(reasons)
