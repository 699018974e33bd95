"""Detection of movers as a statistical test on ``g(u)`` and on the focus of each candidate.

**Statistic.** Every interior local maximum of ``g(u)`` (``eq:OBJg``) on its coarse grid
is a candidate. Its statistic is the peak over a *local* floor,

    T = 20 log10(g(u_c) / median{ g(u) : 2 delta_u <= |u - u_c| <= 12 delta_u })   (dB),

``delta_u`` the range-speed resolution (:func:`range_speed_resolution`). The median of
the ring ignores the candidate's own peak and a neighbour or two; the local floor
follows the broad swell of the misaligned traces of stationary residue, which a global
median does not (such swells stand several dB above the global median on a real GOTCHA
degree separated by RPCA, and about 1 dB above the local floor).

**Null distribution** (no mover). The threshold comes from the distribution of ``T``
over every candidate with ``|u| >= 1.1`` m/s on data without movers: the real GOTCHA
degrees separated by RPCA, and simulated point clutter (10-80 targets, 0-30 dB SNR)
separated by the combined method and by RPCA. Above its 90 % quantile ``t_0`` the tail
is exponential, ``P(T > t) = p_0 exp(-(t - t_0) / s)`` with ``p_0 = 0.1``; the model
(:data:`NULL_TAIL`) takes the heaviest of these populations, so that it is
conservative for the others. With ``N`` candidates per ``g(u)`` (about 110 over +-30 m/s
on a GOTCHA degree) the per-scene false-alarm rate ``alpha`` is met by
:func:`threshold_db` ``= t_0 + s ln(p_0 N / alpha)``, about 5.5 dB for ``alpha = 1 %``.
The threshold is the one stated principle; the two tests below only remove candidates.
``benchmarks/detector_null.py`` measures the distribution again on seeds of its own
(quantiles, tail fits and the check on held-out seeds: ``docs/notes/detector.md``).

**Shape.** A point mover's ``g`` peak has the half-height width of
:func:`point_peak_width`: its aligned trace tilts by ``du s`` in range, so
``g(u + du) / g(u)`` is the slow-time mean of the compressed-pulse envelope at
``2 du s / c`` (2.1 resolutions for the GOTCHA rect spectrum, 4.25 for the paper's
Gaussian pulse). On the coarse grid a mover's peak is one to a point width and a half,
and two movers within 3 resolutions merge into one peak up to 2.5 point widths, while
the residue of stationary clutter near the stationary band is broader (three point
widths and more; figures in ``docs/notes/detector.md``). Candidates wider than
``max_width`` point widths (the analysis uses 2.5, between the two) are rejected.

**Focus gain against a stationary explanation.** Over one degree a mover's range history
is shared by a one-parameter family of uniform motions (:mod:`sarmotion.motion.aperture`);
the member with zero range speed is a (nearly) stationary point ``dy`` off in cross
range, ``dy ~ u L / V``. A slow candidate (``|u|`` of 0.5 m/s gives 70 m at GOTCHA) may
be a stationary target off the image: on the real degrees every slow candidate was, to
a few hundredths of a dB (one the calibration reflector at (-27.8, 38.8) m). The focus
gain is the coherent matched filter of the candidate's maximum-likelihood fit over the
same data imaged as stationary, at the best stationary point near that member,
``G = 20 log10(|I_u(rho^e)| / max |I_0|)`` (dB, >= 0 up to the search tolerance). When
the member lies within the cross-range extent free of azimuth aliasing,
``lambda L / (2 dx)`` (``dx`` the pulse spacing; 150 m at GOTCHA), candidates with
``G < min_focus_gain_db`` (1 dB) are stationary and rejected. Farther out, a stationary
target would alias and is no explanation.

Positions in m, speeds in m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import Acquisition, C, Traces, as_traces, range_speed
from ..imaging import refine_location, resolution
from .aperture import family_member
from .range_speed import RangeSpeeds, _over_floor_db, estimate_range_speeds, range_speed_objective
from .speed_resolution import range_speed_resolution

__all__ = [
    "NULL_TAIL",
    "PeakStatistics",
    "RangeSpeedDetection",
    "detect_range_speeds",
    "local_floor",
    "local_statistic",
    "point_peak_width",
    "peak_statistics",
    "threshold_db",
    "false_alarm_probability",
    "StationaryExplanation",
    "alias_free_extent_m",
    "stationary_explanation",
]

#: Exponential tail of the null statistic above its 90 % quantile (module notes): that of
#: the heaviest population, simulated point clutter separated by RPCA
#: (``benchmarks/detector_null.py``, ``docs/notes/detector.md``).
NULL_TAIL = {"t0_db": 1.34, "scale_db": 0.60, "p0": 0.10}


@dataclass(frozen=True, kw_only=True, eq=False)
class PeakStatistics:
    """The candidates of one ``g(u)`` curve (:func:`peak_statistics`).

    Attributes
    ----------
    speeds_mps : (k,) ndarray
        Grid speeds of the local maxima (m/s).
    values : (k,) ndarray
        ``g`` there (trace units).
    floors : (k,) ndarray
        Local floors, medians of ``g`` over the ring (trace units).
    statistic_db : (k,) ndarray
        ``20 log10(values / floors)`` (dB).
    width_resolutions : (k,) ndarray
        Contiguous width at half height above the floor (range-speed resolutions).
    """

    speeds_mps: NDArray[np.float64]
    values: NDArray[np.float64]
    floors: NDArray[np.float64]
    statistic_db: NDArray[np.float64]
    width_resolutions: NDArray[np.float64]


def peak_statistics(
    grid_mps: ArrayLike,
    objective: ArrayLike,
    resolution_mps: float,
    *,
    guard: float = 2.0,
    outer: float = 12.0,
) -> PeakStatistics:
    """Local-floor statistic and half-height width of every local maximum of ``g``.

    Parameters
    ----------
    grid_mps : (n,) array_like
        Uniform grid of range speeds (m/s).
    objective : (n,) array_like
        ``g`` on the grid (> 0).
    resolution_mps : float
        Range-speed resolution ``delta_u`` (m/s).
    guard, outer : float
        The ring of the floor, ``guard delta_u <= |u - u_c| <= outer delta_u``.

    Returns
    -------
    PeakStatistics
        Candidates in grid order.
    """
    u = np.asarray(grid_mps, dtype=np.float64)
    g = np.asarray(objective, dtype=np.float64)
    if u.ndim != 1 or g.shape != u.shape or u.size < 3:
        raise ValueError(
            f"grid_mps and objective must be 1-D of the same size >= 3, got {u.shape}, {g.shape}"
        )
    step = float(u[1] - u[0])
    i = np.arange(1, u.size - 1)
    peaks = i[(g[i] >= g[i - 1]) & (g[i] > g[i + 1])]
    floors = np.empty(peaks.size)
    widths = np.empty(peaks.size)
    for n, p in enumerate(peaks):
        d = np.abs(u - u[p])
        floors[n] = np.median(g[(d >= guard * resolution_mps) & (d <= outer * resolution_mps)])
        half = floors[n] + 0.5 * (g[p] - floors[n])
        lo, hi = p, p
        while lo > 0 and g[lo - 1] >= half:
            lo -= 1
        while hi < u.size - 1 and g[hi + 1] >= half:
            hi += 1
        widths[n] = (hi - lo + 1) * step / resolution_mps
    return PeakStatistics(
        speeds_mps=u[peaks],
        values=g[peaks],
        floors=floors,
        statistic_db=20.0 * np.log10(g[peaks] / floors),
        width_resolutions=widths,
    )


def threshold_db(false_alarm_rate: float, n_candidates: int) -> float:
    """Statistic threshold for a per-scene false-alarm rate (module notes).

    ``t_0 + s ln(p_0 N / alpha)`` with the null tail :data:`NULL_TAIL`: ``N``
    candidates, each beyond the threshold with probability ``alpha / N``.
    """
    if not 0.0 < false_alarm_rate < 1.0:
        raise ValueError(f"false_alarm_rate must be in (0, 1), got {false_alarm_rate!r}")
    n = max(int(n_candidates), 1)
    t = NULL_TAIL
    return float(t["t0_db"] + t["scale_db"] * np.log(t["p0"] * n / false_alarm_rate))


def false_alarm_probability(statistic_db: float, n_candidates: int) -> float:
    """Probability that the largest of ``N`` null candidates reaches ``statistic_db``.

    The union bound ``min(1, N p_0 exp(-(T - t_0) / s))`` of the null tail, valid
    above ``t_0``; the per-scene significance of a detection.
    """
    t = NULL_TAIL
    n = max(int(n_candidates), 1)
    excess = (float(statistic_db) - t["t0_db"]) / t["scale_db"]
    return float(min(1.0, n * t["p0"] * np.exp(-excess)))


@dataclass(frozen=True, kw_only=True)
class StationaryExplanation:
    """The best stationary point on a candidate's family (:func:`stationary_explanation`).

    Attributes
    ----------
    position_m : (3,) ndarray
        The stationary point (m).
    cross_offset_m : float
        Its cross-range offset from the candidate's fitted position (m).
    within_extent : bool
        Whether it lies within the alias-free cross-range extent of the reference point.
    focus_gain_db : float
        ``20 log10(|I_u(rho^e)| / |I_0(position_m)|)`` (dB).
    """

    position_m: NDArray[np.float64]
    cross_offset_m: float
    within_extent: bool
    focus_gain_db: float


def alias_free_extent_m(traces: Acquisition | Traces) -> float:
    """Cross-range extent free of azimuth aliasing, ``lambda L / (2 dx)`` (m)."""
    dx = float(np.median(np.linalg.norm(np.diff(traces.positions_m, axis=0), axis=1)))
    return float(traces.radar.wavelength_m * traces.geometry.range_m / (2.0 * dx))


def stationary_explanation(
    data: Traces | ArrayLike,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    value: complex,
    *,
    acquisition: Acquisition | None = None,
    extent_m: float | None = None,
    extent_centre_m: ArrayLike | None = None,
) -> StationaryExplanation:
    """The zero-range-speed member of a fit's family, refined as a stationary point.

    The member (:func:`sarmotion.motion.aperture.family_member`) at the cross-range
    offset where the range speed vanishes (three secant steps from the family's tangent)
    is the stationary point with the candidate's range history; its location is refined
    on ``|I_0|`` (:func:`sarmotion.imaging.refine_location`, no motion compensation).

    Parameters
    ----------
    data : Traces or (n_pulses, n_samples) array_like
        The data the candidate was fitted on.
    position_m : (3,) array_like
        Fitted position (m).
    velocity_mps : (2,) array_like
        Fitted ground velocity (m/s).
    value : complex
        Matched filter at the fit (data units times ``n_pulses``).
    acquisition : Acquisition, optional
        The acquisition of ``data`` (about a degree); required when it is an array.
    extent_m : float, optional
        The cross-range extent (m) about ``extent_centre_m`` within which a stationary
        point may explain the fit (``within_extent``): the data's alias-free extent.
        Default :func:`alias_free_extent_m` of ``data``'s own pulses; traces resampled to
        fewer pulses (a collection's patch) hold, through the wrap of the data's Doppler
        at the data's pulse rate, echoes of stationary points over the data's extent,
        not their own.
    extent_centre_m : (2,) or (3,) array_like, optional
        Where that extent is centred (m): the data's reference point. Default ``data``'s
        reference point.

    Returns
    -------
    StationaryExplanation
    """
    tr = as_traces(data, acquisition)
    geom = tr.geometry

    def speed_at(dy: float) -> tuple[float, NDArray[np.float64]]:
        p, v, _ = family_member(tr, position_m, velocity_mps, dy)
        return range_speed(v, geom), p

    u0 = range_speed(velocity_mps, geom)
    slope = speed_at(1.0)[0] - u0
    dy = -u0 / slope
    for _ in range(3):
        u, _ = speed_at(dy)
        dy -= u / slope
    _, member = speed_at(dy)
    best, stat = refine_location(tr, member, velocity_mps=None, step_m=0.05)
    cross = resolution(tr).cross_range_direction
    centre = tr.reference_point_m if extent_centre_m is None else np.asarray(extent_centre_m)
    reach = abs(float((best[:2] - np.asarray(centre, dtype=np.float64)[:2]) @ cross))
    gain = 20.0 * np.log10(max(abs(value), 1e-300) / max(abs(stat), 1e-300))
    return StationaryExplanation(
        position_m=best,
        cross_offset_m=float(dy),
        within_extent=reach <= (alias_free_extent_m(tr) if extent_m is None else extent_m),
        focus_gain_db=float(gain),
    )


def local_floor(
    grid_mps: ArrayLike,
    objective: ArrayLike,
    resolution_mps: float,
    *,
    guard: float = 2.0,
    outer: float = 12.0,
) -> NDArray[np.float64]:
    """The local floor of :func:`peak_statistics` at every grid speed (trace units).

    ``floor * 10**(threshold_db / 20)`` is the level a peak there must reach: the
    threshold curve of the report's ``g(u)`` panel.
    """
    u = np.asarray(grid_mps, dtype=np.float64)
    g = np.asarray(objective, dtype=np.float64)
    out = np.empty(u.size)
    for i in range(u.size):
        d = np.abs(u - u[i])
        out[i] = np.median(g[(d >= guard * resolution_mps) & (d <= outer * resolution_mps)])
    return out


@dataclass(frozen=True, kw_only=True, eq=False)
class RangeSpeedDetection:
    """``g(u)``, its candidates and the test applied to them (:func:`detect_range_speeds`).

    Attributes
    ----------
    range_speeds : RangeSpeeds
        ``g`` on its grid; ``speeds_mps``, ``peak_values`` and ``over_floor_db`` are the
        candidates that passed the statistic, speed and shape tests, by decreasing
        statistic; ``floor`` is the global median.
    statistics : PeakStatistics
        Every candidate of the curve.
    threshold_db : float
        Threshold on the statistic (dB).
    false_alarm_rate : float
        Per-scene false-alarm rate the threshold was set for (:func:`threshold_db`).
    min_speed_mps : float
        Candidates slower than this were not tested (stationary band), m/s.
    max_width : float
        Widest accepted peak (range-speed resolutions): the caller's factor times
        :func:`point_peak_width`.
    statistic_db : (k,) ndarray
        The statistic of the accepted candidates: each peak over its local floor (dB).
    widths : (k,) ndarray
        Half-height widths of the accepted candidates (resolutions).
    floor_curve : (n_grid,) ndarray
        :func:`local_floor` on the grid, for plotting.
    """

    range_speeds: RangeSpeeds
    statistics: PeakStatistics
    threshold_db: float
    false_alarm_rate: float
    min_speed_mps: float
    max_width: float
    statistic_db: NDArray[np.float64]
    widths: NDArray[np.float64]
    floor_curve: NDArray[np.float64]

    @property
    def n_candidates(self) -> int:
        """Number of local maxima of ``g`` (the ``N`` of the false-alarm rate)."""
        return int(self.statistics.speeds_mps.size)

    def false_alarm_probability(self, statistic_db: float) -> float:
        """Per-scene significance of a statistic (:func:`false_alarm_probability`)."""
        return false_alarm_probability(statistic_db, self.n_candidates)


def detect_range_speeds(
    traces: Traces,
    *,
    speed_range_mps: tuple[float, float] = (-30.0, 30.0),
    false_alarm_rate: float = 0.01,
    threshold: float | None = None,
    min_speed_mps: float = 0.0,
    max_width: float = 2.0,
) -> RangeSpeedDetection:
    """Candidate range speeds of movers: ``g(u)`` peaks that pass the statistical test.

    ``g`` on its coarse grid (:func:`sarmotion.motion.estimate_range_speeds`), the
    local-floor statistic of every local maximum (:func:`peak_statistics`), kept when it
    reaches the threshold of ``false_alarm_rate`` (or ``threshold``, dB), is at least
    ``min_speed_mps`` from zero, at least one resolution from a stronger kept one, and at
    most ``max_width`` times as wide as a point mover's peak (:func:`point_peak_width`).
    The focus test needs a fit of each candidate
    and is left to the caller (:func:`stationary_explanation`).

    Parameters
    ----------
    traces : Traces
        Moving traces of about a degree (stationary ones removed).
    speed_range_mps : (float, float)
        Range speeds searched (m/s).
    false_alarm_rate : float
        Per-scene false-alarm rate of the statistic, in (0, 1).
    threshold : float, optional
        Threshold on the statistic (dB), overriding the one of ``false_alarm_rate``.
    min_speed_mps : float
        Slowest candidate tested (m/s).
    max_width : float
        Widest candidate accepted, in widths of a point mover's peak.

    Returns
    -------
    RangeSpeedDetection
    """
    curve = estimate_range_speeds(
        traces, speed_range_mps=speed_range_mps, max_movers=0, threshold_db=-np.inf
    )
    res = range_speed_resolution(traces)
    stats = peak_statistics(curve.grid_mps, curve.objective, res)
    widest = float(max_width) * point_peak_width(traces)
    n = stats.speeds_mps.size
    thr = threshold_db(false_alarm_rate, n) if threshold is None else float(threshold)
    kept: list[int] = []
    for i in np.argsort(-stats.statistic_db, kind="stable"):
        u = stats.speeds_mps[i]
        if stats.statistic_db[i] < thr:
            break
        if abs(u) < min_speed_mps or stats.width_resolutions[i] > widest:
            continue
        if all(abs(u - stats.speeds_mps[j]) >= res for j in kept):
            kept.append(int(i))
    idx = np.asarray(kept, dtype=int)
    accepted = RangeSpeeds(
        speeds_mps=stats.speeds_mps[idx],
        peak_values=stats.values[idx],
        over_floor_db=_over_floor_db(stats.values[idx], curve.floor),
        floor=curve.floor,
        resolution_mps=res,
        grid_mps=curve.grid_mps,
        objective=curve.objective,
    )
    return RangeSpeedDetection(
        range_speeds=accepted,
        statistics=stats,
        threshold_db=thr,
        false_alarm_rate=float(false_alarm_rate),
        min_speed_mps=float(min_speed_mps),
        max_width=widest,
        statistic_db=stats.statistic_db[idx],
        widths=stats.width_resolutions[idx],
        floor_curve=local_floor(curve.grid_mps, curve.objective, res),
    )


def local_statistic(
    traces: Traces,
    speed_mps: float,
    *,
    step_mps: float | None = None,
    guard: float = 2.0,
    outer: float = 12.0,
) -> float:
    """The statistic of :func:`peak_statistics` at one speed, from ``g`` on its ring only.

    ``g`` is evaluated at ``speed_mps`` +- ``outer`` resolutions on the grid step of
    :func:`estimate_range_speeds` (half a resolution) and the value at the centre, the
    largest within half a step, is compared with the median of the ring. Used to test a
    candidate again once stronger movers have been subtracted (a shoulder of a strong
    mover's peak then falls to the floor; a second mover of nearby range speed stays).

    Returns
    -------
    float
        ``20 log10(g / floor)`` (dB).
    """
    res = range_speed_resolution(traces)
    step = 0.5 * res if step_mps is None else float(step_mps)
    k = int(np.ceil(outer * res / step))
    offsets = step * np.arange(-k, k + 1)
    centre = np.array([-0.5 * step, 0.0, 0.5 * step])
    g = range_speed_objective(traces, np.concatenate([speed_mps + offsets, speed_mps + centre]))
    ring = g[: offsets.size][(np.abs(offsets) >= guard * res) & (np.abs(offsets) <= outer * res)]
    return float(20.0 * np.log10(g[offsets.size :].max() / np.median(ring)))


def point_peak_width(traces: Traces, *, oversample: int = 16) -> float:
    """Half-height width of a noise-free point mover's ``g`` peak (range-speed resolutions).

    A range-speed error ``du`` shifts the aligned trace of pulse ``j`` by ``2 du s_j / c``
    in fast time, so ``g(u + du) / g(u) = mean_j |p(2 du s_j / c)| / |p(0)|`` with ``p``
    the compressed pulse; its width at half height between its peak and its far level.
    ``p`` is the inverse transform (oversampled) of the pulse spectrum *measured on the
    data*, ``sqrt(mean_s |P(s, f)|^2)``: the cross terms of targets at different ranges
    average out over slow time, and a file format that does not record the pulse shape
    (GOTCHA's) cannot mislead it. The mean is taken on ``|P|`` scaled by its largest
    value, so that data of any magnitude (1e-300 squares to zero) give the same shape;
    data with no signal at all (every sample zero) measure nothing, and the radar's
    nominal spectrum (:meth:`~sarmotion.core.radar.Radar.spectral_weights`) is used.
    """
    magnitude = np.abs(traces.phase_history())
    peak = float(magnitude.max()) if magnitude.size else 0.0
    if peak > 0.0 and np.isfinite(peak):
        w = np.sqrt(np.mean((magnitude / peak) ** 2, axis=0))
    else:
        w = np.asarray(traces.radar.spectral_weights(), dtype=np.float64)
    n = w.size
    pad = n * (oversample - 1)
    spectrum = np.pad(w, (pad // 2, pad - pad // 2))
    pulse = np.abs(np.fft.fftshift(np.fft.ifft(np.fft.ifftshift(spectrum))))
    pulse /= pulse.max()
    t = (np.arange(pulse.size) - pulse.size // 2) / (pulse.size * traces.radar.frequency_step_hz)
    res = range_speed_resolution(traces)
    s = traces.slow_times_s - traces.slow_times_s.mean()
    du = np.linspace(-10.0 * res, 10.0 * res, 801)
    g = np.interp(2.0 * du[:, None] * s[None, :] / C, t, pulse).mean(axis=1)
    above = du[g >= 0.5 * (g.max() + g.min())]
    return float((above.max() - above.min()) / res)
