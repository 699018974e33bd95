"""Movers the separation took for stationary: found by their defocus, fitted on the data.

A mover whose apparent range speed lies in the stationary band that ``g(u)`` leaves
untested (:func:`~sarmotion.pipeline.find_range_speeds`) images inside the scene as a
string of stationary points, and the separation leaves most of its echo in ``L``
(:mod:`sarmotion.motion.defocus`). Such movers are sought on the data ``D`` of the
central sub-aperture, less the movers already accepted (their models at full
amplitude: :func:`search_data`), one at a time:

1. the cross-range-speed bank (:func:`~sarmotion.motion.defocus_scan`) over the
   stationary band and the scene's range span, at the analysis's false-alarm rate;
2. the strongest cell (largest statistic, the power over its interference) of each of
   its first ``MAX_REJECTED`` echoes (an echo: cells within two range cells and two
   range-speed resolutions, one target seen at several ``w``), strongest echo first, is
   fitted by maximum likelihood from its cell
   (:func:`~sarmotion.motion.fit_point_mover_at`) and rejected when stationary points
   explain it (:meth:`CandidateTest.stationary`): the fit is focused as a stationary
   point (its cross-range speed under the bank's first step), or the best stationary
   point with its range history focuses it within ``min_focus_gain_db``
   (:func:`~sarmotion.motion.stationary_explanation`), or the stationary points near its
   range history, fitted jointly with it, leave it less than half its amplitude
   (:func:`joint_amplitude`: several stationary points whose Doppler tones lie along
   a moving signature's sweep match it in part, and none of them alone does), or its
   per-pulse sums keep less than half their power in their coherent sum (one point
   target's echo keeps all of it; clutter matched in part turns in phase from pulse to
   pulse). A fit that stationary points do not explain is still rejected when it does
   not cancel its echo (:attr:`CandidateTest.residue`): one point target's model,
   subtracted, leaves at the cells of its own echo (its main lobe in the candidate's
   hypothesis) only the interference there, which the screen's smear margin holds under
   half the candidate's amplitude, so at most ``MAX_ECHO_RESIDUE`` of its peak power, and
   nothing elsewhere in the echo's extent that the stationary points' smears do not
   explain (:func:`~sarmotion.motion.defocus.echo_residue`); an
   echo the model does not describe (the residue of a bright echo cut by a patch's
   fast-time window among clutter smears) keeps its power or gains. A rejected echo's
   most powerful cell, when it is another (:func:`cells_to_fit`), is fitted and tested
   the same way: the statistic divides by the interference of the cell's range bin, so
   a hypothesis whose bin holds less clutter can rank a cell first where the echo
   focuses worse. The false-alarm rate is the screen's (the interference model and the
   union bound over the bank's cells); the tests only remove candidates, and their
   measured effect on data without movers is
   ``benchmarks/results/detector_null_defocus.md``;
3. an accepted fit's model is subtracted and the bank runs again, until a bank gives
   no candidate that passes, ``max_movers`` is reached, or its first ``MAX_REJECTED``
   echoes were rejected (the bank ranks them by statistic, so those after are weaker
   still).

**The wide search.** A mover slower across the line of sight than the central bank's
first step ``w_1`` has, over the central sub-aperture, at most a quarter turn of
quadratic phase against the stationary point with its range history: its fit is
refused as a stationary point (:attr:`CandidateTest.focused_stationary`, or a focus
gain under ``min_focus_gain_db``), and a weak fit that comes with its echo can be
accepted instead (on the square-kilometre benchmark, a false mover 27 range cells from
the echo of a 12.8 m/s mover 0.8 m/s across the line of sight, gone once that echo is
subtracted). The quadratic phase
grows with the aperture's square: with ``wide_defocus_search`` (off by default:
:class:`~sarmotion.pipeline.AnalysisOptions` says why), where the data hold more pulses,
the bank also searches ``|w| <= w_1`` over twice the central sub-aperture about the same
middle pulse
(:func:`wide_pulses`; its steps about ``w_1 / 4``), keystoned
(:func:`~sarmotion.motion.defocus.keystone_spectrum`: over that span the band's
stationary points walk through several range cells, which the screen's smear model does
not take). Both banks share one union bound (the sum of their cells,
:func:`~sarmotion.motion.defocus.screen_cells`, at the analysis's false-alarm rate);
each round their echoes are tried together, the strongest by statistic first, each
fitted and tested on its own span's data (the two share ``s = 0``: a fit on one is a
fit on the other), and an accepted fit is subtracted from both.

The mover stage then takes the data without the stationary targets near these movers
(``D - L'``, :func:`~sarmotion.pipeline.refit.data_without_stationary`) as their moving
traces, since ``S`` holds little of them.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import maximum_filter

from ..core import Traces
from ..core.constants import C
from ..core.geometry import range_direction_velocity
from ..imaging import backproject_points, resolution
from ..motion import (
    PointFit,
    StationaryExplanation,
    defocus_scan,
    fit_point_mover_at,
    point_model,
    stationary_explanation,
)
from ..motion.acceleration import HOLD_COHERENCE, uniform_start_holds
from ..motion.aperture import ranges_m
from ..motion.defocus import (
    DefocusCandidate,
    DefocusScan,
    cross_speed_bank,
    echo_residue,
    screen_cells,
)
from ..motion.detector import peak_statistics
from ..motion.likelihood import noise_variance
from ..motion.range_speed import range_speed_objective
from ..motion.speed_resolution import range_speed_resolution
from ..separation.combined import stationary_location
from .detection import DetectionResult
from .results import DefocusEvidence, MoverEvidence

log = logging.getLogger(__name__)

__all__ = [
    "MAX_ECHO_RESIDUE",
    "MAX_REJECTED",
    "CandidateTest",
    "defocused_movers",
    "cells_to_fit",
    "distinct_echoes",
    "JOINT_RATIO",
    "MAX_NEAR",
    "joint_amplitude",
    "scan_detection",
    "search_data",
    "stationary_near",
    "test_candidate",
    "wide_pulses",
]

#: Echoes rejected after which a bank's remaining candidates are not tried.
MAX_REJECTED = 3

#: Ground-range cells either side of a fit's range where stationary points that may
#: explain it are sought (:func:`stationary_near`): a point's range side lobes there are
#: within the compressed pulse's first three.
NEAR_CELLS = 3

#: Most stationary points sought near a candidate's range history (:func:`stationary_near`).
MAX_NEAR = 16

#: Least fraction of a candidate's amplitude left when fitted with the stationary points
#: near its range history (:func:`joint_amplitude`): half, the bank's 6 dB smear margin.
JOINT_RATIO = 0.5

#: Most of a candidate's echo power (the peak over its model's main lobe and the echo's
#: cells no stationary smear explains, :func:`~sarmotion.motion.defocus.echo_residue`)
#: that its fit may leave once subtracted:
#: ``(1/2)^2``, the screen's smear margin (what is left of a point target's echo are the
#: smears, under half its amplitude).
MAX_ECHO_RESIDUE = 0.25


def _g_speed(traces: Traces, rate_mps: float) -> float:
    """The ``g(u)`` range speed whose aligned trace has range rate ``rate_mps`` (m/s)."""
    ref = traces.reference_point_m
    along = range_direction_velocity(1.0, traces.geometry)
    r = ranges_m(traces, ref, along) - ranges_m(traces, ref, np.zeros(2))
    return float(rate_mps) / float(np.polyfit(traces.slow_times_s, r, 1)[0])


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


@dataclass(frozen=True, kw_only=True, eq=False)
class CandidateTest:
    """One bank candidate fitted and tested (:func:`test_candidate`).

    Attributes
    ----------
    candidate : DefocusCandidate
        The bank's cell.
    fit : PointFit
        The maximum-likelihood fit from it, on the data searched.
    explanation : StationaryExplanation
        The best stationary point with the fit's range history, and the focus gain.
    focused_stationary : bool
        The fit's cross-range speed is under the bank's first step: a stationary point.
    joint_ratio : float
        ``|a_joint| / |a|``: the fit's amplitude when fitted jointly (least squares) with
        the stationary points whose range histories pass near its own, over its
        amplitude alone (:func:`joint_amplitude`); NaN when not computed
        (:func:`test_candidate`).
    coherence : float
        The coherent share of the fit's per-pulse power, noise removed
        (:func:`~sarmotion.motion.acceleration.uniform_start_holds`): 1 for one point
        target's echo, NaN without power above the noise.
    residue : float
        The peak power of the candidate's echo once the fit's model is subtracted, over
        its peak power before, at the cells of the model's own echo and at those of the
        echo's extent that no stationary smear explains
        (:func:`~sarmotion.motion.defocus.echo_residue`): near 0 for one point target's
        echo.
    """

    candidate: DefocusCandidate
    fit: PointFit
    explanation: StationaryExplanation
    focused_stationary: bool
    joint_ratio: float
    coherence: float
    residue: float

    @property
    def cancels(self) -> bool:
        """Whether the fit's model removes its echo: ``residue <= MAX_ECHO_RESIDUE``."""
        return bool(self.residue <= MAX_ECHO_RESIDUE)

    def stationary(self, min_focus_gain_db: float) -> bool:
        """Whether the stationary scene explains it (then it is not a mover).

        The fit is focused as a stationary point, or the best stationary point with its
        range history focuses it within ``min_focus_gain_db``, or the stationary points
        near its range history, fitted with it, leave it less than half its amplitude
        (``JOINT_RATIO``: the 6 dB of the bank's smear margin), or its echo is not one
        point target's: its per-pulse sums keep less than ``HOLD_COHERENCE`` of their
        power in their coherent sum (the clutter's tones along a moving signature turn
        in phase from pulse to pulse; a point mover's do not). The share is at most 1
        (Cauchy-Schwarz); an estimate further above 1 than the rule's margin below it
        (``2 - HOLD_COHERENCE``) means the noise taken off exceeded what the candidate's
        pulses hold beyond it: its power is at the noise level, the share is not
        measured, and the candidate is not confirmed. A joint ratio not computed (NaN,
        :func:`test_candidate`) refuses nothing: the other tests decide.
        """
        why = self.explanation
        return (
            self.focused_stationary
            or (why.within_extent and why.focus_gain_db < min_focus_gain_db)
            or self.joint_ratio < JOINT_RATIO
            or not HOLD_COHERENCE <= self.coherence <= 2.0 - HOLD_COHERENCE
        )


