"""The mover stage of the analysis, as named steps.

:func:`estimate_movers` takes what :func:`~sarmotion.pipeline.detect` found and, on the
central sub-aperture:

1. **candidates** (:func:`fit_candidates`): strongest first, each candidate of the
   range-speed test is fitted by maximum likelihood on ``S`` minus the movers already
   accepted, rejected when a stationary point explains it, and the detector runs again
   on what the accepted ones leave (**redetection**);
2. **joint refinement** (:func:`~sarmotion.motion.refine_jointly`): each mover re-fitted
   with the others subtracted;
3. **refit** (:mod:`sarmotion.pipeline.refit`): the movers at their amplitude on the
   data, a stationary estimate of the data made without them (**re-separation**), and
   each re-fitted on the data minus it; a fit that repeats a stronger one's range
   history, or that the stronger one's echo can make (a fit at its range-speed alias),
   is the same mover and is dropped (:func:`~sarmotion.motion.duplicate_fits`);
4. **records** (:func:`mover_record`): ``g_perp`` at each fit, the noise level around
   it, its Cramér–Rao bound and its cross-range family;
5. **whole aperture** (:func:`~sarmotion.motion.refine_on_aperture`): for a wide
   aperture, each estimate moved to the aperture's ``s = 0`` and focused on all pulses;
   then its range acceleration with its bound
   (:func:`~sarmotion.motion.fit_range_acceleration`, :func:`with_acceleration`), which
   one sub-aperture does not separate from the cross-range speed;
6. **extraction** (:func:`extract_mover`): each mover's own traces taken from the
   residual in turn.

Each step's wall-clock time is in :attr:`MoverStage.timings_s` under ``movers.<step>``;
the redetection is part of the candidates' time and the re-separation part of the
refit's. Positions in m (data frame), speeds in m/s.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.acquisition import Acquisition
from ..core.geometry import cross_range_speed, ground_velocity, range_speed
from ..core.progress import ProgressCallback, report
from ..core.spectral import to_fast_time, to_frequency
from ..core.traces import Traces, as_traces
from ..imaging import resolution
from ..motion import (
    ApertureFit,
    PointBound,
    PointFit,
    RangeSpeedDetection,
    StationaryExplanation,
    aligned_range,
    aligned_trace,
    coherent_false_alarm_probability,
    coherent_statistic_db,
    coherent_threshold_db,
    detect_range_speeds,
    duplicate_fits,
    estimate_cross_range_speed,
    family_direction,
    fit_point_mover,
    fit_range_acceleration,
    matched_filter_noise_variance,
    point_model,
    point_mover_bound,
    point_peak_width,
    range_gradients,
    range_speed_resolution,
    refine_jointly,
    refine_on_aperture,
    stationary_explanation,
)
from ..separation import aligned_constant_part
from ._timing import timed
from .defocused import defocused_movers
from .detection import DetectionResult
from .options import AnalysisOptions
from .refit import at_full_amplitude, data_without_stationary, refit_in_cell
from .results import Mover, MoverEvidence, NotEstimated

__all__ = [
    "MoverStage",
    "estimate_movers",
    "fit_candidates",
    "mover_record",
    "extract_mover",
    "with_acceleration",
]

log = logging.getLogger(__name__)

#: Half-width of the fast time around an accepted mover's aligned trace that a second
#: candidate at its speed passes over (:func:`_candidate_trace`), in range resolutions
#: ``1 / B``: the point model leaves a mover's remnant within about a resolution of its
#: trace (a remnant of RPCA's distortion of it), and two resolutions keep a second
#: trace off that remnant's main lobe.
_TRACE_GUARD_RESOLUTIONS = 2.0


@dataclass(frozen=True, kw_only=True, eq=False)
class MoverStage:
    """What :func:`estimate_movers` returns.

    Attributes
    ----------
    movers : tuple of Mover
        The movers, strongest first, without image or trajectory.
    residual : (n_pulses, n_samples) ndarray
        ``S`` minus every mover's traces (whole aperture).
    timings_s : dict of str to float
        Wall-clock time of each step (s), keys ``movers.<step>`` (module docstring).
    not_estimated : tuple of NotEstimated
        The candidates still above the threshold once ``max_movers`` were accepted.
    """

    movers: tuple[Mover, ...]
    residual: NDArray[np.complex128]
    timings_s: dict[str, float] = field(default_factory=dict)
    not_estimated: tuple[NotEstimated, ...] = ()


def estimate_movers(
    detection: DetectionResult,
    *,
    refit: bool = True,
    keep: Callable[[PointFit], bool] | None = None,
    progress: ProgressCallback | None = None,
) -> MoverStage:
    """Maximum-likelihood movers with their bounds, then extracted (module docstring).

    Parameters
    ----------
    detection : DetectionResult
        The separation and the range-speed test (:func:`~sarmotion.pipeline.detect`).
    refit : bool
        Whether step 3 runs (default, as in :func:`~sarmotion.pipeline.analyze`);
        ``False`` stops at the fits on the separated traces.
    keep : callable, optional
        ``keep(fit)``: whether an accepted candidate's fit is estimated further (steps
        2-6). A fit it declines is still subtracted while the candidates are fitted (it
        hides no other mover), and its model is taken out of ``S`` before step 2, but it
        is not a mover of the result. Default: every fit is kept.
    progress : callable, optional
        ``progress("movers", done, total)`` as candidates are tried.

    Returns
    -------
    MoverStage
    """
    opts = detection.options
    sub, moving_sub = detection.sub, np.asarray(detection.moving_sub)
    timings: dict[str, float] = {}
    beyond: list[NotEstimated] = []
    with timed(timings, "movers.candidates"):
        found = fit_candidates(
            moving_sub,
            detection.candidates,
            opts,
            acquisition=sub.acquisition,
            peak_width_mps=point_peak_width(sub) * range_speed_resolution(sub),
            timings=timings,
            progress=progress,
            not_estimated=beyond,
        )
    if beyond:
        log.info(
            "%d candidate(s) above the threshold not estimated (max_movers = %d)",
            len(beyond),
            opts.max_movers,
        )
    banded_fits: list[PointFit] = []
    if opts.defocus_search and len(found) < opts.max_movers:
        with timed(timings, "movers.defocus"):
            extra = defocused_movers(
                detection,
                at_full_amplitude(sub, [f for f, _ in found]),
                max_movers=opts.max_movers - len(found),
            )
        if extra:
            # S holds little of these movers: the moving traces become D - L'
            banded_fits = [f for f, _ in extra]
            full = at_full_amplitude(sub, [f for f, _ in found]) + banded_fits
            threshold = opts.separation.candidate_threshold_db
            moving_sub = data_without_stationary(sub, detection.image, full, threshold_db=threshold)
            found = list(found) + extra
    if keep is not None:
        declined = [f for f, _ in found if not keep(f)]
        if declined:
            log.info("%d fit(s) declined: not estimated further", len(declined))
            found = [(f, e) for f, e in found if all(f is not d for d in declined)]
            moving_sub = moving_sub - sum(
                point_model(sub.acquisition, d.position_m, d.velocity_mps, d.amplitude)
                for d in declined
            )
    with timed(timings, "movers.joint_refinement"):
        separated = refine_jointly(
            moving_sub,
            [f for f, _ in found],
            acquisition=sub.acquisition,
            rounds=opts.joint_rounds,
        )
    fits, kept, data_sub = list(separated), [None] * len(separated), moving_sub
    if refit and separated:
        with timed(timings, "movers.refit"):
            fits, kept, data_sub = _refit(sub, detection, separated, timings)
    drop = set(duplicate_fits(sub, fits))  # one mover is not declared twice
    if drop:
        log.info("%d fit(s) repeat a stronger mover's range history or its echo: merged", len(drop))
        keep = [k for k in range(len(fits)) if k not in drop]
        fits, separated, found, kept = (
            [x[k] for k in keep] for x in (fits, separated, found, kept)
        )
    with timed(timings, "movers.records"):
        movers = _records(
            moving_sub, data_sub, found, separated, fits, kept, opts, acquisition=sub.acquisition
        )
    residual = np.array(detection.separation.moving, dtype=np.complex128)
    band_data = None  # D - L' on the whole aperture: where the movers in the band are
    if banded_fits:
        band_data = data_without_stationary(
            detection.traces,
            detection.image,
            at_full_amplitude(detection.traces, fits),
            threshold_db=opts.separation.candidate_threshold_db,
        )
    whole = detection.traces.acquisition
    out = []
    for k, mover in enumerate(movers):
        banded = band_data is not None and mover.evidence.defocus is not None
        source = band_data if banded else residual
        if not detection.whole_aperture:
            with timed(timings, "movers.whole_aperture"):
                mover = on_whole_aperture(
                    source, mover, acquisition=whole, central=detection.central
                )
            with timed(timings, "movers.acceleration"):
                sub_pulses = len(range(*detection.central.indices(whole.n_pulses)))
                x0, x1, y0, y1 = detection.image.grid.extent
                mover = with_acceleration(
                    source,
                    mover,
                    acquisition=whole,
                    noise_variance=_bound_noise(mover, whole, sub_pulses),
                    cross_range_std_m=0.5 * max(x1 - x0, y1 - y0),
                )
        with timed(timings, "movers.extraction"):
            own = extract_mover(
                source,
                acquisition=whole,
                position_m=mover.position_m,
                velocity_mps=mover.velocity_mps,
                half_window=opts.mover_half_window,
            )
        if banded:
            band_data = band_data - own
        else:
            residual = residual - own
        out.append(_with(mover, traces=own))
        log.info(
            "mover %d: position (%.2f, %.2f) m, velocity (%.2f, %.2f) m/s, the member of its "
            "cross-range family at the reference cross range (the data fix its range only)",
            k + 1,
            *mover.position_m[:2],
            *mover.velocity_mps,
        )
    return MoverStage(
        movers=tuple(out), residual=residual, timings_s=timings, not_estimated=tuple(beyond)
    )


def _refit(
    sub: Traces,
    detection: DetectionResult,
    separated: Sequence[PointFit],
    timings: dict[str, float],
) -> tuple[list[PointFit], list[bool | None], NDArray[np.complex128]]:
    """Step 3: the fits at full amplitude, ``D - L'`` (timed) and the re-fit on it."""
    full = at_full_amplitude(sub, separated)
    with timed(timings, "movers.re_separation"):
        threshold = detection.options.separation.candidate_threshold_db
        data = data_without_stationary(sub, detection.image, full, threshold_db=threshold)
    fits, kept = refit_in_cell(data, full, acquisition=sub.acquisition)
    return fits, list(kept), data


