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

from ..core import Traces, as_point, delta_tau, target_positions, travel_time
from ..core.ascent import ResponseDerivatives, newton_ascent
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
        :class:`~sarmotion.core.spectral.FrequencyPlanes` (frequency-major: faster when
        many sums run over the same rows, as in searches).

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
        (:func:`sarmotion.core.spectral.phased_row_sums`: no complex exponential per term,
        the same values as forming :func:`sarmotion.core.spectral.delay_phase` to ~1e-13).
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
    step_m: float = 0.2,
    tol_m: float = 1e-3,
    max_iter: int = 50,
) -> tuple[NDArray[np.float64], complex]:
    """Refine a location by maximising ``|I(rho)|^2`` (safeguarded Newton from ``point_m``).

    ``I`` and its gradient and Hessian in the ground position come in one pass over the
    phase history: ``I = (1/K) sum_j A_j(d_j)`` with ``A_j`` pulse ``j``'s sum over
    frequencies at its differential delay ``d_j(rho)``, so ``grad I = (1/K) sum_j A_j'
    grad d_j`` and ``hess I = (1/K) sum_j (A_j'' grad d_j grad d_j^T + A_j' hess d_j)``
    (:meth:`~sarmotion.core.spectral.FrequencyPlanes.sums_and_derivatives`). Each step is
    the Newton step of ``|I|^2`` when its Hessian is negative definite, else the gradient
    direction, cut to a trust radius (first ``step_m``, doubled after a full step
    that gained, quartered after a step that did not); it stops when a step gaining
    ``|I|^2`` is shorter than ``tol_m``, or the radius falls below it. Near the peak the
    steps shrink quadratically, so the last accepted location is within ``~tol_m^2 /
    (resolution)`` of the maximum. On the 67 refinements of Scene 1's analysis: median 4,
    mean 5.7 evaluations of ``I`` and its derivatives (each 1.8x one of ``I``: 60 against
    34 us on 117 x 424),
    where a Nelder-Mead search to the same ``tol_m`` took about 70 of ``I``; the
    locations agree with it to 3e-5 m, ``|I|`` higher by 1e-10 to 1e-9 of itself.

    Parameters
    ----------
    traces : Traces
        Data and acquisition.
    point_m : (2,) or (3,) array_like
        Starting location (m), e.g. a pixel peak.
    velocity_mps : (2,) array_like, optional
        Compensated ground velocity (m/s).
    phase_history : array_like or FrequencyPlanes, optional
        Precomputed ``traces.phase_history()`` (or its planes).
    step_m : float
        First trust radius (m), about half a range resolution cell.
    tol_m : float
        Location tolerance (m).
    max_iter : int
        Iteration cap (evaluations of ``I`` and its derivatives).

    Returns
    -------
    position : (3,) ndarray
        Refined location (m); ``point_m`` itself if no step gained.
    value : complex
        ``I`` at that location.
    """
    P = _phase_history(traces, phase_history)
    if not isinstance(P, FrequencyPlanes):
        P = FrequencyPlanes(P)  # many sums of the same rows: frequency-major, contiguous
    p0 = as_point(point_m, name="point_m")
    ant = traces.positions_m
    shift = np.zeros((traces.n_pulses, 3))
    if velocity_mps is not None:
        vel = np.asarray(velocity_mps, dtype=np.float64)
        shift[:, :2] = traces.slow_times_s[:, None] * vel[None, :2]
    response = ResponseDerivatives(
        P,
        ant,
        travel_time(ant, traces.reference_point_m),
        float(traces.frequencies_hz[0]),
        float(traces.radar.frequency_step_hz),
        1.0 / traces.n_samples,
    )
    jacobian = np.broadcast_to(np.eye(3)[:, :2], (traces.n_pulses, 3, 2))

    def evaluate(xy: NDArray[np.float64]):
        return response(np.array([xy[0], xy[1], p0[2]]) + shift, jacobian)

    xy, value, moved, _ = newton_ascent(
        evaluate, p0[:2], radius=float(step_m), tol=tol_m, max_iter=max_iter
    )
    if not moved:
        return p0, complex(value)
    return np.array([xy[0], xy[1], p0[2]]), complex(value)
