"""What the analysis found: movers, stationary targets, images and the traces behind them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.text import fixed
from ..core.traces import Traces
from ..imaging import Image
from ..motion import (
    ApertureFit,
    CrossRangeSpeed,
    PointBound,
    PointFit,
    RangeAcceleration,
    RangeSpeedDetection,
    RangeSpeeds,
    TrajectoryEstimate,
    azimuth_span_deg,
)
from ..separation import Separation
from .options import AnalysisOptions

__all__ = ["MoverEvidence", "Mover", "NotEstimated", "StationaryTarget", "AnalysisResult"]


def _pair(v: NDArray[np.float64] | tuple[float, ...], digits: int = 2) -> str:
    return f"({fixed(v[0], digits)}, {fixed(v[1], digits)})"


@dataclass(frozen=True, kw_only=True)
class MoverEvidence:
    """Why a mover was declared (:mod:`sarmotion.motion.detector`).

    Attributes
    ----------
    statistic_db : float
        ``g(u)`` peak over its local floor (dB), the detector's statistic, re-measured
        after the stronger movers were subtracted.
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
    coherent_statistic_db, coherent_threshold_db, coherent_p_value : float or None
        With the coherent detector (:mod:`sarmotion.motion.coherent`): the fit's
        generalized likelihood ratio ``10 log10(|I|^2 / sigma_I^2)`` (dB), the threshold
        it passed (dB) and its per-scene significance; ``None`` with the ``g(u)``
        detector.
    defocus : DefocusEvidence or None
        For a mover in the stationary band, found by its focus over the cross-range-speed
        bank (:mod:`sarmotion.pipeline.defocused`): the bank's record. The ``g(u)``
        numbers above are then ``g``'s at its range speed, for the record (in the band
        ``g`` does not test).
    """

    statistic_db: float
    threshold_db: float
    false_alarm_rate: float
    p_value: float
    width_resolutions: float
    focus_gain_db: float
    stationary_point_m: tuple[float, float]
    stationary_within_extent: bool
    coherent_statistic_db: float | None = None
    coherent_threshold_db: float | None = None
    coherent_p_value: float | None = None
    defocus: DefocusEvidence | None = None


@dataclass(frozen=True, kw_only=True)
class DefocusEvidence:
    """Why a mover in the stationary band was declared (:mod:`sarmotion.motion.defocus`).

    Attributes
    ----------
    statistic_db : float
        Its bank cell's power over its interference level (dB): the noise, or its range
        bin's mean power beyond a main-lobe guard (:mod:`sarmotion.motion.defocus`).
    threshold_db : float
        The level the interference reaches in some cell with probability
        ``false_alarm_rate`` (dB, union bound).
    p_value : float
        Union-bound probability that the interference alone reaches ``statistic_db`` in
        some cell.
    smear_margin_db : float
        Its amplitude over the brightest stationary smear at its cell (dB).
    bank_cross_range_speed_mps : float
        The bank's cross-range speed that focused it (m/s).
    """

    statistic_db: float
    threshold_db: float
    p_value: float
    smear_margin_db: float
    bank_cross_range_speed_mps: float


@dataclass(frozen=True, kw_only=True, eq=False)
class Mover:
    """One mover, from its detection to its image: the record :func:`analyze` returns.

    The mover stage (:func:`~sarmotion.pipeline.estimate_movers`) makes it with
    everything but the image and the trajectory; the later stages add those
    (:func:`dataclasses.replace`). Its history is typed: the detection test
    (:attr:`evidence`), the fit on the separated traces (:attr:`separated_fit`), the
    re-fit on the data (:attr:`fit`, :attr:`refit_kept`), ``g_perp`` at the fit
    (:attr:`g_perp`) and the focus on the whole aperture (:attr:`aperture`).

    Attributes
    ----------
    position_m : (3,) ndarray
        Location at ``s = 0`` (m), data frame: the whole-aperture focus when there is
        one, else the final fit.
    velocity_mps : (2,) ndarray
        Ground velocity ``(ux, uy)`` (m/s), idem.
    range_speed_mps, cross_range_speed_mps : float
        ``u . m_o`` (``eq:rangeu``) and ``u_perp`` (``eq:crangeu``) of that velocity
        in the acquisition's geometry (m/s).
    evidence : MoverEvidence
        The detection test it passed.
    separated_fit : PointFit
        The maximum-likelihood fit on the separated traces ``S`` of the sub-aperture it
        was estimated on, jointly refined with the other movers.
    fit : PointFit
        The final fit on that sub-aperture: the re-fit on the data minus a stationary
        estimate made without the movers (:mod:`sarmotion.pipeline.refit`) when it was
        kept, else :attr:`separated_fit` (with its amplitude measured on the data when
        the re-fit ran).
    refit_kept : bool or None
        Whether the re-fit was kept; ``None`` when no re-fit ran.
    g_perp : CrossRangeSpeed
        ``g_perp`` (``eq:OBJ2``) at the fit's range speed and position, on the mover
        alone (the others' fits subtracted), for comparison with the fit.
    aperture : ApertureFit or None
        The estimate moved to the whole aperture's ``s = 0`` and focused on all pulses;
        ``None`` when the sub-aperture is the whole aperture.
    bound : PointBound
        Cramér–Rao bound of its range position, range and cross-range speeds and
        amplitude at its measured SNR, on the sub-aperture (:mod:`sarmotion.motion.bounds`):
        its standard errors.
    family_position_per_m, family_velocity_per_m : (2,) ndarray
        Tangent of the family of motions with the same traces
        (:func:`sarmotion.motion.family_direction`): ``position + t a``, ``velocity +
        t b`` fit the data as well for ``t`` metres of cross-range offset (m/m and
        (m/s)/m). The data of a few degrees do not fix ``t`` (:mod:`sarmotion.motion.aperture`).
    traces : (n_pulses, n_samples) ndarray or None
        The mover's own separated traces ``D_q`` (data units, whole aperture); None
        before the extraction step.
    image : Image or None
        Its image compensated at the estimated velocity (``eq:imagecompu``).
    image_peak_m : (2,) ndarray or None
        Sub-pixel position of the brightest pixel of :attr:`image` (m).
    image_peak_db : float or None
        That peak relative to the brightest pixel of the stationary image (dB).
    trajectory : TrajectoryEstimate or None
        Phase-space trajectory, if requested.
    acceleration : RangeAcceleration or None
        Its range acceleration over the whole aperture with its Cramér–Rao bound
        (:mod:`sarmotion.motion.acceleration`); ``None`` when the sub-aperture is the
        whole aperture (about a degree does not separate it from the cross-range speed).
    """

    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64]
    range_speed_mps: float
    cross_range_speed_mps: float
    evidence: MoverEvidence
    separated_fit: PointFit
    fit: PointFit
    refit_kept: bool | None
    g_perp: CrossRangeSpeed
    aperture: ApertureFit | None
    bound: PointBound
    family_position_per_m: NDArray[np.float64]
    family_velocity_per_m: NDArray[np.float64]
    traces: NDArray[np.complexfloating] | None = None
    image: Image | None = None
    image_peak_m: NDArray[np.float64] | None = None
    image_peak_db: float | None = None
    trajectory: TrajectoryEstimate | None = None
    acceleration: RangeAcceleration | None = None

    def __repr__(self) -> str:
        """One line: position at ``s = 0``, velocity, range and cross-range speeds, statistic."""
        return (
            f"Mover(position_m={_pair(self.position_m)}, velocity_mps={_pair(self.velocity_mps)}, "
            f"range_speed_mps={fixed(self.range_speed_mps)}, "
            f"cross_range_speed_mps={fixed(self.cross_range_speed_mps)}, "
            f"statistic_db={fixed(self.evidence.statistic_db, 1)})"
        )


def acceleration_text(acc: RangeAcceleration | None) -> str:
    """A mover's range acceleration in words: the value and its bound, or why there is none."""
    if acc is None:
        return (
            "not estimable: the analysis ran on one sub-aperture, over which it is one "
            "with the cross-range speed (sarmotion.motion.acceleration)"
        )
    if not acc.estimable:
        return (
            f"not estimable: its bound {acc.std_mps2:.2g} m/s^2 is over the prior's "
            f"{acc.prior_std_mps2:.2g} m/s^2 (sarmotion.motion.acceleration)"
        )
    return (
        f"{fixed(acc.range_acceleration_mps2, 3)} +- {acc.std_mps2:.2g} m/s^2 "
        "(rate of change of the range speed)"
    )


@dataclass(frozen=True, kw_only=True)
class NotEstimated:
    """A candidate that passed the detector but was not estimated: ``max_movers`` was reached.

    Attributes
    ----------
    range_speed_mps : float
        Its ``g(u)`` peak (m/s), on what the estimated movers leave of ``S``.
    statistic_db : float
        Its detector statistic there (dB, ``g`` peak over its local floor), above the
        threshold.
    width_resolutions : float
        Half-height width of its ``g`` peak (range-speed resolutions).
    range_m : float
        Ground-range coordinate ``(rho - rho_o) . e_r`` of its range history at ``s = 0``
        (m): the brightest fast-time sample of the traces aligned at that range speed and
        zero cross-range speed, not fitted (good to about a range resolution).
    """

    range_speed_mps: float
    statistic_db: float
    width_resolutions: float
    range_m: float


@dataclass(frozen=True, kw_only=True)
class StationaryTarget:
    """A bright point of the stationary image.

    Attributes
    ----------
    position_m : (float, float)
        Position ``(x, y)`` (m).
    level_db : float
        ``20 log10(|I(rho)| / max |I|)`` on the stationary image (dB, <= 0).
    """

    position_m: tuple[float, float]
    level_db: float


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
    movers : tuple of Mover
        The movers, in the order they were separated (strongest first).
    residual : (n_pulses, n_samples) ndarray
        ``S`` minus every mover's traces.
    preliminary_image, stationary_image : Image
        ``eq:image`` of ``M`` and of the stationary traces.
    stationary : tuple of StationaryTarget
        Bright points of the stationary image.
    timings_s : dict of str to float
        Wall-clock time per stage (s) and ``total``, their sum; the ``movers.<step>``
        entries break the ``movers`` stage down (:mod:`sarmotion.pipeline.movers`) and
        are not in ``total``.
    options : AnalysisOptions
        The options the analysis ran with, every data-dependent default filled.
    movers_not_estimated : tuple of NotEstimated
        The candidates that passed the detector after ``options.max_movers`` movers were
        accepted, strongest first: detected, neither estimated nor tested against a
        stationary explanation.
    stationary_sidelobes : int
        Local maxima of the stationary image above the listing threshold that a brighter
        one's sidelobes explain, not listed
        (:func:`~sarmotion.pipeline.stages.stationary_targets`).
    stationary_mover_images : int
        Listings of the stationary image that lie on a found mover's smeared echo,
        dropped from :attr:`stationary` (the collection's rule,
        :func:`sarmotion.collection.merge.drop_mover_images`, applied by
        :func:`sarmotion.collection.drop_smear`); 0 when that rule was not applied.
    """

    traces: Traces
    separation: Separation
    range_speeds: RangeSpeeds
    detection: RangeSpeedDetection | None = None
    movers: tuple[Mover, ...]
    residual: NDArray[np.complexfloating]
    preliminary_image: Image
    stationary_image: Image
    stationary: tuple[StationaryTarget, ...]
    timings_s: dict[str, float]
    options: AnalysisOptions
    movers_not_estimated: tuple[NotEstimated, ...] = ()
    stationary_sidelobes: int = 0
    stationary_mover_images: int = 0

    def __repr__(self) -> str:
        """One line: pulses, samples, movers, stationary targets, method and total time."""
        return (
            f"AnalysisResult({self.traces.n_pulses} pulses x {self.traces.n_samples} samples, "
            f"{len(self.movers)} mover(s), {len(self.stationary)} stationary target(s), "
            f"method {self.method!r}, timings_s['total'] = "
            f"{self.timings_s.get('total', float('nan')):.2f} s)"
        )

    def summary(self) -> str:
        """The analysis in a few lines of text: what the data fix and what they do not.

        The acquisition and the frame; each mover's range offset, range speed and
        cross-range speed with their standard errors (Cramér–Rao bound at the measured
        SNR, :class:`~sarmotion.motion.PointBound`, conditional on the mover sitting at
        the reference cross range), the range speed's span over its cross-range family
        across the stationary image (every member fits the data as well) and its
        detection statistic against the threshold; the stationary targets; what is known
        of the movers' cross-range positions; the time the stages took.

        Frame: ground coordinates ``(x, y)`` (m) of the scene; the range direction is
        ``b``, the ground projection of ``m_o`` (from the reference point towards the
        antenna at ``s = 0``), normalised, and the cross-range direction is ``b`` turned
        by +90 degrees. A mover's range offset is ``(position - rho_o) . b`` and its range
        speed ``u . m_o`` (``eq:rangeu``): both positive towards the radar (a positive
        range speed closes the range).
        """
        tr = self.traces
        geometry = tr.geometry
        b = np.asarray(geometry.ground_m_o, dtype=np.float64)
        b = b / np.linalg.norm(b)
        rho_o = np.asarray(tr.reference_point_m, dtype=np.float64)[:2]
        span = float(azimuth_span_deg(tr))
        lines = [
            f"sarmotion analysis: {tr.n_pulses} pulses x {tr.n_samples} samples, "
            f"{span:.2f} deg of azimuth, separation {self.method!r}",
            f"frame: ground x, y (m); reference point {_pair(rho_o)} m; range direction "
            f"b = {_pair(b, 3)} (towards the radar), cross range {_pair((-b[1], b[0]), 3)}",
        ]
        det = self.detection
        test = (
            f" (detector: statistic >= {fixed(det.threshold_db, 1)} dB, false-alarm rate "
            f"{det.false_alarm_rate:g} per scene)"
            if det is not None
            else ""
        )
        lines.append(f"{len(self.movers)} mover(s){test}" + (":" if self.movers else ""))
        for k, m in enumerate(self.movers):
            offset = float(np.dot(np.asarray(m.position_m[:2]) - rho_o, b))
            sd = m.bound
            err = (
                (
                    f" +- {sd.range_position_m:.2g}",
                    f" +- {sd.range_speed_mps:.2g}",
                    f" +- {sd.cross_range_speed_mps:.2g}",
                )
                if sd is not None
                else ("", "", "")
            )
            lines.append(
                f"  mover {k + 1}: range offset {fixed(offset)}{err[0]} m, range speed "
                f"{fixed(m.range_speed_mps)}{err[1]} m/s{self._span(m)}, cross-range speed "
                f"{fixed(m.cross_range_speed_mps)}{err[2]} m/s, statistic "
                f"{fixed(m.evidence.statistic_db, 1)} dB"
            )
            lines.append(
                f"    position at s = 0 {_pair(m.position_m)} m, velocity "
                f"{_pair(m.velocity_mps)} m/s: one member of the family position + t "
                f"{_pair(m.family_position_per_m, 3)}, velocity + t "
                f"{_pair(m.family_velocity_per_m, 3)} (t: m of cross-range offset)"
            )
            lines.append(f"    range acceleration: {acceleration_text(m.acceleration)}")
        if self.movers:
            lines.append(
                "  cross range: not known. The data fix each mover's range offset and range "
                "history; every member of its family fits them as well, and the position "
                "listed is the member at the reference point's cross range, not a "
                "measurement. The standard errors (+-) are conditional on that cross range; "
                "the range speed's span across the scene is the family's."
            )
        brightest = (
            f" (brightest at {_pair(self.stationary[0].position_m)} m)" if self.stationary else ""
        )
        lines.append(f"{len(self.stationary)} stationary target(s){brightest}")
        lines.append(
            f"time: {self.timings_s.get('total', float('nan')):.2f} s in the analysis stages "
            "(timings_s)"
        )
        return "\n".join(lines)

    def _span(self, m: Mover) -> str:
        """`` at the reference cross range; A to B m/s across the scene`` (the family's)."""
        from .family import family_segment

        g = self.stationary_image.grid
        extent = (float(g.x_m[0]), float(g.x_m[-1]), float(g.y_m[0]), float(g.y_m[-1]))
        tr = self.traces
        seg = family_segment(tr, m.position_m, m.velocity_mps, m.family_position_per_m, extent)
        if seg is None:
            return " at the reference cross range (its family does not cross the scene)"
        rates = seg.velocities_mps @ np.asarray(tr.geometry.m_o, dtype=np.float64)[:2]
        return (
            f" at the reference cross range; {fixed(float(rates.min()))} to "
            f"{fixed(float(rates.max()))} m/s across the scene"
        )

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
