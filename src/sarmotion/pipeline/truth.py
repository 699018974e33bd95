"""Comparison of an analysis with the true scene of a simulation or an injection.

An estimated mover is matched on what the data fix of it: its cross-range family
(positions and velocities that fit the data equally, ``docs/results.md``), slid to the
cross range of a true mover. It matches that mover when the family member there lies
within :data:`MATCH_CELLS` ground-range resolution cells of the true position, its
velocity within :data:`MATCH_CELLS` cross-range-speed resolutions of the true velocity,
and its range speed within :data:`MATCH_CELLS` range-speed resolutions; among several,
the nearest in those units, each true mover once. An estimate with none is a false
mover, a true mover with none a missed one: an echo that aliased in range (a mover 145 m
from its truth, folded into the window) is both, whatever its range speed.

Errors are estimate minus truth; the position error is also split along the ground range
and cross-range directions at the reference point. ``family_*`` compare the truth with
the member of the estimate's cross-range family at the truth's cross-range offset: the
part of the error the data of a few degrees can resolve (:mod:`sarmotion.motion.aperture`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from ..core.acquisition import Acquisition
from ..core.geometry import cross_range_speed, range_speed
from ..core.traces import Traces
from ..imaging import resolution
from ..motion import cross_range_speed_resolution, family_member, trajectory_error
from ..simulation import Scene
from .results import AnalysisResult, Mover

__all__ = [
    "MATCH_CELLS",
    "TrueMover",
    "MoverErrors",
    "TruthComparison",
    "compare_with_truth",
    "family_errors",
    "family_match",
]


#: A match lies within this many resolutions (ground range, range speed, cross-range
#: speed) of the truth: as the range-speed detector's own peak separation, four.
MATCH_CELLS = 4.0


@dataclass(frozen=True, kw_only=True)
class TrueMover:
    """A true mover: ``position_m`` at ``s = 0`` (m), ground velocity and its components (m/s)."""

    label: str
    position_m: tuple[float, float]
    velocity_mps: tuple[float, float]
    range_speed_mps: float
    cross_range_speed_mps: float


@dataclass(frozen=True, kw_only=True)
class MoverErrors:
    """Errors of one estimated mover against the true mover it was matched to.

    Distances (m) and speed errors (m/s) are estimate minus truth; ``*_range_m`` and
    ``*_cross_range_m`` are components along the ground range and cross-range directions.
    ``family_offset_m`` is the cross-range offset (m) of the truth along the estimate's
    family, ``family_position_m`` and ``family_velocity_mps`` the distances of the truth
    from that family member. ``trajectory_*`` are ``None`` without a trajectory.
    """

    matched: str
    position_m: float
    position_range_m: float
    position_cross_range_m: float
    image_peak_m: float
    image_peak_range_m: float
    image_peak_cross_range_m: float
    velocity_mps: float
    range_speed_mps: float
    cross_range_speed_mps: float
    family_offset_m: float
    family_position_m: float
    family_velocity_mps: float
    trajectory_max_m: float | None = None
    trajectory_rms_m: float | None = None


@dataclass(frozen=True, kw_only=True)
class TruthComparison:
    """The true movers, one :class:`MoverErrors` (or ``None``: a false mover) per estimate."""

    truth: tuple[TrueMover, ...]
    errors: tuple[MoverErrors | None, ...]

    @property
    def false_movers(self) -> int:
        """Estimates matched to no true mover."""
        return sum(e is None for e in self.errors)

    @property
    def missed_movers(self) -> int:
        """True movers matched by no estimate."""
        return len(self.truth) - (len(self.errors) - self.false_movers)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``truth``, ``errors``, ``false_movers``, ``missed_movers``."""
        return {
            "truth": [dataclasses.asdict(t) for t in self.truth],
            "errors": [None if e is None else dataclasses.asdict(e) for e in self.errors],
            "false_movers": self.false_movers,
            "missed_movers": self.missed_movers,
        }


def compare_with_truth(result: AnalysisResult, scene: Scene) -> TruthComparison:
    """Match the estimated movers of ``result`` to the movers of ``scene`` (module docstring).

    Parameters
    ----------
    result : AnalysisResult
        The analysis.
    scene : Scene
        The true scene (its movers' positions at ``s = 0`` and ground velocities).

    Returns
    -------
    TruthComparison
    """
    geom = result.traces.geometry
    truth = tuple(
        TrueMover(
            label=t.label or f"mover {i + 1}",
            position_m=(float(t.position_m[0]), float(t.position_m[1])),
            velocity_mps=(float(t.velocity_mps[0]), float(t.velocity_mps[1])),
            range_speed_mps=float(range_speed(t.velocity_mps, geom)),
            cross_range_speed_mps=float(cross_range_speed(t.velocity_mps, geom)),
        )
        for i, t in enumerate(scene.moving)
    )
    res = resolution(result.traces)
    scales = (
        float(res.ground_range_m),
        float(result.range_speeds.resolution_mps),
        float(cross_range_speed_resolution(result.traces)),
    )
    used: set[int] = set()
    errors: list[MoverErrors | None] = []
    for m in result.movers:
        cands = []
        for i, t in enumerate(truth):
            if i in used:
                continue
            cost = family_match(
                position_m=m.position_m[:2],
                velocity_mps=m.velocity_mps,
                range_speed_mps=m.range_speed_mps,
                position_per_m=m.family_position_per_m,
                velocity_per_m=m.family_velocity_per_m,
                truth=t,
                cross_range_direction=res.cross_range_direction,
                scales=scales,
            )
            if cost is not None:
                cands.append((cost, i))
        if not cands:
            errors.append(None)
            continue
        i = min(cands)[1]
        used.add(i)
        errors.append(_errors(result, m, truth[i]))
    return TruthComparison(truth=truth, errors=tuple(errors))


