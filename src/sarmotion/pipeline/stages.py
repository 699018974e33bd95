"""The stages of the analysis, each a function with typed inputs and outputs.

:func:`~sarmotion.pipeline.analyze` calls them in order; each can also be called alone.
Nothing here reads or writes files or prints; progress goes through
``progress(stage, done, total)``. Positions in m (data frame), speeds in m/s.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.geometry import cross_range_speed, ground_velocity, range_speed
from ..core.progress import ProgressCallback, report
from ..core.spectral import to_fast_time, to_frequency
from ..core.traces import Traces
from ..errors import EstimationError
from ..imaging import Image, ImageGrid, backproject, resolution, scene_grid
from ..motion import (
    MoverEstimate,
    PointBound,
    PointFit,
    RangeSpeedDetection,
    StationaryExplanation,
    TrajectoryEstimate,
    detect_range_speeds,
    duplicate_fits,
    estimate_cross_range_speed,
    estimate_trajectory,
    family_direction,
    fit_point_mover,
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
from ..separation import Separation, aligned_constant_part
from .options import AnalysisOptions
from .refit import refit_movers_on_data, with_refit_history
from .results import MoverEvidence, MoverResult, StationaryTarget

__all__ = [
    "MoverFit",
    "preliminary_image",
    "find_range_speeds",
    "estimate_movers",
    "extract_mover",
    "estimate_trajectories",
    "stationary_image",
    "mover_results",
    "stationary_targets",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True, eq=False)
class MoverFit:
    """One mover as estimated and extracted, before imaging.

    Attributes
    ----------
    estimate : MoverEstimate
        Location at ``s = 0`` (m) and velocity (m/s), focused on the whole aperture.
    traces : (n_pulses, n_samples) ndarray
        The mover's own traces (data units).
    family_position_per_m, family_velocity_per_m : (2,) ndarray
        Tangent of its cross-range family (m/m, (m/s)/m).
    evidence : MoverEvidence
        The detection test it passed.
    bound : PointBound
        Its Cramér–Rao bound at its measured SNR (sub-aperture).
    fit : PointFit
        Its maximum-likelihood fit on the sub-aperture.
    """

    estimate: MoverEstimate
    traces: NDArray[np.complex128]
    family_position_per_m: NDArray[np.float64]
    family_velocity_per_m: NDArray[np.float64]
    evidence: MoverEvidence
    bound: PointBound
    fit: PointFit


def preliminary_image(
    traces: Traces, options: AnalysisOptions, *, progress: ProgressCallback | None = None
) -> Image:
    """``eq:image`` of the data on the square scene grid of ``options`` (resolved)."""
    grid = scene_grid(traces, size_m=options.image_size_m, spacing_m=options.spacing_m)
    return backproject(traces, grid, progress=_staged(progress, "preliminary image"))


def find_range_speeds(
    traces: Traces, moving: NDArray[np.complexfloating], options: AnalysisOptions
) -> RangeSpeedDetection:
    """Candidate range speeds: the ``g(u)`` peaks on ``moving`` that pass the detector.

    The statistic is each peak over its local floor, the threshold that of
    ``options.false_alarm_rate`` (:mod:`sarmotion.motion.detector`), peaks wider than
    ``options.max_peak_width`` resolutions are stationary residue. Peaks slower than the
    stationary band are not tested: the apparent range speed ``V y / L`` (``eq:Dtau``)
    of a stationary target at the image's half-diagonal, and at least two range-speed
    resolutions (the stationary peak's main lobe). Slower candidates than the paper's
    ``u >> V R / L`` (``eq:AnnihCond``) are admitted because the focus test of
    :func:`estimate_movers` rejects those a stationary point explains.
    """
    data = traces.with_data(moving)
    geom = traces.geometry
    apparent = geom.speed_mps * (options.image_size_m / np.sqrt(2.0)) / geom.range_m
    detection = detect_range_speeds(
        data,
        speed_range_mps=options.speed_range_mps,
        false_alarm_rate=options.false_alarm_rate,
        threshold=options.threshold_db,
        min_speed_mps=max(2.0 * range_speed_resolution(data), apparent),
        max_width=options.max_peak_width,
    )
    rs = detection.range_speeds
    log.info(
        "g(u): %d candidate(s) at %s m/s over the %.2f dB threshold",
        rs.n_movers,
        np.round(rs.speeds_mps, 2),
        detection.threshold_db,
    )
    return detection


def estimate_movers(
    traces: Traces,
    moving: NDArray[np.complexfloating],
    detection: RangeSpeedDetection,
    options: AnalysisOptions,
    *,
    central: slice,
    image: Image | None = None,
    progress: ProgressCallback | None = None,
) -> tuple[list[MoverFit], NDArray[np.complex128]]:
    """Maximum-likelihood movers, jointly refined, with their bounds; then extracted.

    On the central sub-aperture: each candidate is fitted (:func:`_fit_candidates`),
    all fits are refined jointly (``options.joint_rounds``), and, given the preliminary
    ``image``, re-fitted on the data minus a stationary estimate made without them
    (:func:`~sarmotion.pipeline.refit.refit_movers_on_data`); the noise level around each
    is measured on what they leave of the data of the last fit as the matched filter
    sees it (:func:`_local_noise`), and each gets its Cramér–Rao bound and, for
    comparison and the paper's figures, ``g_perp`` (``eq:OBJ2``) at its range speed and
    position. A wide aperture's estimates are then
    focused on all pulses. Each mover's own traces are extracted from the residual
    (:func:`extract_mover`) in turn. Returns the fits and the final residual.
    """
    sub = traces.select_pulses(central.start, central.stop)
    moving_sub = np.asarray(moving)[central]
    found = _fit_candidates(sub, moving_sub, detection, options, progress)
    fits = refine_jointly(sub, moving_sub, [f for f, _ in found], rounds=options.joint_rounds)
    on_s, data_sub = fits, moving_sub
    if image is not None and fits:
        threshold = options.separation.candidate_threshold_db
        fits, data_sub = refit_movers_on_data(sub, image, fits, threshold_db=threshold)
    drop = set(duplicate_fits(sub, fits))  # one mover is not declared twice
    if drop:
        log.info("%d fit(s) repeat a stronger mover's range history: merged", len(drop))
        keep = [k for k in range(len(fits)) if k not in drop]
        fits, on_s, found = ([x[k] for k in keep] for x in (fits, on_s, found))
    models = [point_model(sub, f.position_m, f.velocity_mps, f.amplitude) for f in fits]
    left = data_sub - sum(models, np.zeros(sub.shape, dtype=complex))
    residual = np.array(moving, dtype=np.complex128)
    out: list[MoverFit] = []
    for k, (fit, (_, evidence)) in enumerate(zip(fits, found, strict=True)):
        others = sum((m for j, m in enumerate(models) if j != k), np.zeros(sub.shape, complex))
        est = _estimate(sub, moving_sub - others, fit, detection, evidence, options)
        if fit is not on_s[k]:
            est = with_refit_history(est, on_s[k], fit)
        family = family_direction(sub, est.position_m, est.velocity_mps)
        if central != slice(0, traces.n_pulses):
            est = _on_whole_aperture(traces, residual, est, central)
        own = extract_mover(
            traces,
            residual,
            position_m=est.position_m,
            velocity_mps=est.velocity_mps,
            half_window=options.mover_half_window,
        )
        residual = residual - own
        out.append(
            MoverFit(
                estimate=est,
                traces=own,
                family_position_per_m=family[0],
                family_velocity_per_m=family[1],
                evidence=evidence,
                bound=_bound(sub, fit, _local_noise(sub, left, fit)),
                fit=fit,
            )
        )
        log.info(
            "mover %d: position (%.2f, %.2f) m, velocity (%.2f, %.2f) m/s",
            k + 1,
            *est.position_m[:2],
            *est.velocity_mps,
        )
    return out, residual


def _fit_candidates(
    sub: Traces,
    moving: NDArray[np.complexfloating],
    detection: RangeSpeedDetection,
    options: AnalysisOptions,
    progress: ProgressCallback | None,
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
    """
    residual = np.array(moving, dtype=np.complex128)
    current = detection
    tried: list[float] = []
    out: list[tuple[PointFit, MoverEvidence]] = []
    res = detection.range_speeds.resolution_mps
    while len(out) < options.max_movers:
        rs = current.range_speeds
        untried = [
            k for k, u in enumerate(rs.speeds_mps) if all(abs(u - t) > 0.5 * res for t in tried)
        ]
        report(progress, "movers", len(tried), len(tried) + len(untried))
        if not untried:
            break
        k = untried[0]
        u, statistic = float(rs.speeds_mps[k]), float(rs.peak_db[k])
        tried.append(u)
        fit = fit_point_mover(sub, residual, u, cross_speed_range_mps=options.speed_range_mps)
        if any(_same_trace(sub, fit, f) for f, _ in out):
            log.info("g(u) candidate at %.2f m/s: what a subtracted mover left", u)
            continue
        value = fit.amplitude * sub.n_pulses
        why = stationary_explanation(sub, residual, fit.position_m, fit.velocity_mps, value)
        if why.within_extent and why.focus_gain_db < options.min_focus_gain_db:
            log.info(
                "g(u) candidate at %.2f m/s: a stationary point at (%.1f, %.1f) m explains it "
                "(focus gain %.2f dB)",
                u,
                *why.position_m[:2],
                why.focus_gain_db,
            )
            continue
        residual = residual - point_model(sub, fit.position_m, fit.velocity_mps, fit.amplitude)
        out.append((fit, _evidence(detection, statistic, float(current.widths[k]), why)))
        current = _redetect(sub.with_data(residual), detection, options)
    return out


def _same_trace(sub: Traces, a: PointFit, b: PointFit) -> bool:
    """Whether two fits share a range cell at ``s = 0`` and the width of a ``g`` peak.

    The width is that of a point mover's peak (:func:`~sarmotion.motion.point_peak_width`,
    2.1 range-speed resolutions, 0.58 m/s, on a GOTCHA degree).
    """
    cells = resolution(sub)
    dx = abs(float((a.position_m[:2] - b.position_m[:2]) @ cells.range_direction))
    du = abs(a.range_speed_mps - b.range_speed_mps)
    return dx < cells.ground_range_m and du < point_peak_width(sub) * range_speed_resolution(sub)


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


def _evidence(
    detection: RangeSpeedDetection, statistic: float, width: float, why: StationaryExplanation
) -> MoverEvidence:
    """The detection record of an accepted candidate."""
    return MoverEvidence(
        statistic_db=statistic,
        threshold_db=detection.threshold_db,
        false_alarm_rate=detection.false_alarm_rate,
        p_value=detection.false_alarm_probability(statistic),
        width_resolutions=width,
        focus_gain_db=why.focus_gain_db,
        stationary_point_m=(float(why.position_m[0]), float(why.position_m[1])),
        stationary_within_extent=why.within_extent,
    )


def _estimate(
    sub: Traces,
    data: NDArray[np.complexfloating],
    fit: PointFit,
    detection: RangeSpeedDetection,
    evidence: MoverEvidence,
    options: AnalysisOptions,
) -> MoverEstimate:
    """The :class:`MoverEstimate` of a fit, with ``g_perp`` at its range speed and position.

    ``data`` holds the mover alone (the other movers' fits subtracted). ``g_perp`` is
    kept for the paper's figures and measured against the fit: its minimum is recorded
    beside the maximum-likelihood cross-range speed in ``history``.
    """
    cross = estimate_cross_range_speed(
        sub.with_data(data),
        range_speed_mps=fit.range_speed_mps,
        position_m=fit.position_m,
        speed_range_mps=options.speed_range_mps,
    )
    g = detection.range_speeds
    history = (
        {"stage": "detection", "statistic_db": evidence.statistic_db},
        {"stage": "g_perp", "cross_range_speed_mps": cross.speed_mps},
        {
            "stage": "maximum likelihood",
            "position_m": fit.position_m.tolist(),
            "range_speed_mps": fit.range_speed_mps,
            "cross_range_speed_mps": fit.cross_range_speed_mps,
        },
    )
    i = int(np.argmin(np.abs(g.grid_mps - fit.range_speed_mps)))
    return MoverEstimate(
        position_m=np.asarray(fit.position_m, dtype=np.float64).copy(),
        velocity_mps=np.asarray(fit.velocity_mps, dtype=np.float64).copy(),
        range_speed_mps=fit.range_speed_mps,
        cross_range_speed_mps=fit.cross_range_speed_mps,
        peak_value=float(g.objective[i]),
        peak_db=evidence.statistic_db,
        image_value=complex(fit.amplitude * sub.n_pulses),
        range_curve=g,
        cross_curve=cross,
        history=history,
    )


def _local_noise(sub: Traces, residual: NDArray[np.complexfloating], fit: PointFit) -> float:
    """Noise variance around a mover as the matched filter sees it, on what the fits leave.

    Positions within 10 m of the fit, range speeds within 2 m/s and cross-range speeds
    within 5 m/s of its own (:func:`~sarmotion.motion.matched_filter_noise_variance`):
    clutter residue is not white, and its level where the mover is sets the bound.
    """
    return matched_filter_noise_variance(
        sub, residual, half_size_m=10.0, centre_m=fit.position_m, velocity_mps=fit.velocity_mps
    )


def _bound(sub: Traces, fit: PointFit, variance: float) -> PointBound:
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


def extract_mover(
    traces: Traces,
    data: ArrayLike,
    *,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    half_window: int | None = None,
) -> NDArray[np.complex128]:
    """One mover's own traces from ``data``: its ``s``-independent part in its frame.

    ``T_+^{u, rho}`` (``eq:TTu+``) at the estimate ``(rho, u)`` brings the mover's trace
    to ``t = 0`` with a phase independent of ``s``: in that frame it is rank one and
    constant in slow time, while the other movers' and the residual clutter's traces
    still cross the window obliquely. The mover's part is the slow-time mean of the
    aligned traces in the fast-time window ``|t| <= half_window`` samples (the
    projection on ``s``-independent traces there), mapped back by ``T_-^{u, rho}``.

    Parameters
    ----------
    traces : Traces
        The acquisition (geometry, frequencies, reference point).
    data : (n_pulses, n_samples) array_like
        The traces the mover is taken from (e.g. the current moving residual).
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
    d = np.asarray(data)
    if d.shape != traces.shape:
        raise ValueError(f"data must have the traces' shape {traces.shape}, got {d.shape}")
    part = aligned_constant_part(
        traces, to_frequency(d), position_m, velocity_mps=velocity_mps, half_window=half_window
    )
    return to_fast_time(part)


def _on_whole_aperture(
    traces: Traces, residual: NDArray[np.complex128], est: MoverEstimate, central: slice
) -> MoverEstimate:
    """A (central sub-aperture's) estimate moved to ``s = 0`` and focused on all pulses."""
    fit = refine_on_aperture(
        traces.with_data(residual), est.position_m, est.velocity_mps, central=central
    )
    geom = traces.geometry
    log.info(
        "whole-aperture focus %.4g -> %.4g (x n_pulses)",
        fit.start_focus / traces.n_pulses,
        fit.focus / traces.n_pulses,
    )
    return dataclasses.replace(
        est,
        position_m=fit.position_m,
        velocity_mps=fit.velocity_mps,
        range_speed_mps=range_speed(fit.velocity_mps, geom),
        cross_range_speed_mps=cross_range_speed(fit.velocity_mps, geom),
        image_value=complex(fit.focus),
        history=(
            *est.history,
            {
                "stage": "whole aperture",
                "position_m": fit.position_m.tolist(),
                "velocity_mps": fit.velocity_mps.tolist(),
                "focus": fit.focus,
                "start_focus": fit.start_focus,
            },
        ),
    )


def stationary_targets(
    image: Image, sep: Separation, traces: Traces, options: AnalysisOptions
) -> tuple[StationaryTarget, ...]:
    """Bright points of the stationary image, brightest first.

    With the combined separation the points are the stationary locations it accepted
    (refined on the point response, Doppler-tested: sidelobes of bright targets are not
    listed); otherwise the local maxima of ``|I|`` at least one cross-range resolution
    cell apart. Each keeps its level ``20 log10(|I(rho)| / max |I|)`` (dB, nearest pixel
    of the refined position, so a point may read a fraction of a dB low) when it is
    above ``options.stationary_threshold_db``; at most ``options.max_stationary``.
    """
    threshold_db, max_targets = options.stationary_threshold_db, options.max_stationary
    if max_targets == 0:
        return ()
    mag = image.magnitude
    peak = float(mag.max())
    if peak <= 0:
        return ()
    if sep.method == "combined" and len(sep.stationary_points_m):
        points = [tuple(p[:2]) for p in sep.stationary_points_m]
    else:
        cells = resolution(traces)
        cell = max(cells.ground_range_m, cells.cross_range_m)
        points = [(x, y) for x, y, _ in image.peaks(max_targets, min_separation_m=cell)]
    left, right, bottom, top = image.grid.extent
    found = []
    for x, y in points:
        if not (left <= x <= right and bottom <= y <= top):
            continue
        iy, ix = image.grid.nearest_index((x, y))
        db = float(20.0 * np.log10(max(mag[iy, ix], 1e-300) / peak))
        if db >= threshold_db:
            found.append(StationaryTarget(position_m=(float(x), float(y)), peak_db=db))
    found.sort(key=lambda t: -t.peak_db)
    return tuple(found[:max_targets])


def estimate_trajectories(
    traces: Traces, fits: list[MoverFit], *, progress: ProgressCallback | None = None
) -> list[TrajectoryEstimate | None]:
    """Each mover's trajectory by the phase-space algorithm, from its own traces."""
    out: list[TrajectoryEstimate | None] = []
    for k, fit in enumerate(fits):
        est = fit.estimate
        try:
            out.append(
                estimate_trajectory(
                    traces.with_data(fit.traces),
                    est.position_m,
                    velocity_guess_mps=est.velocity_mps,
                )
            )
        except EstimationError as exc:  # e.g. too few pulses, or the search past the edge
            log.warning("trajectory of mover %d not estimated: %s", k + 1, exc)
            out.append(None)
        report(progress, "trajectories", k + 1, len(fits))
    return out


def stationary_image(
    traces: Traces,
    separation: Separation,
    fits: list[MoverFit],
    grid: ImageGrid,
    *,
    progress: ProgressCallback | None = None,
) -> Image:
    """``eq:image`` of the stationary traces: ``L``, or ``M`` minus the movers' traces."""
    if separation.stationary is not None:
        data = separation.stationary
    else:
        data = traces.data - sum((f.traces for f in fits), np.zeros(traces.shape))
    return backproject(traces.with_data(data), grid, progress=_staged(progress, "stationary image"))


def mover_results(
    traces: Traces,
    fits: list[MoverFit],
    trajectories: list[TrajectoryEstimate | None],
    stationary: Image,
    options: AnalysisOptions,
) -> tuple[MoverResult, ...]:
    """Each mover's image (``eq:imagecompu`` at its velocity) and its result record."""
    stat_peak = float(stationary.magnitude.max()) or 1.0
    movers = []
    for fit, tj in zip(fits, trajectories, strict=True):
        est = fit.estimate
        mgrid = ImageGrid.square(
            centre_m=tuple(est.position_m[:2]),
            size_m=options.mover_image_size_m,
            spacing_m=options.spacing_m,
        )
        img = backproject(traces.with_data(fit.traces), mgrid, velocity_mps=est.velocity_mps)
        x, y, v = img.peak(refine=True)
        movers.append(
            MoverResult(
                estimate=est,
                traces=fit.traces,
                image=img,
                image_peak_m=np.array([x, y]),
                peak_db=float(20.0 * np.log10(max(abs(v), 1e-300) / stat_peak)),
                family_position_per_m=fit.family_position_per_m,
                family_velocity_per_m=fit.family_velocity_per_m,
                trajectory=tj,
                evidence=fit.evidence,
                bound=fit.bound,
                fit=fit.fit,
            )
        )
    return tuple(movers)


def _staged(progress: ProgressCallback | None, stage: str) -> ProgressCallback | None:
    """``progress`` with its stage name replaced by ``stage``."""
    if progress is None:
        return None
    return lambda _, done, total: progress(stage, done, total)