def _records(
    moving_sub: NDArray[np.complexfloating],
    data_sub: NDArray[np.complexfloating],
    found: Sequence[tuple[PointFit, MoverEvidence]],
    separated: Sequence[PointFit],
    fits: Sequence[PointFit],
    kept: Sequence[bool | None],
    options: AnalysisOptions,
    *,
    acquisition: Acquisition,
) -> list[Mover]:
    """Step 4 for every mover: ``g_perp`` on the mover alone, the noise around it, its bound.

    ``g_perp`` is taken on ``S`` minus the other movers' final models; the noise on the
    data of the final fits (``D - L'`` after a refit, else ``S``) minus every model.
    """
    sub = acquisition
    models = [point_model(sub, f.position_m, f.velocity_mps, f.amplitude) for f in fits]
    zero = np.zeros(sub.shape, dtype=complex)
    left = data_sub - sum(models, zero)
    out = []
    for k, fit in enumerate(fits):
        others = sum((m for j, m in enumerate(models) if j != k), zero)
        out.append(
            mover_record(
                moving_sub - others,
                acquisition=sub,
                evidence=found[k][1],
                separated_fit=separated[k],
                fit=fit,
                refit_kept=kept[k],
                noise_variance=_local_noise(left, fit, acquisition=sub),
                options=options,
            )
        )
    return out


