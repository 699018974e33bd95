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

from ..core.geometry import cross_range_speed, range_speed
from ..core.progress import ProgressCallback, report
from ..core.spectral import to_fast_time, to_frequency
from ..core.traces import Traces
from ..imaging import Image, ImageGrid, backproject, resolution, scene_grid
from ..motion import (
    MoverEstimate,
    RangeSpeeds,
    TrajectoryEstimate,
    cross_range_speed_resolution,
    estimate_range_speeds,
    estimate_trajectory,
    estimate_velocity,
    family_direction,
    range_speed_resolution,
    refine_on_aperture,
)
from ..separation import Separation, aligned_constant_part
from .options import AnalysisOptions
from .results import MoverResult, StationaryTarget

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
    """

    estimate: MoverEstimate
    traces: NDArray[np.complex128]
    family_position_per_m: NDArray[np.float64]
    family_velocity_per_m: NDArray[np.float64]


def preliminary_image(
    traces: Traces, options: AnalysisOptions, *, progress: ProgressCallback | None = None
) -> Image:
    """``eq:image`` of the data on the square scene grid of ``options`` (resolved)."""
    grid = scene_grid(traces, size_m=options.image_size_m, spacing_m=options.spacing_m)
    return backproject(traces, grid, progress=_staged(progress, "preliminary image"))


def find_range_speeds(
    traces: Traces, moving: NDArray[np.complexfloating], options: AnalysisOptions
) -> RangeSpeeds:
    """The number of movers and their range speeds: the peaks of ``g(u)`` on ``moving``.

    A stationary target at cross-range offset ``y`` has an apparent range speed
    ``V y / L`` (``eq:Dtau``); movers must be well above it over the imaged scene
    (``eq:AnnihCond``, ``u >> V R / L``): here twice its value at the image's
    half-diagonal, and at least four range-speed resolutions.
    """
    data = traces.with_data(moving)
    geom = traces.geometry
    apparent = geom.speed_mps * (options.image_size_m / np.sqrt(2.0)) / geom.range_m
    speeds = estimate_range_speeds(
        data,
        speed_range_mps=options.speed_range_mps,
        max_movers=options.max_movers,
        threshold_db=options.threshold_db,
        min_speed_mps=max(4.0 * range_speed_resolution(data), 2.0 * apparent),
    )
    log.info("g(u): %d mover(s) at %s m/s", speeds.n_movers, np.round(speeds.speeds_mps, 2))
    return speeds


def estimate_movers(
    traces: Traces,
    moving: NDArray[np.complexfloating],
    speeds: RangeSpeeds,
    options: AnalysisOptions,
    *,
    central: slice,
    progress: ProgressCallback | None = None,
) -> tuple[list[MoverFit], NDArray[np.complex128]]:
    """Movers one at a time, strongest first, each extracted from the residual.

    For each ``g(u)`` peak: location and velocity on the central sub-aperture of the
    current residual (``estimate_velocity``), the cross-range family, the focus on the
    whole aperture, then extraction (:func:`extract_mover`) and subtraction before the
    next mover. Returns the fits and the final residual.
    """
    residual = np.array(moving, dtype=np.complex128)
    sub = traces.select_pulses(central.start, central.stop)
    fits: list[MoverFit] = []
    for k, u_hint in enumerate(speeds.speeds_mps):
        fit = _one_mover(traces, sub, residual, float(u_hint), options, central)
        if fit is not None:
            residual = residual - fit.traces
            fits.append(fit)
            log.info(
                "mover %d: position (%.2f, %.2f) m, velocity (%.2f, %.2f) m/s",
                len(fits),
                *fit.estimate.position_m[:2],
                *fit.estimate.velocity_mps,
            )
        report(progress, "movers", k + 1, speeds.n_movers)
    return fits, residual


def _one_mover(
    traces: Traces,
    sub: Traces,
    residual: NDArray[np.complex128],
    u_hint: float,
    options: AnalysisOptions,
    central: slice,
) -> MoverFit | None:
    """Estimate, focus and extract the mover of one ``g(u)`` peak (None if rejected)."""
    lo, hi = options.speed_range_mps
    current = sub.with_data(residual[central])
    est = estimate_velocity(
        current, range_speed_mps=u_hint, speed_range_mps=(lo, hi), cross_speed_range_mps=(lo, hi)
    )
    # A g_perp minimum on the edge of the searched interval is no minimum: the traces at
    # this range speed do not curve like one mover's (on the real 4-degree GOTCHA scene,
    # clutter left in S gave such "movers" at u_perp = +-30 m/s).
    edge = cross_range_speed_resolution(current)
    if not (lo + edge < est.cross_range_speed_mps < hi - edge):
        log.warning(
            "g(u) peak at %.2f m/s rejected: cross-range speed %.1f m/s on the search edge",
            u_hint,
            est.cross_range_speed_mps,
        )
        return None
    family = family_direction(sub, est.position_m, est.velocity_mps)
    est = _on_whole_aperture(traces, residual, est, central)
    own = extract_mover(
        traces,
        residual,
        position_m=est.position_m,
        velocity_mps=est.velocity_mps,
        half_window=options.mover_half_window,
    )
    return MoverFit(
        estimate=est, traces=own, family_position_per_m=family[0], family_velocity_per_m=family[1]
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
        except ValueError as exc:  # e.g. a mover too close to the window edge
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
            )
        )
    return tuple(movers)


def _staged(progress: ProgressCallback | None, stage: str) -> ProgressCallback | None:
    """``progress`` with its stage name replaced by ``stage``."""
    if progress is None:
        return None
    return lambda _, done, total: progress(stage, done, total)
