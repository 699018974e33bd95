"""Separation by the paper's combination (``sect:sepdisc``) for scenes of point-like targets.

The preliminary image is windowed around each stationary target found in it; the
subscene's traces are brought to that target's frame by ``T_+^{rho}`` (``eq:TT+``),
where they no longer depend on slow time; the subscene is the fast-time window of the
aligned traces that holds the target's pulse, and its low-rank (slow-time constant)
part is taken out and mapped back by ``T_-^{rho}``. Details in :func:`separate_combined`.
"""

from __future__ import annotations

import logging
import time
from typing import Any

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import Acquisition, ProgressCallback, Traces, delay_phase, to_fast_time, to_frequency
from ..core.progress import report
from ..imaging import refine_location
from .candidates import doppler_contrast_db, stationary_candidates
from .result import Separation
from .transforms import travel_time_delays

log = logging.getLogger(__name__)

__all__ = [
    "separate_combined",
    "aligned_constant_part",
    "default_half_window",
    "DOPPLER_CONTRAST_DB",
    "stationary_location",
]

#: Doppler contrast (dB) a stationary candidate must reach (:func:`separate_combined`).
DOPPLER_CONTRAST_DB = 10.0


def default_half_window(traces: Acquisition | Traces) -> int:
    """Three compressed-pulse lengths ``3 / (B dt)`` in fast-time samples (at least 1)."""
    pulse_samples = 1.0 / (traces.radar.bandwidth_hz * traces.radar.sample_interval_s)
    return max(1, int(np.ceil(3.0 * pulse_samples)))


