"""The ``sarmotion.tracks/1`` document: the movers followed through an acquisition.

::

    {"schema": "sarmotion.tracks/1",
     "sub_apertures": [{"index", "time_s", "first_pulse", "stop_pulse", "look_direction",
                        "n_detections", "seconds"}],
     "tracks": [{"id": 1, "n_detections": 7,
                 "fit": {"time_s", "position_m", "velocity_mps", "covariance",
                         "position_std_m", "fixed", "chi2", "dof", "n_looks",
                         "aspect_deg", "prior_std_m", "error_factors",
                         "acceleration_std_mps2",
                         "family": {"position_per_m", "velocity_per_m"}} or null,
                 "turn": {"flagged", "statistic", "threshold", "dof", "false_alarm",
                          "n_pairs", "apparent_turn_rate_deg_s", "apparent_turn_rate_std_deg_s",
                          "turn_rate": {"rate_deg_s", "interval_deg_s", "fixed",
                                        "confidence", "n_looks"} or null},
                 "coherent": {"time_s", "position_m", "velocity_mps", "covariance",
                              "bound_covariance", "position_std_m", "position_bound_m",
                              "error_factor", "coherence", "coherent", "amplitude",
                              "snr_db", "n_pulses", "n_sub_apertures", "shift_m"} or null,
                 "end": {"reason", "time_s", "next_time_s", "predicted_position_m",
                         "range_offset_m", "range_half_extent_m", "fixed", "text"},
                 "states": [{"time_s", "sub_aperture", "position_m": [x, y],
                             "velocity_mps": [ux, uy], "position_std_m",
                             "position_cov_m2", "velocity_std_mps", "speed_mps",
                             "range_speed_mps", "detected",
                             "measurement": {"position_m", "velocity_mps"},
                             "road": {"name", "angle_deg", "fixed", "std_m"},
                             "road_missed": "...",
                             "cross_range_family": {"position_per_m",
                                                    "velocity_per_m"}}]}],
     "roads": [{"name", "points_m"}], "options": {...}, "timings_s": {...}}

``time_s`` is slow time with ``s = 0`` at the centre of the whole acquisition; positions
in the scene's ground coordinates (m), velocities in m/s, ``range_speed_mps = u . m_o``
of the sub-aperture. ``road`` is present when the detection's cross-range family
crossed a road (``fixed`` false: the road runs nearly parallel to the family and fixes
no point); ``road_missed`` when roads were given and none gave the detection a member:
why, road by road (:func:`sarmotion.tracking.roads.road_misses`; a key added without
changing any other); ``cross_range_family`` when no road fixed the state: the data are then as
consistent with ``position + t position_per_m``, ``velocity + t velocity_per_m`` for
any ``t`` (m), and ``position_std_m`` is large accordingly. ``turn`` (a key added without
changing any other; null when a detection lacks its velocity's covariance) is the test
of :mod:`sarmotion.tracking.turns`: the largest chi-square statistic (``dof`` 2) of the
velocity change between detections that share no pulse, its threshold at the track's
false-alarm probability ``false_alarm`` (Bonferroni over ``n_pairs``), whether it was
exceeded, and the heading rate of the velocity estimates between the first and last
detections with its standard error (degrees per second, counter-clockwise positive; null
when they overlap): the *apparent* turn rate, which for a mover that accelerates differs
from its own (:mod:`sarmotion.tracking.turns`); ``turn_rate`` (a key added without
changing any other) is, where the track's position is fixed, the constant-rate turn in
the ground frame that fits its looks, with the hull of its confidence set and whether
that set fixes it (:mod:`sarmotion.tracking.turn_rate`). ``coherent`` (a key added
without changing any other) is, where the track's position is fixed, its uniform motion
focused over all its pulses (:mod:`sarmotion.tracking.coherent`): the Cramér–Rao bound,
the measured error factor and the covariance they make, and the coherence of its
sub-apertures' echoes. ``end`` (a key added without changing any
other) says why the track ends where it does (:mod:`sarmotion.tracking.ends`): ``"data"``
(its last detection is in the last sub-aperture), ``"left_scene"`` (moving on uniformly
it is outside the imaged scene at the next sub-aperture: in ground range whatever its
place along the family, or, its position fixed, outside the image) or
``"not_detected"``, with ``text`` the same in words.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np

from .schema import stamped

if TYPE_CHECKING:  # annotations only: Stone Soup takes ~0.9 s to import
    from ..tracking import TrackingResult, TrackState, TurnTest

__all__ = ["TRACKS_SCHEMA", "tracks_document"]

#: Schema name of the tracks document.
TRACKS_SCHEMA = "sarmotion.tracks/1"


def tracks_document(result: TrackingResult) -> dict[str, Any]:
    """The ``sarmotion.tracks/1`` document of ``result`` (lists, floats, strings)."""
    opts = dataclasses.asdict(result.options)
    opts["analysis"] = result.options.analysis.to_dict()
    return stamped(
        TRACKS_SCHEMA,
        {
            "sub_apertures": [
                {
                    "index": s.index,
                    "time_s": s.time_s,
                    "first_pulse": s.pulses.start,
                    "stop_pulse": s.pulses.stop,
                    "look_direction": s.look_direction.tolist(),
                    "n_detections": len(s.detections),
                    "seconds": s.seconds,
                }
                for s in result.sub_apertures
            ],
            "tracks": [
                {
                    "id": t.id,
                    "n_detections": t.n_detections,
                    "turn": _turn(t.turn),
                    "fit": _fit(t.fit),
                    "coherent": _coherent(t.coherent),
                    **({"end": _end(t.end)} if t.end is not None else {}),
                    "states": [_state(s, result) for s in t.states],
                }
                for t in result.tracks
            ],
            "roads": [{"name": r.name, "points_m": r.points_m.tolist()} for r in result.roads],
            "options": opts,
            "timings_s": dict(result.timings_s),
        },
    )


def _fit(fit: Any) -> dict[str, Any] | None:
    """The track's uniform motion fitted over all its looks (``tracking.PositionFit``)."""
    if fit is None:
        return None
    return {
        "time_s": float(fit.time_s),
        "position_m": [float(v) for v in fit.state[:2]],
        "velocity_mps": [float(v) for v in fit.state[2:]],
        "covariance": np.asarray(fit.covariance, dtype=float).tolist(),
        "position_std_m": fit.position_std_m,
        "fixed": bool(fit.fixed),
        "chi2": float(fit.chi2),
        "dof": int(fit.dof),
        "n_looks": int(fit.n_looks),
        "aspect_deg": float(fit.aspect_deg),
        "prior_std_m": float(fit.prior_std_m),
        "error_factors": [float(v) for v in fit.error_factors],
        "acceleration_std_mps2": float(fit.acceleration_std_mps2),
        "family": {
            "position_per_m": [float(v) for v in fit.family_position_per_m],
            "velocity_per_m": [float(v) for v in fit.family_velocity_per_m],
        },
    }


