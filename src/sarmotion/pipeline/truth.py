"""Comparison of an analysis with the true scene of a simulation or an injection.

Each estimated mover is matched to the unused true mover of nearest range speed within
four range-speed resolutions; an estimate with none is a false mover. Errors are estimate
minus truth; the position error is also split along the ground range and cross-range
directions at the reference point. ``family_*`` compare the truth with the member of the
estimate's cross-range family at the truth's cross-range offset: the part of the error
the data of a few degrees can resolve (:mod:`sarmotion.motion.aperture`).
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
from ..motion import family_member, trajectory_error
from ..simulation import Scene
from .results import AnalysisResult, Mover

__all__ = [
    "TrueMover",
    "MoverErrors",
    "TruthComparison",
    "compare_with_truth",
    "family_errors",
]


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
    used: set[int] = set()
    errors: list[MoverErrors | None] = []
    tol = 4.0 * result.range_speeds.resolution_mps
    for m in result.movers:
        u = m.range_speed_mps
        cands = [(abs(t.range_speed_mps - u), i) for i, t in enumerate(truth) if i not in used]
        cands = [c for c in cands if c[0] <= tol]
        if not cands:
            errors.append(None)
            continue
        i = min(cands)[1]
        used.add(i)
        errors.append(_errors(result, m, truth[i]))
    return TruthComparison(truth=truth, errors=tuple(errors))


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
