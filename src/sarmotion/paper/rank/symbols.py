"""Szegő asymptotics of the rank: Toeplitz symbols and the closed-form rank fractions."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._validation import positive as _positive
from ...core import C, LookGeometry, as_point
from .model import Model, _as_velocity3, _check_model
from .numerical import _kappa

__all__ = [
    "alpha",
    "alpha_j",
    "beta",
    "toeplitz_symbol_sequence",
    "two_target_sequence",
    "hankel_sequence",
    "two_target_gram",
    "symbol",
    "baseband_symbol",
    "szego_rank_fraction",
    "baseband_rank_fraction",
    "symbol_rank_fraction",
]


# ---------------------------------------------------------- Toeplitz asymptotics
def alpha(position_m: ArrayLike, velocity_mps: ArrayLike, geometry: LookGeometry) -> float:
    """Slope ``alpha = d dtau / ds`` at ``s = 0`` of a target's trace (``eq:Toep2``).

    ``alpha = -2 u.m_o / c - 2 (V t - u) . P_o (rho - rho_o) / (c L)``, dimensionless
    (delay in s per s of slow time), so that ``dtau(s) ~ dtau(0) + alpha s``.

    Parameters
    ----------
    position_m : (2,) or (3,) array_like
        Target position ``rho = rho(0)`` (m).
    velocity_mps : (2,) or (3,) array_like
        Target velocity ``u`` (m/s).
    geometry : LookGeometry
        ``m_o``, ``t``, ``L``, ``V`` and ``rho_o`` (:func:`sarmotion.core.geometry.look_geometry`).

    Returns
    -------
    float
        ``alpha`` (dimensionless).

    Notes
    -----
    The stationary term ``-2 V t.P_o (rho - rho_o) / (c L)`` is the paper's (``eq:Toep2``,
    ``eq:alphaj``); the range-speed term carries the sign of the derivative of
    ``eq:DeltaTau`` (a target approaching the radar shortens its delay), whereas
    ``eq:Toep2`` prints ``+2 u.m_o / c``. A single target's rank depends on ``|alpha|``
    only, and the two conventions give the same ``|alpha|`` whenever one of the terms
    vanishes (all the paper's examples).
    """
    rho = as_point(position_m, name="position_m")
    u = _as_velocity3(velocity_mps)
    g = geometry
    d = g.projector @ (rho - g.reference_point_m)
    return float(
        -2.0 * (u @ g.m_o) / C - 2.0 * ((g.speed_mps * g.tangent - u) @ d) / (C * g.range_m)
    )


def alpha_j(position_m: ArrayLike, geometry: LookGeometry) -> float:
    """``alpha_j = -2 V t.P_o (rho_j - rho_o) / (c L)`` of a stationary target (``eq:alphaj``).

    Parameters
    ----------
    position_m : (2,) or (3,) array_like
        Target position (m).
    geometry : LookGeometry
        Look geometry.

    Returns
    -------
    float
        ``alpha_j`` (dimensionless).
    """
    return alpha(position_m, np.zeros(3), geometry)


def beta(position_1_m: ArrayLike, position_2_m: ArrayLike, geometry: LookGeometry) -> float:
    """Delay offset ``beta`` between two targets (``eq:beta``), in s.

    ``beta = (2/c) sum_j (-1)^j [m_o.(rho_j - rho_o) + (m_o.(rho_j - rho_o))^2 / (2 L)]``,
    i.e. to first order ``dtau_1(0) - dtau_2(0)``. ``B |beta| >> 1`` means the two traces
    do not overlap in fast time and the g-Hankel part of ``eq:covar2`` is negligible.

    Parameters
    ----------
    position_1_m, position_2_m : (2,) or (3,) array_like
        ``rho_1``, ``rho_2`` (m).
    geometry : LookGeometry
        Look geometry (``m_o``, ``L``, ``rho_o``).

    Returns
    -------
    float
        ``beta`` (s).
    """
    total = 0.0
    for sign, p in ((-1.0, position_1_m), (1.0, position_2_m)):
        r = float(geometry.m_o @ (as_point(p) - geometry.reference_point_m))
        total += sign * (r + r * r / (2.0 * geometry.range_m))
    return 2.0 * total / C


def _alphas(alpha_: ArrayLike) -> NDArray[np.float64]:
    a = np.atleast_1d(np.asarray(alpha_, dtype=np.float64))
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)):
        raise ValueError(f"alpha must be a finite number or 1-D sequence, got {alpha_!r}")
    return a


def toeplitz_symbol_sequence(
    alpha: ArrayLike,
    *,
    n: int,
    carrier_hz: float,
    bandwidth_hz: float,
    pulse_interval_s: float,
    sample_interval_s: float = 1.0,
    model: Model = "passband",
) -> NDArray[np.float64] | NDArray[np.complex128]:
    """Diagonals ``y_j``, ``j = 0..n``, of the Toeplitz approximation of ``Y``.

    ``"passband"`` (``eq:defcj``; for several ``alpha`` the sum ``eq:seqc``)::

        y_j = sqrt(pi) / (2 B dt) sum_q cos(w_o ds |alpha_q| j) exp(-(B ds alpha_q j)^2 / 4)

    ``"baseband"`` (module Notes), Hermitian, ``y_(-j) = conj(y_j)``::

        y_j = sqrt(pi) / (B dt) sum_q exp(-i w_o ds alpha_q j) exp(-(B ds alpha_q j)^2 / 4)

    Parameters
    ----------
    alpha : float or (n_targets,) array_like
        Trace slopes (dimensionless), e.g. from :func:`alpha`.
    n : int
        Largest index; ``Y`` is ``(n + 1, n + 1)`` with ``Y_jl = y_(j - l)``
        (``scipy.linalg.toeplitz(y, y.conj())``).
    carrier_hz, bandwidth_hz : float
        ``nu_o`` and ``B`` (Hz).
    pulse_interval_s : float
        ``ds`` (s).
    sample_interval_s : float
        Fast-time step ``dt`` (s) of the Riemann sum ``eq:covar1p``; 1 gives ``Y`` per
        unit ``1/dt``.
    model : {"passband", "baseband"}
        Real cosine-modulated traces (the paper) or complex baseband.

    Returns
    -------
    (n + 1,) ndarray
        ``y_0 .. y_n``; float64 (passband) or complex128 (baseband).
    """
    _check_model(model)
    if not (isinstance(n, (int, np.integer)) and n >= 0):
        raise ValueError(f"n must be a non-negative integer, got {n!r}")
    a = _alphas(alpha)
    w0 = 2.0 * np.pi * _positive(carrier_hz, "carrier_hz")
    bw = _positive(bandwidth_hz, "bandwidth_hz")
    ds = _positive(pulse_interval_s, "pulse_interval_s")
    dt = _positive(sample_interval_s, "sample_interval_s")
    j = np.arange(n + 1, dtype=np.float64)
    env = np.exp(-0.25 * (bw * ds * np.outer(a, j)) ** 2)
    if model == "passband":
        return (
            np.sqrt(np.pi)
            / (2 * bw * dt)
            * np.sum(np.cos(w0 * ds * np.outer(np.abs(a), j)) * env, axis=0)
        )
    return np.sqrt(np.pi) / (bw * dt) * np.sum(np.exp(-1j * w0 * ds * np.outer(a, j)) * env, axis=0)


def two_target_sequence(
    alpha_1: float,
    alpha_2: float,
    *,
    n: int,
    carrier_hz: float,
    bandwidth_hz: float,
    pulse_interval_s: float,
    sample_interval_s: float = 1.0,
) -> NDArray[np.float64]:
    """Toeplitz sequence ``y_j``, ``j = 0..n``, of two stationary targets (``eq:seqc``).

    Parameters
    ----------
    alpha_1, alpha_2 : float
        ``alpha_j`` of the targets (``eq:alphaj``), dimensionless.
    n, carrier_hz, bandwidth_hz, pulse_interval_s, sample_interval_s
        As in :func:`toeplitz_symbol_sequence`.

    Returns
    -------
    (n + 1,) ndarray
        ``y_j``, float64.
    """
    return toeplitz_symbol_sequence(
        [alpha_1, alpha_2],
        n=n,
        carrier_hz=carrier_hz,
        bandwidth_hz=bandwidth_hz,
        pulse_interval_s=pulse_interval_s,
        sample_interval_s=sample_interval_s,
    )


def hankel_sequence(
    alpha_1: float,
    beta: float,
    *,
    n_terms: int,
    carrier_hz: float,
    bandwidth_hz: float,
    pulse_interval_s: float,
    sample_interval_s: float = 1.0,
) -> NDArray[np.float64]:
    """g-Hankel sequence ``h_j``, ``j = 0..n_terms-1``, of two targets (``eq:seqh``).

    ``h_j = sqrt(pi)/(2 B dt) exp(-[B ds |alpha_1| (j + zeta)]^2/4)
    cos[w_o ds |alpha_1| (j + zeta)]`` with ``zeta = beta / (|alpha_1| ds)``. An
    ``(n+1) x (n+1)`` g-Hankel matrix ``H_jl = h_(j + g l)`` needs ``n_terms = (g+1) n + 1``.

    Parameters
    ----------
    alpha_1 : float
        ``alpha_1`` (``eq:alphaj``), non-zero.
    beta : float
        Delay offset (``eq:beta``), s.
    n_terms : int
        Number of terms.
    carrier_hz, bandwidth_hz, pulse_interval_s, sample_interval_s
        As in :func:`toeplitz_symbol_sequence`.

    Returns
    -------
    (n_terms,) ndarray
        ``h_j``, float64.
    """
    if alpha_1 == 0:
        raise ValueError("alpha_1 must be non-zero (zeta = beta / (|alpha_1| ds))")
    w0 = 2.0 * np.pi * _positive(carrier_hz, "carrier_hz")
    bw = _positive(bandwidth_hz, "bandwidth_hz")
    ds = _positive(pulse_interval_s, "pulse_interval_s")
    dt = _positive(sample_interval_s, "sample_interval_s")
    a = abs(float(alpha_1))
    x = ds * a * (np.arange(int(n_terms), dtype=np.float64) + float(beta) / (a * ds))
    return np.sqrt(np.pi) / (2 * bw * dt) * np.exp(-0.25 * (bw * x) ** 2) * np.cos(w0 * x)


def two_target_gram(
    alpha_1: float,
    alpha_2: float,
    beta: float,
    *,
    n: int,
    carrier_hz: float,
    bandwidth_hz: float,
    pulse_interval_s: float,
    sample_interval_s: float = 1.0,
    cross_terms: bool = True,
) -> NDArray[np.float64]:
    """Model Gram matrix ``Y(s_j, s_l)`` of two stationary targets (``eq:covar2``).

    Slow times ``s_j = (j - n/2) ds``, ``j = 0..n``. With ``cross_terms=False`` only the
    Toeplitz part (first line of ``eq:covar2``) is kept; the other two lines are the
    g-Toeplitz/g-Hankel interaction terms, negligible when ``B |beta| >> 1``.

    Parameters
    ----------
    alpha_1, alpha_2 : float
        Trace slopes (dimensionless).
    beta : float
        Delay offset (s), ``eq:beta``.
    n, carrier_hz, bandwidth_hz, pulse_interval_s, sample_interval_s
        As in :func:`toeplitz_symbol_sequence`.
    cross_terms : bool
        Include the interaction terms.

    Returns
    -------
    (n + 1, n + 1) ndarray
        ``Y``, real symmetric.
    """
    w0 = 2.0 * np.pi * _positive(carrier_hz, "carrier_hz")
    bw = _positive(bandwidth_hz, "bandwidth_hz")
    ds = _positive(pulse_interval_s, "pulse_interval_s")
    dt = _positive(sample_interval_s, "sample_interval_s")
    s = (np.arange(n + 1, dtype=np.float64) - 0.5 * n) * ds
    diff = s[:, None] - s[None, :]

    def kern(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.cos(w0 * x) * np.exp(-0.25 * (bw * x) ** 2)

    y = kern(alpha_1 * diff) + kern(alpha_2 * diff)
    if cross_terms:
        c = alpha_1 * s[:, None] - alpha_2 * s[None, :] + beta
        y = y + kern(c) + kern(c.T)
    return np.sqrt(np.pi) / (2 * bw * dt) * y


def symbol(
    alpha: ArrayLike,
    theta: ArrayLike,
    *,
    carrier_hz: float,
    bandwidth_hz: float,
    pulse_interval_s: float,
    sample_interval_s: float = 1.0,
    model: Model = "passband",
) -> NDArray[np.float64]:
    """Symbol ``y_hat(theta) = sum_j y_j exp(i j theta)`` (``eq:series``), closed form.

    By Poisson summation, with ``b_q = B ds |alpha_q|`` and ``w_q = w_o ds alpha_q``::

        passband: y_hat = sqrt(pi)/(2 B dt) sum_q (sqrt(pi)/b_q)
                          sum_k [G(theta - w_q + 2 pi k) + G(theta + w_q + 2 pi k)]
        baseband: y_hat = sqrt(pi)/(B dt) sum_q (2 sqrt(pi)/b_q) sum_k G(theta - w_q + 2 pi k)

    with ``G(x) = exp(-x^2 / b_q^2)``: two Gaussian bumps at ``+-w_q`` (passband) or one at
    ``w_q`` (baseband) per target, periodised. The sum over ``k`` is truncated where
    ``G < 1e-300`` relative.

    Parameters
    ----------
    alpha : float or (n_targets,) array_like
        Trace slopes (dimensionless), all non-zero. Several give the symbol of the
        Toeplitz part ``eq:seqc``.
    theta : array_like
        Angles (rad).
    carrier_hz, bandwidth_hz, pulse_interval_s, sample_interval_s, model
        As in :func:`toeplitz_symbol_sequence`.

    Returns
    -------
    ndarray
        ``y_hat(theta)``, same shape as ``theta``, float64 (the symbol is real).
    """
    _check_model(model)
    a = _alphas(alpha)
    if np.any(a == 0):
        raise ValueError("alpha must be non-zero: the symbol of alpha = 0 is a Dirac comb")
    w0 = 2.0 * np.pi * _positive(carrier_hz, "carrier_hz")
    bw = _positive(bandwidth_hz, "bandwidth_hz")
    ds = _positive(pulse_interval_s, "pulse_interval_s")
    dt = _positive(sample_interval_s, "sample_interval_s")
    th = np.asarray(theta, dtype=np.float64)
    out = np.zeros(th.shape, dtype=np.float64)
    centres_sign = (1.0, -1.0) if model == "passband" else (1.0,)
    pref = np.sqrt(np.pi) / (2 * bw * dt) if model == "passband" else np.sqrt(np.pi) / (bw * dt)
    scale = 1.0 if model == "passband" else 2.0
    for aq in a:
        b = bw * ds * abs(aq)
        w = w0 * ds * aq
        kmax = int(np.ceil(27.0 * b / (2 * np.pi))) + 1
        acc = np.zeros(th.shape, dtype=np.float64)
        for sg in centres_sign:
            phi = np.mod(th - sg * w + np.pi, 2 * np.pi) - np.pi
            for k in range(-kmax, kmax + 1):
                acc += np.exp(-(((phi + 2 * np.pi * k) / b) ** 2))
        out += pref * scale * np.sqrt(np.pi) / b * acc
    return out


def baseband_symbol(
    alpha: ArrayLike,
    theta: ArrayLike,
    *,
    carrier_hz: float,
    bandwidth_hz: float,
    pulse_interval_s: float,
    sample_interval_s: float = 1.0,
) -> NDArray[np.float64]:
    """Symbol of the complex-baseband Toeplitz matrix: one bump per target (module Notes).

    Same as :func:`symbol` with ``model="baseband"``::

        y_hat(theta) = 2 pi / (B dt b) sum_k exp(-(theta - w + 2 pi k)^2 / b^2),
        b = B ds |alpha|,  w = w_o ds alpha.

    Parameters
    ----------
    alpha, theta, carrier_hz, bandwidth_hz, pulse_interval_s, sample_interval_s
        As in :func:`symbol`.

    Returns
    -------
    ndarray
        ``y_hat(theta)``, real, same shape as ``theta``.
    """
    return symbol(
        alpha,
        theta,
        carrier_hz=carrier_hz,
        bandwidth_hz=bandwidth_hz,
        pulse_interval_s=pulse_interval_s,
        sample_interval_s=sample_interval_s,
        model="baseband",
    )


def szego_rank_fraction(
    alpha: float, *, bandwidth_hz: float, pulse_interval_s: float, eps: float = 1e-3
) -> float:
    """Closed-form Szegő estimate ``rank(Y)/(n+1)`` of the passband model (``eq:AS_RANK``).

    ``min(2 |alpha| B ds sqrt(log 1/eps) / pi, 1)``; threshold ``eps * max y_hat``. Assumes
    the two bumps of the symbol at ``+-w_o ds alpha`` do not overlap (see
    :func:`symbol_rank_fraction` for the exact measure).

    Parameters
    ----------
    alpha : float
        Trace slope (dimensionless).
    bandwidth_hz : float
        ``B`` (Hz).
    pulse_interval_s : float
        ``ds`` (s).
    eps : float
        Relative threshold in (0, 1).

    Returns
    -------
    float
        Rank fraction in [0, 1].
    """
    k = _kappa(eps)
    b = _positive(bandwidth_hz, "bandwidth_hz") * _positive(pulse_interval_s, "pulse_interval_s")
    return float(min(2.0 * abs(float(alpha)) * b * k / np.pi, 1.0))


def baseband_rank_fraction(
    alpha: float, *, bandwidth_hz: float, pulse_interval_s: float, eps: float = 1e-3
) -> float:
    """Closed-form Szegő estimate ``rank(Y)/(n+1)`` for complex-baseband traces.

    ``min(|alpha| B ds sqrt(log 1/eps) / pi, 1)`` -- half of ``eq:AS_RANK`` (derivation in
    the module Notes); threshold ``eps * max y_hat``.

    Parameters
    ----------
    alpha : float
        Trace slope (dimensionless).
    bandwidth_hz : float
        ``B`` (Hz).
    pulse_interval_s : float
        ``ds`` (s).
    eps : float
        Relative threshold in (0, 1).

    Returns
    -------
    float
        Rank fraction in [0, 1].
    """
    k = _kappa(eps)
    b = _positive(bandwidth_hz, "bandwidth_hz") * _positive(pulse_interval_s, "pulse_interval_s")
    return float(min(abs(float(alpha)) * b * k / np.pi, 1.0))


def symbol_rank_fraction(
    alpha: ArrayLike,
    *,
    carrier_hz: float,
    bandwidth_hz: float,
    pulse_interval_s: float,
    eps: float = 1e-3,
    model: Model = "passband",
    n_theta: int | None = None,
) -> float:
    """Right-hand side of ``eq:RANK_AS`` evaluated numerically from the symbol.

    ``(1/2 pi) |{theta in (-pi, pi]: y_hat(theta) >= eps max y_hat}|`` on a uniform grid.
    Unlike :func:`szego_rank_fraction` it accounts for overlapping and aliased bumps and
    for several targets (the symbol of ``eq:seqc``).

    Parameters
    ----------
    alpha : float or (n_targets,) array_like
        Trace slopes (dimensionless), non-zero.
    carrier_hz, bandwidth_hz, pulse_interval_s : float
        ``nu_o``, ``B`` (Hz) and ``ds`` (s).
    eps : float
        Relative threshold in (0, 1).
    model : {"passband", "baseband"}
        Symbol model.
    n_theta : int, optional
        Grid size; default resolves the narrowest bump with >= 50 points per ``b``.

    Returns
    -------
    float
        Rank fraction in [0, 1].
    """
    _kappa(eps)
    a = _alphas(alpha)
    if n_theta is None:
        bmin = _positive(bandwidth_hz, "bandwidth_hz") * pulse_interval_s * float(np.min(np.abs(a)))
        n_theta = int(min(max(2**14, np.ceil(50 * 2 * np.pi / max(bmin, 1e-300))), 2**24))
    theta = np.linspace(-np.pi, np.pi, int(n_theta), endpoint=False)
    y = symbol(
        a,
        theta,
        carrier_hz=carrier_hz,
        bandwidth_hz=bandwidth_hz,
        pulse_interval_s=pulse_interval_s,
        model=model,
    )
    return float(np.count_nonzero(y >= eps * y.max()) / theta.size)
