"""Movers followed across sub-apertures: Stone Soup tracking and the paper's first scenario.

Each sub-aperture's analysis gives its movers' positions and velocities (the paper's
second scenario, both sought). :class:`Tracker` associates them into tracks with
Stone Soup (a global-nearest-neighbour associator on Mahalanobis-gated hypotheses, a
Kalman filter on the state ``(x, ux, y, uy)`` with a nearly-constant-velocity model),
and, for every detection it associates to a track, uses the track's prediction as the
mover's known position (the first scenario, ``position_m`` of
:func:`sarmotion.motion.estimate_velocity`): only the velocity is then sought, on the
mover's own traces of that sub-aperture.

**The measurement.** Over a few degrees the data fix a mover's range history, not its
cross-range position (:mod:`sarmotion.motion.aperture`): the estimate is one point of the
family ``(p + t a, v + t b)``. A detection is therefore a measurement of the whole state
``z = (x, y, ux, uy)`` whose covariance is degenerate along the family::

    R = sigma_f^2 w w^T + blockdiag(R_p, R_v),   w = (a, b),

with ``sigma_f`` = ``family_std_m`` (the prior spread of the cross-range offset: half
the scene), ``R_p`` half a ground-range cell across the family and one cross-range cell
along it, and ``R_v`` half a resolution of the range speed (``g``) and of the
cross-range speed (``g_perp``) in the look frame. A known position from the track's
prediction is the point of the family nearest it (the data still do not fix ``t``; the
same ``R`` holds). With roads (:func:`sarmotion.tracking.roads.road_fix`), the member
on the nearest road replaces the family: ``R_p`` becomes the road fix's covariance and
the family term goes; a road parallel to the family leaves the measurement free. Of
the roads a family line crosses, only those along which the member's velocity runs
count (its speed across the road within three cross-range-speed resolutions: on real
clutter the side maxima of ``g_perp`` can put a single degree's cross-range speed a few
resolutions off, ``docs/notes/tracking.md``), and of those the crossing nearest the
track's prediction (or the detection, for a new track). A vehicle on a road moves along
it: the road-fixed velocity measurement is fused with the pseudo-measurement "speed
across the road 0 +- ``road_cross_speed_std_mps``" (information form).

Because the family is degenerate over tens of degrees of a circular pass (1/220 of a
wavelength for 10 m over 4 degrees), the detections of one mover in successive
sub-apertures are not independent draws along their families: the estimator places
each near the reference cross range whatever the truth. Averaging them would shrink the
cross-range uncertainty by the square root of their number without bringing the track
any nearer the truth (on GOTCHA with an injected mover off the reference cross range,
the filter's standard deviation halves over four sub-apertures while the error stays:
``docs/notes/tracking.md``). Only a track's first detection therefore sets its
position along the family, with ``sigma_f``; its updates carry ``100 sigma_f`` there,
i.e. no information along the family. ``position_std_m`` thus stays as large as the data
make it, and without roads each state carries its family.

**Where the look turns.** Over tens of degrees of a circular pass the families of the
sub-apertures turn with the look and cross at the mover. :meth:`Tracker.tracks` gives
each track the fit of its detections' range histories through their looks
(:func:`~sarmotion.tracking.wide_aspect.fit_track`: the position with its standard
deviation and whether the data fix it, else the family; the mover allowed the
acceleration that keeps it within an eighth of the radar's wavelength of uniform motion
over the track, the fit's coherence margin), and first joins the tracks of
one uniform mover (:func:`~sarmotion.tracking.wide_aspect.join_tracks`): the filter above
takes each detection's velocity for the mover's, and on a wide pass a uniform mover's
detections drift as the look turns, so the filter cuts it into several tracks. Each
track's turn test is, where every detection has its bound and 3 of them come from
sub-apertures that share no pulse, the comparison of uniform motion with a constant
acceleration through the looks (:func:`~sarmotion.tracking.turns.look_turn_test`),
else the pairs of velocities (:func:`~sarmotion.tracking.turns.turn_test`).

Overlapping sub-apertures share pulses: their measurement errors are correlated, and
the filter, which takes them as independent, is then overconfident in range and range
speed (by about ``1 / sqrt(1 - overlap)`` in standard deviation).

**Defaults** (:class:`TrackingOptions`): white-noise acceleration of spectral density
1 m^2/s^3 (a road vehicle's accelerations of about 1 m/s^2 sustained over a second);
association gate at the 0.999 quantile of chi-square with 4 degrees of freedom; a track
is kept after 2 detections and ends after 2 sub-apertures without one.

Times: slow time of the whole acquisition (s, ``s = 0`` at its centre); positions in m,
velocities in m/s.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .._validation import integer, positive
from ..core import Traces
from ..errors import EstimationError
from ..motion import estimate_velocity
from ..pipeline import AnalysisOptions
from .coherent import CoherentFit, refine_coherently
from .ends import TrackEnd, track_end
from .roads import Road, RoadFix, road_fix, road_misses
from .sub_apertures import Detection, SubApertureDetections, check_overlap, disjoint_in_time
from .turns import TurnTest, look_turn_test, turn_test
from .wide_aspect import (
    PositionFit,
    antenna_state,
    fit_track,
    join_tracks,
    look_measurement,
    pooled_factors,
)

if TYPE_CHECKING:
    from stonesoup.types.detection import Detection as StoneDetection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track as StoneTrack

__all__ = ["TrackingOptions", "TrackState", "Track", "Tracker"]

log = logging.getLogger(__name__)

_EPOCH = datetime(2000, 1, 1)

_STONESOUP: SimpleNamespace | None = None


def _stonesoup() -> SimpleNamespace:
    """Stone Soup's classes, imported when the first detection arrives.

    Stone Soup imports scipy.stats, which builds its distributions' documentation on
    import (most of a second of CPU): a pass without detections never needs it, and
    with detections the import runs while later sub-apertures are still analysed.
    """
    global _STONESOUP
    if _STONESOUP is None:
        from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
        from stonesoup.deleter.time import UpdateTimeStepsDeleter
        from stonesoup.hypothesiser.distance import DistanceHypothesiser
        from stonesoup.initiator.simple import SimpleMeasurementInitiator
        from stonesoup.measures import Mahalanobis
        from stonesoup.models.measurement.linear import LinearGaussian
        from stonesoup.models.transition.linear import (
            CombinedLinearGaussianTransitionModel,
            ConstantVelocity,
        )
        from stonesoup.predictor.kalman import KalmanPredictor
        from stonesoup.types.detection import Detection as StoneDetection
        from stonesoup.types.hypothesis import SingleHypothesis
        from stonesoup.types.state import GaussianState
        from stonesoup.types.update import Update
        from stonesoup.updater.kalman import KalmanUpdater

        _STONESOUP = SimpleNamespace(
            GNNWith2DAssignment=GNNWith2DAssignment,
            UpdateTimeStepsDeleter=UpdateTimeStepsDeleter,
            DistanceHypothesiser=DistanceHypothesiser,
            SimpleMeasurementInitiator=SimpleMeasurementInitiator,
            Mahalanobis=Mahalanobis,
            LinearGaussian=LinearGaussian,
            CombinedLinearGaussianTransitionModel=CombinedLinearGaussianTransitionModel,
            ConstantVelocity=ConstantVelocity,
            KalmanPredictor=KalmanPredictor,
            StoneDetection=StoneDetection,
            SingleHypothesis=SingleHypothesis,
            GaussianState=GaussianState,
            Update=Update,
            KalmanUpdater=KalmanUpdater,
        )
    return _STONESOUP


# State (x, ux, y, uy); measurement (x, y, ux, uy).
_MAPPING = (0, 2, 1, 3)
# Along the family a track's update carries no information: its standard deviation there
# is this many times sigma_f (module notes).
_UNOBSERVED = 100.0


@dataclass(frozen=True, kw_only=True)
class TrackingOptions:
    """Choices of :func:`sarmotion.tracking.track`; every field keyword-only with a default.

    Attributes
    ----------
    analysis : AnalysisOptions
        Options of each sub-aperture's analysis. Default: the analysis defaults without
        phase-space trajectories.
    sub_aperture_deg : float
        Azimuth span of a sub-aperture (degrees, > 0). Default 1, as the motion
        estimates assume.
    overlap : float
        Fraction of a sub-aperture shared with the next (0 <= overlap <= 0.9,
        :data:`~sarmotion.tracking.sub_apertures.MAX_OVERLAP`). Default 0.5.
    acceleration_psd : float
        Spectral density ``q`` of the white-noise acceleration of the
        nearly-constant-velocity model (m^2/s^3, > 0). Default 1.
    family_std_m : float or None
        Spread of the cross-range offset along a detection's family (m); ``None``: half
        the analysis' image side.
    gate_probability : float
        Probability of the Mahalanobis association gate (chi-square, 4 degrees of
        freedom). Default 0.999.
    min_detections : int
        Detections a track needs to be reported (>= 1). Default 2.
    max_misses : int
        Consecutive sub-apertures without a detection that end a track (>= 0). Default 2.
    known_position : bool
        Re-estimate each associated detection's velocity at the known position (the
        track's prediction on its family, or its road member). Default True.
    road_std_m, max_road_std_m : float
        Offset of a vehicle from a road's centre line, and the largest along-road
        standard deviation of a road fix (m); see :func:`sarmotion.tracking.roads.road_fix`.
        Defaults 0.5 m (a car within its lane) and 5 m (four GOTCHA cross-range cells).
    road_cross_speed_std_mps : float
        Speed across its road of a vehicle on it (m/s). Default 0.5 m/s (a road's bends
        and lane changes).
    turn_false_alarm : float
        Probability that a uniform mover's track is flagged as turning
        (:mod:`sarmotion.tracking.turns`; 0 < p < 1). Default 0.01.
    coherent : bool
        Focus each track whose position the looks fix over all its pulses
        (:mod:`sarmotion.tracking.coherent`; about a second a track over 30 degrees).
        Default True.
    """

    analysis: AnalysisOptions = dataclasses.field(
        default_factory=lambda: AnalysisOptions(trajectory=False)
    )
    sub_aperture_deg: float = 1.0
    overlap: float = 0.5
    acceleration_psd: float = 1.0
    family_std_m: float | None = None
    gate_probability: float = 0.999
    min_detections: int = 2
    max_misses: int = 2
    known_position: bool = True
    road_std_m: float = 0.5
    max_road_std_m: float = 5.0
    road_cross_speed_std_mps: float = 0.5
    turn_false_alarm: float = 0.01
    coherent: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.analysis, AnalysisOptions):
            raise TypeError(
                f"analysis must be an AnalysisOptions, got {type(self.analysis).__name__}"
            )
        positive(self.sub_aperture_deg, "sub_aperture_deg", unit="degrees")
        check_overlap(self.overlap)
        positive(self.acceleration_psd, "acceleration_psd", unit="m^2/s^3")
        if self.family_std_m is not None:
            positive(self.family_std_m, "family_std_m", unit="m")
        if not (0.0 < self.gate_probability < 1.0):
            raise ValueError(f"gate_probability must be in (0, 1), got {self.gate_probability!r}")
        integer(self.min_detections, "min_detections", minimum=1)
        integer(self.max_misses, "max_misses", minimum=0)
        if not isinstance(self.known_position, bool):
            raise TypeError(f"known_position must be a bool, got {self.known_position!r}")
        positive(self.road_std_m, "road_std_m", unit="m")
        positive(self.max_road_std_m, "max_road_std_m", unit="m")
        positive(self.road_cross_speed_std_mps, "road_cross_speed_std_mps", unit="m/s")
        if not (0.0 < self.turn_false_alarm < 1.0):
            raise ValueError(f"turn_false_alarm must be in (0, 1), got {self.turn_false_alarm!r}")
        if not isinstance(self.coherent, bool):
            raise TypeError(f"coherent must be a bool, got {self.coherent!r}")


@dataclass(frozen=True, kw_only=True, eq=False)
class TrackState:
    """A track at one sub-aperture's centre time.

    Attributes
    ----------
    time_s : float
        Slow time of the whole acquisition (s).
    sub_aperture : int
        Index of the sub-aperture.
    position_m, velocity_mps : (2,) ndarray
        Filtered ground position (m) and velocity (m/s).
    position_cov_m2 : (2, 2) ndarray
        Position covariance (m^2).
    velocity_cov_m2ps2 : (2, 2) ndarray
        Velocity covariance ((m/s)^2).
    look_direction : (3,) ndarray
        ``m_o`` of the sub-aperture: the range speed is ``u . m_o``.
    detection : Detection or None
        The sub-aperture's detection associated to the track (None: coasted on the
        prediction).
    measured_position_m, measured_velocity_mps : (2,) ndarray or None
        The measurement the filter was updated with (the known position and the
        velocity sought there).
    road : RoadFix or None
        The road member of the detection's family, if a road was crossed.
    road_missed : str or None
        With roads, for a detection no road gave a member: why, road by road
        (:func:`~sarmotion.tracking.roads.road_misses`); None otherwise.
    """

    time_s: float
    sub_aperture: int
    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64]
    position_cov_m2: NDArray[np.float64]
    velocity_cov_m2ps2: NDArray[np.float64]
    look_direction: NDArray[np.float64]
    detection: Detection | None = None
    measured_position_m: NDArray[np.float64] | None = None
    measured_velocity_mps: NDArray[np.float64] | None = None
    road: RoadFix | None = None
    road_missed: str | None = None

    @property
    def position_std_m(self) -> float:
        """Largest standard deviation of the position (m)."""
        return float(np.sqrt(max(0.0, np.linalg.eigvalsh(self.position_cov_m2)[-1])))

    @property
    def range_speed_mps(self) -> float:
        """Range speed ``u . m_o`` of the filtered velocity (m/s)."""
        return float(self.velocity_mps @ self.look_direction[:2])

    @property
    def on_road(self) -> bool:
        """True when a road fixed the position of this state's measurement."""
        return self.road is not None and self.road.fixed