def family_match(
    *,
    position_m: Any,
    velocity_mps: Any,
    range_speed_mps: float,
    position_per_m: Any,
    velocity_per_m: Any,
    truth: TrueMover,
    cross_range_direction: Any,
    scales: tuple[float, float, float],
) -> float | None:
    """How far a mover's family passes from a true mover, in resolutions; None: no match.

    The estimate (``position_m`` (2,) m, ``velocity_mps`` (2,) m/s, its range speed and
    its family tangent per metre of cross-range offset) is slid along its family to the
    truth's cross-range coordinate (along the unit ground vector
    ``cross_range_direction``). ``scales`` are the ground-range resolution (m), the
    range-speed and the cross-range-speed resolutions (m/s). The distances there, of
    the position, the range speed and the velocity, each divided by its scale, must be
    at most :data:`MATCH_CELLS`; the result is the root sum of their squares.
    """
    e_c = np.asarray(cross_range_direction, dtype=np.float64)
    a = np.asarray(position_per_m, dtype=np.float64)[:2]
    dp = np.asarray(position_m, dtype=np.float64)[:2] - np.asarray(truth.position_m)
    ac = float(a @ e_c)
    offset = -float(dp @ e_c) / ac if abs(ac) > 1e-12 else 0.0
    fp = float(np.hypot(*(dp + offset * a)))
    fv = np.asarray(velocity_mps, dtype=np.float64) + offset * np.asarray(velocity_per_m)
    fv_err = float(np.hypot(*(fv - np.asarray(truth.velocity_mps))))
    du = abs(float(range_speed_mps) - truth.range_speed_mps)
    units = np.array([fp, du, fv_err]) / np.asarray(scales, dtype=np.float64)
    if not np.all(units <= MATCH_CELLS):
        return None
    return float(np.sqrt(np.sum(units**2)))


def _errors(result: AnalysisResult, m: Mover, t: TrueMover) -> MoverErrors:
    res = resolution(result.traces)
    e_r, e_c = res.range_direction, res.cross_range_direction
    e = m
    dp = np.asarray(e.position_m[:2]) - np.asarray(t.position_m)
    di = np.asarray(m.image_peak_m) - np.asarray(t.position_m)
    offset = -float(dp @ e_c) / float(m.family_position_per_m @ e_c)
    fp = dp + offset * m.family_position_per_m
    fv = e.velocity_mps + offset * m.family_velocity_per_m - np.asarray(t.velocity_mps)
    traj: dict[str, float] = {}
    if m.trajectory is not None:
        te = trajectory_error(m.trajectory, t.position_m, t.velocity_mps)
        traj = {
            "trajectory_max_m": float(te.max()),
            "trajectory_rms_m": float(np.sqrt(np.mean(te**2))),
        }
    return MoverErrors(
        matched=t.label,
        position_m=float(np.hypot(*dp)),
        position_range_m=float(dp @ e_r),
        position_cross_range_m=float(dp @ e_c),
        image_peak_m=float(np.hypot(*di)),
        image_peak_range_m=float(di @ e_r),
        image_peak_cross_range_m=float(di @ e_c),
        velocity_mps=float(np.hypot(*(e.velocity_mps - np.asarray(t.velocity_mps)))),
        range_speed_mps=float(e.range_speed_mps - t.range_speed_mps),
        cross_range_speed_mps=float(e.cross_range_speed_mps - t.cross_range_speed_mps),
        family_offset_m=offset,
        family_position_m=float(np.hypot(*fp)),
        family_velocity_mps=float(np.hypot(*fv)),
        **traj,
    )


class _Motion(Protocol):
    """A location at ``s = 0`` (m) and a ground velocity (m/s)."""

    @property
    def position_m(self) -> Any: ...

    @property
    def velocity_mps(self) -> Any: ...


def family_errors(traces: Acquisition | Traces, estimate: _Motion, truth: _Motion) -> np.ndarray:
    """Errors of ``estimate`` on the truth's cross-range family at the estimate's cross range.

    The truth is slid along its own (exact) family
    (:func:`~sarmotion.motion.family_member`) to the estimate's cross-range coordinate,
    where a fit's Cramér–Rao bound is defined (cross-range coordinate held).

    Parameters
    ----------
    traces : Acquisition or Traces
        The acquisition the estimate was made on (its geometry and resolution).
    estimate, truth
        Objects with ``position_m`` ((2,) or (3,), m) and ``velocity_mps`` ((2,), m/s),
        e.g. a :class:`~sarmotion.motion.PointFit` and a
        :class:`~sarmotion.simulation.PointTarget`.

    Returns
    -------
    (3,) ndarray
        Estimate minus truth: range position (m), range speed and cross-range speed (m/s).
    """
    geom = traces.geometry
    cells = resolution(traces)
    pos = np.asarray(estimate.position_m, dtype=np.float64)
    dy = float((pos[:2] - np.asarray(truth.position_m)[:2]) @ cells.cross_range_direction)
    p, v, _ = family_member(traces, truth.position_m, truth.velocity_mps, dy)
    return np.array(
        [
            float((pos[:2] - p[:2]) @ cells.range_direction),
            range_speed(estimate.velocity_mps, geom) - range_speed(v, geom),
            cross_range_speed(estimate.velocity_mps, geom) - cross_range_speed(v, geom),
        ]
    )
