"""The ``sarmotion.results/1`` document: an analysis as JSON-ready data.

Top-level keys: ``schema``, ``method``, ``reference_point_m``, ``platform_speed_mps``,
``n_pulses``, ``n_samples``, ``aperture_s``, ``aperture_deg``,
``range_speed_resolution_mps``, ``detection`` (the test: statistic, threshold,
false-alarm rate, the measured null tail, every candidate), ``movers`` (position_m,
velocity_mps, range and cross-range speeds, peak levels, ``detection`` (statistic,
threshold, false-alarm rate, p-value, width, focus gain), ``standard_errors`` (the
Cramér–Rao bound at the measured SNR), ``snr_db``, ``amplitude``,
``g_perp_cross_range_speed_mps``, ``likelihood_lobes``, ``cross_range_family``,
``trajectory``),
``stationary``, ``timings_s``, ``options``, ``source``; for simulated inputs also
``truth``, per-mover ``errors``, ``false_movers`` and ``missed_movers``
(:mod:`sarmotion.pipeline.truth`).

The schema name stays ``sarmotion.results/1``: ``detection``, and per mover
``detection``, ``standard_errors``, ``snr_db``, ``amplitude`` and
``g_perp_cross_range_speed_mps``, were added; no key was removed or changed meaning
except ``g_peak_db``, now the ``g(u)`` peak over its *local* floor (the detector's
statistic) instead of over the global median. ``timings_s`` also holds
``movers.<step>`` entries, the mover stage's steps (:mod:`sarmotion.pipeline.movers`),
which ``total`` does not count. Per mover, ``likelihood_lobes`` was added: whether the
matched filter's likelihood has a second maximum on another lobe within
``motion.likelihood.NEAR_EQUAL_LOBES`` of the fit's ``|I|`` (``ambiguous``), the ratio of
the best other lobe's ``|I|`` to the fit's (``lobe_ratio``) and that lobe's cross-range
speed (m/s, null when there is none).
"""

from __future__ import annotations

from typing import Any

from ..motion import NULL_TAIL, azimuth_span_deg
from ..pipeline import AnalysisResult, Mover, TruthComparison

__all__ = ["RESULTS_SCHEMA", "results_document"]

#: Schema name of the results document.
RESULTS_SCHEMA = "sarmotion.results/1"


def results_document(
    result: AnalysisResult, *, truth: TruthComparison | None = None
) -> dict[str, Any]:
    """The ``sarmotion.results/1`` document of ``result`` (lists, floats, strings).

    Parameters
    ----------
    result : AnalysisResult
        The analysis.
    truth : TruthComparison, optional
        Its comparison with the true scene; adds ``truth``, per-mover ``errors``,
        ``false_movers`` and ``missed_movers``.
    """
    tr = result.traces
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
        "detection": _detection(result),
        "movers": [_mover(m) for m in result.movers],
        "stationary": [
            {"position_m": list(s.position_m), "peak_db": float(s.level_db)}
            for s in result.stationary
        ],
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


def _mover(m: Mover) -> dict[str, Any]:
    entry: dict[str, Any] = {
        "position_m": [float(v) for v in m.position_m[:2]],
        "velocity_mps": [float(v) for v in m.velocity_mps],
        "range_speed_mps": float(m.range_speed_mps),
        "cross_range_speed_mps": float(m.cross_range_speed_mps),
        "peak_db": float(m.image_peak_db),
        "g_peak_db": float(m.evidence.statistic_db),
        "image_peak_m": [float(v) for v in m.image_peak_m],
        "cross_range_family": {
            "position_per_m": [float(v) for v in m.family_position_per_m],
            "velocity_mps_per_m": [float(v) for v in m.family_velocity_per_m],
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
    entry["standard_errors"] = {
        "range_position_m": b.range_position_m,
        "range_speed_mps": b.range_speed_mps,
        "cross_range_speed_mps": b.cross_range_speed_mps,
        "amplitude": b.amplitude,
        "kind": "Cramér–Rao bound at the measured SNR, cross-range coordinate held",
    }
    entry["snr_db"] = b.snr_db
    entry["amplitude"] = [float(m.fit.amplitude.real), float(m.fit.amplitude.imag)]
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
    if m.trajectory is not None:
        knots = m.trajectory.knot_times_s
        entry["trajectory"] = {
            "slow_times_s": knots[:, 0].tolist() + [float(knots[-1, 1])],
            "velocities_mps": m.trajectory.velocities_mps.tolist(),
        }
    return entry


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
