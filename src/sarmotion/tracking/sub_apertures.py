"""A long acquisition as overlapping sub-apertures, each analysed on its own.

The motion estimates of :mod:`sarmotion.motion` assume about a degree of aperture
(uniform motion, a straight look). A pass of many degrees is therefore cut into
sub-apertures of ``sub_aperture_deg`` whose starts advance by ``(1 - overlap)`` of a
sub-aperture; each is analysed by :func:`sarmotion.pipeline.analyze` independently of
the others (the unit of work that :mod:`sarmotion.tracking.scale` distributes), and
reduced to a compact :class:`SubApertureDetections`: the movers' estimates, cross-range
families and own traces, the look directions, and the stationary image's magnitude.

Times are slow times of the whole acquisition (s, ``s = 0`` at its centre); positions
in m, velocities in m/s.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core import LookGeometry, Traces, ground_velocity
from ..imaging import ImageGrid, resolution
from ..motion import azimuth_span_deg
from ..motion.speed_resolution import cross_range_speed_resolution, range_speed_resolution
from ..pipeline import AnalysisOptions, Mover, analyze

__all__ = [
    "MAX_OVERLAP",
    "MIN_CROSS_RANGE_CELLS",
    "MIN_PULSES",
    "Detection",
    "SubApertureDetections",
    "analyze_sub_aperture",
    "check_overlap",
    "check_sub_apertures",
    "disjoint_in_time",
    "sub_aperture_slices",
]

#: Largest overlap of consecutive sub-apertures. At 0.9 every pulse is analysed ten
#: times; beyond it the work grows as 1 / (1 - overlap) (0.99: a hundred times, 353
#: sub-apertures on four GOTCHA degrees) for tracks sampled more finely than the
#: sub-apertures' own time resolution, which stays one sub-aperture.
MAX_OVERLAP = 0.9

#: Fewest cross-range resolution cells a sub-aperture's image must hold across its side.
#: With one cell or less, the sub-aperture resolves nothing in cross range: every target
#: of the image lies in one cell, and neither separation nor the cross-range speed can
#: work. Two cells is the least that resolves anything.
MIN_CROSS_RANGE_CELLS = 2

#: Fewest pulses of a sub-aperture: the range-speed search of :mod:`sarmotion.motion`
#: refuses fewer than three.
MIN_PULSES = 3


def check_overlap(overlap: float) -> float:
    """ValueError unless ``0 <= overlap <= MAX_OVERLAP``; return it as a float."""
    if not (isinstance(overlap, (int, float, np.floating, np.integer)) and np.isfinite(overlap)):
        raise ValueError(f"overlap must be a fraction in [0, {MAX_OVERLAP}], got {overlap!r}")
    if not 0.0 <= overlap <= MAX_OVERLAP:
        raise ValueError(
            f"overlap must be in [0, {MAX_OVERLAP}] (at {MAX_OVERLAP} every pulse is analysed "
            f"{round(1 / (1 - MAX_OVERLAP))} times), got {overlap!r}"
        )
    return float(overlap)


def sub_aperture_slices(
    traces: Traces, sub_aperture_deg: float = 1.0, overlap: float = 0.5
) -> list[slice]:
    """Pulse ranges of overlapping sub-apertures covering the whole acquisition.

    Each holds ``m = round(n_pulses sub_aperture_deg / span)`` pulses (span: the
    azimuth span of the acquisition, :func:`sarmotion.motion.azimuth_span_deg`); their
    starts are evenly spread from the first pulse to ``n_pulses - m``, ``round((n_pulses
    - m) / step) + 1`` of them for a step of ``m (1 - overlap)`` pulses (the overlap is
    met to a pulse or two: 469 GOTCHA pulses of 4 degrees give 4 sub-apertures with
    ``overlap=0``, 7 with 0.5).

    Parameters
    ----------
    traces : Traces
        The whole acquisition.
    sub_aperture_deg : float
        Azimuth span of one sub-aperture (degrees, > 0).
    overlap : float
        Fraction of a sub-aperture shared with the next (0 <= overlap <= 0.9,
        :data:`MAX_OVERLAP`).

    Returns
    -------
    list of slice
        In slow-time order; a single slice of every pulse if the acquisition is
        shorter than 1.5 sub-apertures.
    """
    if not (np.isfinite(sub_aperture_deg) and sub_aperture_deg > 0):
        raise ValueError(f"sub_aperture_deg must be positive (degrees), got {sub_aperture_deg!r}")
    overlap = check_overlap(overlap)
    n = traces.n_pulses
    span = azimuth_span_deg(traces)
    if span <= 1.5 * sub_aperture_deg:
        return [slice(0, n)]
    m = min(n, max(2, int(round(n * sub_aperture_deg / span))))
    step = max(1, int(np.floor(m * (1.0 - overlap) + 1e-9)))
    count = max(1, int(round((n - m) / step))) + 1
    starts = np.round(np.linspace(0, n - m, count)).astype(int)
    return [slice(int(a), int(a) + m) for a in starts]


def check_sub_apertures(
    traces: Traces, slices: Sequence[slice], sub_aperture_deg: float, image_size_m: float
) -> None:
    """Refuse sub-apertures too short to resolve their image (before any work starts).

    The rule: each sub-aperture holds at least :data:`MIN_PULSES` pulses, and its
    cross-range cell ``lambda_o L / (2 a)`` (:func:`sarmotion.imaging.resolution`: the
    wavelength, the range to the reference point and the aperture flown) is at most
    ``image_size_m / MIN_CROSS_RANGE_CELLS``, so that its image holds at least two
    cross-range cells. The aperture of a sub-aperture grows with its span, so the least
    span that passes is ``sub_aperture_deg x cell / (image_size_m / 2)``, which the
    message gives.

    Parameters
    ----------
    traces : Traces
        The whole acquisition.
    slices : sequence of slice
        Its sub-apertures (:func:`sub_aperture_slices`).
    sub_aperture_deg : float
        Their requested span (degrees).
    image_size_m : float
        Side of each sub-aperture's image (m).

    Raises
    ------
    ValueError
        Naming ``sub_aperture_deg``, the least span that passes and why.
    """
    fewest = min(sl.stop - sl.start for sl in slices)
    if fewest < MIN_PULSES:
        raise ValueError(
            f"sub_aperture_deg {sub_aperture_deg:g} gives sub-apertures of {fewest} pulse(s) "
            f"(at least {MIN_PULSES} needed)"
        )
    widest = max(  # the first, middle and last: the geometry changes slowly along a pass
        float(resolution(traces.select_pulses(sl.start, sl.stop)).cross_range_m)
        for sl in (slices[0], slices[len(slices) // 2], slices[-1])
    )
    largest = image_size_m / MIN_CROSS_RANGE_CELLS
    if widest > largest:
        least = sub_aperture_deg * widest / largest
        raise ValueError(
            f"sub_aperture_deg {sub_aperture_deg:g} is too short to resolve the "
            f"{image_size_m:g} m image: its cross-range cell is {widest:.3g} m, and at least "
            f"{MIN_CROSS_RANGE_CELLS} cells must fit across (at least {least:.2g} degrees)"
        )


@dataclass(frozen=True, kw_only=True, eq=False)
class Detection:
    """One mover found in one sub-aperture (the second scenario: position and velocity).

    The tracker's projection of the analysis's :class:`~sarmotion.pipeline.Mover`
    (:meth:`from_mover`, the one place it is made): the fields the tracker reads, the
    position on the ground at the sub-aperture's centre time. It leaves out the Mover's
    fits, evidence, bounds, image and trajectory, so that what each Dask worker returns
    and what the tracker keeps over a whole pass stays small.

    Attributes
    ----------
    position_m : (2,) ndarray
        Ground position at the sub-aperture's centre time (m).
    velocity_mps : (2,) ndarray
        Ground velocity (m/s).
    range_speed_mps, cross_range_speed_mps : float
        ``u . m_o`` and the cross-range speed (m/s) of the estimate.
    family_position_per_m, family_velocity_per_m : (2,) ndarray
        Tangent of the cross-range family (m/m, (m/s)/m): ``position + t a``,
        ``velocity + t b`` fit the sub-aperture's data as well for any ``t``
        (:func:`sarmotion.motion.family_direction`).
    peak_db : float
        Its image peak relative to the stationary image's brightest pixel (dB).
    traces : (n_pulses, n_samples) ndarray or None
        Its own separated traces over the sub-aperture (data units); None in what the
        tracker keeps (:meth:`light`): over a whole pass they would hold 0.8 MB per
        detection.
    velocity_cov_m2ps2 : (2, 2) ndarray or None
        Covariance of ``velocity_mps`` ((m/s)^2): the Cramér–Rao bound of the range and
        cross-range speeds (:attr:`~sarmotion.pipeline.Mover.bound`) in the ground
        frame, ``B C B^T`` with ``B = (b_r, b_p)`` the ground velocities of unit range
        and cross-range speed; None when made without the geometry.
    bound_cov : (3, 3) ndarray or None
        The Cramér–Rao bound of the ground-range position (along the sub-aperture's
        ``range_direction``), the range speed and the cross-range speed
        (m^2, m^2/s, m^2/s^2; :mod:`sarmotion.motion.bounds`): the covariance of the
        range history the detection measures (:mod:`sarmotion.tracking.wide_aspect`);
        None when made without the geometry.
    """

    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64]
    range_speed_mps: float
    cross_range_speed_mps: float
    family_position_per_m: NDArray[np.float64]
    family_velocity_per_m: NDArray[np.float64]
    peak_db: float
    traces: NDArray[np.complexfloating] | None
    velocity_cov_m2ps2: NDArray[np.float64] | None = None
    bound_cov: NDArray[np.float64] | None = None

    @classmethod
    def from_mover(cls, mover: Mover, geometry: LookGeometry | None = None) -> Detection:
        """The detection of an analysis's mover (its position at ``s = 0``, on the ground).

        ``geometry``: the sub-aperture's look geometry, for the velocity's covariance.
        """
        cov = bound = None
        if geometry is not None:
            bound = np.array(mover.bound.covariance[:3, :3], dtype=np.float64)
            basis = np.column_stack(
                [ground_velocity(1.0, 0.0, geometry), ground_velocity(0.0, 1.0, geometry)]
            )
            cov = basis @ mover.bound.covariance[1:3, 1:3] @ basis.T
        return cls(
            velocity_cov_m2ps2=cov,
            bound_cov=bound,
            position_m=np.asarray(mover.position_m, dtype=np.float64)[:2].copy(),
            velocity_mps=np.asarray(mover.velocity_mps, dtype=np.float64).copy(),
            range_speed_mps=float(mover.range_speed_mps),
            cross_range_speed_mps=float(mover.cross_range_speed_mps),
            family_position_per_m=np.asarray(mover.family_position_per_m, dtype=np.float64),
            family_velocity_per_m=np.asarray(mover.family_velocity_per_m, dtype=np.float64),
            peak_db=float(mover.image_peak_db),
            traces=mover.traces,
        )

    def light(self) -> Detection:
        """The same detection without its traces."""
        return dataclasses.replace(self, traces=None)


@dataclass(frozen=True, kw_only=True, eq=False)
class SubApertureDetections:
    """What one sub-aperture's analysis gives the tracker.

    Attributes
    ----------
    index : int
        Position of the sub-aperture in slow-time order.
    pulses : slice
        Its pulses in the whole acquisition.
    time_s : float
        Its centre time ``(s_first + s_last) / 2`` in the whole acquisition's slow time
        (s); the detections' positions are at this time.
    look_direction : (3,) ndarray
        Unit vector ``m_o`` from the reference point to the antenna at ``time_s``: a
        velocity's range speed is ``u . m_o``.
    range_direction, cross_range_direction : (2,) ndarray
        Ground unit vectors of range and cross range (:func:`sarmotion.imaging.resolution`).
    range_cell_m, cross_range_cell_m : float
        Ground-range and cross-range resolution cells (m).
    range_speed_resolution_mps, cross_range_speed_resolution_mps : float
        Resolutions of the range speed (``g``) and of the cross-range speed (``g_perp``)
        over the sub-aperture (m/s).
    cross_range_speed_row : (2,) ndarray
        Ground row vector giving the cross-range speed ``t . P_o u`` of a ground velocity.
    detections : tuple of Detection
        The movers found, strongest first.
    stationary_db : (ny, nx) ndarray or None
        Stationary image magnitude (dB re its brightest pixel); None in what
        :func:`~sarmotion.tracking.track` keeps (it keeps their mean).
    grid : ImageGrid
        Its grid.
    seconds : float
        Wall-clock time of the analysis (s).
    """

    index: int
    pulses: slice
    time_s: float
    look_direction: NDArray[np.float64]
    range_direction: NDArray[np.float64]
    cross_range_direction: NDArray[np.float64]
    range_cell_m: float
    cross_range_cell_m: float
    range_speed_resolution_mps: float
    cross_range_speed_resolution_mps: float
    cross_range_speed_row: NDArray[np.float64]
    detections: tuple[Detection, ...]
    stationary_db: NDArray[np.float64] | None
    grid: ImageGrid
    seconds: float

    def light(self) -> SubApertureDetections:
        """The same sub-aperture without its image and its detections' traces."""
        return dataclasses.replace(
            self, detections=tuple(d.light() for d in self.detections), stationary_db=None
        )


