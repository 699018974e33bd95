"""The first steps of the analysis: preliminary image, separation and the range-speed test.

:func:`detect` runs them as :func:`~sarmotion.pipeline.analyze` does and returns a
:class:`DetectionResult`, which :func:`~sarmotion.pipeline.estimate_movers` takes. Tests
and benchmarks that look inside the analysis call these two instead of copying the
stages. Positions in m (data frame), speeds in m/s, times in s.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.acquisition import Acquisition
from ..core.progress import ProgressCallback
from ..core.traces import Traces
from ..imaging import Image, backproject, scene_grid
from ..motion import (
    RangeSpeedDetection,
    azimuth_span_deg,
    central_sub_aperture,
    detect_range_speeds,
    range_speed_resolution,
    screen_threshold_db,
)
from ..separation import Separation, separate
from ._timing import staged, timed
from .options import AnalysisOptions

__all__ = ["DetectionResult", "detect", "preliminary_image", "find_range_speeds"]

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True, eq=False)
class DetectionResult:
    """What the first three steps of the analysis found (:func:`detect`).

    Attributes
    ----------
    traces : Traces
        The data ``M``, the whole aperture.
    options : AnalysisOptions
        The options, every data-dependent default filled (:meth:`AnalysisOptions.resolved`).
    central : slice
        The pulses of the central sub-aperture the movers are detected and estimated on
        (``options.sub_aperture_deg``); every pulse for a narrow aperture.
    sub : Traces
        ``M`` on those pulses, slow time re-centred on them (``traces.select_pulses``).
    image : Image
        The preliminary image ``eq:image`` of ``M``.
    separation : Separation
        ``S`` (moving) and ``L`` (stationary) of the whole aperture.
    candidates : RangeSpeedDetection
        The ``g(u)`` peaks of ``S`` on the central sub-aperture and their test.
    timings_s : dict of str to float
        Wall-clock time of each step (s): ``preliminary_image``, ``separation``,
        ``range_speeds``.
    """

    traces: Traces
    options: AnalysisOptions
    central: slice
    sub: Traces
    image: Image
    separation: Separation
    candidates: RangeSpeedDetection
    timings_s: dict[str, float] = field(default_factory=dict)

    @property
    def moving_sub(self) -> NDArray[np.complexfloating]:
        """``S`` on the central sub-aperture, shape ``sub.shape``."""
        return self.separation.moving[self.central]

    @property
    def whole_aperture(self) -> bool:
        """Whether the central sub-aperture is every pulse."""
        return self.central == slice(0, self.traces.n_pulses)


def detect(
    traces: Traces,
    options: AnalysisOptions | None = None,
    *,
    image_outline_m: ArrayLike | None = None,
    progress: ProgressCallback | None = None,
) -> DetectionResult:
    """Preliminary image, stationary/moving separation and range-speed candidates.

    Steps 1-3 of :func:`~sarmotion.pipeline.analyze`: ``eq:image`` on the square scene
    grid, ``M = L + S`` (:func:`~sarmotion.separation.separate`), and the ``g(u)`` peaks
    of ``S`` on the central sub-aperture that pass the detector
    (:func:`find_range_speeds`).

    Parameters
    ----------
    traces : Traces
        Data ``M``.
    options : AnalysisOptions, optional
        Every choice of the analysis (resolved here against ``traces``).
    image_outline_m : (4, 2) array_like, optional
        The preliminary image's pixels are formed only within this ground parallelogram
        (m) (:func:`preliminary_image`).
    progress : callable, optional
        ``progress(stage, done, total)`` during the long steps.

    Returns
    -------
    DetectionResult
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a sarmotion Traces, got {type(traces).__name__}")
    if options is not None and not isinstance(options, AnalysisOptions):
        raise TypeError(
            f"options must be an AnalysisOptions (AnalysisOptions(**mapping) builds one from "
            f"a dict), got {type(options).__name__}"
        )
    opts = (options or AnalysisOptions()).resolved(traces)
    timings: dict[str, float] = {}
    central = central_sub_aperture(traces, opts.sub_aperture_deg)
    if central != slice(0, traces.n_pulses):
        log.info(
            "aperture of %.1f degrees: movers estimated on pulses %d-%d, refined on all",
            azimuth_span_deg(traces),
            central.start,
            central.stop - 1,
        )
    with timed(timings, "preliminary_image"):
        prelim = preliminary_image(traces, opts, outline_m=image_outline_m, progress=progress)
    with timed(timings, "separation"):
        sep = separate(traces, prelim, opts.separation, progress=progress)
    with timed(timings, "range_speeds"):
        sub = traces.select_pulses(central.start, central.stop)
        candidates = find_range_speeds(sep.moving[central], opts, acquisition=sub.acquisition)
    return DetectionResult(
        traces=traces,
        options=opts,
        central=central,
        sub=sub,
        image=prelim,
        separation=sep,
        candidates=candidates,
        timings_s=timings,
    )


