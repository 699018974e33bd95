"""The ``sarmotion.results/2`` document: an analysis as JSON-ready data.

Every key, with its unit, frame and reference, is described in ``docs/results-schema.json``
(JSON Schema) and the frame in ``docs/results.md``. Top-level keys: ``schema``,
``method``, ``reference_point_m``, ``platform_speed_mps``, ``n_pulses``, ``n_samples``,
``aperture_s``, ``aperture_deg``, ``range_speed_resolution_mps``, ``frame`` (the look
direction and the unit vectors the range and cross-range coordinates and speeds are
measured along), ``scene_extent_m``, ``detection`` (the test: statistic, threshold,
false-alarm rate, the measured null tail, every candidate), ``movers``,
``movers_not_estimated`` (candidates above the threshold beyond ``max_movers``),
``stationary``, ``stationary_sidelobes_dropped`` (local maxima a brighter one's sidelobes
explain, not listed), ``timings_s``, ``options``, ``source``; for simulated inputs also
``truth``, per-mover ``errors``, ``false_movers`` and ``missed_movers``
(:mod:`sarmotion.pipeline.truth`).

Per mover: what the data fix and what they do not. ``range_m`` and ``range_std_m`` (the
ground-range coordinate and its Cramér–Rao standard error) are measured;
``cross_range_known`` is false (a few degrees of one antenna do not fix the cross-range
position) and ``position_m`` is one member of ``cross_range_family``, the one at the
reference point's cross range; ``cross_range_family.in_scene`` lists the family's members
across the imaged scene (positions and velocities). Then the velocity, range and
cross-range speeds, peak levels, ``detection``, ``standard_errors``, ``snr_db``,
``amplitude`` (``[re, im]``) and ``amplitude_complex`` (``{"re", "im"}``),
``g_perp_cross_range_speed_mps``, ``likelihood_lobes``, the range acceleration
(``range_acceleration_mps2``, ``range_acceleration_std_mps2``,
``range_acceleration_estimable``: :mod:`sarmotion.motion.acceleration`; null over one
sub-aperture) and ``trajectory`` (knot times, velocities and the positions at the knot
times).

Version 2 (from ``sarmotion.results/1``): ``g_peak_db`` is the ``g(u)`` peak over its
*local* floor (the detector's statistic), no longer over the global median; added
``frame``, ``scene_extent_m``, ``movers_not_estimated`` and per mover
``cross_range_known``, ``range_m``, ``range_std_m``, ``cross_range_family.in_scene``,
``amplitude_complex`` and ``trajectory.positions_m``. No key was removed and no number
changed. Readers of the document (the HTML report) accept both versions.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.traces import Traces
from ..imaging import resolution
from ..motion import NULL_TAIL, TrajectoryEstimate, azimuth_span_deg
from ..pipeline import (
    AnalysisResult,
    Mover,
    NotEstimated,
    TruthComparison,
    family_segment,
    range_coordinate,
)

__all__ = ["RESULTS_SCHEMA", "READABLE_RESULTS_SCHEMAS", "results_document"]

#: Schema name of the results document.
RESULTS_SCHEMA = "sarmotion.results/2"

#: Versions a reader of results.json (the HTML report) accepts.
READABLE_RESULTS_SCHEMAS = ("sarmotion.results/1", RESULTS_SCHEMA)


def results_document(
    result: AnalysisResult, *, truth: TruthComparison | None = None
) -> dict[str, Any]:
    """The ``sarmotion.results/2`` document of ``result`` (lists, floats, strings).

    Parameters
    ----------
    result : AnalysisResult
        The analysis.
    truth : TruthComparison, optional
        Its comparison with the true scene; adds ``truth``, per-mover ``errors``,
        ``false_movers`` and ``missed_movers``.
    """
    tr = result.traces
    g = result.stationary_image.grid
    extent = (float(g.x_m[0]), float(g.x_m[-1]), float(g.y_m[0]), float(g.y_m[-1]))
    doc: dict[str, Any] = {
        "schema": RESULTS_SCHEMA,
        "method": result.method,
        "reference_point_m": [float(v) for v in tr.reference_point_m],
        "platform_speed_mps": float(tr.geometry.speed_mps),
        "n_pulses": int(tr.n_pulses),
        "n_samples": int(tr.n_samples),
        "aperture_s": float(tr.slow_times_s[-1] - tr.slow_times_s[0]),
        "aperture_deg": float(azimuth_span_deg(tr)),
        "range_speed_resolution_mps": float(result.range_speeds.resolution_mps),
        "frame": _frame(tr),
        "scene_extent_m": list(extent),
        "detection": _detection(result),
        "movers": [_mover(m, tr, extent) for m in result.movers],
        "movers_not_estimated": [_not_estimated(c) for c in result.movers_not_estimated],
        "stationary": [
            {"position_m": list(s.position_m), "peak_db": float(s.level_db)}
            for s in result.stationary
        ],
        "stationary_sidelobes_dropped": int(result.stationary_sidelobes),
        "timings_s": {k: float(v) for k, v in result.timings_s.items()},
        "options": result.options.to_dict(),
        "source": {k: v for k, v in tr.metadata.items() if _jsonable(v)},
    }
    if truth is not None:
        cmp = truth.to_dict()
        doc["truth"] = cmp["truth"]
        for entry, err in zip(doc["movers"], cmp["errors"], strict=True):
            entry["errors"] = err
        doc["false_movers"] = cmp["false_movers"]
        doc["missed_movers"] = cmp["missed_movers"]
    return doc


def _frame(tr: Traces) -> dict[str, Any]:
    """The look direction and the ground unit vectors of range and cross range (module notes)."""
    geom = tr.geometry
    cells = resolution(tr)
    m_o, t = np.asarray(geom.m_o, float), np.asarray(geom.tangent, float)
    return {
        "look_direction": m_o.tolist(),
        "flight_tangent": t.tolist(),
        "range_direction": [float(v) for v in cells.range_direction],
        "cross_range_direction": [float(v) for v in cells.cross_range_direction],
        "range_speed_vector": m_o[:2].tolist(),
        "cross_range_speed_vector": (geom.projector @ t)[:2].tolist(),
    }


def _mover(m: Mover, tr: Traces, extent: tuple[float, float, float, float]) -> dict[str, Any]:
    seg = family_segment(tr, m.position_m, m.velocity_mps, m.family_position_per_m, extent)
    in_scene = (
        None
        if seg is None
        else {
            "cross_offsets_m": seg.cross_offsets_m.tolist(),
            "positions_m": seg.positions_m.tolist(),
            "velocities_mps": seg.velocities_mps.tolist(),
            "range_history_rms_m": seg.rms_m.tolist(),
        }
    )
    entry: dict[str, Any] = {
        "position_m": [float(v) for v in m.position_m[:2]],
        "cross_range_known": False,
        "range_m": range_coordinate(tr, m.position_m),
        "range_std_m": float(m.bound.range_position_m),
        "velocity_mps": [float(v) for v in m.velocity_mps],
        "range_speed_mps": float(m.range_speed_mps),
        "cross_range_speed_mps": float(m.cross_range_speed_mps),
        "peak_db": float(m.image_peak_db),
        "g_peak_db": float(m.evidence.statistic_db),
        "image_peak_m": [float(v) for v in m.image_peak_m],
        "cross_range_family": {
            "position_per_m": [float(v) for v in m.family_position_per_m],
            "velocity_mps_per_m": [float(v) for v in m.family_velocity_per_m],
            "in_scene": in_scene,
        },
    }
    ev, b = m.evidence, m.bound
    entry["detection"] = {
        "statistic_db": float(ev.statistic_db),
        "threshold_db": float(ev.threshold_db),
        "false_alarm_rate": float(ev.false_alarm_rate),
        "p_value": float(ev.p_value),
        "width_resolutions": float(ev.width_resolutions),
        "focus_gain_db": float(ev.focus_gain_db),
        "stationary_point_m": [float(v) for v in ev.stationary_point_m],
        "stationary_within_extent": bool(ev.stationary_within_extent),
    }
    if ev.coherent_statistic_db is not None:  # the coherent detector's stage 2
        entry["detection"]["coherent"] = {
            "statistic_db": float(ev.coherent_statistic_db),
            "threshold_db": float(ev.coherent_threshold_db),
            "p_value": float(ev.coherent_p_value),
        }
    if ev.defocus is not None:  # found in the stationary band by its focus
        d = ev.defocus
        entry["detection"]["defocus"] = {
            "statistic_db": float(d.statistic_db),
            "threshold_db": float(d.threshold_db),
            "p_value": float(d.p_value),
            "smear_margin_db": float(d.smear_margin_db),
            "bank_cross_range_speed_mps": float(d.bank_cross_range_speed_mps),
        }
    entry["standard_errors"] = {
        "range_position_m": b.range_position_m,
        "range_speed_mps": b.range_speed_mps,
        "cross_range_speed_mps": b.cross_range_speed_mps,
        "amplitude": b.amplitude,
        "kind": "Cramér–Rao bound at the measured SNR, cross-range coordinate held",
    }
    entry["snr_db"] = b.snr_db
    entry["amplitude"] = [float(m.fit.amplitude.real), float(m.fit.amplitude.imag)]
    entry["amplitude_complex"] = {"re": entry["amplitude"][0], "im": entry["amplitude"][1]}
    entry["g_perp_cross_range_speed_mps"] = float(m.g_perp.speed_mps)
    lobes = m.separated_fit  # the global search over cross-range speed ran on S
    entry["likelihood_lobes"] = {
        "ambiguous": bool(lobes.ambiguous),
        "lobe_ratio": float(lobes.lobe_ratio),
        "other_cross_range_speed_mps": (
            None
            if lobes.other_cross_range_speed_mps is None
            else float(lobes.other_cross_range_speed_mps)
        ),
    }
    acc = m.acceleration  # None on one sub-aperture: not separable from u_p there
    entry["range_acceleration_mps2"] = (
        float(acc.range_acceleration_mps2) if acc is not None and acc.estimable else None
    )
    entry["range_acceleration_std_mps2"] = None if acc is None else float(acc.std_mps2)
    entry["range_acceleration_estimable"] = bool(acc is not None and acc.estimable)
    if m.trajectory is not None:
        knots = m.trajectory.knot_times_s
        times = np.r_[knots[:, 0], knots[-1, 1]]
        entry["trajectory"] = {
            "slow_times_s": times.tolist(),
            "velocities_mps": m.trajectory.velocities_mps.tolist(),
            "positions_m": _knot_positions(m.trajectory, times).tolist(),
        }
    return entry


def _knot_positions(tj: TrajectoryEstimate, times: np.ndarray) -> np.ndarray:
    """Ground positions (m) of the piecewise-linear trajectory at ``times`` (s), shape (n, 2).

    ``rho(t) = rho(0) + integral_0^t u(s) ds`` with ``u`` the velocity of each straight
    segment ``[knot_k, knot_k+1]`` (the estimate's definition).
    """
    a, b = tj.knot_times_s[:, 0], tj.knot_times_s[:, 1]
    t = np.asarray(times, dtype=np.float64)[:, None]
    # signed length of each segment's overlap with [0, t] (negative for t < 0)
    forward = np.clip(np.minimum(b, t) - np.maximum(a, 0.0), 0.0, None)
    backward = np.clip(np.minimum(b, 0.0) - np.maximum(a, t), 0.0, None)
    lengths = np.where(t >= 0.0, forward, -backward)
    return tj.position_at_zero_m[:2][None, :] + lengths @ tj.velocities_mps


def _not_estimated(c: NotEstimated) -> dict[str, Any]:
    return {
        "range_speed_mps": float(c.range_speed_mps),
        "statistic_db": float(c.statistic_db),
        "width_resolutions": float(c.width_resolutions),
        "range_m": float(c.range_m),
    }


def _detection(result: AnalysisResult) -> dict[str, Any] | None:
    """The detector's test and every ``g(u)`` candidate (:mod:`sarmotion.motion.detector`)."""
    d = result.detection
    if d is None:
        return None
    st = d.statistics
    return {
        "statistic": "g(u) peak over the median of g at 2-12 range-speed resolutions (dB)",
        "threshold_db": float(d.threshold_db),
        "false_alarm_rate": float(d.false_alarm_rate),
        "n_candidates": d.n_candidates,
        "null_tail": dict(NULL_TAIL),
        "min_speed_mps": float(d.min_speed_mps),
        "max_width_resolutions": float(d.max_width),
        "min_focus_gain_db": float(result.options.min_focus_gain_db),
        "candidates": [
            {"range_speed_mps": float(u), "statistic_db": float(t), "width_resolutions": float(w)}
            for u, t, w in zip(st.speeds_mps, st.statistic_db, st.width_resolutions, strict=True)
            if t >= d.threshold_db - 3.0
        ],
    }


def _jsonable(v: Any) -> bool:
    return isinstance(v, str | int | float | bool) or (
        isinstance(v, list | tuple) and all(isinstance(x, str | int | float | bool) for x in v)
    )