def fit_candidates(
    moving: NDArray[np.complexfloating],
    detection: RangeSpeedDetection,
    options: AnalysisOptions,
    *,
    acquisition: Acquisition,
    peak_width_mps: float,
    timings: dict[str, float] | None = None,
    progress: ProgressCallback | None = None,
    not_estimated: list[NotEstimated] | None = None,
) -> list[tuple[PointFit, MoverEvidence]]:
    """Fit the candidates one at a time, strongest first, each on what the others leave.

    The strongest untried candidate is fitted (:func:`~sarmotion.motion.fit_point_mover`)
    and rejected when a stationary point explains it
    (:func:`~sarmotion.motion.stationary_explanation`); otherwise its fitted traces are
    subtracted and the detector runs again on the residual (a second mover within a
    resolution of the first, hidden under its peak, then stands out; a shoulder of the
    subtracted peak falls to the floor). The threshold stays the first run's. A fit
    within a range cell and a ``g`` peak's width of an accepted mover is what the
    point model could not subtract of it (RPCA keeps a distorted 15-40 % of a mover's
    amplitude in ``S``: on a real degree with two strong injected movers such remnants
    made a third "mover" 0.3 m/s and 0.2 m from one of them), not a new mover.

    A speed is tried once (half a resolution) on the ``g(u)`` peak's own trace. Two
    movers with the same range speed share one ``g`` peak; once the first is subtracted
    the strongest trace at that speed is as often as not its remnant, and the second
    mover lies on another trace (reopening the accepted speed to its strongest trace
    instead made three false movers on Scene 1 written as GOTCHA files). Within a ``g``
    peak's width of an accepted mover the candidate is therefore tried again on the
    strongest trace at least ``_TRACE_GUARD_RESOLUTIONS`` from the accepted movers'
    (:func:`_candidate_trace`), when that trace's own ``g`` statistic reaches the
    threshold.

    Parameters
    ----------
    moving : (n_pulses, n_samples) ndarray
        ``S`` on the central sub-aperture.
    detection : RangeSpeedDetection
        The first run of the detector on ``moving``.
    options : AnalysisOptions
        ``max_movers``, ``speed_range_mps``, ``min_focus_gain_db``, ``max_peak_width``.
    acquisition : Acquisition
        The acquisition of ``moving`` (the central sub-aperture).
    peak_width_mps : float
        Width of a point mover's ``g`` peak (m/s): a fit that close in range speed and
        within a range cell of an accepted mover is what was left of it
        (:func:`~sarmotion.motion.point_peak_width` of the data ``M`` times the
        range-speed resolution).
    timings : dict, optional
        Adds the redetections' wall-clock time under ``movers.redetection`` (s).
    progress : callable, optional
        ``progress("movers", done, total)``.
    not_estimated : list, optional
        Receives, strongest first, the candidates still above the threshold (on what the
        accepted movers leave) once ``max_movers`` were accepted: detected, not fitted
        (:class:`~sarmotion.pipeline.NotEstimated`). Nothing is dropped silently.

    Returns
    -------
    list of (PointFit, MoverEvidence)
        The accepted candidates' fits and detection records, in the order accepted.
    """
    timings = {} if timings is None else timings
    sub = acquisition
    residual = np.array(moving, dtype=np.complex128)
    current = detection
    tried: list[tuple[float, float]] = []  # (speed, delay of the trace fitted)
    fitted: list[tuple[float, float]] = []  # accepted movers: (speed, delay of their trace)
    out: list[tuple[PointFit, MoverEvidence]] = []
    res = detection.range_speeds.resolution_mps
    guard = _TRACE_GUARD_RESOLUTIONS / sub.radar.bandwidth_hz
    while len(out) < options.max_movers:
        rs = current.range_speeds
        left = Traces(data=residual, acquisition=sub)
        following = _next_untried(left, current, tried, fitted, (0.5 * res, peak_width_mps), guard)
        if following is None:
            break
        k, delay = following
        # the candidates from the k-th on may all still be fitted
        report(progress, "movers", len(tried), len(tried) + rs.n_movers - k)
        u, statistic = float(rs.speeds_mps[k]), float(current.statistic_db[k])
        fit = fit_point_mover(
            residual,
            u,
            acquisition=sub,
            cross_speed_range_mps=options.speed_range_mps,
            trace_delay_s=delay,
        )
        model = point_model(sub, fit.position_m, fit.velocity_mps, fit.amplitude)
        # tried: the trace asked for, and the one the fit took (the global search may
        # leave the strongest trace at u for another of the same speed)
        own = aligned_trace(Traces(data=model, acquisition=sub), u)[0]
        if delay is not None:
            tried.append((u, delay))
        tried.append((u, own))
        if any(_same_trace(sub, fit, f, peak_width_mps) for f, _ in out):
            log.info("g(u) candidate at %.2f m/s: what a subtracted mover left", u)
            continue
        value = fit.amplitude * sub.n_pulses
        coherent = _coherent_test(residual, fit, detection, options, acquisition=sub)
        if coherent is not None and coherent[0] < coherent[1]:
            log.info(
                "g(u) candidate at %.2f m/s: likelihood ratio %.2f dB under %.2f dB",
                u,
                coherent[0],
                coherent[1],
            )
            continue
        why = stationary_explanation(
            residual,
            fit.position_m,
            fit.velocity_mps,
            value,
            acquisition=sub,
            extent_m=options.alias_free_extent_m,
            extent_centre_m=options.alias_free_centre_m,
        )
        if why.within_extent and why.focus_gain_db < options.min_focus_gain_db:
            log.info(
                "g(u) candidate at %.2f m/s: a stationary point at (%.1f, %.1f) m explains it "
                "(focus gain %.2f dB)",
                u,
                *why.position_m[:2],
                why.focus_gain_db,
            )
            continue
        residual = residual - model
        fitted.append((u, own))
        evidence = _evidence(detection, statistic, float(current.widths[k]), why, coherent)
        out.append((fit, evidence))
        with timed(timings, "movers.redetection"):
            current = _redetect(Traces(data=residual, acquisition=sub), detection, options)
    if not_estimated is not None and len(out) >= options.max_movers:
        left = Traces(data=residual, acquisition=sub)
        accepted = [f for f, _ in out]
        speeds = [v for v, _ in tried]
        not_estimated.extend(_beyond_cap(left, current, speeds, accepted, peak_width_mps))
    return out