def _end(end: Any) -> dict[str, Any]:
    """Why the track ends (``tracking.TrackEnd``)."""
    p = end.predicted_position_m
    return {
        "reason": end.reason,
        "time_s": float(end.time_s),
        "next_time_s": None if end.next_time_s is None else float(end.next_time_s),
        "predicted_position_m": None if p is None else [float(v) for v in p],
        "range_offset_m": None if end.range_offset_m is None else float(end.range_offset_m),
        "range_half_extent_m": (
            None if end.range_half_extent_m is None else float(end.range_half_extent_m)
        ),
        "fixed": bool(end.fixed),
        "text": end.describe(),
    }


def _turn(turn: TurnTest | None) -> dict[str, Any] | None:
    """The turn test of a track (:mod:`sarmotion.tracking.turns`)."""
    if turn is None:
        return None
    return {
        "flagged": turn.flagged,
        "statistic": turn.statistic,
        "threshold": turn.threshold,
        "dof": 2,
        "false_alarm": turn.false_alarm,
        "n_pairs": turn.n_pairs,
        "apparent_turn_rate_deg_s": turn.apparent_turn_rate_deg_s,
        "apparent_turn_rate_std_deg_s": turn.apparent_turn_rate_std_deg_s,
        "turn_rate": _turn_rate(turn.turn_rate),
    }


def _coherent(fit: Any) -> dict[str, Any] | None:
    """The track focused over all its pulses (``tracking.CoherentFit``), or None."""
    if fit is None:
        return None
    measured = bool(np.isfinite(fit.error_factor))
    return {
        "time_s": float(fit.time_s),
        "position_m": [float(v) for v in fit.state[:2]],
        "velocity_mps": [float(v) for v in fit.state[2:]],
        "covariance": np.asarray(fit.covariance, dtype=float).tolist() if measured else None,
        "bound_covariance": np.asarray(fit.bound_covariance, dtype=float).tolist(),
        "position_std_m": fit.position_std_m if measured else None,
        "position_bound_m": fit.position_bound_m,
        "error_factor": float(fit.error_factor) if measured else None,
        "coherence": float(fit.coherence),
        "coherent": bool(fit.coherent),
        "amplitude": float(abs(fit.amplitude)),
        "snr_db": float(fit.snr_db),
        "n_pulses": int(fit.n_pulses),
        "n_sub_apertures": int(fit.n_sub_apertures),
        "shift_m": float(fit.shift_m),
    }


def _turn_rate(rate: Any) -> dict[str, Any] | None:
    """The turn rate in the ground frame (``tracking.TurnRate``), or None."""
    if rate is None:
        return None
    return {
        "rate_deg_s": float(rate.rate_deg_s),
        "interval_deg_s": [float(v) for v in rate.interval_deg_s],
        "fixed": bool(rate.fixed),
        "confidence": float(rate.confidence),
        "n_looks": int(rate.n_looks),
    }


def _state(s: TrackState, result: TrackingResult) -> dict[str, Any]:
    out: dict[str, Any] = {
        "time_s": s.time_s,
        "sub_aperture": s.sub_aperture,
        "position_m": s.position_m.tolist(),
        "velocity_mps": s.velocity_mps.tolist(),
        "position_std_m": s.position_std_m,
        "position_cov_m2": s.position_cov_m2.tolist(),
        "velocity_std_mps": float(np.sqrt(max(0.0, np.linalg.eigvalsh(s.velocity_cov_m2ps2)[-1]))),
        "speed_mps": float(np.hypot(*s.velocity_mps)),
        "range_speed_mps": s.range_speed_mps,
        "detected": s.detection is not None,
    }
    if s.measured_position_m is not None and s.detection is not None:
        out["measurement"] = {
            "position_m": s.measured_position_m.tolist(),
            "velocity_mps": s.measured_velocity_mps.tolist(),
        }
    if s.road is not None:
        out["road"] = {
            "name": result.roads[s.road.road].name,
            "angle_deg": s.road.angle_deg,
            "fixed": s.road.fixed,
            "std_m": s.road.std_m,
        }
    if s.road_missed is not None:
        out["road_missed"] = s.road_missed
    if s.detection is not None and not s.on_road:
        out["cross_range_family"] = {
            "position_per_m": s.detection.family_position_per_m.tolist(),
            "velocity_per_m": s.detection.family_velocity_per_m.tolist(),
        }
    return out
