"""What the analysis found: movers, stationary targets, images and the traces behind them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.traces import Traces
from ..imaging import Image
from ..motion import (
    MoverEstimate,
    PointBound,
    PointFit,
    RangeSpeedDetection,
    RangeSpeeds,
    TrajectoryEstimate,
)
from ..separation import Separation
from .options import AnalysisOptions

__all__ = ["MoverEvidence", "MoverResult", "StationaryTarget", "AnalysisResult"]


@dataclass(frozen=True, kw_only=True)
class MoverEvidence:
    """Why a mover was declared (:mod:`sarmotion.motion.detector`).

    Attributes
    ----------
    statistic_db : float
        ``g(u)`` peak over its local floor (dB), re-measured after the stronger movers
        were subtracted.
    threshold_db : float
        Threshold it passed (dB).
    false_alarm_rate : float
        Per-scene false-alarm rate the threshold was set for.
    p_value : float
        Per-scene probability that clutter and noise alone reach ``statistic_db``
        (the measured null tail, union over the candidates).
    width_resolutions : float
        Half-height width of the ``g`` peak (range-speed resolutions).
    focus_gain_db : float
        Matched filter at the fit over the best stationary point with the same range
        history (dB).
    stationary_point_m : (float, float)
        That stationary point (m).
    stationary_within_extent : bool
        Whether it lies within the alias-free cross-range extent (only then is the gain
        tested).
    """

    statistic_db: float
    threshold_db: float
    false_alarm_rate: float
    p_value: float
    width_resolutions: float
    focus_gain_db: float
    stationary_point_m: tuple[float, float]
    stationary_within_extent: bool


@dataclass(frozen=True, kw_only=True, eq=False)
class MoverResult:
    """One mover found by :func:`analyze`.

    Attributes
    ----------
    estimate : MoverEstimate
        Location at ``s = 0`` (m) and ground velocity (m/s), with the ``g`` and
        ``g_perp`` curves (:func:`sarmotion.motion.estimate_velocity`).
    traces : (n_pulses, n_samples) ndarray
        The mover's own separated traces ``D_q`` (data units).
    image : Image
        Its image compensated at the estimated velocity (``eq:imagecompu``).
    image_peak_m : (2,) ndarray
        Sub-pixel position of the brightest pixel of :attr:`image` (m).
    peak_db : float
        Image peak relative to the brightest pixel of the stationary image (dB).
    family_position_per_m, family_velocity_per_m : (2,) ndarray
        Tangent of the family of motions with the same traces
        (:func:`sarmotion.motion.family_direction`): ``position + t a``, ``velocity +
        t b`` fit the data as well for ``t`` metres of cross-range offset (m/m and
        (m/s)/m). The data of a few degrees do not fix ``t`` (:mod:`sarmotion.motion.aperture`).
    trajectory : TrajectoryEstimate or None
        Phase-space trajectory, if requested.
    evidence : MoverEvidence or None
        The detection test it passed.
    bound : PointBound or None
        Cramér–Rao bound of its range position, range and cross-range speeds and
        amplitude at its measured SNR, on the sub-aperture it was estimated on
        (:mod:`sarmotion.motion.bounds`): its standard errors.
    fit : PointFit or None
        The maximum-likelihood fit on that sub-aperture (with the global
        cross-range-speed profile).
    """

    estimate: MoverEstimate
    traces: NDArray[np.complexfloating]
    image: Image
    image_peak_m: NDArray[np.float64]
    peak_db: float
    family_position_per_m: NDArray[np.float64]
    family_velocity_per_m: NDArray[np.float64]
    trajectory: TrajectoryEstimate | None = None
    evidence: MoverEvidence | None = None
    bound: PointBound | None = None
    fit: PointFit | None = None

    @property
    def position_m(self) -> NDArray[np.float64]:
        """Location at ``s = 0`` (m), ``(x, y)``."""
        return self.estimate.position_m[:2]

    @property
    def velocity_mps(self) -> NDArray[np.float64]:
        """Ground velocity ``(ux, uy)`` (m/s)."""
        return self.estimate.velocity_mps


@dataclass(frozen=True, kw_only=True)
class StationaryTarget:
    """A bright point of the stationary image.

    Attributes
    ----------
    position_m : (float, float)
        Position ``(x, y)`` (m).
    peak_db : float
        Level relative to the brightest pixel of the stationary image (dB).
    """

    position_m: tuple[float, float]
    peak_db: float


@dataclass(frozen=True, kw_only=True, eq=False)
class AnalysisResult:
    """Everything :func:`analyze` computed.

    Attributes
    ----------
    traces : Traces
        The input traces ``M``.
    separation : Separation
        ``S`` (moving) and ``L`` (stationary, None for annihilation).
    range_speeds : RangeSpeeds
        ``g(u)`` on ``S`` and the candidates that passed its statistical test.
    detection : RangeSpeedDetection or None
        The test: every candidate's statistic, the threshold and its false-alarm rate.
    movers : tuple of MoverResult
        The movers, in the order they were separated (strongest first).
    residual : (n_pulses, n_samples) ndarray
        ``S`` minus every mover's traces.
    preliminary_image, stationary_image : Image
        ``eq:image`` of ``M`` and of the stationary traces.
    stationary : tuple of StationaryTarget
        Bright points of the stationary image.
    timings_s : dict of str to float
        Wall-clock time per stage (s).
    options : AnalysisOptions
        The options the analysis ran with, every data-dependent default filled.
    """

    traces: Traces
    separation: Separation
    range_speeds: RangeSpeeds
    detection: RangeSpeedDetection | None = None
    movers: tuple[MoverResult, ...]
    residual: NDArray[np.complexfloating]
    preliminary_image: Image
    stationary_image: Image
    stationary: tuple[StationaryTarget, ...]
    timings_s: dict[str, float]
    options: AnalysisOptions

    @property
    def stationary_traces(self) -> NDArray[np.complexfloating]:
        """``L``, or ``M`` minus the movers' traces for the annihilation filter."""
        if self.separation.stationary is not None:
            return self.separation.stationary
        return self.traces.data - sum((m.traces for m in self.movers), np.zeros(1))

    @property
    def method(self) -> str:
        """The stationary/moving separation method used."""
        return self.separation.method
