"""Separating the traces of stationary and moving targets (paper ``sect:algdesc``).

Three methods, all on :class:`~sarmotion.traces.Traces`:

``annihilation``
    The composed travel-time annihilation filter ``Q = Q^{rho_N} ... Q^{rho_1}``
    (``eq:OP1``, ``eq:OP2``) at stationary locations read from a preliminary image (or
    given). Linear; ``S = Q M`` is in units of ``M`` per pulse^N (differences).
``rpca``
    Principal component pursuit on the trace matrix, whole or in fast-time windows
    (``eq:OPTIMIZATION``, ``sect:RPCA``): ``M = L + S``.
``combined``
    The combination proposed at the end of ``sect:sepdisc`` for extended scenes: the
    preliminary image is windowed around each stationary target found in it; the
    subscene's traces are brought to that target's frame by ``T_+^{rho}`` (``eq:TT+``),
    where they no longer depend on slow time; the subscene is the fast-time window of
    the aligned traces that holds the target's pulse, and its low-rank part is taken out
    and mapped back by ``T_-^{rho}``. Details in :func:`separate_combined`.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .detection import detect_peaks, refine_location
from .imaging import resolution
from .scene import PointTarget
from .spectral import delay_phase, to_fast_time, to_frequency
from .traces import Traces
from .transforms import Annihilator, annihilate, travel_time_delays

__all__ = [
    "Separation",
    "separate_annihilation",
    "separate_rpca",
    "separate_combined",
    "separation_quality",
    "stationary_candidates",
    "mover_trace_coverage",
    "doppler_contrast_db",
    "aligned_constant_part",
    "default_half_window",
]

log = logging.getLogger(__name__)

Progress = Callable[[int, int], None]


@dataclass(frozen=True, kw_only=True, eq=False)
class Separation:
    """Result of a separation.

    Attributes
    ----------
    moving : (n_pulses, n_samples) ndarray
        ``S``: the traces attributed to moving targets.
    stationary : (n_pulses, n_samples) ndarray or None
        ``L``: the traces attributed to stationary targets (None for the annihilation
        filter, whose output is a filtered version of the data, not a split of it).
    method : str
        ``"annihilation"``, ``"rpca"`` or ``"combined"``.
    stationary_points_m : (k, 3) ndarray
        Stationary locations used (annihilation, combined), m.
    info : dict
        Method details (iterations, windows, timings in s).
    """

    moving: NDArray[np.complexfloating]
    stationary: NDArray[np.complexfloating] | None
    method: str
    stationary_points_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    info: dict[str, Any] = field(default_factory=dict)


# ----------------------------------------------------------------- candidates
def stationary_candidates(
    image_values: ArrayLike,
    *,
    x_m: ArrayLike,
    y_m: ArrayLike,
    traces: Traces,
    threshold_db: float = -25.0,
    max_targets: int = 100,
    separation_cells: float = 0.5,
) -> NDArray[np.float64]:
    """Bright points of a preliminary image, resolution-aware (brightest first), m.

    The non-maximum-suppression radius is ``separation_cells`` times the larger of the
    ground-range and cross-range resolutions of ``traces`` (see
    :func:`sarmotion.imaging.resolution`).
    """
    res = resolution(traces)
    radius = separation_cells * max(res.ground_range_m, res.cross_range_m)
    return detect_peaks(
        image_values,
        x_m=x_m,
        y_m=y_m,
        threshold_db=threshold_db,
        min_separation_m=radius,
        max_peaks=max_targets,
    )


def doppler_contrast_db(
    traces: Traces, point_m: ArrayLike, *, phase_history: ArrayLike | None = None
) -> float:
    """Zero-Doppler over median Doppler power (dB) of the column ``t = 0`` after ``T_+^{rho}``.

    A stationary target at ``rho`` is a zero-Doppler peak of that column (tens of dB);
    the streak of a mover is a short burst with a flat Doppler spectrum (~0 dB).
    """
    P = traces.phase_history() if phase_history is None else np.asarray(phase_history)
    f = traces.frequencies_hz
    column = np.sum(P * delay_phase(travel_time_delays(traces, point_m), f), axis=1)
    column /= traces.n_samples
    doppler = np.abs(np.fft.fft(column)) ** 2
    floor = float(np.median(doppler))
    if floor <= 0:
        return float("inf")
    return float(10 * np.log10(max(doppler[0], np.finfo(float).tiny) / floor))


# --------------------------------------------------------------- annihilation
def separate_annihilation(
    traces: Traces,
    points_m: ArrayLike,
    *,
    kind: Annihilator = "difference",
    contrast_db: float | None = 10.0,
) -> Separation:
    """Composed annihilation filter ``Q`` (``eq:OP2``) at the given stationary locations.

    Candidates whose Doppler contrast (:func:`doppler_contrast_db`) is below
    ``contrast_db`` are taken for movers' streaks and get no filter (``None`` keeps all).

    Parameters
    ----------
    traces : Traces
        Data ``M``.
    points_m : (k, 2|3) array_like
        Estimated stationary locations ``rho_j^e`` (m), e.g. from
        :func:`stationary_candidates`.
    kind : {"difference", "difference2", "savgol", "mean"}
        Slow-time annihilator (see :func:`sarmotion.transforms.slow_time_difference`).

    Returns
    -------
    Separation
        ``moving = Q M``; ``stationary`` is None.
    """
    pts = np.atleast_2d(np.asarray(points_m, dtype=np.float64))
    if pts.size and pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    t0 = time.perf_counter()
    n_candidates = len(pts)
    if contrast_db is not None and pts.size:
        P = traces.phase_history()
        keep = [doppler_contrast_db(traces, p, phase_history=P) >= contrast_db for p in pts]
        pts = pts[np.array(keep, dtype=bool)]
    if pts.size == 0:
        out = traces.data.copy()
    else:
        out = annihilate(traces, pts, kind=kind).data
    info = {
        "kind": kind,
        "n_candidates": int(n_candidates),
        "n_filters": int(len(pts)),
        "seconds": time.perf_counter() - t0,
    }
    pts = pts.reshape(-1, 3)
    return Separation(
        moving=out, stationary=None, method="annihilation", stationary_points_m=pts, info=info
    )


# ----------------------------------------------------------------------- rpca
def separate_rpca(
    traces: Traces,
    *,
    window: int | None = None,
    overlap: float = 0.5,
    eta: float | None = None,
    eta_scale: float = 1.0,
    tol: float = 1e-6,
    max_iter: int = 500,
    callback: Progress | None = None,
) -> Separation:
    """Robust-PCA separation ``M = L + S``, whole-matrix or windowed in fast time.

    Parameters
    ----------
    traces : Traces
        Data ``M`` (n_pulses, n_samples).
    window : int, optional
        Fast-time window (samples); ``None`` chooses it from the data
        (:func:`sarmotion.rpca.choose_window`); ``>= n_samples`` is whole-matrix RPCA.
    overlap : float
        Fractional overlap of consecutive windows, in ``[0, 1)``.
    eta : float, optional
        Sparsity weight; default ``1/sqrt(max(n_pulses, window))`` per window (the
        paper's choice).
    eta_scale : float
        Factor on the default ``eta`` (ignored when ``eta`` is given). Real clutter is
        distributed, far from low rank (a 1-degree GOTCHA file needs rank ~26 of 64 for
        90 % of a window's energy), and a larger weight on ``||S||_1`` keeps it out of
        ``S``: on a GOTCHA file with two injected movers, ``eta_scale=2`` leaves 14 dB
        less clutter in ``S`` than ``1`` (5 dB) while keeping both movers' traces.
    tol, max_iter
        Stopping rule of the solver (relative residual) and iteration cap.
    callback : callable, optional
        ``callback(done, total)`` after each window (progress).
    """
    from .rpca import windowed_rpca

    t0 = time.perf_counter()
    if not eta_scale > 0:
        raise ValueError(f"eta_scale must be positive, got {eta_scale!r}")
    if eta is None and eta_scale != 1.0:
        from .rpca import choose_window, default_eta

        w = window if window is not None else choose_window(traces.data)
        eta = eta_scale * default_eta((traces.n_pulses, min(int(w), traces.n_samples)))
    res = windowed_rpca(
        traces.data,
        window=window,
        overlap=overlap,
        eta=eta,
        tol=tol,
        max_iter=max_iter,
        callback=callback,
    )
    info = {
        "windows": [list(w) for w in res.windows],
        "n_iter": int(res.n_iter),
        "converged": bool(res.converged),
        "rank": int(res.rank),
        "seconds": time.perf_counter() - t0,
    }
    return Separation(moving=res.sparse, stationary=res.low_rank, method="rpca", info=info)


def default_half_window(traces: Traces) -> int:
    """Three compressed-pulse lengths ``3 / (B dt)`` in fast-time samples (at least 1)."""
    pulse_samples = 1.0 / (traces.radar.bandwidth_hz * traces.radar.sample_interval_s)
    return max(1, int(np.ceil(3.0 * pulse_samples)))


def aligned_constant_part(
    traces: Traces,
    spectrum: ArrayLike,
    point_m: ArrayLike,
    *,
    velocity_mps: ArrayLike | None = None,
    half_window: int | None = None,
) -> NDArray[np.complex128]:
    """The part of the traces that ``T_+^{u,rho}`` makes constant in slow time near ``t = 0``.

    After ``T_+^{u,rho}`` (``eq:TT+``, ``eq:TTu+``) the trace of a target on
    ``rho + s u`` sits at ``t = 0`` with a phase independent of ``s``: in that frame it is
    rank one and constant in slow time, while other targets' traces cross the window
    obliquely or rotate in phase. Its estimate is the slow-time mean of the aligned
    traces in the fast-time window ``|t| <= half_window`` (the orthogonal projection on
    ``s``-independent traces there), mapped back by ``T_-^{u,rho}``.

    Parameters
    ----------
    traces : Traces
        The acquisition (geometry, frequencies, reference point).
    spectrum : (n_pulses, n_samples) array_like
        Phase history of the data the part is taken from (``to_frequency(data)``).
    point_m : (2,) or (3,) array_like
        ``rho`` at ``s = 0`` (m).
    velocity_mps : (2,) array_like, optional
        ``u`` (m/s); ``None`` for a stationary point.
    half_window : int, optional
        Half-width of the window (samples); default :func:`default_half_window`.

    Returns
    -------
    (n_pulses, n_samples) ndarray
        Phase history of the part (subtract it from ``spectrum`` to remove the target).
    """
    P = np.asarray(spectrum)
    if P.shape != traces.shape:
        raise ValueError(f"spectrum must have the traces' shape {traces.shape}, got {P.shape}")
    m = traces.n_samples
    h = default_half_window(traces) if half_window is None else int(half_window)
    if not 0 < h < m // 2:
        raise ValueError(f"half_window must be in [1, {m // 2 - 1}] samples, got {h}")
    phase = delay_phase(
        travel_time_delays(traces, point_m, velocity_mps=velocity_mps), traces.frequencies_hz
    )
    aligned = to_fast_time(P * phase)
    c = m // 2
    low = np.zeros_like(aligned)
    low[:, c - h : c + h + 1] = aligned[:, c - h : c + h + 1].mean(axis=0, keepdims=True)
    return to_frequency(low) * np.conj(phase)


# ------------------------------------------------------------------- combined
def separate_combined(
    traces: Traces,
    *,
    points_m: ArrayLike | None = None,
    image_values: ArrayLike | None = None,
    x_m: ArrayLike | None = None,
    y_m: ArrayLike | None = None,
    threshold_db: float = -25.0,
    max_targets: int = 200,
    half_window: int | None = None,
    passes: int = 2,
    contrast_db: float = 10.0,
    refine: bool = True,
    callback: Progress | None = None,
) -> Separation:
    """Image-guided separation in travel-time-aligned frames (``sect:sepdisc``).

    For every candidate stationary location ``rho`` (bright points of the preliminary
    image, brightest first):

    1. refine ``rho`` by maximising the exact point response ``|I(rho)|`` on the current
       residual (:func:`sarmotion.detection.refine_location`);
    2. transform the residual by ``T_+^{rho}`` (``eq:TT+``): the target's trace becomes
       independent of ``s`` and sits at ``t = 0``;
    3. take the subscene, the fast-time window ``|t| <= half_window`` samples of the
       aligned traces (the windowed image of a resolution cell around ``rho``);
    4. test it: in the Doppler spectrum (DFT over ``s``) of the aligned column at
       ``t = 0`` a stationary target at ``rho`` is a peak at zero Doppler (other stationary
       targets in the same range cell are peaks elsewhere), while the streak of a mover,
       whose aligned trace still crosses ``t = 0`` within a few pulses, is a short burst
       with a flat spectrum. The *Doppler contrast*, zero-Doppler power over the median
       power, must reach ``contrast_db``, else the candidate is skipped;
    5. take the subscene's low-rank part: for a single aligned target it is rank one and
       constant in ``s``, i.e. the slow-time mean of each column (the orthogonal
       projection on ``s``-independent traces, the ``"mean"`` annihilator restricted to
       the window);
    6. map it back by ``T_-^{rho}`` and subtract it from the residual.

    ``passes`` sweeps over the candidates remove what the first sweep left of targets
    closer than a resolution cell (each sweep on the updated residual). ``S`` is the final
    residual and ``L = M - S``.

    Parameters
    ----------
    traces : Traces
        Data ``M``.
    points_m : (k, 2|3) array_like, optional
        Candidate stationary locations (m); else detected in ``image_values``.
    image_values : (ny, nx) array_like, optional
        Preliminary image, with its axes ``x_m`` (nx,) and ``y_m`` (ny,) in m.
    threshold_db, max_targets
        Detection threshold (dB re the brightest pixel) and cap.
    half_window : int, optional
        Subscene half-width in fast-time samples; default three compressed-pulse
        lengths ``3 / (B dt)``.
    passes : int
        Number of sweeps over the candidates.
    contrast_db : float
        Doppler contrast (dB) below which a candidate is taken for a mover and skipped.
    refine : bool
        Refine each location by maximising the point response.
    callback : callable, optional
        ``callback(done, total)`` progress.

    Returns
    -------
    Separation
        ``moving`` (S), ``stationary`` (L), the locations used and per-candidate details.
    """
    t0 = time.perf_counter()
    if points_m is None:
        if image_values is None or x_m is None or y_m is None:
            raise ValueError("give points_m, or image_values with x_m and y_m")
        cand = stationary_candidates(
            image_values,
            x_m=x_m,
            y_m=y_m,
            traces=traces,
            threshold_db=threshold_db,
            max_targets=max_targets,
        )
    else:
        cand = np.atleast_2d(np.asarray(points_m, dtype=np.float64))
        if cand.size and cand.shape[1] == 2:
            cand = np.column_stack([cand, np.zeros(len(cand))])
    if passes < 1:
        raise ValueError(f"passes must be >= 1, got {passes}")
    if half_window is None:
        half_window = default_half_window(traces)
    if not 0 < half_window < traces.n_samples // 2:
        raise ValueError(
            f"half_window must be in [1, {traces.n_samples // 2 - 1}] samples, got {half_window}"
        )

    spectrum = to_frequency(traces.data)  # residual, kept in the frequency domain
    used: list[NDArray[np.float64]] = []
    records: list[dict[str, Any]] = []
    locations = [c.copy() for c in cand]
    total = passes * len(cand)
    done = 0
    for sweep in range(passes):
        for i, p0 in enumerate(locations):
            # The contrast barely depends on a sub-pixel offset (the whole column shifts
            # alike), so movers' streaks are rejected before the costlier refinement.
            contrast = doppler_contrast_db(traces, p0, phase_history=spectrum)
            p = p0
            accepted = contrast >= contrast_db
            if accepted and refine and sweep == 0:
                p, _ = refine_location(traces, p0, phase_history=spectrum)
                contrast = doppler_contrast_db(traces, p, phase_history=spectrum)
                accepted = contrast >= contrast_db
            if accepted:
                spectrum = spectrum - aligned_constant_part(
                    traces, spectrum, p, half_window=half_window
                )
                locations[i] = p
                if sweep == 0:
                    used.append(p)
            records.append(
                {
                    "sweep": sweep,
                    "position_m": p.tolist(),
                    "doppler_contrast_db": contrast,
                    "accepted": accepted,
                }
            )
            done += 1
            if callback is not None:
                callback(done, total)
    moving = to_fast_time(spectrum)
    info = {
        "candidates": records,
        "half_window": int(half_window),
        "passes": int(passes),
        "contrast_db": float(contrast_db),
        "seconds": time.perf_counter() - t0,
    }
    pts = np.array(used) if used else np.zeros((0, 3))
    log.info("combined separation: %d of %d candidates accepted", len(used), len(cand))
    return Separation(
        moving=moving,
        stationary=traces.data - moving,
        method="combined",
        stationary_points_m=pts,
        info=info,
    )


# -------------------------------------------------------------------- quality
def separation_quality(
    separation: Separation,
    *,
    true_stationary: ArrayLike,
    true_moving: ArrayLike,
    operator: Callable[[NDArray], NDArray] | None = None,
) -> dict[str, float]:
    """Quality of a separation against the simulator's ground truth.

    For a split ``M = L + S`` (rpca, combined):

    - ``relative_error_moving`` = ``||S - S_true|| / ||S_true||``;
    - ``relative_error_stationary`` = ``||L - L_true|| / ||L_true||``;
    - ``mover_retained`` = ``Re<S, S_true> / ||S_true||^2``, the fraction of the movers'
      traces kept in ``S`` (projection coefficient);
    - ``stationary_leak_db`` = ``10 log10(||S - S_true||^2 / ||L_true||^2)``: what of
      ``S`` is not the movers, relative to the stationary energy in ``M``;
    - ``signal_to_clutter_db`` = ``10 log10(||S_true||^2 / ||S - S_true||^2)``.

    For a linear filter (annihilation) pass ``operator`` (the filter as a function of a
    trace matrix): its output is not in the units of ``M``, so the two parts are filtered
    separately and only ``signal_to_clutter_db = 10 log10(||Q S_true||^2 / ||Q L_true||^2)``
    is returned (see :func:`mover_trace_coverage` for how much of the movers' traces the
    filter keeps).
    """
    Lt = np.asarray(true_stationary)
    St = np.asarray(true_moving)
    nL2 = float(np.vdot(Lt, Lt).real)
    nS2 = float(np.vdot(St, St).real)
    tiny = np.finfo(float).tiny
    if operator is not None:
        qL = operator(Lt)
        qS = operator(St)
        eL = float(np.vdot(qL, qL).real)
        eS = float(np.vdot(qS, qS).real)
        return {"signal_to_clutter_db": 10 * np.log10(eS / max(eL, tiny))}
    S = separation.moving
    err = S - St
    e2 = float(np.vdot(err, err).real)
    out = {
        "relative_error_moving": float(np.sqrt(e2 / nS2)),
        "mover_retained": float(np.vdot(St, S).real / nS2),
        "stationary_leak_db": 10 * np.log10(max(e2, tiny) / nL2),
        "signal_to_clutter_db": 10 * np.log10(nS2 / max(e2, tiny)),
    }
    if separation.stationary is not None:
        eL = separation.stationary - Lt
        out["relative_error_stationary"] = float(np.sqrt(np.vdot(eL, eL).real / nL2))
    return out


def mover_trace_coverage(
    moving: ArrayLike,
    traces: Traces,
    movers: Sequence[PointTarget],
    *,
    half_width: int = 3,
    drop_db: float = 6.0,
) -> float:
    """Fraction of each mover's trace that a separation keeps, in any units.

    For every pulse ``s_j`` and mover ``q``, the energy of ``moving`` within
    ``half_width`` samples of the mover's delay ``dtau_q(s_j)`` is compared with its median
    along that mover's trace; the coverage is the fraction of (pulse, mover) pairs where it
    is at most ``drop_db`` below that median. It measures what the paper describes as a
    filter that "removes some parts of the traces from the moving targets": a separation
    that keeps the whole trace scores 1, whatever its scaling.

    Parameters
    ----------
    moving : (n_pulses, n_samples) array_like
        Separated moving traces ``S`` (or a filtered output such as ``Q M``).
    traces : Traces
        Acquisition of the data.
    movers : sequence of PointTarget
        The true movers (positions at ``s = 0`` in m, velocities in m/s).
    half_width : int
        Half-width of the band around the trace (samples).
    drop_db : float
        Allowed drop below the median (dB).
    """
    from .transforms import travel_time_delays

    s = np.asarray(moving)
    n, m = s.shape
    kept = []
    for mover in movers:
        d = travel_time_delays(traces, mover.position_m, velocity_mps=mover.velocity_mps)
        idx = np.round(d / traces.radar.sample_interval_s).astype(int) + m // 2
        energy = np.array(
            [
                np.sum(np.abs(s[j, max(i - half_width, 0) : max(i + half_width + 1, 0)]) ** 2)
                for j, i in enumerate(idx)
            ]
        )
        inside = (idx >= 0) & (idx < m)
        med = np.median(energy[inside])
        kept.append(energy[inside] >= med * 10.0 ** (-drop_db / 10.0))
    return float(np.mean(np.concatenate(kept))) if kept else 1.0
