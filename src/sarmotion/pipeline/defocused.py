"""Movers the separation took for stationary: found by their defocus, fitted on the data.

A mover whose apparent range speed lies in the stationary band that ``g(u)`` leaves
untested (:func:`~sarmotion.pipeline.find_range_speeds`) images inside the scene as a
string of stationary points, and the separation leaves most of its echo in ``L``
(:mod:`sarmotion.motion.defocus`). Such movers are sought on the data ``D`` of the
central sub-aperture, less the movers already accepted (their models at full
amplitude), one at a time:

1. the cross-range-speed bank (:func:`~sarmotion.motion.defocus_scan`) over the
   stationary band and the scene's range span, at the analysis's false-alarm rate;
2. its candidates, most powerful first, are fitted by
   maximum likelihood from their cell (:func:`~sarmotion.motion.fit_point_mover_at`)
   and tested: the generalized likelihood ratio of the fit against the interference
   around it (:func:`~sarmotion.motion.coherent_statistic_db`, whose neighbourhood
   level counts the smears of the stationary clutter the data still hold) must reach
   the coherent detector's threshold for the candidates fitted so far
   (:func:`~sarmotion.motion.coherent_threshold_db`, the measured null tail and the union
   bound), the best stationary point with the same range history must not focus them
   within ``min_focus_gain_db`` (:func:`~sarmotion.motion.stationary_explanation`), and
   the fit's cross-range speed must be at least the bank's first step from zero (else
   it is a stationary point, focused);
3. an accepted fit's model is subtracted and the bank runs again, until a bank gives
   no candidate that passes, ``max_movers`` is reached, or ``MAX_REJECTED`` echoes
   were rejected (the bank ranks by power, so those after are weaker still; a rejected
   echo's cells at other ``w``, within two range cells and two range-speed resolutions,
   are not tried again).

The mover stage then takes the data without the stationary targets near these movers
(``D - L'``, :func:`~sarmotion.pipeline.refit.data_without_stationary`) as their moving
traces, since ``S`` holds little of them.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..core import Traces
from ..core.constants import C
from ..core.geometry import range_direction_velocity
from ..motion import (
    PointFit,
    coherent_false_alarm_probability,
    coherent_statistic_db,
    coherent_threshold_db,
    defocus_scan,
    fit_point_mover_at,
    point_model,
    stationary_explanation,
)
from ..motion.defocus import DefocusCandidate, DefocusScan
from ..motion.detector import peak_statistics
from ..motion.range_speed import range_speed_objective
from ..motion.speed_resolution import range_speed_resolution
from .detection import DetectionResult
from .results import DefocusEvidence, MoverEvidence

log = logging.getLogger(__name__)

__all__ = ["MAX_REJECTED", "defocused_movers"]

#: Echoes rejected after which a bank's remaining candidates are not tried.
MAX_REJECTED = 3


def _g_speed(traces: Traces, rate_mps: float) -> float:
    """The ``g(u)`` range speed whose aligned trace has range rate ``rate_mps`` (m/s)."""
    s = traces.slow_times_s
    ref = traces.reference_point_m
    x = traces.positions_m

    def rate(u: float) -> float:
        v = np.r_[range_direction_velocity(u, traces.geometry), 0.0]
        r = np.linalg.norm(x - (ref[None, :] + s[:, None] * v[None, :]), axis=1)
        r -= np.linalg.norm(x - ref[None, :], axis=1)
        return float(np.polyfit(s, r, 1)[0])

    return float(rate_mps) / rate(1.0)


def _g_evidence(traces: Traces, speed_mps: float) -> tuple[float, float]:
    """``g(u)``'s statistic (dB) and peak width (resolutions) at ``speed_mps`` on ``traces``.

    ``g`` on +-12 range-speed resolutions at half a resolution, the local maximum nearest
    ``speed_mps`` (:func:`~sarmotion.motion.detector.peak_statistics`); for the record:
    the mover was declared by its focus, and its ``g`` peak is in the stationary band.
    """
    res = range_speed_resolution(traces)
    grid = speed_mps + 0.5 * res * np.arange(-24, 25)
    stats = peak_statistics(grid, range_speed_objective(traces, grid), res)
    if stats.speeds_mps.size == 0:  # g has no local maximum there
        return float("-inf"), 0.0
    i = int(np.argmin(np.abs(stats.speeds_mps - speed_mps)))
    return float(stats.statistic_db[i]), float(stats.width_resolutions[i])


def _same_echo(a: DefocusCandidate, b: DefocusCandidate, cell_s: float, res_u: float) -> bool:
    """Within two range cells and two range-speed resolutions: one echo, seen at two ``w``."""
    return (
        abs(a.delay_s - b.delay_s) <= 2.0 * cell_s
        and abs(a.range_speed_mps - b.range_speed_mps) <= 2.0 * res_u
    )


def _try(
    data: NDArray[np.complexfloating],
    cand: DefocusCandidate,
    sub: Traces,
    min_step_mps: float,
    min_focus_gain_db: float,
    glr_threshold_db: float,
) -> tuple[PointFit, object, float] | None:
    """The fit of one candidate and its stationary explanation, or ``None`` if rejected."""
    tr = sub.with_data(data)
    fit = fit_point_mover_at(
        tr, cand.delay_s, _g_speed(sub, cand.range_speed_mps), cand.cross_range_speed_mps
    )
    if abs(fit.cross_range_speed_mps) < min_step_mps:
        log.info("defocus candidate: the fit is focused as a stationary point")
        return None
    value = fit.amplitude * sub.n_pulses
    glr = coherent_statistic_db(tr, fit.position_m, fit.velocity_mps, value=value)
    if glr < glr_threshold_db:
        log.info(
            "defocus candidate at u_p %.2f m/s: likelihood ratio %.2f dB under %.2f dB",
            fit.cross_range_speed_mps,
            glr,
            glr_threshold_db,
        )
        return None
    why = stationary_explanation(tr, fit.position_m, fit.velocity_mps, value)
    if why.within_extent and why.focus_gain_db < min_focus_gain_db:
        log.info(
            "defocus candidate at u_p %.2f m/s: a stationary point at (%.1f, %.1f) m explains "
            "it (focus gain %.2f dB)",
            fit.cross_range_speed_mps,
            *why.position_m[:2],
            why.focus_gain_db,
        )
        return None
    return fit, why, glr


def defocused_movers(
    detection: DetectionResult,
    accepted: Sequence[PointFit],
    *,
    max_movers: int,
) -> list[tuple[PointFit, MoverEvidence]]:
    """Movers in the stationary band, fitted on the data (module notes).

    Parameters
    ----------
    detection : DetectionResult
        The separation and the ``g(u)`` test: its central sub-aperture's data ``D``, its
        stationary band (``candidates.min_speed_mps``), threshold and the scene's grid.
    accepted : sequence of PointFit
        The movers ``g(u)`` found, at full amplitude on ``D`` (their models are
        subtracted first).
    max_movers : int
        How many more may be accepted.

    Returns
    -------
    list of (PointFit, MoverEvidence)
        The accepted fits (on ``D``) and their records, in the order accepted.
    """
    opts = detection.options
    sub = detection.sub
    data = np.array(sub.data, dtype=np.complex128)
    for f in accepted:
        data -= point_model(sub, f.position_m, f.velocity_mps, f.amplitude)
    x0, x1, y0, y1 = detection.image.grid.extent
    half_diagonal = 0.5 * float(np.hypot(x1 - x0, y1 - y0))
    band = float(detection.candidates.min_speed_mps)
    max_speed = float(max(abs(v) for v in opts.speed_range_mps))
    out: list[tuple[PointFit, MoverEvidence]] = []
    tried = 0  # candidates fitted: the N of the likelihood ratio's union bound
    cell_s = 1.0 / sub.radar.bandwidth_hz
    res_u = range_speed_resolution(sub)
    while len(out) < max_movers:
        scan = defocus_scan(
            sub.with_data(data),
            max_speed_mps=max_speed,
            band_mps=band,
            half_span_s=2.0 * half_diagonal / C,
            false_alarm_rate=opts.false_alarm_rate,
        )
        step = float(np.min(np.abs(scan.speeds_mps[scan.speeds_mps != 0.0])))
        found = None
        rejected: list[DefocusCandidate] = []
        for cand in scan.candidates:
            if len(rejected) >= MAX_REJECTED:
                break
            if any(_same_echo(cand, r, cell_s, res_u) for r in rejected):
                continue  # that echo's focus at another w: rejected already
            tried += 1
            threshold = coherent_threshold_db(opts.false_alarm_rate, tried)
            got = _try(data, cand, sub, step, opts.min_focus_gain_db, threshold)
            if got is not None:
                found = (cand, *got)
                break
            rejected.append(cand)
        if found is None:
            break
        cand, fit, why, glr = found
        data -= point_model(sub, fit.position_m, fit.velocity_mps, fit.amplitude)
        coherent = (glr, coherent_threshold_db(opts.false_alarm_rate, tried), tried)
        out.append((fit, _evidence(sub.with_data(data), detection, scan, cand, fit, why, coherent)))
        log.info(
            "defocus: mover at u_r %.2f m/s, u_p %.2f m/s (margin %.1f dB over the stationary "
            "smear, %.1f dB over noise)",
            fit.range_speed_mps,
            fit.cross_range_speed_mps,
            cand.leak_db,
            cand.statistic_db,
        )
    return out


def _evidence(
    left: Traces,
    detection: DetectionResult,
    scan: DefocusScan,
    cand: DefocusCandidate,
    fit: PointFit,
    why: object,
    coherent: tuple[float, float, int],
) -> MoverEvidence:
    """The record of a mover found by its defocus: the bank's numbers and ``g``'s."""
    det = detection.candidates
    alone = left.with_data(
        left.data + point_model(left, fit.position_m, fit.velocity_mps, fit.amplitude)
    )
    stat, width = _g_evidence(alone, fit.range_speed_mps)
    return MoverEvidence(
        statistic_db=stat,
        threshold_db=det.threshold_db,
        false_alarm_rate=det.false_alarm_rate,
        p_value=det.false_alarm_probability(stat),
        width_resolutions=width,
        focus_gain_db=why.focus_gain_db,
        stationary_point_m=(float(why.position_m[0]), float(why.position_m[1])),
        stationary_within_extent=why.within_extent,
        coherent_statistic_db=coherent[0],
        coherent_threshold_db=coherent[1],
        coherent_p_value=coherent_false_alarm_probability(coherent[0], coherent[2]),
        defocus=DefocusEvidence(
            statistic_db=cand.statistic_db,
            threshold_db=scan.threshold_db,
            p_value=scan.p_value(cand.statistic_db),
            smear_margin_db=cand.leak_db,
            bank_cross_range_speed_mps=cand.cross_range_speed_mps,
        ),
    )