@dataclass(frozen=True, kw_only=True, eq=False)
class Track:
    """One mover followed over the acquisition.

    Attributes
    ----------
    id : int
        Identifier (1, 2, ... in order of first detection).
    states : tuple of TrackState
        From the first to the last detection, in time order.
    turn : TurnTest or None
        Whether its velocity changed between independent sub-apertures, through the
        looks where it can (:mod:`sarmotion.tracking.turns`); None when a detection lacks its
        velocity's covariance.
    fit : PositionFit or None
        The uniform motion fitted to the range histories of all its detections through
        their looks, with whether the data fix its position
        (:mod:`sarmotion.tracking.wide_aspect`); None when a detection lacks its bound.
    end : TrackEnd or None
        Why it ends where it does: the data's end, the imaged scene's edge, or no
        detection (:mod:`sarmotion.tracking.ends`).
    coherent : CoherentFit or None
        Where :attr:`fit` fixes the position and
        :attr:`TrackingOptions.coherent` asks for it: the uniform motion focused over
        all its pulses, with its bound, measured error factor and coherence
        (:mod:`sarmotion.tracking.coherent`).
    """

    id: int
    states: tuple[TrackState, ...]
    turn: TurnTest | None = None
    fit: PositionFit | None = None
    end: TrackEnd | None = None
    coherent: CoherentFit | None = None

    @property
    def n_detections(self) -> int:
        """Number of states updated by a detection."""
        return sum(s.detection is not None for s in self.states)


