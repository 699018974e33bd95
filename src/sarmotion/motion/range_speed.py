"""Number of movers and their range speeds: the peaks of ``g(u)`` (``eq:OBJg``)."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import finite as _finite
from .._validation import interval as _interval
from .._validation import positive as _positive
from ..core import C, Traces, as_point
from ..core.geometry import range_direction_velocity
from ._aligned import (
    _Aligner,
    _check_traces,
    _range_trials,
    _refine_max,
    _speeds,
)
from .speed_resolution import range_speed_resolution

log = logging.getLogger(__name__)

__all__ = [
    "RangeSpeeds",
    "aligned_range",
    "aligned_trace",
    "range_speed_objective",
    "estimate_range_speeds",
]


# ==================================================================== g(u)
def range_speed_objective(
    traces: Traces,
    speeds_mps: ArrayLike,
    *,
    reference_m: ArrayLike | None = None,
    cross_range_speed_mps: float | None = None,
) -> NDArray[np.float64]:
    """The range-speed objective ``g(u)`` of ``eq:OBJg`` for an array of range speeds.

    ``g(u) = max_l sum_j |[T_+^{u_vec, rho^e} D](s_j, t_l)|`` with ``rho^e`` =
    ``reference_m`` and ``u_vec`` = :func:`~sarmotion.core.geometry.range_direction_velocity`
    ``(u)`` (range speed exactly ``u``; see the module notes), or, when
    ``cross_range_speed_mps`` is given, the ground velocity with range speed ``u`` and that
    cross-range speed (used to re-estimate ``u`` once ``u_perp`` is known).

    ``T_+`` is the phase modulation ``exp(2i pi f dtau(s))`` of the phase history
    (``eq:FFT``); the fast-time samples ``t_l`` are those of the traces refined twice by
    band-limited interpolation (zero padding of the spectrum), so that the maximum over
    ``l`` of a pulse falling between two samples loses at most 3 % (Gaussian pulse)
    instead of 12 %.

    Parameters
    ----------
    traces : Traces
        Traces of the moving targets ``D_r(s, t)``, shape (n_pulses, n_samples).
    speeds_mps : (n_speeds,) array_like
        Trial range speeds ``u`` (m/s).
    reference_m : (2,) or (3,) array_like, optional
        ``rho^e`` (m), the target's location at ``s = 0`` if known; default the
        range-compression reference point ``rho_o`` of ``traces`` (the paper's choice when
        the location is unknown).
    cross_range_speed_mps : float, optional
        Cross-range speed ``u_perp`` (m/s) of the trial velocities; default: trials along
        the ground range direction.

    Returns
    -------
    (n_speeds,) ndarray
        ``g(u)`` in units of the trace samples (a sum of ``n_pulses`` moduli); an aligned
        unit point target gives ``n_pulses``.
    """
    tr = _check_traces(traces)
    u = _speeds(speeds_mps, "speeds_mps")
    rho = tr.reference_point_m if reference_m is None else as_point(reference_m, name="reference_m")
    up = (
        None
        if cross_range_speed_mps is None
        else _finite(cross_range_speed_mps, "cross_range_speed_mps")
    )
    aligner = _Aligner(tr, rho)
    return aligner.g_values(_range_trials(u, tr.geometry, up))


@dataclass(frozen=True, kw_only=True, eq=False)
class RangeSpeeds:
    """Range speeds of the movers found in ``g(u)`` (:func:`estimate_range_speeds`).

    Attributes
    ----------
    speeds_mps : (n_movers,) ndarray
        Refined peak locations of ``g`` (m/s), strongest peak first.
    peak_values : (n_movers,) ndarray
        ``g`` at those speeds (trace units).
    over_floor_db : (n_movers,) ndarray
        ``20 log10(peak_values / floor)`` over the global floor :attr:`floor` (dB; ``g``
        is a sum of moduli, an amplitude). Not the detector's statistic, which is over
        the *local* floor (:class:`~sarmotion.motion.RangeSpeedDetection`).
    floor : float
        Median of ``g`` over the coarse grid: the robust level of the misaligned traces,
        clutter and noise (trace units).
    resolution_mps : float
        Range-speed resolution :func:`range_speed_resolution` (m/s).
    grid_mps : (n_grid,) ndarray
        Coarse trial speeds (m/s).
    objective : (n_grid,) ndarray
        ``g`` on ``grid_mps``, for plotting (``fig:filtComp``).
    """

    speeds_mps: NDArray[np.float64]
    peak_values: NDArray[np.float64]
    over_floor_db: NDArray[np.float64]
    floor: float
    resolution_mps: float
    grid_mps: NDArray[np.float64]
    objective: NDArray[np.float64]

    @property
    def n_movers(self) -> int:
        """Number of movers detected."""
        return int(self.speeds_mps.size)


def estimate_range_speeds(
    traces: Traces,
    *,
    speed_range_mps: tuple[float, float] = (-30.0, 30.0),
    coarse_step_mps: float | None = None,
    max_movers: int = 5,
    threshold_db: float = 10.0,
    min_speed_mps: float | None = None,
    min_separation_mps: float | None = None,
    reference_m: ArrayLike | None = None,
    tol_mps: float = 1e-3,
) -> RangeSpeeds:
    """Range speeds of the movers: peaks of ``g(u)`` (``eq:OBJg``), coarse to fine.

    ``g`` is evaluated on a coarse grid over ``speed_range_mps``; its interior local
    maxima are candidates. A candidate is a mover when

    * ``20 log10(g / floor) >= threshold_db`` with ``floor`` the median of ``g`` over the
      grid (most trial speeds align nothing, so the median is the level of misaligned
      traces, residual clutter and noise);
    * ``|u| >= min_speed_mps``: slower peaks are stationary targets, whose traces have
      the apparent range speed ``V y / L`` of their cross-range offset ``y``
      (``eq:Dtau`` with ``u = 0``; after ``eq:AnnihCond``);
    * it is at least ``min_separation_mps`` from a stronger accepted peak;

    at most ``max_movers``, strongest first. Each is then refined by a bounded Brent
    search over ``+- coarse_step_mps`` to ``tol_mps``.

    Parameters
    ----------
    traces : Traces
        Traces of the moving targets (stationary ones removed).
    speed_range_mps : (float, float)
        Searched range speeds ``(low, high)`` (m/s).
    coarse_step_mps : float, optional
        Grid step (m/s); default half of :func:`range_speed_resolution` (0.14 m/s for
        GOTCHA, 440 trials over +-30 m/s; the peak of ``g`` is ~5 resolutions wide at
        half height for the paper's Gaussian pulse, so it is sampled by ~10 points).
    max_movers : int
        Cap on the number of movers returned (>= 0).
    threshold_db : float
        Minimum peak-to-floor ratio (dB); ``-inf`` keeps every peak. Default 10 dB: a
        mover stands 23-33 dB above the floor of the moving traces of the paper's scenes,
        pure noise fluctuates by < 1 dB, and the slope-crossing bumps of 10-30 stationary
        traces reach 5-7.5 dB outside the stationary band.
    min_speed_mps : float, optional
        Peaks with ``|u|`` below this are attributed to stationary targets (m/s); default
        four resolutions (1.1 m/s for GOTCHA, beyond ``V y / L`` for ``|y| < 150`` m and
        the width of the stationary peak).
    min_separation_mps : float, optional
        Minimum distance between two movers' peaks (m/s); default one resolution.
    reference_m : (2,) or (3,) array_like, optional
        ``rho^e`` (m); default the traces' reference point.
    tol_mps : float
        Tolerance of the refinement (m/s).

    Returns
    -------
    RangeSpeeds
    """
    tr = _check_traces(traces)
    lo, hi = _interval(speed_range_mps, "speed_range_mps")
    res = range_speed_resolution(tr)
    step = 0.5 * res if coarse_step_mps is None else _positive(coarse_step_mps, "coarse_step_mps")
    if isinstance(max_movers, bool) or not isinstance(max_movers, (int, np.integer)):
        raise TypeError(f"max_movers must be an integer, got {max_movers!r}")
    if max_movers < 0:
        raise ValueError(f"max_movers must be >= 0, got {max_movers}")
    try:
        thr = float(threshold_db)
    except (TypeError, ValueError):
        raise TypeError(f"threshold_db must be a real number (dB), got {threshold_db!r}") from None
    if np.isnan(thr) or thr == np.inf:
        raise ValueError(f"threshold_db must be a number or -inf (dB), got {threshold_db!r}")
    vmin = 4.0 * res if min_speed_mps is None else _finite(min_speed_mps, "min_speed_mps")
    if vmin < 0:
        raise ValueError(f"min_speed_mps must be >= 0, got {min_speed_mps!r}")
    sep = res if min_separation_mps is None else _positive(min_separation_mps, "min_separation_mps")
    tol = _positive(tol_mps, "tol_mps")
    n_grid = int(np.floor((hi - lo) / step)) + 1
    if n_grid < 3:
        raise ValueError(
            f"speed_range_mps {speed_range_mps!r} holds fewer than 3 grid points of "
            f"coarse_step_mps = {step:g}"
        )
    rho = tr.reference_point_m if reference_m is None else as_point(reference_m, name="reference_m")
    grid = lo + step * np.arange(n_grid)
    aligner = _Aligner(tr, rho)
    geom = tr.geometry
    curve = aligner.g_values(_range_trials(grid, geom, None))
    floor = float(np.median(curve))

    def g_at(u: float) -> float:
        return float(aligner.g_values(_range_trials(np.array([u]), geom, None))[0])

    interior = np.arange(1, n_grid - 1)
    is_max = (curve[interior] >= curve[interior - 1]) & (curve[interior] > curve[interior + 1])
    cand = interior[is_max]
    cand = cand[np.argsort(-curve[cand], kind="stable")]
    level = floor * 10.0 ** (thr / 20.0) if floor > 0 else 0.0
    speeds: list[float] = []
    values: list[float] = []
    for i in cand:
        if len(speeds) >= max_movers or curve[i] < level or floor <= 0:
            break
        if abs(grid[i]) < vmin or any(abs(grid[i] - u) < sep for u in speeds):
            continue
        u, val = _refine_max(g_at, float(grid[i]), step, tol)
        speeds.append(u)
        values.append(val)
    vals = np.asarray(values, dtype=np.float64)
    over_floor_db = _over_floor_db(vals, floor)
    log.debug("range speeds %s (peak/floor %s dB)", speeds, over_floor_db)
    return RangeSpeeds(
        speeds_mps=np.asarray(speeds, dtype=np.float64),
        peak_values=vals,
        over_floor_db=over_floor_db,
        floor=floor,
        resolution_mps=res,
        grid_mps=grid,
        objective=curve,
    )


def _over_floor_db(values: NDArray[np.float64], floor: float) -> NDArray[np.float64]:
    """``20 log10(values / floor)`` (dB); infinite for a zero floor."""
    v = np.asarray(values, dtype=np.float64)
    return 20.0 * np.log10(v / floor) if floor > 0 else np.full(v.size, np.inf)


def aligned_trace(
    traces: Traces,
    range_speed_mps: float,
    *,
    avoid_s: Sequence[float] = (),
    guard_s: float = 0.0,
) -> tuple[float, float]:
    """Fast-time delay (s) and ``g`` value of the strongest aligned trace at range speed ``u``.

    The traces aligned on the reference point at the ground velocity of range speed
    ``u`` and zero cross-range speed; the delay ``t`` (relative to the reference point's,
    on the twice-oversampled fast time of the alignment) where ``sum_s |T_+ d(s, t)|``
    peaks: the trace ``g(u)`` takes, and that sum (``g(u)`` itself, in trace units, when
    nothing is avoided). Samples within ``guard_s`` of a delay of ``avoid_s`` are passed
    over (the trace of a mover already fitted at that speed); ``(nan, 0)`` when none is
    left.
    """
    al = _Aligner(traces, traces.reference_point_m)
    profile = al.trace_profile(range_direction_velocity(float(range_speed_mps), traces.geometry))
    for t in avoid_s:
        profile[np.abs(al.times_s - t) <= guard_s] = -np.inf
    if not np.isfinite(profile.max()):
        return float("nan"), 0.0
    best = int(np.argmax(profile))
    return float(al.times_s[best]), float(profile[best])


def aligned_range(traces: Traces, range_speed_mps: float) -> float:
    """Ground-range coordinate of a ``g(u)`` peak's range history at ``s = 0`` (m), not fitted.

    The traces are aligned on the reference point ``rho_o`` at the ground velocity of
    range speed ``u`` and zero cross-range speed
    (:func:`~sarmotion.core.geometry.range_direction_velocity`); the fast-time sample
    ``t`` where ``sum_s |T_+ d(s, t)|`` peaks (the one ``g(u)`` takes) puts the range
    history at ``R = L + c t / 2`` at ``s = 0``. The coordinate is the ``x`` of the point
    ``rho_o + x e_r`` at that distance from the antenna (``e_r``: ground range direction
    at ``rho_o``, :func:`sarmotion.imaging.resolution`):
    ``|L m_o - x e_r| = R``, the root nearer ``rho_o``. Good to about a range resolution
    (the sample grid is oversampled, the cross-range speed is not searched).

    Parameters
    ----------
    traces : Traces
        Traces holding the mover (e.g. what the estimated movers leave of ``S``).
    range_speed_mps : float
        The ``g(u)`` peak (m/s).

    Returns
    -------
    float
        ``x`` (m).
    """
    from ..imaging import resolution  # imaging imports motion's neighbours: at call time

    geom = traces.geometry
    slant = geom.range_m + 0.5 * C * aligned_trace(traces, range_speed_mps)[0]
    e_r = resolution(traces).range_direction
    cos = float(geom.m_o[:2] @ e_r)
    length = geom.range_m
    disc = max(0.0, (length * cos) ** 2 + slant**2 - length**2)
    return float(length * cos - np.sign(cos) * np.sqrt(disc))