def joint_amplitude(data: Traces, fit: PointFit, stationary_m: NDArray[np.float64]) -> complex:
    """The fit's amplitude, least squares jointly with stationary points (data units).

    The columns are the fit's signature and each stationary point's
    (:func:`~sarmotion.motion.point_model`, unit amplitude); the data are ``data``. A
    mover's signature, defocused against every stationary one, keeps its amplitude; a
    structure of several stationary points that a moving signature partly matches
    (their Doppler tones along its sweep) goes to the stationary columns.
    """
    cols = [point_model(data, fit.position_m, fit.velocity_mps, 1.0).ravel()]
    cols += [point_model(data, p, np.zeros(2), 1.0).ravel() for p in stationary_m]
    a = np.stack(cols, axis=1)
    coef = np.linalg.lstsq(a, np.asarray(data.data, dtype=np.complex128).ravel(), rcond=None)[0]
    return complex(coef[0])


def stationary_near(
    data: Traces, fit: PointFit, cross_offset_m: float, *, phase_history: NDArray | None = None
) -> NDArray[np.float64]:
    """Stationary points that may explain a fit (m), shape ``(k, 3)``.

    Searched within ``NEAR_CELLS`` ground-range cells of the fit's range (whose range side
    lobes reach it) over the cross ranges its Doppler sweeps (the zero-range-speed
    member's, ``cross_offset_m`` from the fit, plus or minus ``|u_p| T`` and two
    cross-range cells), sampled at a quarter of a cross-range cell and half a range cell,
    for points at least half as bright as the fit's ``|I|`` (a defocused mover's own image
    breaks into peaks of about ``1 / sqrt(TB)`` of its amplitude, ``TB`` its Doppler sweep
    over the resolution: under half beyond the bank's first steps), each refined and
    Doppler-tested as the combined separation takes its stationary points
    (:func:`~sarmotion.separation.combined.stationary_location`): first the local maxima
    of the stationary image; then, one at a time, the brightest point of the image of
    what the points found leave of the data (least squares on their unit signatures,
    :func:`~sarmotion.motion.point_model`; a point that fails the test is skipped with
    the samples beside it). Two points closer than a resolution cell, which the image
    shows as one broad peak, are so found as two: one point at the peak leaves the other
    in the residual. At most ``MAX_NEAR`` points. ``phase_history`` is the data's, if
    already computed.
    """
    cells = resolution(data)
    e_r = np.r_[cells.range_direction, 0.0]
    e_c = np.r_[cells.cross_range_direction, 0.0]
    duration = float(np.ptp(data.slow_times_s))
    half = abs(fit.cross_range_speed_mps) * duration + 2.0 * cells.cross_range_m
    step = 0.25 * cells.cross_range_m
    ys = cross_offset_m + np.arange(-half, half + step, step)  # along cross range
    xs = 0.5 * cells.ground_range_m * np.arange(-2 * NEAR_CELLS, 2 * NEAR_CELLS + 1)
    pts = (
        np.asarray(fit.position_m, dtype=np.float64)[None, None, :]
        + xs[:, None, None] * e_r[None, None, :]
        + ys[None, :, None] * e_c[None, None, :]
    )
    level = 0.5 * abs(fit.amplitude) * data.n_pulses
    out: list[NDArray[np.float64]] = []

    def add(traces: Traces, point: NDArray[np.float64], spectrum: NDArray | None) -> bool:
        p = stationary_location(traces, point, phase_history=spectrum)
        if p is None or any(np.hypot(*(p[:2] - q[:2])) <= 0.5 * step for q in out):
            return False
        out.append(p)
        return True

    mag = np.abs(backproject_points(data, pts))  # (rows, ny)
    peak = (mag == maximum_filter(mag, size=3, mode="constant")) & (mag >= level)
    for r, i in zip(*np.nonzero(peak), strict=True):
        add(data, pts[r, i], phase_history)
    d = np.asarray(data.data, dtype=np.complex128).ravel()
    skipped = np.zeros(pts.shape[:2], dtype=bool)
    columns = [point_model(data, p, np.zeros(2), 1.0).ravel() for p in out]
    while out and len(out) < MAX_NEAR:
        columns += [point_model(data, p, np.zeros(2), 1.0).ravel() for p in out[len(columns) :]]
        a = np.stack(columns, axis=1)
        left = data.with_data((d - a @ np.linalg.lstsq(a, d, rcond=None)[0]).reshape(data.shape))
        mag = np.where(skipped, 0.0, np.abs(backproject_points(left, pts)))
        r, i = np.unravel_index(int(np.argmax(mag)), mag.shape)
        if mag[r, i] < level:
            break
        if not add(left, pts[r, i], None):
            skipped[max(r - 1, 0) : r + 2, max(i - 1, 0) : i + 2] = True
    return np.array(out, dtype=np.float64).reshape(-1, 3)


