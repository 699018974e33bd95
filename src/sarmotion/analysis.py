"""The whole analysis of one acquisition: separate, estimate, separate movers, image.

:func:`analyze` chains the building blocks of the package in the order of the paper
(``sect:algdesc``, ``sect:rotationopt``, ``sect:numeric``):

1. **preliminary image** ``eq:image`` on a square grid around the reference point;
2. **stationary / moving separation** ``M = L + S`` (:mod:`sarmotion.separation`);
3. **number of movers and their range speeds**: the peaks of ``g(u)`` (``eq:OBJg``) on
   ``S`` (:func:`sarmotion.velocity.estimate_range_speeds`);
4. **one mover at a time** (``fig:rpca2movFinalSep``), strongest first, on the current
   residual ``R`` (initially ``S``): location and velocity
   (:func:`sarmotion.velocity.estimate_velocity`, range speed re-refined on ``R``);
   then the mover is *separated*: ``T_+^{u, rho}`` at its estimate makes its trace
   vertical (``s``-independent, rank one) at ``t = 0``; its part is the slow-time mean
   of the aligned traces in a fast-time window of ``+- mover_half_window`` samples
   around ``t = 0`` (the orthogonal projection on ``s``-independent traces, i.e. the
   rank-one part of the window); mapped back by ``T_-^{u, rho}`` it is the mover's own
   trace ``D_q``, and ``R <- R - D_q`` before the next mover is estimated;
   Steps 3 and 4 run on a sub-aperture of about a degree (``sub_aperture_deg``), as the
   velocity estimation assumes: for a wider aperture, on its central degree. Each
   estimate is then moved to the aperture's ``s = 0`` and focused on all pulses
   (:func:`sarmotion.tracking.refine_on_aperture`: the coherent point response is
   maximised over range, range speed and cross-range speed) before its extraction. On
   one degree too this sharpens ``g_perp``'s cross-range speed: on 40 targets + 3 movers
   at 20 dB SNR the errors went from 0.81 / 0.08 / 0.016 m/s to 0.008 / 0.0001 / 0.001
   m/s. Each mover also gets its cross-range *family*
   (:func:`sarmotion.tracking.family_direction`): the data do not fix where along it
   the mover is;
5. **trajectory** of each mover by the phase-space algorithm
   (:func:`sarmotion.phase_space.estimate_trajectory`) from its own traces;
6. **images**: the stationary image from ``L`` (``M - S``), and each mover's image
   ``eq:imagecompu`` from its own traces compensated at its estimated velocity;
7. **stationary targets**: bright points of the stationary image.

The extraction of step 4 was chosen by measurement on Scene 1 (see
:func:`extract_mover`): the windowed slow-time mean leaves less of the mover in the
residual than the annihilator ``Q^{u, rho}`` and costs one transform pair.

Nothing here reads or writes files or prints; progress is reported through a callback
``progress(stage, done, total)``. All positions in m (data frame), speeds in m/s, times
in s.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .geometry import cross_range_speed, range_speed
from .imaging import Image, ImageGrid, backproject, resolution
from .phase_space import TrajectoryEstimate, estimate_trajectory, trajectory_error
from .separation import (
    Separation,
    aligned_constant_part,
    separate_annihilation,
    separate_combined,
    separate_rpca,
    stationary_candidates,
)
from .spectral import to_fast_time, to_frequency
from .traces import Traces
from .tracking import (
    azimuth_span_deg,
    central_sub_aperture,
    family_direction,
    refine_on_aperture,
)
from .velocity import (
    MoverEstimate,
    RangeSpeeds,
    cross_range_speed_resolution,
    estimate_range_speeds,
    estimate_velocity,
    range_speed_resolution,
)

__all__ = [
    "METHODS",
    "SCHEMA",
    "MoverResult",
    "StationaryTarget",
    "AnalysisResult",
    "analyze",
    "extract_mover",
    "default_method",
    "compare_with_truth",
]

log = logging.getLogger(__name__)

SCHEMA = "sarmotion.results/1"
METHODS = ("combined", "rpca", "annihilation")

#: ``progress(stage, done, total)``.
ProgressCallback = Callable[[str, int, int], None]


# ============================================================================ results
@dataclass(frozen=True, kw_only=True, eq=False)
class MoverResult:
    """One mover found by :func:`analyze`.

    Attributes
    ----------
    estimate : MoverEstimate
        Location at ``s = 0`` (m) and ground velocity (m/s), with the ``g`` and
        ``g_perp`` curves (:func:`sarmotion.velocity.estimate_velocity`).
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
        (:func:`sarmotion.tracking.family_direction`): ``position + t a``, ``velocity +
        t b`` fit the data as well for ``t`` metres of cross-range offset (m/m and
        (m/s)/m). The data of a few degrees do not fix ``t`` (:mod:`sarmotion.tracking`).
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
    method : str
        Stationary/moving separation method.
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
    options : dict
        The options the analysis ran with (JSON-serialisable).
    """

    traces: Traces
    method: str
    separation: Separation
    range_speeds: RangeSpeeds
    movers: tuple[MoverResult, ...]
    residual: NDArray[np.complexfloating]
    preliminary_image: Image
    stationary_image: Image
    stationary: tuple[StationaryTarget, ...]
    timings_s: dict[str, float]
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def stationary_traces(self) -> NDArray[np.complexfloating]:
        """``L``, or ``M`` minus the movers' traces for the annihilation filter."""
        if self.separation.stationary is not None:
            return self.separation.stationary
        return self.traces.data - sum((m.traces for m in self.movers), np.zeros(1))

    def to_json_dict(self, *, truth: Any | None = None) -> dict[str, Any]:
        """The ``sarmotion.results/1`` document (JSON-ready: lists, floats, strings).

        Parameters
        ----------
        truth : Scene, optional
            For simulated inputs: the true scene; adds ``truth`` and per-mover ``errors``
            (see :func:`compare_with_truth`).
        """
        tr = self.traces
        geom = tr.geometry
        movers = []
        for m in self.movers:
            e = m.estimate
            entry: dict[str, Any] = {
                "position_m": [float(v) for v in e.position_m[:2]],
                "velocity_mps": [float(v) for v in e.velocity_mps],
                "range_speed_mps": float(e.range_speed_mps),
                "cross_range_speed_mps": float(e.cross_range_speed_mps),
                "peak_db": float(m.peak_db),
                "g_peak_db": float(e.peak_db),
                "image_peak_m": [float(v) for v in m.image_peak_m],
                "cross_range_family": {
                    "position_per_m": [float(v) for v in m.family_position_per_m],
                    "velocity_mps_per_m": [float(v) for v in m.family_velocity_per_m],
                },
            }
            if m.trajectory is not None:
                entry["trajectory"] = {
                    "slow_times_s": m.trajectory.knot_times_s[:, 0].tolist()
                    + [float(m.trajectory.knot_times_s[-1, 1])],
                    "velocities_mps": m.trajectory.velocities_mps.tolist(),
                }
            movers.append(entry)
        doc: dict[str, Any] = {
            "schema": SCHEMA,
            "method": self.method,
            "reference_point_m": [float(v) for v in tr.reference_point_m],
            "platform_speed_mps": float(geom.speed_mps),
            "n_pulses": int(tr.n_pulses),
            "n_samples": int(tr.n_samples),
            "aperture_s": float(tr.slow_times_s[-1] - tr.slow_times_s[0]),
            "range_speed_resolution_mps": float(self.range_speeds.resolution_mps),
            "movers": movers,
            "stationary": [
                {"position_m": list(s.position_m), "peak_db": float(s.peak_db)}
                for s in self.stationary
            ],
            "timings_s": {k: float(v) for k, v in self.timings_s.items()},
            "options": self.options,
            "source": {k: v for k, v in tr.metadata.items() if _jsonable(v)},
        }
        if truth is not None:
            cmp = compare_with_truth(self, truth)
            doc["truth"] = cmp["truth"]
            for entry, err in zip(doc["movers"], cmp["errors"], strict=True):
                entry["errors"] = err
            doc["false_movers"] = cmp["false_movers"]
            doc["missed_movers"] = cmp["missed_movers"]
        return doc