def aligned_constant_part(
    spectrum: ArrayLike,
    point_m: ArrayLike,
    *,
    acquisition: Acquisition,
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
    spectrum : (n_pulses, n_samples) array_like
        Phase history of the data the part is taken from (``to_frequency(data)``).
    point_m : (2,) or (3,) array_like
        ``rho`` at ``s = 0`` (m).
    acquisition : Acquisition
        The acquisition of ``spectrum`` (geometry, frequencies, reference point).
    velocity_mps : (2,) array_like, optional
        ``u`` (m/s); ``None`` for a stationary point.
    half_window : int, optional
        Half-width of the window (samples); default :func:`default_half_window`.

    Returns
    -------
    (n_pulses, n_samples) ndarray
        Phase history of the part (subtract it from ``spectrum`` to remove the target).
    """
    row, phase = _constant_row(spectrum, point_m, acquisition, velocity_mps, half_window)
    return row[None, :] * np.conj(phase)


def _constant_row(
    spectrum: ArrayLike,
    point_m: ArrayLike,
    acquisition: Acquisition,
    velocity_mps: ArrayLike | None,
    half_window: int | None,
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """``(row, phase)``: :func:`aligned_constant_part` is ``row[None, :] * conj(phase)``.

    ``row`` (n_samples,) is the spectrum of the window's slow-time mean of the aligned
    traces, the same for every pulse; ``phase`` (n_pulses, n_samples) is ``T_+``'s.
    The slow-time mean of the aligned traces is the transform of the mean aligned
    spectrum (the transform is linear), and the windowed mean is one trace: one
    transform of length n_samples each way instead of two of the whole array (the
    same values to rounding, ~1e-16 of the traces' moduli).
    """
    traces = acquisition.acquisition if isinstance(acquisition, Traces) else acquisition
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
    mean = _phased_column_mean(np.ascontiguousarray(P, dtype=np.complex128), phase)
    c = m // 2
    low = np.zeros(m, dtype=np.complex128)
    low[c - h : c + h + 1] = to_fast_time(mean)[c - h : c + h + 1]
    return to_frequency(low), phase


@numba.njit(nogil=True, cache=True)
def _phased_column_mean(values, phase):  # pragma: no cover - compiled
    """``mean_j values[j, k] phase[j, k]`` for each column ``k``, shape (n_samples,)."""
    n, m = values.shape
    acc = np.zeros(m, dtype=np.complex128)
    for j in range(n):
        for k in range(m):
            acc[k] += values[j, k] * phase[j, k]
    return acc / n


@numba.njit(nogil=True, cache=True)
def _subtract_unaligned(spectrum, row, phase):  # pragma: no cover - compiled
    """``spectrum -= row[None, :] * conj(phase)`` in place (one pass, no temporaries)."""
    n, m = spectrum.shape
    for j in range(n):
        for k in range(m):
            spectrum[j, k] -= row[k] * np.conj(phase[j, k])


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
    contrast_db: float = DOPPLER_CONTRAST_DB,
    refine: bool = True,
    progress: ProgressCallback | None = None,
) -> Separation:
    """Image-guided separation in travel-time-aligned frames (``sect:sepdisc``).

    For every candidate stationary location ``rho`` (bright points of the preliminary
    image, brightest first):

    1. refine ``rho`` by maximising the exact point response ``|I(rho)|`` on the current
       residual (:func:`sarmotion.imaging.point_response.refine_location`);
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
    progress : callable, optional
        ``progress("combined separation", done, total)``.

    Returns
    -------
    Separation
        ``moving`` (S), ``stationary`` (L), the locations used and per-candidate details.
    """
    t0 = time.perf_counter()
    cand = _candidates(traces, points_m, image_values, x_m, y_m, threshold_db, max_targets)
    if passes < 1:
        raise ValueError(f"passes must be >= 1, got {passes}")
    if half_window is None:
        half_window = default_half_window(traces)
    if not 0 < half_window < traces.n_samples // 2:
        raise ValueError(
            f"half_window must be in [1, {traces.n_samples // 2 - 1}] samples, got {half_window}"
        )

    # residual, kept in the frequency domain (its own array: updated in place)
    spectrum = np.ascontiguousarray(to_frequency(traces.data), dtype=np.complex128)
    used: list[NDArray[np.float64]] = []
    records: list[dict[str, Any]] = []
    locations = [c.copy() for c in cand]
    total = passes * len(cand)
    for sweep in range(passes):
        for i, p0 in enumerate(locations):
            p, contrast, accepted = _test_location(
                traces, spectrum, p0, contrast_db=contrast_db, refine=refine and sweep == 0
            )
            if accepted:  # spectrum - aligned_constant_part(...), in place
                row, phase = _constant_row(spectrum, p, traces.acquisition, None, half_window)
                _subtract_unaligned(spectrum, row, phase)
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
            report(progress, "combined separation", len(records), total)
    # nothing accepted: the data are all moving, exactly (not through a transform pair)
    moving = to_fast_time(spectrum) if used else np.array(traces.data, copy=True)
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


def _candidates(
    traces: Traces,
    points_m: ArrayLike | None,
    image_values: ArrayLike | None,
    x_m: ArrayLike | None,
    y_m: ArrayLike | None,
    threshold_db: float,
    max_targets: int,
) -> NDArray[np.float64]:
    """Candidate stationary locations ``(k, 3)`` (m): given, or read from the image."""
    if points_m is not None:
        cand = np.atleast_2d(np.asarray(points_m, dtype=np.float64))
        if cand.size and cand.shape[1] == 2:
            cand = np.column_stack([cand, np.zeros(len(cand))])
        return cand
    if image_values is None or x_m is None or y_m is None:
        raise ValueError("give points_m, or image_values with x_m and y_m")
    return stationary_candidates(
        image_values,
        x_m=x_m,
        y_m=y_m,
        traces=traces,
        threshold_db=threshold_db,
        max_targets=max_targets,
    )


def stationary_location(
    traces: Traces, point_m: NDArray[np.float64], *, phase_history: ArrayLike | None = None
) -> NDArray[np.float64] | None:
    """A candidate refined on the point response if it passes the Doppler test, else ``None``.

    As :func:`separate_combined` takes its stationary points: the Doppler contrast
    (:func:`~sarmotion.separation.doppler_contrast_db`) must reach
    ``DOPPLER_CONTRAST_DB`` before and after the refinement (m).
    """
    spectrum = traces.phase_history() if phase_history is None else np.asarray(phase_history)
    p, _, accepted = _test_location(
        traces,
        spectrum,
        np.asarray(point_m, dtype=np.float64),
        contrast_db=DOPPLER_CONTRAST_DB,
        refine=True,
    )
    return p if accepted else None


def _test_location(
    traces: Traces,
    spectrum: NDArray[np.complexfloating],
    p0: NDArray[np.float64],
    *,
    contrast_db: float,
    refine: bool,
) -> tuple[NDArray[np.float64], float, bool]:
    """Doppler-test (and refine) one candidate: ``(location, contrast_db, accepted)``.

    The contrast barely depends on a sub-pixel offset (the whole column shifts alike), so
    movers' streaks are rejected before the costlier refinement.
    """
    contrast = doppler_contrast_db(traces, p0, phase_history=spectrum)
    p = p0
    accepted = contrast >= contrast_db
    if accepted and refine:
        p, _ = refine_location(traces, p0, phase_history=spectrum)
        contrast = doppler_contrast_db(traces, p, phase_history=spectrum)
        accepted = contrast >= contrast_db
    return p, contrast, accepted