def preliminary_image(
    traces: Traces,
    options: AnalysisOptions,
    *,
    outline_m: ArrayLike | None = None,
    progress: ProgressCallback | None = None,
) -> Image:
    """``eq:image`` of the data on the square scene grid of ``options`` (resolved).

    ``outline_m``: a ground parallelogram (m) beyond which the traces hold no stationary
    echo; the pixels outside it are 0 and not formed
    (:func:`~sarmotion.imaging.backproject`).
    """
    grid = scene_grid(traces, size_m=options.image_size_m, spacing_m=options.spacing_m)
    return backproject(
        traces,
        grid,
        progress=staged(progress, "preliminary image"),
        device=options.device,
        method=options.image_method or "exact",
        outline_m=outline_m,
    )


def find_range_speeds(
    moving: NDArray[np.complexfloating], options: AnalysisOptions, *, acquisition: Acquisition
) -> RangeSpeedDetection:
    """Candidate range speeds: the ``g(u)`` peaks on ``moving`` that pass the detector.

    The statistic is each peak over its local floor, the threshold that of
    ``options.false_alarm_rate`` (:mod:`sarmotion.motion.detector`), peaks wider than
    ``options.max_peak_width`` resolutions are stationary residue. Peaks slower than the
    stationary band are not tested: the apparent range speed ``V y / L`` (``eq:Dtau``)
    of a stationary target at the image's half-diagonal, and at least two range-speed
    resolutions (the stationary peak's main lobe); or ``options.stationary_speed_mps``
    where given (the caller knows its image's stationary band). Slower candidates than the paper's
    ``u >> V R / L`` (``eq:AnnihCond``) are admitted because the focus test of the mover
    stage rejects those a stationary point explains. ``acquisition`` is that of
    ``moving`` (the central sub-aperture).

    With ``options.detector == "coherent"`` this is the first stage of the coherent
    detector (:mod:`sarmotion.motion.coherent`): the threshold is the ``g(u)`` null's
    per-candidate point :func:`~sarmotion.motion.screen_threshold_db` (unless
    ``options.threshold_db`` is given), and the mover stage tests each candidate's fit.
    """
    data = Traces(data=moving, acquisition=acquisition)
    threshold = options.threshold_db
    if options.detector == "coherent" and threshold is None:
        threshold = screen_threshold_db()
    geom = acquisition.geometry
    slowest = options.stationary_speed_mps
    if slowest is None:
        apparent = geom.speed_mps * (options.image_size_m / np.sqrt(2.0)) / geom.range_m
        slowest = max(2.0 * range_speed_resolution(data), apparent)
    detection = detect_range_speeds(
        data,
        speed_range_mps=options.speed_range_mps,
        false_alarm_rate=options.false_alarm_rate,
        threshold=threshold,
        min_speed_mps=slowest,
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