def _jsonable(v: Any) -> bool:
    return isinstance(v, (str, int, float, bool)) or (
        isinstance(v, (list, tuple)) and all(isinstance(x, (str, int, float, bool)) for x in v)
    )


# ===================================================================== comparison
def compare_with_truth(result: AnalysisResult, scene: Any) -> dict[str, Any]:
    """Match estimated movers to the true ones and list the errors.

    Each estimate is matched to the unused true mover of nearest range speed (within
    four range-speed resolutions, else it is a false mover). Errors are estimate minus
    truth, with the position error also split along the ground range and cross-range
    directions at the reference point. ``family_*`` compare the truth with the point of
    the estimate's family (:attr:`MoverResult.family_position_per_m`) at the truth's
    cross-range offset: the part of the error the data can resolve.

    Parameters
    ----------
    result : AnalysisResult
        The analysis.
    scene : Scene
        The true scene (its movers' positions at ``s = 0`` and ground velocities).

    Returns
    -------
    dict
        ``truth`` (list of true movers), ``errors`` (one dict or None per estimate),
        ``false_movers`` and ``missed_movers`` (counts).
    """
    tr = result.traces
    geom = tr.geometry
    res = resolution(tr)
    e_r, e_c = res.range_direction, res.cross_range_direction
    truth = []
    for t in scene.moving:
        truth.append(
            {
                "label": t.label,
                "position_m": [float(v) for v in t.position_m[:2]],
                "velocity_mps": [float(v) for v in t.velocity_mps],
                "range_speed_mps": float(range_speed(t.velocity_mps, geom)),
                "cross_range_speed_mps": float(cross_range_speed(t.velocity_mps, geom)),
            }
        )
    used: set[int] = set()
    errors: list[dict[str, Any] | None] = []
    tol = 4.0 * result.range_speeds.resolution_mps
    for m in result.movers:
        e = m.estimate
        cands = [
            (abs(t["range_speed_mps"] - e.range_speed_mps), i)
            for i, t in enumerate(truth)
            if i not in used
        ]
        cands = [c for c in cands if c[0] <= tol]
        if not cands:
            errors.append(None)
            continue
        _, i = min(cands)
        used.add(i)
        t = truth[i]
        dp = np.asarray(e.position_m[:2]) - np.asarray(t["position_m"])
        di = np.asarray(m.image_peak_m) - np.asarray(t["position_m"])
        err: dict[str, Any] = {
            "matched": t["label"] or f"mover {i + 1}",
            "position_m": float(np.hypot(*dp)),
            "position_range_m": float(dp @ e_r),
            "position_cross_range_m": float(dp @ e_c),
            "image_peak_m": float(np.hypot(*di)),
            "image_peak_range_m": float(di @ e_r),
            "image_peak_cross_range_m": float(di @ e_c),
            "velocity_mps": float(np.hypot(*(e.velocity_mps - np.asarray(t["velocity_mps"])))),
            "range_speed_mps": float(e.range_speed_mps - t["range_speed_mps"]),
            "cross_range_speed_mps": float(e.cross_range_speed_mps - t["cross_range_speed_mps"]),
        }
        offset = -float(dp @ e_c) / float(m.family_position_per_m @ e_c)
        fp = dp + offset * m.family_position_per_m
        fv = e.velocity_mps + offset * m.family_velocity_per_m - np.asarray(t["velocity_mps"])
        err["family_offset_m"] = offset
        err["family_position_m"] = float(np.hypot(*fp))
        err["family_velocity_mps"] = float(np.hypot(*fv))
        if m.trajectory is not None:
            te = trajectory_error(m.trajectory, t["position_m"], t["velocity_mps"])
            err["trajectory_max_m"] = float(te.max())
            err["trajectory_rms_m"] = float(np.sqrt(np.mean(te**2)))
        errors.append(err)
    return {
        "truth": truth,
        "errors": errors,
        "false_movers": sum(e is None for e in errors),
        "missed_movers": len(truth) - len(used),
    }


