"""The exact point response of the data at a point, and point locations refined on it.

The annihilation filters and the combined separation need the locations ``rho^e`` of
the stationary targets, read from a preliminary image (paper ``sect:ANNIH``, peaks from
:func:`sarmotion.imaging.find_peaks`). A location is refined by maximising the modulus
of the exact point response

    I(rho) = (1/K) sum_j sum_k P(s_j, f_k) exp(2i pi f_k dtau(s_j, rho + s_j u)),

the backprojection (``eq:image``, ``eq:imagecompu``) evaluated without interpolation
from the phase history ``P``: equivalently ``n`` times the slow-time mean, at ``t = 0``,
of the traces transformed by ``T_+^{u,rho}``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize

from ..core import Traces, as_point, delta_tau, target_positions
from ..core.spectral import FrequencyPlanes, phased_row_sums

__all__ = ["point_response", "pulse_responses", "refine_location"]


def point_response(
    traces: Traces,
    points_m: ArrayLike,
    *,
    velocity_mps: ArrayLike | None = None,
    phase_history: ArrayLike | None = None,
) -> NDArray[np.complex128]:
    """Exact backprojection value at a few points (no interpolation).

    Parameters
    ----------
    traces : Traces
        Data and acquisition.
    points_m : (3,) or (k, 2|3) array_like
        Points (m) at ``s = 0``.
    velocity_mps : (2,) array_like, optional
        Compensated ground velocity (m/s).
    phase_history : (n_pulses, n_samples) array_like or FrequencyPlanes, optional
        ``traces.phase_history()`` if already computed (saves a transform), or its
        :class:`~sarmotion.core.spectral.FrequencyPlanes` (3x faster sums, for searches).

    Returns
    -------
    (k,) ndarray
        ``I(rho)`` for each point (complex, units of the data times ``n_pulses``).
    """
    P = _phase_history(traces, phase_history)
    pts = np.atleast_2d(np.asarray(points_m, dtype=np.float64))
    out = np.empty(len(pts), dtype=np.complex128)
    for i, p in enumerate(pts):
        rho = as_point(p, name="points_m")
        out[i] = pulse_responses(traces, rho, velocity_mps, phase_history=P).sum()
    return out


def pulse_responses(
    traces: Traces,
    position_m: ArrayLike,
    velocity_mps: ArrayLike | None = None,
    *,
    phase_history: ArrayLike | None = None,
    pulses: slice = slice(None),
) -> NDArray[np.complex128]:
    """Each pulse's term of :func:`point_response` at one point.

    Sums over blocks of pulses are the responses of sub-apertures.

    Parameters
    ----------
    traces : Traces
        Data and acquisition.
    position_m : (2,) or (3,) array_like
        Point (m) at ``s = 0``.
    velocity_mps : (2,) array_like, optional
        Compensated ground velocity (m/s).
    phase_history : (n_pulses, n_samples) array_like or FrequencyPlanes, optional
        ``traces.phase_history()`` if already computed, or its
        :class:`~sarmotion.core.spectral.FrequencyPlanes`.
    pulses : slice
        Only these pulses (slow time, and so ``position_m``, still the whole aperture's).

    Returns
    -------
    (k,) ndarray
        ``(1 / n_samples) sum_f P(s, f) exp(2i pi f delta_tau(s, rho(s)))`` for the
        ``k`` selected pulses, data units. The sums over ``f`` run compiled, the phasors
        advancing by a fixed rotation along the (uniform) frequency axis
        (:func:`sarmotion.core.spectral.phased_row_sums`; 7x faster than forming
        :func:`sarmotion.core.spectral.delay_phase`, same values to ~1e-13).
    """
    P = _phase_history(traces, phase_history)
    rho = as_point(position_m, name="position_m")
    s = traces.slow_times_s[pulses]
    where = rho if velocity_mps is None else target_positions(rho, velocity_mps, s)
    d = np.ascontiguousarray(
        delta_tau(traces.positions_m[pulses], where, traces.reference_point_m), dtype=np.float64
    )
    f0 = float(traces.frequencies_hz[0])
    step = float(traces.radar.frequency_step_hz)
    if isinstance(P, FrequencyPlanes):
        sums = P.sums(d, f0, step, rows=pulses)
    else:
        rows = np.ascontiguousarray(P[pulses], dtype=np.complex128)
        sums = phased_row_sums(rows, d, f0, step)
    return sums / traces.n_samples


def _phase_history(
    traces: Traces, phase_history: ArrayLike | FrequencyPlanes | None
) -> NDArray[np.complexfloating] | FrequencyPlanes:
    """``phase_history`` as given (array or planes), or the traces' own."""
    if phase_history is None:
        return traces.phase_history()
    if isinstance(phase_history, FrequencyPlanes):
        if phase_history.shape != traces.shape:
            raise ValueError(
                f"phase_history must have the traces' shape {traces.shape}, "
                f"got planes of {phase_history.shape}"
            )
        return phase_history
    return np.asarray(phase_history)


def refine_location(
    traces: Traces,
    point_m: ArrayLike,
    *,
    velocity_mps: ArrayLike | None = None,
    phase_history: ArrayLike | None = None,
    step_m: tuple[float, float] = (0.2, 0.5),
    tol_m: float = 1e-3,
    max_iter: int = 200,
) -> tuple[NDArray[np.float64], complex]:
    """Refine a location by maximising ``|I(rho)|`` (Nelder-Mead from ``point_m``).

    Parameters
    ----------
    traces : Traces
        Data and acquisition.
    point_m : (2,) or (3,) array_like
        Starting location (m), e.g. a pixel peak.
    velocity_mps : (2,) array_like, optional
        Compensated ground velocity (m/s).
    phase_history : array_like, optional
        Precomputed ``traces.phase_history()``.
    step_m : (float, float)
        Initial simplex steps in x and y (m), about half a resolution cell.
    tol_m : float
        Location tolerance (m).
    max_iter : int
        Iteration cap.

    Returns
    -------
    position : (3,) ndarray
        Refined location (m).
    value : complex
        ``I`` at that location.
    """
    P = _phase_history(traces, phase_history)
    if not isinstance(P, FrequencyPlanes):
        P = FrequencyPlanes(P)  # many sums of the same rows: frequency-major, 3x faster
    p0 = as_point(point_m, name="point_m")

    def cost(q: NDArray[np.float64]) -> float:
        pt = np.array([q[0], q[1], p0[2]])
        return -float(
            np.abs(point_response(traces, pt, velocity_mps=velocity_mps, phase_history=P)[0])
        )

    simplex = np.array([p0[:2], p0[:2] + [step_m[0], 0.0], p0[:2] + [0.0, step_m[1]]])
    start = cost(p0[:2])
    res = minimize(
        cost,
        p0[:2],
        method="Nelder-Mead",
        options={
            "xatol": tol_m,
            "fatol": 1e-9 * abs(start),
            "maxiter": max_iter,
            "initial_simplex": simplex,
        },
    )
    best = np.array([res.x[0], res.x[1], p0[2]]) if res.fun <= start else p0
    value = point_response(traces, best, velocity_mps=velocity_mps, phase_history=P)[0]
    return best, complex(value)