def _next_untried(
    residual: Traces,
    detection: RangeSpeedDetection,
    tried: Sequence[tuple[float, float]],
    fitted: Sequence[tuple[float, float]],
    tolerances_mps: tuple[float, float],
    guard_s: float,
) -> tuple[int, float | None] | None:
    """The strongest candidate not tried yet, and the trace it is fitted on.

    ``tolerances_mps`` is (the speed within which a candidate was tried, a ``g``
    peak's width). A candidate is fitted on the ``g(u)`` peak's own trace (``None``)
    when no tried speed lies within the first; once tried, on another trace beside an
    accepted mover (:func:`_candidate_trace`) when that trace was not tried. ``None``
    when every candidate was tried. The candidates are taken strongest first and the
    search stops at the first untried one (each other trace costs a ``g`` profile).
    """
    tolerance, width_mps = tolerances_mps
    for k, u in enumerate(detection.range_speeds.speeds_mps):
        if _untried(float(u), None, tried, tolerance, guard_s):
            return k, None
        delay = _candidate_trace(residual, float(u), detection, fitted, width_mps, guard_s)
        if delay is not None and _untried(float(u), delay, tried, tolerance, guard_s):
            return k, delay
    return None


def _candidate_trace(
    residual: Traces,
    u: float,
    detection: RangeSpeedDetection,
    fitted: Sequence[tuple[float, float]],
    width_mps: float,
    guard_s: float,
) -> float | None:
    """The trace a candidate at ``u`` is fitted on: ``None`` for the ``g(u)`` peak's own.

    Within a ``g`` peak's width of an accepted mover's speed the strongest trace at
    ``u`` is, as often as not, what the point model left of that mover; a second mover
    of the same range speed at another range lies on another trace. The candidate's
    trace is then the strongest one farther than ``guard_s`` from the accepted movers'
    (:func:`~sarmotion.motion.aligned_trace`), and it must pass the detector on its
    own: its sum over the local floor of ``g`` reaches the detection's threshold (the
    statistic of :mod:`sarmotion.motion.detector` with that trace's value for the peak,
    the largest at speeds within half a peak width of ``u``, in steps of half a
    resolution). ``nan`` when it does not, or no trace is left.
    """
    avoid = [t for ua, t in fitted if abs(u - ua) < width_mps]
    if not avoid:
        return None
    rs = detection.range_speeds
    best, delay = -np.inf, float("nan")
    # the other trace's own peak: its speed within half a peak width of the candidate's
    half = 0.5 * width_mps
    for v in u + np.arange(-half, half + 1e-9, 0.5 * rs.resolution_mps):
        t, value = aligned_trace(residual, float(v), avoid_s=avoid, guard_s=guard_s)
        floor = float(np.interp(v, rs.grid_mps, detection.floor_curve))
        stat = 20.0 * np.log10(value / floor) if value > 0 and floor > 0 else -np.inf
        if stat > best:
            best, delay = stat, t
    return delay if best >= detection.threshold_db else float("nan")