# ================================================================ mover extraction
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


# ======================================================================= analysis
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


def _stationary_targets(
    image: Image, sep: Separation, traces: Traces, *, threshold_db: float, max_targets: int
) -> tuple[StationaryTarget, ...]:
    """Bright points of the stationary image, brightest first.

    With the combined separation the points are the stationary locations it accepted
    (refined on the point response, Doppler-tested: sidelobes of bright targets are not
    listed); otherwise the local maxima of ``|I|`` at least one cross-range resolution
    cell apart. Each keeps its level ``20 log10(|I(rho)| / max |I|)`` (dB, nearest pixel
    of the refined position, so a point may read a fraction of a dB low) when it is
    above ``threshold_db``.
    """
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


def default_method(traces: Traces) -> str:
    """Separation method for ``traces``, chosen by measurement.

    ``"combined"`` for simulated point scenes (Scene 1: ``||S - S_true|| / ||S_true||``
    = 0.13, both movers within 0.03 m/s); ``"rpca"`` (``eta_scale = 2``) for measured
    data: on a GOTCHA degree with two injected movers its ``g`` peaks stand 23.6 and
    21.9 dB above the floor against 13.3 and 11.0 dB for ``"combined"`` (distributed
    clutter is not a set of points) and it takes 0.4 s instead of 19 s;
    ``"annihilation"`` there lost one mover.
    """
    return "combined" if traces.metadata.get("source") == "simulation" else "rpca"