def analyze_sub_aperture(
    traces: Traces, options: AnalysisOptions, *, index: int, pulses: slice, time_s: float
) -> SubApertureDetections:
    """Analyse one sub-aperture (:func:`sarmotion.pipeline.analyze`) and keep its detections.

    Parameters
    ----------
    traces : Traces
        The sub-aperture's traces (slow time re-centred on it, ``Traces.select_pulses``).
    options : AnalysisOptions
        Options of the analysis (the same for every sub-aperture).
    index : int
        Its position in slow-time order.
    pulses : slice
        Its pulses in the whole acquisition.
    time_s : float
        Its centre time in the whole acquisition (s).

    Returns
    -------
    SubApertureDetections
    """
    result = analyze(traces, options)
    geom = traces.geometry
    cells = resolution(traces)
    detections = tuple(Detection.from_mover(m, geom) for m in result.movers)
    magnitude = np.abs(result.stationary_image.values)
    top = float(magnitude.max())
    with np.errstate(divide="ignore"):
        db = 20.0 * np.log10(magnitude / top) if top > 0 else np.full(magnitude.shape, -np.inf)
    return SubApertureDetections(
        index=int(index),
        pulses=pulses,
        time_s=float(time_s),
        look_direction=np.asarray(geom.m_o, dtype=np.float64).copy(),
        range_direction=np.asarray(cells.range_direction, dtype=np.float64),
        cross_range_direction=np.asarray(cells.cross_range_direction, dtype=np.float64),
        range_cell_m=float(cells.ground_range_m),
        cross_range_cell_m=float(cells.cross_range_m),
        range_speed_resolution_mps=float(range_speed_resolution(traces)),
        cross_range_speed_resolution_mps=float(cross_range_speed_resolution(traces)),
        cross_range_speed_row=(geom.tangent @ geom.projector)[:2].copy(),
        detections=detections,
        stationary_db=db.astype(np.float32),
        grid=result.stationary_image.grid,
        seconds=float(result.timings_s["total"]),
    )


def sub_aperture_time_s(traces: Traces, pulses: slice) -> float:
    """Centre time of the pulses ``pulses`` in ``traces``' slow time (s)."""
    s = traces.slow_times_s
    return float(0.5 * (s[pulses.start] + s[pulses.stop - 1]))


def disjoint_in_time(pulses: Sequence[tuple[int, int]]) -> list[int]:
    """Indices of sub-apertures that share no pulse, greedily in time.

    ``pulses``: each one's ``(start, stop)`` pulses, in time order. Their errors are
    then independent (:mod:`sarmotion.tracking.turns`, :mod:`sarmotion.tracking.coherent`).
    """
    keep: list[int] = []
    for k, (start, _) in enumerate(pulses):
        if not keep or start >= pulses[keep[-1]][1]:
            keep.append(k)
    return keep