def _untried(
    u: float,
    delay: float | None,
    tried: Sequence[tuple[float, float]],
    speed_tolerance_mps: float,
    guard_s: float,
) -> bool:
    """Whether a candidate at ``u`` on the trace at ``delay`` was not tried yet.

    A candidate on the ``g(u)`` peak's own trace (``delay`` ``None``) was tried when a
    tried speed lies within ``speed_tolerance_mps``; one on another trace (beside an
    accepted mover, :func:`_candidate_trace`) when, besides, the tried trace lies within
    ``guard_s`` of its own.
    """
    if delay is not None and not np.isfinite(delay):
        return False
    near = [t for v, t in tried if abs(u - v) <= speed_tolerance_mps]
    if delay is None:
        return not near
    return all(abs(delay - t) > guard_s for t in near)


def _beyond_cap(
    residual: Traces,
    current: RangeSpeedDetection,
    tried: Sequence[float],
    accepted: Sequence[PointFit],
    width_mps: float,
) -> list[NotEstimated]:
    """The untried candidates of ``current``, strongest first.

    Untried: half a resolution from every tried speed. A candidate within a ``g`` peak's
    width and a range cell of an accepted mover is what the point model left of it (the
    rule :func:`fit_candidates` applies to fits, here on the aligned range), not a mover.
    """
    rs = current.range_speeds
    res = rs.resolution_mps
    cells = resolution(residual)
    ref = residual.reference_point_m[:2]
    fitted = [
        (f.range_speed_mps, float((f.position_m[:2] - ref) @ cells.range_direction))
        for f in accepted
    ]
    out = []
    for k, u in enumerate(rs.speeds_mps):
        if any(abs(u - t) <= 0.5 * res for t in tried):
            continue
        rng = aligned_range(residual, float(u))
        if any(
            abs(u - fu) < width_mps and abs(rng - fx) < cells.ground_range_m for fu, fx in fitted
        ):
            log.info("g(u) candidate at %.2f m/s beyond the cap: what a subtracted mover left", u)
            continue
        out.append(
            NotEstimated(
                range_speed_mps=float(u),
                statistic_db=float(current.statistic_db[k]),
                width_resolutions=float(current.widths[k]),
                range_m=rng,
            )
        )
    return sorted(out, key=lambda c: -c.statistic_db)