def test_candidate(
    data: Traces,
    cand: DefocusCandidate,
    min_step_mps: float,
    min_focus_gain_db: float | None = None,
    *,
    band_mps: float,
    extent_m: float | None = None,
    extent_centre_m: ArrayLike | None = None,
) -> CandidateTest:
    """Fit one bank candidate on ``data`` from its cell and test it against stationary points.

    The stationary points that may explain it (:func:`stationary_near`) are fitted with
    it (:func:`joint_amplitude`), and its echo is measured with and without the fit's
    model (:attr:`CandidateTest.residue`; ``band_mps``, m/s, the bank's stationary band,
    whose points' smears explain cells of the echo's extent). With ``min_focus_gain_db``
    (the analysis's rule, dB) that joint fit, the costliest test, runs only when the others
    have not already refused the candidate (its echo not cancelled, focused as stationary,
    a stationary point within the focus gain, or incoherent): the verdict of
    :meth:`CandidateTest.stationary` and :attr:`CandidateTest.cancels` together is the
    same, and ``joint_ratio`` is NaN when skipped. Without it every test runs.
    ``extent_m``, ``extent_centre_m``: where a stationary point may explain it (m,
    :func:`~sarmotion.motion.stationary_explanation`; default the data's own).
    """
    fit = fit_point_mover_at(
        data, cand.delay_s, _g_speed(data, cand.range_speed_mps), cand.cross_range_speed_mps
    )
    value = fit.amplitude * data.n_pulses
    why = stationary_explanation(
        data,
        fit.position_m,
        fit.velocity_mps,
        value,
        extent_m=extent_m,
        extent_centre_m=extent_centre_m,
    )
    track = fit.position_m[None, :] + data.slow_times_s[:, None] * np.r_[fit.velocity_mps, 0.0]
    _, kappa = uniform_start_holds(data, track, noise_variance=noise_variance(data.data))
    model = point_model(data, fit.position_m, fit.velocity_mps, fit.amplitude)
    test = CandidateTest(
        candidate=cand,
        fit=fit,
        explanation=why,
        focused_stationary=abs(fit.cross_range_speed_mps) < min_step_mps,
        joint_ratio=float("nan"),
        coherence=float(kappa),
        residue=echo_residue(data, cand, model, band_mps),
    )
    if min_focus_gain_db is not None and (not test.cancels or test.stationary(min_focus_gain_db)):
        return test  # refused whatever the joint fit gives
    near = stationary_near(data, fit, why.cross_offset_m, phase_history=data.phase_history())
    joint = joint_amplitude(data, fit, near) if len(near) else fit.amplitude
    return replace(test, joint_ratio=abs(joint) / max(abs(fit.amplitude), 1e-300))


