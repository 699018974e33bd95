"""Newton ascent of ``|I(theta)|^2`` for exact point responses with analytic derivatives.

The exact point response (``eq:image``, ``eq:imagecompu``) and the matched filter are sums
over pulses of frequency sums at one delay each,

    I(theta) = w sum_j A_j(d_j(theta)),   A_j(d) = sum_k P_jk exp(2i pi f_k d),

with ``d_j`` the differential travel time of pulse ``j`` to the target's position
``rho_j(theta) = rho_0 + J_j theta`` (linear in the parameters: a ground position, or a
range offset and the two speeds, ``rho_j`` moving as ``s_j u``). Then

    grad I = w sum_j A_j' J_j^T grad d_j,
    hess I = w sum_j (A_j'' (J_j^T grad d_j)(J_j^T grad d_j)^T + A_j' J_j^T hess d_j J_j),

``grad d_j = -(2/c) e_j`` and ``hess d_j = (2/c)(I - e_j e_j^T) / R_j`` for the unit
vector ``e_j`` from the target to the antenna at range ``R_j``. ``A_j, A_j', A_j''`` come
in one pass over the phase history
(:meth:`~sarmotion.core.spectral.FrequencyPlanes.sums_and_derivatives`).

:func:`newton_ascent` climbs ``|I|^2`` from a start inside the main lobe: the Newton step
where the Hessian is negative definite and the step short enough, else the step
that maximises the quadratic model on the trust radius. Positions in m, speeds in m/s, delays in s.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from .constants import C
from .spectral import FrequencyPlanes

__all__ = ["ResponseDerivatives", "newton_ascent"]

#: ``(|I|^2, gradient, Hessian, I)`` at one parameter vector.
Evaluation = tuple[float, NDArray[np.float64], NDArray[np.float64], complex]


class ResponseDerivatives:
    """``|I|^2`` with its gradient and Hessian in parameters that move the target linearly.

    Parameters
    ----------
    planes : FrequencyPlanes
        The phase history (rows: pulses), frequency-major.
    antenna_m : (n, 3) ndarray
        Antenna positions (m).
    reference_delays_s : (n,) ndarray
        Travel time to the range-compression reference point per pulse (s).
    f_first_hz, f_step_hz : float
        First frequency of the rows and frequency step (Hz).
    weight : float
        ``w``: the scale of the sum (e.g. ``1 / n_samples``).
    rows : slice
        The pulses summed (a contiguous slice of the planes' rows); ``antenna_m`` and
        ``reference_delays_s`` are those of these pulses.
    """

    def __init__(
        self,
        planes: FrequencyPlanes,
        antenna_m: NDArray[np.float64],
        reference_delays_s: NDArray[np.float64],
        f_first_hz: float,
        f_step_hz: float,
        weight: float,
        rows: slice = slice(None),
    ) -> None:
        self.rows = rows
        self.planes = planes
        self.antenna = np.asarray(antenna_m, dtype=np.float64)
        self.reference = np.asarray(reference_delays_s, dtype=np.float64)
        self.f_first = float(f_first_hz)
        self.f_step = float(f_step_hz)
        self.weight = float(weight)

    def __call__(
        self, positions_m: NDArray[np.float64], jacobians: NDArray[np.float64]
    ) -> Evaluation:
        """Evaluate at the pulses' target positions and their parameter Jacobians.

        Parameters
        ----------
        positions_m : (n, 3) ndarray
            ``rho_j(theta)`` (m).
        jacobians : (n, 3, p) ndarray
            ``d rho_j / d theta`` (m per parameter unit).

        Returns
        -------
        tuple
            ``|I|^2``, its gradient (p,) and Hessian (p, p) in the parameters, and ``I``.
        """
        diff = self.antenna - positions_m
        r = np.sqrt(np.einsum("jk,jk->j", diff, diff))
        e = diff / r[:, None]
        d = 2.0 * r / C - self.reference
        a0, a1, a2 = self.planes.sums_and_derivatives(d, self.f_first, self.f_step, self.rows)
        grad_d = -(2.0 / C) * np.einsum("jk,jkp->jp", e, jacobians)  # (n, p)
        jj = np.einsum("jkp,jkq->jpq", jacobians, jacobians)
        ej = np.einsum("jk,jkp->jp", e, jacobians)
        hess_d = (2.0 / C) * (jj - ej[:, :, None] * ej[:, None, :]) / r[:, None, None]
        w = self.weight
        value = complex(a0.sum() * w)
        g = (a1 @ grad_d) * w
        h = (np.einsum("j,jp,jq->pq", a2, grad_d, grad_d) + np.einsum("j,jpq->pq", a1, hess_d)) * w
        f = abs(value) ** 2
        grad = 2.0 * np.real(np.conj(value) * g)
        hess = 2.0 * np.real(np.outer(g, np.conj(g)) + np.conj(value) * h)
        return f, grad, 0.5 * (hess + hess.T), value

    def on_track(
        self,
        slow_times_s: NDArray[np.float64],
        position_m: NDArray[np.float64],
        velocity_mps: NDArray[np.float64],
        position_direction: NDArray[np.float64],
        velocity_directions: tuple[NDArray[np.float64], NDArray[np.float64]],
    ) -> Callable[[NDArray[np.float64]], Evaluation]:
        """``q -> self(rho(q), J)`` for a straight track moved by three parameters.

        ``rho_j(q) = position + q[0] e + s_j (velocity + q[1] a + q[2] b)`` with ``e =
        position_direction`` (m per unit of ``q[0]``) and ``(a, b) = velocity_directions``
        (m/s per unit of ``q[1]``, ``q[2]``); ground vectors of 2 or 3 components (``z``
        held). ``slow_times_s`` are those of the summed pulses.
        """
        s = np.asarray(slow_times_s, dtype=np.float64)

        def ground(v: NDArray[np.float64]) -> NDArray[np.float64]:
            v = np.asarray(v, dtype=np.float64)
            return np.r_[v[:2], 0.0] if v.size == 2 else v

        p0 = np.asarray(position_m, dtype=np.float64)
        v0, e = ground(velocity_mps), ground(position_direction)
        a, b = (ground(d) for d in velocity_directions)
        jacobian = np.empty((s.size, 3, 3))
        jacobian[:, :, 0] = e[None, :]
        jacobian[:, :, 1] = s[:, None] * a[None, :]
        jacobian[:, :, 2] = s[:, None] * b[None, :]

        def evaluate(q: NDArray[np.float64]) -> Evaluation:
            where = (p0 + q[0] * e)[None, :] + s[:, None] * (v0 + q[1] * a + q[2] * b)[None, :]
            return self(where, jacobian)

        return evaluate


def newton_ascent(
    evaluate: Callable[[NDArray[np.float64]], Evaluation],
    x0: NDArray[np.float64],
    *,
    radius: float,
    tol: float,
    max_iter: int,
    scale: NDArray[np.float64] | None = None,
    max_radius: float | None = None,
) -> tuple[NDArray[np.float64], complex, bool, int]:
    """Maximise ``|I|^2`` from ``x0`` by safeguarded Newton steps.

    Each step maximises the quadratic model within the trust radius
    (:func:`_trust_region_step`: the Newton step when the Hessian is negative definite
    and the step fits, else the Levenberg-Marquardt step on the radius); the radius is
    doubled (up to ``max_radius``) after a step to the radius that gained, quartered
    after a step that did not. It stops when a gaining step is shorter than ``tol``,
    when the radius falls below ``tol``, or after ``max_iter`` evaluations. Near the
    maximum the steps shrink quadratically, so the last accepted point is within about
    ``tol^2`` (over the lobe's width) of it. A local search: the start must lie on the
    main lobe's slope (within a fraction of a resolution in every parameter), as the
    steps only climb.

    Parameters
    ----------
    evaluate : callable
        ``x -> (|I|^2, gradient, Hessian, I)``.
    x0 : (p,) ndarray
        Start (parameter units).
    radius : float
        First trust radius, in units of ``x / scale``.
    max_radius : float, optional
        Largest trust radius (default ``radius``): a local search must not jump to
        another lobe of an oscillating response.
    tol : float
        Step tolerance, in units of ``x / scale``.
    max_iter : int
        Most evaluations after the first.
    scale : (p,) ndarray, optional
        Unit of each parameter for the radius and the tolerance (e.g. the expected
        step in each); default ones.

    Returns
    -------
    x : (p,) ndarray
        The best point found (``x0`` when no step gained).
    value : complex
        ``I`` there.
    moved : bool
        Whether any step gained.
    n_evaluations : int
        Evaluations made, the first included.
    """
    max_radius = radius if max_radius is None else float(max_radius)
    x = np.asarray(x0, dtype=np.float64).copy()
    unit = np.ones_like(x) if scale is None else np.asarray(scale, dtype=np.float64)
    f, grad, hess, value = evaluate(x)
    # scaled coordinates z = x / unit: gradient * unit, Hessian * unit unit^T
    moved = False
    n_eval = 1
    for _ in range(int(max_iter)):
        gz = grad * unit
        hz = hess * np.outer(unit, unit)
        step = _trust_region_step(gz, -hz, radius)
        if step is None:
            break
        length = float(np.linalg.norm(step))
        trial = x + step * unit
        f_new, grad_new, hess_new, value_new = evaluate(trial)
        n_eval += 1
        if f_new > f:
            x, f, grad, hess, value = trial, f_new, grad_new, hess_new, value_new
            moved = True
            if length < tol:
                break
            if length >= radius:
                radius = min(2.0 * radius, max_radius)
        else:
            radius = 0.25 * length
            if radius < tol:
                break
    return x, value, moved, n_eval


def _trust_region_step(
    g: NDArray[np.float64], b: NDArray[np.float64], radius: float
) -> NDArray[np.float64] | None:
    """The maximiser of ``g.z - z.B z / 2`` over ``|z| <= radius`` (``B = -Hessian``).

    ``(B + lam I) z = g`` with the smallest ``lam >= 0`` that makes ``B + lam I`` positive
    definite and ``|z| <= radius`` (Moré and Sorensen's characterisation; ``lam`` by
    bisection on the eigenvalues of the small ``B``, the hard case taken as the
    boundary gradient step). ``None`` if ``g`` is zero or not finite.
    """
    if not np.all(np.isfinite(g)) or not np.all(np.isfinite(b)) or not np.any(g):
        return None
    mu, v = np.linalg.eigh(b)
    gv = v.T @ g

    def step(lam: float) -> NDArray[np.float64]:
        return v @ (gv / (mu + lam))

    lo = max(0.0, -float(mu[0]))
    if mu[0] > 0.0:
        z = step(0.0)
        if np.linalg.norm(z) <= radius:
            return z
    # |step(lam)| decreases on (lo, inf): bracket and bisect |step| = radius
    hi = lo + float(np.linalg.norm(g)) / radius + abs(float(mu[-1])) + 1e-300
    if lo > 0.0 or mu[0] <= 0.0:
        lo_eval = lo * (1.0 + 1e-12) + 1e-300
        if np.linalg.norm(step(lo_eval)) <= radius:  # hard case: no lam reaches the radius
            return g * (radius / float(np.linalg.norm(g)))
        lo = lo_eval
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if np.linalg.norm(step(mid)) > radius:
            lo = mid
        else:
            hi = mid
    return step(hi)