def _same_trace(sub: Acquisition, a: PointFit, b: PointFit, width_mps: float) -> bool:
    """Whether two fits share a range cell at ``s = 0`` and the width of a ``g`` peak (m/s)."""
    cells = resolution(sub)
    dx = abs(float((a.position_m[:2] - b.position_m[:2]) @ cells.range_direction))
    du = abs(a.range_speed_mps - b.range_speed_mps)
    return dx < cells.ground_range_m and du < width_mps


def _redetect(
    traces: Traces, first: RangeSpeedDetection, options: AnalysisOptions
) -> RangeSpeedDetection:
    """The detector on a residual, with the first run's threshold and speed floor."""
    return detect_range_speeds(
        traces,
        speed_range_mps=options.speed_range_mps,
        threshold=first.threshold_db,
        min_speed_mps=first.min_speed_mps,
        max_width=options.max_peak_width,
    )


def _coherent_test(
    residual: NDArray[np.complexfloating],
    fit: PointFit,
    detection: RangeSpeedDetection,
    options: AnalysisOptions,
    *,
    acquisition: Acquisition,
) -> tuple[float, float, float] | None:
    """Stage 2 of the coherent detector: ``(Lambda, threshold, p-value)`` of a fit (dB).

    ``None`` for the ``g(u)`` detector. ``N`` of the union bound is the number of
    candidates the first screen passed (:func:`~sarmotion.motion.coherent_threshold_db`).
    """
    if options.detector != "coherent":
        return None
    n = max(1, detection.range_speeds.n_movers)
    stat = coherent_statistic_db(
        residual,
        fit.position_m,
        fit.velocity_mps,
        acquisition=acquisition,
        value=fit.amplitude * acquisition.n_pulses,
    )
    return (
        stat,
        coherent_threshold_db(options.false_alarm_rate, n),
        coherent_false_alarm_probability(stat, n),
    )


def _evidence(
    detection: RangeSpeedDetection,
    statistic: float,
    width: float,
    why: StationaryExplanation,
    coherent: tuple[float, float, float] | None = None,
) -> MoverEvidence:
    """The detection record of an accepted candidate."""
    extra = {}
    if coherent is not None:
        extra = dict(
            coherent_statistic_db=coherent[0],
            coherent_threshold_db=coherent[1],
            coherent_p_value=coherent[2],
        )
    return MoverEvidence(
        **extra,
        statistic_db=statistic,
        threshold_db=detection.threshold_db,
        false_alarm_rate=detection.false_alarm_rate,
        p_value=detection.false_alarm_probability(statistic),
        width_resolutions=width,
        focus_gain_db=why.focus_gain_db,
        stationary_point_m=(float(why.position_m[0]), float(why.position_m[1])),
        stationary_within_extent=why.within_extent,
    )


