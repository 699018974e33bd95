"""What the analysis found: movers, stationary targets, images and the traces behind them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.traces import Traces
from ..imaging import Image
from ..motion import MoverEstimate, RangeSpeeds, TrajectoryEstimate
from ..separation import Separation
from .options import AnalysisOptions

__all__ = ["MoverResult", "StationaryTarget", "AnalysisResult"]


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
    """

    estimate: MoverEstimate
    traces: NDArray[np.complexfloating]
    image: Image
    image_peak_m: NDArray[np.float64]
    peak_db: float
    family_position_per_m: NDArray[np.float64]
    family_velocity_per_m: NDArray[np.float64]
    trajectory: TrajectoryEstimate | None = None

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
        ``g(u)`` on ``S`` and its peaks (the number of movers).
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