def wide_pulses(detection: DetectionResult) -> slice | None:
    """The pulses of the wide search: twice the central sub-aperture, about its middle.

    ``e = min(start, n - stop, (stop - start) // 2)`` pulses either side of the central
    sub-aperture ``start:stop`` of ``n``, so the two share their middle pulse and their
    ``s = 0`` (:meth:`~sarmotion.core.Traces.select_pulses`): a fit on either is a fit on
    the other. None where the data hold no pulse beyond the central sub-aperture.
    """
    c, n = detection.central, detection.traces.n_pulses
    e = min(c.start, n - c.stop, (c.stop - c.start) // 2)
    return slice(c.start - e, c.stop + e) if e > 0 else None


def search_data(
    detection: DetectionResult, accepted: Sequence[PointFit] = (), pulses: slice | None = None
) -> NDArray:
    """The data the bank searches: ``D`` of the central sub-aperture less accepted movers.

    The accepted movers' models (at full amplitude on ``D``) are subtracted; the
    stationary points stay, their smears tested against by the screen and their
    explanations by :meth:`CandidateTest.stationary` (removing them first, as the
    combined separation does, also removes up to half of a defocused mover, whose smear
    it partly takes for stationary points). ``pulses``: another span sharing the central
    sub-aperture's ``s = 0`` (:func:`wide_pulses`) instead of it.
    """
    sub = detection.sub if pulses is None else _pulses(detection, pulses)
    data = np.array(sub.data, dtype=np.complex128)
    for f in accepted:
        data -= point_model(sub, f.position_m, f.velocity_mps, f.amplitude)
    return data


def _pulses(detection: DetectionResult, pulses: slice) -> Traces:
    return detection.traces.select_pulses(pulses.start, pulses.stop)


def scan_detection(
    detection: DetectionResult,
    data: Traces,
    *,
    threshold_db: float | None = None,
    within_mps: float | None = None,
    cells_tested: int | None = None,
    keystone: bool = False,
) -> DefocusScan:
    """The bank on ``data`` over the detection's stationary band and its image's range span.

    ``threshold_db`` overrides the screen's level; ``within_mps`` limits the bank to
    ``|w| <= within_mps``, ``cells_tested`` is the union bound's count of cells and
    ``keystone`` keystones the data first (:func:`~sarmotion.motion.defocus_scan`).
    """
    return defocus_scan(
        data,
        **_bank_span(detection),
        false_alarm_rate=detection.options.false_alarm_rate,
        max_candidates=64,
        threshold_db=threshold_db,
        within_mps=within_mps,
        cells_tested=cells_tested,
        keystone=keystone,
    )


def _bank_span(detection: DetectionResult) -> dict[str, float]:
    """The bank's speeds, band and range span of the detection (m/s, m/s, s)."""
    opts = detection.options
    x0, x1, y0, y1 = detection.image.grid.extent
    half_diagonal = 0.5 * float(np.hypot(x1 - x0, y1 - y0))
    return {
        "max_speed_mps": float(max(abs(v) for v in opts.speed_range_mps)),
        "band_mps": float(detection.candidates.min_speed_mps),
        "half_span_s": 2.0 * half_diagonal / C,
    }


@dataclass(frozen=True, kw_only=True, eq=False)
class _Search:
    """One aperture the bank searches: its traces, data left, first step, bank limit and cells.

    ``cells``: the independent cells its bank tests (:func:`~sarmotion.motion.defocus.
    screen_cells`), summed over the searches for their shared union bound.
    """

    traces: Traces
    data: NDArray
    step_mps: float
    within_mps: float | None
    cells: int

    def scan(self, detection: DetectionResult, cells: int) -> DefocusScan:
        return scan_detection(
            detection,
            self.traces.with_data(self.data),
            within_mps=self.within_mps,
            cells_tested=cells,
            keystone=self.within_mps is not None,
        )


def _searches(detection: DetectionResult, accepted: Sequence[PointFit]) -> list[_Search]:
    """The central sub-aperture's bank and, where the data are longer, the wide one's.

    The central bank's first step ``w_1`` is where a degree's quadratic phase first
    tells a mover from a stationary point (:data:`~sarmotion.motion.defocus.
    EDGE_PHASE_STEP_RAD`); movers slower across the line of sight than that are
    sought over the wide span (:func:`wide_pulses`), whose steps are about a quarter as
    large (the edge phase grows with the aperture's square), at ``|w| <= w_1`` only.
    """
    span = _bank_span(detection)
    screen = {"band_mps": span["band_mps"], "half_span_s": span["half_span_s"]}
    sub = detection.sub
    central = cross_speed_bank(sub, span["max_speed_mps"])
    step = float(np.min(np.abs(central[central != 0.0])))
    out = [
        _Search(
            traces=sub,
            data=search_data(detection, accepted),
            step_mps=step,
            within_mps=None,
            cells=screen_cells(sub, central, **screen),
        )
    ]
    wide = wide_pulses(detection) if detection.options.wide_defocus_search else None
    if wide is None:
        return out
    tr = _pulses(detection, wide)
    fine = cross_speed_bank(tr, span["max_speed_mps"], within_mps=step)
    if not np.any(fine != 0.0):
        return out
    out.append(
        _Search(
            traces=tr,
            data=search_data(detection, accepted, wide),
            step_mps=float(np.min(np.abs(fine[fine != 0.0]))),
            within_mps=step,
            cells=screen_cells(tr, fine, **screen),
        )
    )
    return out


def distinct_echoes(scan: DefocusScan, data: Traces) -> list[list[DefocusCandidate]]:
    """The scan's candidates grouped by echo, the groups in the order of their strongest.

    One echo: cells within two range cells and two range-speed resolutions of the
    group's strongest; each group by decreasing statistic (the scan's order).
    """
    cell_s = 1.0 / data.radar.bandwidth_hz
    res_u = range_speed_resolution(data)
    groups: list[list[DefocusCandidate]] = []
    for c in scan.candidates:
        for g in groups:
            if _same_echo(c, g[0], cell_s, res_u):
                g.append(c)
                break
        else:
            groups.append([c])
    return groups


def cells_to_fit(echo: Sequence[DefocusCandidate]) -> list[DefocusCandidate]:
    """The cells of one echo that are fitted, in turn, until one passes.

    Its strongest cell by statistic (the screen's ranking, ``echo[0]`` of
    :func:`distinct_echoes`), then its most powerful (``power``: the hypothesis that
    focuses the target best) if that is another cell.
    """
    best = max(echo, key=lambda c: c.power)
    return [echo[0]] if best is echo[0] else [echo[0], best]


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
    searches = _searches(detection, accepted)
    cells = sum(a.cells for a in searches)
    out: list[tuple[PointFit, MoverEvidence]] = []
    taken: list[DefocusCandidate] = []
    cell_s = 1.0 / sub.radar.bandwidth_hz
    res_u = range_speed_resolution(sub)
    band = float(detection.candidates.min_speed_mps)  # the bank's, scan_detection
    while len(out) < max_movers:
        # each aperture's echoes, the strongest first over both (they share s = 0)
        echoes = []
        for a in searches:
            scan = a.scan(detection, cells)
            here = a.traces.with_data(a.data)
            echoes += [
                (e[0].statistic_db, i, a, here, scan, e)
                for i, e in enumerate(distinct_echoes(scan, here))
                if not any(_same_echo(e[0], t, cell_s, res_u) for t in taken)
            ]
        echoes.sort(key=lambda x: (-x[0], x[1]))
        found: tuple[CandidateTest, DefocusScan] | None = None
        for _, _, a, here, scan, echo in echoes[:MAX_REJECTED]:
            for cell in cells_to_fit(echo):
                test = test_candidate(
                    here,
                    cell,
                    a.step_mps,
                    opts.min_focus_gain_db,
                    band_mps=band,
                    extent_m=opts.alias_free_extent_m,
                    extent_centre_m=opts.alias_free_centre_m,
                )
                if not test.stationary(opts.min_focus_gain_db) and test.cancels:
                    found = (test, scan)
                    break
                _log_refusal(test)
            if found is not None:
                break
        if found is None:
            break
        test, scan = found
        fit = test.fit
        taken.append(test.candidate)  # what its model leaves there is not another mover
        for a in searches:
            a.data[...] -= point_model(a.traces, fit.position_m, fit.velocity_mps, fit.amplitude)
        out.append((fit, _evidence(sub.with_data(searches[0].data), detection, scan, test)))
        log.info(
            "defocus: mover at u_r %.2f m/s, u_p %.2f m/s (margin %.1f dB over the stationary "
            "smear, %.1f dB over its interference, %.2f of its amplitude left by the stationary "
            "points)",
            fit.range_speed_mps,
            fit.cross_range_speed_mps,
            test.candidate.leak_db,
            test.candidate.statistic_db,
            test.joint_ratio,
        )
    return out


def _log_refusal(test: CandidateTest) -> None:
    if not test.cancels:
        log.info(
            "defocus candidate at u_p %.2f m/s: its fit leaves %.2f of its echo's "
            "peak power (not one point target's echo)",
            test.fit.cross_range_speed_mps,
            test.residue,
        )
        return
    why = test.explanation
    log.info(
        "defocus candidate at u_p %.2f m/s: stationary (focus gain %.2f dB over "
        "(%.1f, %.1f) m, %.2f of its amplitude left by the stationary points near it, "
        "coherence %.2f)",
        test.fit.cross_range_speed_mps,
        why.focus_gain_db,
        *why.position_m[:2],
        test.joint_ratio,
        test.coherence,
    )


def _evidence(
    left: Traces,
    detection: DetectionResult,
    scan: DefocusScan,
    test: CandidateTest,
) -> MoverEvidence:
    """The record of a mover found by its defocus: the bank's numbers and ``g``'s."""
    det = detection.candidates
    fit, cand, why = test.fit, test.candidate, test.explanation
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
        defocus=DefocusEvidence(
            statistic_db=cand.statistic_db,
            threshold_db=scan.threshold_db,
            p_value=scan.p_value(cand.statistic_db),
            smear_margin_db=cand.leak_db,
            bank_cross_range_speed_mps=cand.cross_range_speed_mps,
        ),
    )