def mover_record(
    alone: NDArray[np.complexfloating],
    *,
    acquisition: Acquisition,
    evidence: MoverEvidence,
    separated_fit: PointFit,
    fit: PointFit,
    refit_kept: bool | None,
    noise_variance: float,
    options: AnalysisOptions,
) -> Mover:
    """Step 4: the :class:`~sarmotion.pipeline.Mover` of a sub-aperture fit.

    Parameters
    ----------
    alone : (n_pulses, n_samples) ndarray
        ``S`` with the other movers' fits subtracted: ``g_perp`` (``eq:OBJ2``) is taken
        on it at the fit's range speed and position, for comparison with the fit.
    acquisition : Acquisition
        The sub-aperture the fit was made on.
    evidence, separated_fit, fit, refit_kept
        The mover's history so far (:class:`~sarmotion.pipeline.Mover`).
    noise_variance : float
        Noise variance per fast-time sample around the mover (data units squared).
    options : AnalysisOptions
        ``speed_range_mps`` of the ``g_perp`` search.

    Returns
    -------
    Mover
        Its estimate is ``fit``; no traces, image or trajectory yet.
    """
    sub = acquisition
    g_perp = estimate_cross_range_speed(
        Traces(data=alone, acquisition=sub),
        range_speed_mps=fit.range_speed_mps,
        position_m=fit.position_m,
        speed_range_mps=options.speed_range_mps,
    )
    family = family_direction(sub, fit.position_m, fit.velocity_mps)
    return Mover(
        position_m=np.asarray(fit.position_m, dtype=np.float64).copy(),
        velocity_mps=np.asarray(fit.velocity_mps, dtype=np.float64).copy(),
        range_speed_mps=fit.range_speed_mps,
        cross_range_speed_mps=fit.cross_range_speed_mps,
        evidence=evidence,
        separated_fit=separated_fit,
        fit=fit,
        refit_kept=refit_kept,
        g_perp=g_perp,
        aperture=None,
        bound=_bound(sub, fit, noise_variance),
        family_position_per_m=family[0],
        family_velocity_per_m=family[1],
    )


def _local_noise(
    residual: NDArray[np.complexfloating], fit: PointFit, *, acquisition: Acquisition
) -> float:
    """Noise variance around a mover as the matched filter sees it, on what the fits leave.

    Positions within 10 m of the fit, range speeds within 2 m/s and cross-range speeds
    within 5 m/s of its own (:func:`~sarmotion.motion.matched_filter_noise_variance`):
    clutter residue is not white, and its level where the mover is sets the bound.
    """
    return matched_filter_noise_variance(
        residual,
        acquisition=acquisition,
        half_size_m=10.0,
        centre_m=fit.position_m,
        velocity_mps=fit.velocity_mps,
    )


def _bound(sub: Acquisition, fit: PointFit, variance: float) -> PointBound:
    """Cramér–Rao bound of a fit at its amplitude and the measured noise variance.

    ``variance`` is per fast-time sample; the phase history's is ``n_samples`` times it
    (:mod:`sarmotion.motion.bounds`).
    """
    geom = sub.geometry
    grads = range_gradients(
        sub.positions_m,
        sub.slow_times_s,
        fit.position_m,
        fit.velocity_mps,
        range_direction=resolution(sub).range_direction,
        range_basis_mps=ground_velocity(1.0, 0.0, geom),
        cross_basis_mps=ground_velocity(0.0, 1.0, geom),
    )
    return point_mover_bound(
        grads,
        sub.frequencies_hz,
        sub.radar.spectral_weights(),
        amplitude=max(abs(fit.amplitude), 1e-300),
        noise_variance=max(sub.n_samples * variance, 1e-300),
    )


def on_whole_aperture(
    residual: NDArray[np.complexfloating], mover: Mover, *, acquisition: Acquisition, central: slice
) -> Mover:
    """Step 5: a (central sub-aperture's) estimate moved to ``s = 0`` and focused on all pulses.

    Parameters
    ----------
    residual : (n_pulses, n_samples) ndarray
        ``S`` minus the movers extracted so far (whole aperture).
    mover : Mover
        The mover as estimated on the pulses ``central``.
    acquisition : Acquisition
        The whole acquisition.
    central : slice
        Those pulses.

    Returns
    -------
    Mover
        With its whole-aperture focus (:attr:`~sarmotion.pipeline.Mover.aperture`) and
        the estimate it gives.
    """
    fit: ApertureFit = refine_on_aperture(
        Traces(data=residual, acquisition=acquisition),
        mover.position_m,
        mover.velocity_mps,
        central=central,
    )
    geom = acquisition.geometry
    log.info(
        "whole-aperture focus %.4g -> %.4g (x n_pulses)",
        fit.start_focus / acquisition.n_pulses,
        fit.focus / acquisition.n_pulses,
    )
    return _with(
        mover,
        position_m=fit.position_m,
        velocity_mps=fit.velocity_mps,
        range_speed_mps=range_speed(fit.velocity_mps, geom),
        cross_range_speed_mps=cross_range_speed(fit.velocity_mps, geom),
        aperture=fit,
    )