def _default_size_m(traces: Traces) -> float:
    """Side of the preliminary image (m): the unambiguous ground-range window, <= 100 m."""
    span = 0.5 * 299_792_458.0 / traces.radar.frequency_step_hz  # slant range window
    ground = span / np.cos(traces.geometry.elevation_rad)
    return float(min(100.0, 0.6 * ground))


def analyze(
    traces: Traces,
    *,
    method: str | None = None,
    max_movers: int = 5,
    progress: ProgressCallback | None = None,
    image_size_m: float | None = None,
    spacing_m: float = 0.25,
    mover_image_size_m: float = 20.0,
    speed_range_mps: tuple[float, float] = (-30.0, 30.0),
    threshold_db: float = 15.0,
    candidate_threshold_db: float = -20.0,
    eta_scale: float | None = None,
    rpca_window: int | None = None,
    rpca_tol: float = 1e-4,
    mover_half_window: int | None = None,
    trajectory: bool = True,
    stationary_threshold_db: float = -20.0,
    max_stationary: int = 100,
    sub_aperture_deg: float = 1.0,
) -> AnalysisResult:
    """Separate, estimate and image the stationary and moving targets of ``traces``.

    See the module docstring for the stages.

    Parameters
    ----------
    traces : Traces
        Data ``M``.
    method : {"combined", "rpca", "annihilation"}, optional
        Stationary/moving separation; default :func:`default_method`.
    max_movers : int
        Most movers sought (>= 0).
    progress : callable, optional
        ``progress(stage, done, total)`` during the long stages.
    image_size_m : float, optional
        Side of the square preliminary/stationary image around the reference point (m);
        default the unambiguous range window of the data, at most 100 m.
    spacing_m : float
        Pixel spacing of all images (m).
    mover_image_size_m : float
        Side of each mover's image around its estimated location (m).
    speed_range_mps : (float, float)
        Searched range and cross-range speeds (m/s).
    threshold_db : float
        Peak of ``g`` over its median needed for a mover (dB), see
        :func:`sarmotion.velocity.estimate_range_speeds`. Measured: true movers stand
        17.6-28 dB above the floor (scene1 21.3/21.4; 40 targets + 3 movers at 20 dB SNR
        17.6-20.3; GOTCHA degree + 2 injected 21.9/23.6), while the stationary clutter
        left in S of the real 4-degree GOTCHA scene makes peaks of 11.7-14.4 dB at
        0.2-1.1 m/s (false movers at the old 10 dB).
    candidate_threshold_db : float
        ``combined`` and ``annihilation``: stationary candidates are the bright points of
        the preliminary image above this level re its peak (dB).
    eta_scale : float, optional
        RPCA sparsity factor (``rpca`` only); default 1 for simulations, 2 for measured
        data.
    rpca_window : int, optional
        RPCA fast-time window (samples), default chosen from the data.
    rpca_tol : float
        RPCA stopping rule ``||M - L - S||_F <= tol ||M||_F`` (per window); 1e-4 gives
        the same movers as 1e-6 on GOTCHA (g peaks 23.6/21.9 dB against 23.7/21.9 dB).
    mover_half_window : int, optional
        Half-width of a mover's extraction window, see :func:`extract_mover`.
    trajectory : bool
        Estimate each mover's trajectory by the phase-space algorithm.
    stationary_threshold_db, max_stationary
        Stationary target list (:func:`_stationary_targets`): points above this level re
        the brightest pixel of the stationary image (dB), at most this many.
    sub_aperture_deg : float
        Azimuth span of the sub-aperture the movers are estimated on (degrees). A wider
        aperture is analysed on its central sub-aperture and each mover then focused on
        all pulses (:mod:`sarmotion.tracking`).

    Returns
    -------
    AnalysisResult
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a sarmotion.traces.Traces, got {type(traces).__name__}")
    method = default_method(traces) if method is None else method
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if isinstance(max_movers, bool) or not isinstance(max_movers, (int, np.integer)):
        raise TypeError(f"max_movers must be an integer, got {max_movers!r}")
    if max_movers < 0:
        raise ValueError(f"max_movers must be >= 0, got {max_movers}")
    simulated = traces.metadata.get("source") == "simulation"
    if eta_scale is None:
        eta_scale = 1.0 if simulated else 2.0
    size = _default_size_m(traces) if image_size_m is None else float(image_size_m)
    if not (size > 0 and spacing_m > 0 and size / spacing_m <= 4096):
        raise ValueError(
            f"image_size_m / spacing_m must be positive and give <= 4096 pixels a side, "
            f"got {size} m / {spacing_m} m"
        )
    options = {
        "method": method,
        "max_movers": int(max_movers),
        "image_size_m": size,
        "spacing_m": float(spacing_m),
        "mover_image_size_m": float(mover_image_size_m),
        "speed_range_mps": [float(v) for v in speed_range_mps],
        "threshold_db": float(threshold_db),
        "candidate_threshold_db": float(candidate_threshold_db),
        "eta_scale": float(eta_scale),
        "rpca_tol": float(rpca_tol),
        "trajectory": bool(trajectory),
        "sub_aperture_deg": float(sub_aperture_deg),
    }

    def report(stage: str) -> Callable[[int, int], None] | None:
        if progress is None:
            return None
        return lambda done, total: progress(stage, done, total)

    timings: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(stage: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[stage] = timings.get(stage, 0.0) + now - clock
        clock = now

    # Velocities are estimated on a sub-aperture of about a degree (sarmotion.velocity),
    # the central one of a wider aperture, and focused on the whole aperture after.
    central = central_sub_aperture(traces, sub_aperture_deg)
    wide = central != slice(0, traces.n_pulses)
    if wide:
        log.info(
            "aperture of %.1f degrees: movers estimated on pulses %d-%d, refined on all",
            azimuth_span_deg(traces),
            central.start,
            central.stop - 1,
        )

    # 1. preliminary image
    centre = tuple(float(v) for v in traces.reference_point_m[:2])
    grid = ImageGrid.square(centre_m=centre, size_m=size, spacing_m=spacing_m)
    prelim = backproject(traces, grid, progress=report("preliminary image"))
    lap("preliminary_image")

    # 2. separation
    if method == "combined":
        sep = separate_combined(
            traces,
            image_values=prelim.values,
            x_m=grid.x_m,
            y_m=grid.y_m,
            threshold_db=candidate_threshold_db,
            callback=report("separation"),
        )
    elif method == "rpca":
        # rpca runs its SVDs on one BLAS thread (see sarmotion.rpca).
        sep = separate_rpca(
            traces,
            window=rpca_window,
            eta_scale=eta_scale,
            tol=rpca_tol,
            callback=report("separation"),
        )
    else:
        pts = stationary_candidates(
            prelim.values,
            x_m=grid.x_m,
            y_m=grid.y_m,
            traces=traces,
            threshold_db=candidate_threshold_db,
        )
        sep = separate_annihilation(traces, pts)
    lap("separation")

    # 3. number of movers and their range speeds (central sub-aperture)
    sub = traces.select_pulses(central.start, central.stop)
    moving = sub.with_data(sep.moving[central])
    # A stationary target at cross-range offset y has an apparent range speed V y / L
    # (eq:Dtau): movers must be well above it over the imaged scene (eq:AnnihCond,
    # "u >> V R / L"), here twice its value at the image's half-diagonal.
    geom = traces.geometry
    apparent = geom.speed_mps * (size / np.sqrt(2.0)) / geom.range_m
    speeds = estimate_range_speeds(
        moving,
        speed_range_mps=speed_range_mps,
        max_movers=max_movers,
        threshold_db=threshold_db,
        min_speed_mps=max(4.0 * range_speed_resolution(moving), 2.0 * apparent),
    )
    log.info("g(u): %d mover(s) at %s m/s", speeds.n_movers, np.round(speeds.speeds_mps, 2))
    lap("range_speeds")

    # 4. movers one at a time
    residual = np.array(sep.moving, dtype=np.complex128)
    Family = tuple[NDArray[np.float64], NDArray[np.float64]]
    estimates: list[tuple[MoverEstimate, NDArray[np.complex128], Family]] = []
    n_movers = speeds.n_movers
    for k, u_hint in enumerate(speeds.speeds_mps):
        current = sub.with_data(residual[central])
        est = estimate_velocity(
            current,
            range_speed_mps=float(u_hint),
            speed_range_mps=speed_range_mps,
            cross_speed_range_mps=speed_range_mps,
        )
        # A g_perp minimum on the edge of the searched interval is no minimum: the traces
        # at this range speed do not curve like one mover's (on the real 4-degree GOTCHA
        # scene, clutter left in S gave such "movers" at u_perp = +-30 m/s).
        edge = cross_range_speed_resolution(current)
        if not (speed_range_mps[0] + edge < est.cross_range_speed_mps < speed_range_mps[1] - edge):
            log.warning(
                "g(u) peak at %.2f m/s rejected: cross-range speed %.1f m/s on the search edge",
                u_hint,
                est.cross_range_speed_mps,
            )
            continue
        family = family_direction(sub, est.position_m, est.velocity_mps)
        est = _on_whole_aperture(traces, residual, est, central)
        own = extract_mover(
            traces,
            residual,
            position_m=est.position_m,
            velocity_mps=est.velocity_mps,
            half_window=mover_half_window,
        )
        residual = residual - own
        estimates.append((est, own, family))
        log.info(
            "mover %d: position (%.2f, %.2f) m, velocity (%.2f, %.2f) m/s",
            k + 1,
            *est.position_m[:2],
            *est.velocity_mps,
        )
        if progress is not None:
            progress("movers", k + 1, n_movers)
    lap("movers")

    # 5. trajectories
    trajs: list[TrajectoryEstimate | None] = []
    for k, (est, own, _) in enumerate(estimates):
        tj = None
        if trajectory:
            try:
                tj = estimate_trajectory(
                    traces.with_data(own), est.position_m, velocity_guess_mps=est.velocity_mps
                )
            except ValueError as exc:  # e.g. a mover too close to the window edge
                log.warning("trajectory of mover %d not estimated: %s", k + 1, exc)
        trajs.append(tj)
        if progress is not None and trajectory:
            progress("trajectories", k + 1, len(estimates))
    lap("trajectories")

    # 6. images
    if sep.stationary is not None:
        stat_data = sep.stationary
    else:
        stat_data = traces.data - sum((e[1] for e in estimates), np.zeros(traces.shape))
    stat_img = backproject(traces.with_data(stat_data), grid, progress=report("stationary image"))
    stat_peak = float(stat_img.magnitude.max()) or 1.0
    movers: list[MoverResult] = []
    for (est, own, family), tj in zip(estimates, trajs, strict=True):
        mgrid = ImageGrid.square(
            centre_m=tuple(est.position_m[:2]), size_m=mover_image_size_m, spacing_m=spacing_m
        )
        img = backproject(traces.with_data(own), mgrid, velocity_mps=est.velocity_mps)
        x, y, v = img.peak(refine=True)
        movers.append(
            MoverResult(
                estimate=est,
                traces=own,
                image=img,
                image_peak_m=np.array([x, y]),
                peak_db=float(20.0 * np.log10(max(abs(v), 1e-300) / stat_peak)),
                family_position_per_m=family[0],
                family_velocity_per_m=family[1],
                trajectory=tj,
            )
        )
    lap("images")

    # 7. stationary targets
    stationary = _stationary_targets(
        stat_img,
        sep,
        traces,
        threshold_db=stationary_threshold_db,
        max_targets=max_stationary,
    )
    lap("stationary_targets")
    timings["total"] = float(sum(timings.values()))

    return AnalysisResult(
        traces=traces,
        method=method,
        separation=sep,
        range_speeds=speeds,
        movers=tuple(movers),
        residual=residual,
        preliminary_image=prelim,
        stationary_image=stat_img,
        stationary=tuple(stationary),
        timings_s=timings,
        options=options,
    )