@dataclass(eq=False)
class _Meta:
    """What the tracker keeps for each Stone Soup state it appends."""

    sub: SubApertureDetections
    detection: Detection | None
    measured: tuple[NDArray[np.float64], NDArray[np.float64]] | None
    road: RoadFix | None
    road_missed: str | None = None


class Tracker:
    """Sub-aperture by sub-aperture tracking (module notes).

    Parameters
    ----------
    traces : Traces
        The whole acquisition (the sub-apertures' geometry for the first scenario).
    options : TrackingOptions
        Tracking choices.
    roads : sequence of Road
        Road centre lines (empty: no road constraint).
    """

    def __init__(
        self, traces: Traces, options: TrackingOptions, *, roads: Sequence[Road] = ()
    ) -> None:
        self.traces = traces
        self.options = options
        self.roads = tuple(roads)
        self._ready = False
        self._live: set[StoneTrack] = set()
        self._ended: list[StoneTrack] = []
        self._meta: dict[int, _Meta] = {}
        self._order: dict[StoneTrack, int] = {}
        # every sub-aperture stepped: index, time, ground range direction, image box
        self._subs: list[tuple[int, float, NDArray[np.float64], tuple[float, ...]]] = []

    def _build(self) -> None:
        """Stone Soup's predictor, updater, associator, initiator and deleter (once)."""
        if self._ready:
            return
        ss = _stonesoup()
        options = self.options
        q = options.acceleration_psd
        transition = ss.CombinedLinearGaussianTransitionModel(
            [ss.ConstantVelocity(q), ss.ConstantVelocity(q)]
        )
        self._predictor = ss.KalmanPredictor(transition)
        self._updater = ss.KalmanUpdater(measurement_model=None)
        from scipy.stats import chi2  # scipy.stats takes ~0.7 s to import: when needed

        gate = float(np.sqrt(chi2.ppf(options.gate_probability, 4)))
        hypothesiser = ss.DistanceHypothesiser(
            self._predictor, self._updater, measure=ss.Mahalanobis(), missed_distance=gate
        )
        self._associator = ss.GNNWith2DAssignment(hypothesiser)
        self._initiator = ss.SimpleMeasurementInitiator(
            prior_state=ss.GaussianState(np.zeros((4, 1)), np.zeros((4, 4))),
            measurement_model=None,
        )
        self._deleter = ss.UpdateTimeStepsDeleter(time_steps_since_update=options.max_misses + 1)
        self._ready = True

    # ------------------------------------------------------------------ steps
    def step(self, sub: SubApertureDetections) -> None:
        """Associate, update and start tracks with one sub-aperture (in time order)."""
        x, y = np.asarray(sub.grid.x_m, float), np.asarray(sub.grid.y_m, float)
        dx, dy = (float(v) for v in sub.grid.spacing_m)
        box = (
            0.5 * (x[0] + x[-1]),
            0.5 * (y[0] + y[-1]),
            0.5 * (abs(x[-1] - x[0]) + dx),
            0.5 * (abs(y[-1] - y[0]) + dy),
        )
        self._subs.append((sub.index, sub.time_s, np.asarray(sub.range_direction, float), box))
        if not sub.detections and not self._live:
            return  # nothing to associate, update, start or end
        self._build()
        when = _EPOCH + timedelta(seconds=sub.time_s)
        free = {
            self._measurement(sub, d, d.position_m, d.velocity_mps, None, when, k, update=True)
            for k, d in enumerate(sub.detections)
        }
        hypotheses = self._associator.associate(self._live, free, when)
        used: set[int] = set()
        for trk, hyp in hypotheses.items():
            if not hyp:
                trk.append(hyp.prediction)
                self._meta[id(hyp.prediction)] = _Meta(sub.light(), None, None, None)
                continue
            k = hyp.measurement.metadata["detection"]
            used.add(k)
            pred = np.asarray(hyp.prediction.state_vector, dtype=np.float64).ravel()
            meas, meta = self._known(sub, sub.detections[k], pred[[0, 2]], when, k)
            post = self._updater.update(_stonesoup().SingleHypothesis(hyp.prediction, meas))
            trk.append(post)
            self._meta[id(post)] = meta
        fresh = []
        for k, d in enumerate(sub.detections):
            if k in used:
                continue
            meas, meta = self._known(sub, d, None, when, k)
            fresh.append((meas, meta))
        for meas, meta in fresh:
            (trk,) = self._initiator.initiate({meas}, when)
            self._meta[id(trk[-1])] = meta
            self._order[trk] = len(self._order)
            self._live.add(trk)
        ended = self._deleter.delete_tracks(self._live)
        self._live -= ended
        self._ended.extend(ended)

    def tracks(self) -> tuple[Track, ...]:
        """The tracks with at least ``min_detections`` detections, trimmed to them.

        Tracks of one uniform mover are first joined (:func:`~sarmotion.tracking.
        wide_aspect.join_tracks`: the increase of the joint fit's residual within the
        chi-square gate at ``gate_probability``), each keeping its states; each track
        carries the fit of its detections' range histories.
        """
        raw = sorted([*self._ended, *self._live], key=lambda t: self._order[t])
        trimmed = []
        for trk in raw:
            hits = [i for i, s in enumerate(trk.states) if self._hit(s)]
            trimmed.append(list(trk.states[hits[0] : hits[-1] + 1]) if hits else [])
        looks = [self._looks(states) for states in trimmed]
        factors = None
        if looks and all(g is not None for g in looks):
            measured = [g or [] for g in looks]
            factors = pooled_factors(measured, **self._prior())
            groups = join_tracks(
                measured,
                gate_probability=self.options.gate_probability,
                error_factors=factors,
                **self._prior(),
            )
        else:  # a detection without its bound: no joining
            groups = [[k] for k in range(len(raw))]
        out = []
        for group in groups:
            kept = sorted(
                (s for k in group for s in trimmed[k]), key=lambda s: self._meta[id(s)].sub.time_s
            )
            kept = self._one_per_sub_aperture(kept)
            if sum(self._hit(s) for s in kept) < self.options.min_detections:
                continue
            hits_looks = self._looks(kept)
            fit = (
                fit_track(
                    hits_looks,
                    error_factors=factors,
                    wavelength_m=float(self.traces.radar.wavelength_m),
                    **self._prior(),
                )
                if hits_looks
                else None
            )
            states = tuple(self._state(s) for s in kept)
            fixed = bool(fit is not None and fit.fixed)
            turn = self._turn(kept, rate=fixed)
            coherent = self._coherent(kept, fit) if fixed and self.options.coherent else None
            out.append((states, turn, fit, self._end(states, fit), coherent))
        return tuple(
            Track(id=k + 1, states=s, turn=turn, fit=fit, end=end, coherent=coherent)
            for k, (s, turn, fit, end, coherent) in enumerate(out)
        )

    def _coherent(
        self, states: Sequence[GaussianState], fit: PositionFit | None
    ) -> CoherentFit | None:
        """The track focused over all its pulses (:mod:`~sarmotion.tracking.coherent`).

        Over the pulses from its first detection's sub-aperture to its last; the
        coherence and error factor compare the sub-apertures of its detections that
        share no pulse.
        """
        if fit is None:
            return None
        pulses = [self._meta[id(s)].sub.pulses for s in states if self._hit(s)]
        independent = [pulses[k] for k in disjoint_in_time([(p.start, p.stop) for p in pulses])]
        return refine_coherently(
            self.traces, fit, independent, height_m=float(self.traces.reference_point_m[2])
        )

    def _end(self, states: Sequence[TrackState], fit: PositionFit | None) -> TrackEnd:
        """Why a track ends at its last detection (:mod:`~sarmotion.tracking.ends`)."""
        last = [s for s in states if s.detection is not None][-1]
        return track_end(
            last_time_s=last.time_s,
            last_index=last.sub_aperture,
            position_m=last.position_m,
            velocity_mps=last.velocity_mps,
            fixed=last.on_road or bool(fit is not None and fit.fixed),
            sub_apertures=self._subs,
        )

    def _hit(self, state: GaussianState) -> bool:
        """Whether a Stone Soup state was updated by a detection."""
        return (
            isinstance(state, _stonesoup().Update) and self._meta[id(state)].detection is not None
        )

    def _one_per_sub_aperture(self, states: list[GaussianState]) -> list[GaussianState]:
        """Joined tracks' states in time order, one per sub-aperture (a hit before a coast)."""
        best: dict[int, GaussianState] = {}
        for s in states:
            k = self._meta[id(s)].sub.index
            if k not in best or (self._hit(s) and not self._hit(best[k])):
                best[k] = s
        return [best[k] for k in sorted(best)]

    def _prior(self) -> dict[str, object]:
        """The scene prior of the wide-aspect fit: its spread, centre and the movers' height."""
        sub = next(iter(self._meta.values())).sub
        x0, x1, y0, y1 = sub.grid.extent
        return {
            "prior_std_m": self._family_std(sub),
            "centre_m": np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1)]),
            "height_m": float(self.traces.reference_point_m[2]),
        }

    def _looks(self, states: Sequence[GaussianState]) -> list | None:
        """The hits of ``states`` as range-history measurements; None if one lacks its bound."""
        out = []
        height = float(self.traces.reference_point_m[2])
        for s in states:
            if not self._hit(s):
                continue
            meta = self._meta[id(s)]
            det = meta.detection
            assert det is not None
            if det.bound_cov is None:
                return None
            antenna = antenna_state(self.traces, meta.sub.pulses, meta.sub.time_s)
            out.append(
                look_measurement(
                    meta.sub, det, antenna, height_m=height, overlap=self.options.overlap
                )
            )
        return out

    def _turn(self, states: Sequence[GaussianState], *, rate: bool = False) -> TurnTest | None:
        """The turn test of a track's detections (:mod:`~sarmotion.tracking.turns`).

        Through the looks (:func:`~sarmotion.tracking.turns.look_turn_test`) where every
        detection has its bound and 3 come from sub-apertures that share no pulse, with
        the turn rate in the ground frame where ``rate`` (the track's position fixed);
        else the pairs of velocities (:func:`~sarmotion.tracking.turns.turn_test`).
        """
        metas = [self._meta[id(s)] for s in states]
        hits = [
            m for s, m in zip(states, metas, strict=True)
            if isinstance(s, _stonesoup().Update) and m.detection is not None
        ]  # fmt: skip
        looks = self._looks(states)
        if looks:
            prior = self._prior()
            test = look_turn_test(
                looks,
                [(m.sub.pulses.start, m.sub.pulses.stop) for m in hits],
                false_alarm=self.options.turn_false_alarm,
                prior_std_m=prior["prior_std_m"],  # type: ignore[arg-type]
                centre_m=prior["centre_m"],  # type: ignore[arg-type]
                height_m=prior["height_m"],  # type: ignore[arg-type]
                rate=rate,
            )
            if test is not None:
                return test
        if any(m.detection.velocity_cov_m2ps2 is None for m in hits):
            return None
        return turn_test(
            [m.sub.time_s for m in hits],
            [(m.sub.pulses.start, m.sub.pulses.stop) for m in hits],
            [m.detection.position_m for m in hits],
            [m.detection.velocity_mps for m in hits],
            [m.detection.velocity_cov_m2ps2 for m in hits],
            (
                [m.detection.family_position_per_m for m in hits],
                [m.detection.family_velocity_per_m for m in hits],
            ),
            false_alarm=self.options.turn_false_alarm,
        )

    # ---------------------------------------------------------------- helpers
    def _known(
        self,
        sub: SubApertureDetections,
        det: Detection,
        predicted_m: NDArray[np.float64] | None,
        when: datetime,
        k: int,
    ) -> tuple[StoneDetection, _Meta]:
        """The detection as a measurement at its known position (first scenario)."""
        a, b = det.family_position_per_m, det.family_velocity_per_m
        near = det.position_m if predicted_m is None else predicted_m
        fix = None
        if self.roads:
            fix = road_fix(
                det.position_m,
                a,
                self.roads,
                velocity_mps=det.velocity_mps,
                family_velocity_per_m=b,
                max_cross_speed_mps=3.0 * sub.cross_range_speed_resolution_mps,
                near_m=near,
                max_offset_m=3.0 * self._family_std(sub),
                range_std_m=0.5 * sub.range_cell_m,
                road_std_m=self.options.road_std_m,
                max_std_m=self.options.max_road_std_m,
            )
        missed = None
        if self.roads and fix is None:
            reasons = road_misses(
                det.position_m,
                a,
                self.roads,
                velocity_mps=det.velocity_mps,
                family_velocity_per_m=b,
                max_cross_speed_mps=3.0 * sub.cross_range_speed_resolution_mps,
                max_offset_m=3.0 * self._family_std(sub),
            )
            missed = "; ".join(
                f"road {r.name or k + 1}: {why}"
                for k, (r, why) in enumerate(zip(self.roads, reasons, strict=True))
            )
        if fix is not None and fix.fixed:
            t = fix.offset_m
        elif predicted_m is not None:
            t = float((predicted_m - det.position_m) @ a / (a @ a))
        else:
            t = 0.0
        position = det.position_m + t * a
        velocity = det.velocity_mps + t * b
        if self.options.known_position and (t != 0.0 or predicted_m is not None):
            velocity = self._velocity_at(sub, det, position, velocity)
        road = fix if fix is not None and fix.fixed else None
        meas = self._measurement(
            sub, det, position, velocity, road, when, k, update=predicted_m is not None
        )
        return meas, _Meta(sub.light(), det.light(), (position, velocity), fix, missed)

    def _velocity_at(
        self,
        sub: SubApertureDetections,
        det: Detection,
        position: NDArray[np.float64],
        velocity: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Velocity sought at a known position on the mover's own traces (first scenario)."""
        own = self.traces.select_pulses(sub.pulses.start, sub.pulses.stop).with_data(det.traces)
        # Searched within four resolutions of the family member's speeds: the member's
        # velocity already carries the move along the family, and four cross-range-speed
        # resolutions (3 m/s over a GOTCHA degree) cover g_perp's side maxima on clutter;
        # the search's cost grows with its span (docs/notes/tracking.md).
        u = float(velocity @ sub.look_direction[:2])
        up = float(velocity @ sub.cross_range_speed_row)
        du, dup = 4.0 * sub.range_speed_resolution_mps, 4.0 * sub.cross_range_speed_resolution_mps
        try:
            est = estimate_velocity(
                own,
                position_m=position,
                range_speed_mps=u,
                speed_range_mps=(u - du, u + du),
                cross_speed_range_mps=(up - dup, up + dup),
            )
        except EstimationError as exc:  # no estimate: keep the family member's velocity
            log.warning("velocity at the known position failed (%s); family velocity kept", exc)
            return velocity
        return np.asarray(est.velocity_mps, dtype=np.float64)

    def _family_std(self, sub: SubApertureDetections) -> float:
        if self.options.family_std_m is not None:
            return float(self.options.family_std_m)
        size = self.options.analysis.image_size_m
        if size is None:
            x0, x1, y0, y1 = sub.grid.extent
            size = max(x1 - x0, y1 - y0)
        return 0.5 * float(size)

    def _measurement(
        self,
        sub: SubApertureDetections,
        det: Detection,
        position: NDArray[np.float64],
        velocity: NDArray[np.float64],
        road: RoadFix | None,
        when: datetime,
        k: int,
        *,
        update: bool,
    ) -> StoneDetection:
        """A Stone Soup detection of ``(x, y, ux, uy)`` with the covariance of the notes.

        ``update``: for a track's update, the family term is ``_UNOBSERVED`` times larger
        (no information along the family); for a new track, ``sigma_f`` is its prior.
        """
        e_r, e_c = sub.range_direction, sub.cross_range_direction
        g = np.vstack([sub.look_direction[:2], sub.cross_range_speed_row])
        g_inv = np.linalg.inv(g)
        speeds = np.diag(
            [
                (0.5 * sub.range_speed_resolution_mps) ** 2,
                (0.5 * sub.cross_range_speed_resolution_mps) ** 2,
            ]
        )
        r_v = g_inv @ speeds @ g_inv.T
        r = np.zeros((4, 4))
        r[2:, 2:] = r_v
        z_v = velocity
        if road is not None:
            r[:2, :2] = road.covariance_m2
            seg = self.roads[road.road].points_m
            n_w = _road_normal(seg, position)
            info = (
                np.linalg.inv(r_v) + np.outer(n_w, n_w) / self.options.road_cross_speed_std_mps**2
            )
            r[2:, 2:] = np.linalg.inv(info)
            z_v = r[2:, 2:] @ (np.linalg.inv(r_v) @ velocity)
        else:
            r[:2, :2] = (0.5 * sub.range_cell_m) ** 2 * np.outer(e_r, e_r) + (
                sub.cross_range_cell_m**2
            ) * np.outer(e_c, e_c)
            w = np.r_[det.family_position_per_m, det.family_velocity_per_m]
            scale = _UNOBSERVED if update else 1.0
            r += (scale * self._family_std(sub)) ** 2 * np.outer(w, w)
        ss = _stonesoup()
        model = ss.LinearGaussian(ndim_state=4, mapping=_MAPPING, noise_covar=r)
        z = np.r_[position, z_v].reshape(4, 1)
        return ss.StoneDetection(
            z, timestamp=when, measurement_model=model, metadata={"detection": k}
        )

    def _state(self, state: GaussianState) -> TrackState:
        meta = self._meta[id(state)]
        x = np.asarray(state.state_vector, dtype=np.float64).ravel()
        cov = np.asarray(state.covar, dtype=np.float64)
        pos_idx, vel_idx = [0, 2], [1, 3]
        detection = meta.detection if isinstance(state, _stonesoup().Update) else None
        return TrackState(
            time_s=meta.sub.time_s,
            sub_aperture=meta.sub.index,
            position_m=x[pos_idx],
            velocity_mps=x[vel_idx],
            position_cov_m2=cov[np.ix_(pos_idx, pos_idx)],
            velocity_cov_m2ps2=cov[np.ix_(vel_idx, vel_idx)],
            look_direction=meta.sub.look_direction,
            detection=detection,
            measured_position_m=None if meta.measured is None else meta.measured[0],
            measured_velocity_mps=None if meta.measured is None else meta.measured[1],
            road=meta.road,
            road_missed=meta.road_missed if detection is not None else None,
        )


def _road_normal(
    points_m: NDArray[np.float64], where_m: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Unit normal of the polyline segment nearest ``where_m``."""
    best, normal = np.inf, np.array([1.0, 0.0])
    for s0, s1 in zip(points_m[:-1], points_m[1:], strict=True):
        d = s1 - s0
        length2 = float(d @ d)
        if length2 == 0.0:
            continue
        r = float(np.clip((where_m - s0) @ d / length2, 0.0, 1.0))
        dist = float(np.hypot(*(s0 + r * d - where_m)))
        if dist < best:
            e = d / np.sqrt(length2)
            best, normal = dist, np.array([-e[1], e[0]])
    return normal