def with_acceleration(
    residual: NDArray[np.complexfloating],
    mover: Mover,
    *,
    acquisition: Acquisition,
    noise_variance: float,
    cross_range_std_m: float,
) -> Mover:
    """Step 5, on a wide aperture: the mover's range acceleration with its bound.

    :func:`~sarmotion.motion.fit_range_acceleration` from the whole-aperture estimate, on
    the same traces as its focus. The mover's position and velocity stay the uniform
    estimate's: the acceleration is reported beside them
    (:attr:`~sarmotion.pipeline.Mover.acceleration`).

    Parameters
    ----------
    residual : (n_pulses, n_samples) ndarray
        ``S`` minus the movers extracted so far (whole aperture).
    mover : Mover
        The mover focused on the whole aperture (:func:`on_whole_aperture`).
    acquisition : Acquisition
        The whole acquisition.
    noise_variance : float
        Noise variance per fast-time sample around the mover (data units squared).
    cross_range_std_m : float
        Spread of the mover's true cross-range coordinate about the held one (m): half
        the imaged scene, as the tracker's ``family_std_m``.
    """
    acc = fit_range_acceleration(
        Traces(data=residual, acquisition=acquisition),
        mover.position_m,
        mover.velocity_mps,
        noise_variance=noise_variance,
        cross_range_std_m=cross_range_std_m,
    )
    log.info(
        "range acceleration %.4f +- %.3g m/s^2 (%s; |I| %.4g -> %.4g x n_pulses; "
        "from the %s range history)",
        acc.range_acceleration_mps2,
        acc.std_mps2,
        "estimable" if acc.estimable else "not estimable: bound over the prior",
        abs(acc.uniform_amplitude),
        abs(acc.amplitude),
        acc.start,
    )
    return _with(mover, acceleration=acc)


def _bound_noise(mover: Mover, acquisition: Acquisition, sub_pulses: int) -> float:
    """The noise per fast-time sample the mover's bound was computed with (:func:`_bound`).

    From the bound's amplitude deviation over the ``sub_pulses`` pulses of its
    sub-aperture: ``var(|a|) = sigma_P^2 / (2 n_pulses sum W^2)`` and ``sigma_P^2 =
    n_samples sigma_t^2`` (:mod:`sarmotion.motion.bounds`): the noise
    :func:`_local_noise` measured around it.
    """
    energy = sub_pulses * float(np.sum(acquisition.radar.spectral_weights() ** 2))
    return 2.0 * energy * mover.bound.amplitude**2 / acquisition.n_samples


def _with(mover: Mover, **changes: object) -> Mover:
    """``mover`` with ``changes`` (:func:`dataclasses.replace`)."""
    return dataclasses.replace(mover, **changes)  # type: ignore[arg-type]


def extract_mover(
    data: Traces | ArrayLike,
    *,
    acquisition: Acquisition | None = None,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    half_window: int | None = None,
) -> NDArray[np.complex128]:
    """Step 6: one mover's own traces from ``data``, its ``s``-independent part in its frame.

    ``T_+^{u, rho}`` (``eq:TTu+``) at the estimate ``(rho, u)`` brings the mover's trace
    to ``t = 0`` with a phase independent of ``s``: in that frame it is rank one and
    constant in slow time, while the other movers' and the residual clutter's traces
    still cross the window obliquely. The mover's part is the slow-time mean of the
    aligned traces in the fast-time window ``|t| <= half_window`` samples (the
    projection on ``s``-independent traces there), mapped back by ``T_-^{u, rho}``.

    Parameters
    ----------
    data : Traces or (n_pulses, n_samples) array_like
        The traces the mover is taken from (e.g. the current moving residual).
    acquisition : Acquisition, optional
        Their acquisition (geometry, frequencies, reference point); required when
        ``data`` is an array.
    position_m : (2,) or (3,) array_like
        Mover's location at ``s = 0`` (m).
    velocity_mps : (2,) array_like
        Mover's ground velocity (m/s).
    half_window : int, optional
        Half-width of the window (fast-time samples); default three compressed-pulse
        lengths ``3 / (B dt)`` (as :func:`sarmotion.separation.separate_combined`).

    Returns
    -------
    (n_pulses, n_samples) ndarray
        The mover's traces (data units); ``data`` minus it is the residual.
    """
    traces = as_traces(data, acquisition)
    part = aligned_constant_part(
        to_frequency(traces.data),
        position_m,
        acquisition=traces.acquisition,
        velocity_mps=velocity_mps,
        half_window=half_window,
    )
    return to_fast_time(part)
