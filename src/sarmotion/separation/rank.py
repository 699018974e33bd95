"""Rank of matrices of traces: numerical rank, Szegő asymptotics and predictions.

The robust-PCA separation (paper ``sect:RPCA``) rests on one claim, analysed in
``sect:rpcaanalysis``: the traces of stationary targets near the reference point
``rho_o`` form a low-rank matrix, those of moving targets a high-rank one. This module
computes that rank three ways:

* numerically, from a matrix of traces ``M`` (:func:`numerical_rank`), built with the
  paper's real passband model (:func:`passband_traces`, ``eq:MOD8`` / ``eq:TWO1``) or its
  complex-baseband counterpart (:func:`baseband_traces`, the library's data convention);
* asymptotically, from Szegő's first limit theorem (``eq:RANK_AS``) applied to the
  Toeplitz approximation of ``Y = M M^T`` (``eq:Toep1``, ``eq:defcj``): the symbol
  (:func:`symbol`, ``eq:series``), the closed form ``eq:AS_RANK``
  (:func:`szego_rank_fraction`) and its numerical evaluation
  (:func:`symbol_rank_fraction`); the two-target quantities ``eq:alphaj``, ``eq:beta``,
  ``eq:seqc``, ``eq:seqh``, ``eq:covar2``;
* predictively, for a scene and an aperture (:func:`predict_rank`), and as a rule for
  the fast-time window of a windowed robust PCA (:func:`predict_window`).

Units are SI throughout: positions (m), velocities (m/s), times (s), frequencies (Hz).
The paper's ``B`` is used literally as in ``eq:compPulse``: the compressed pulse is
``exp(-B^2 t^2 / 2)`` with ``B`` the bandwidth in Hz (so ``1/B`` is its width in s),
exactly as :meth:`sarmotion.core.radar.Radar.spectral_weights` does for ``pulse="gaussian"``.
``alpha`` is dimensionless (s of delay per s of slow time).

Thresholds
----------
Every rank here counts eigenvalues of the Gram matrix ``Y = M M^H`` (squared singular
values of ``M``) at or above a threshold ``eps * reference``:

* :func:`numerical_rank` uses ``reference = lambda_max(Y)`` unless ``reference`` is given
  (pass ``max(symbol)`` to reproduce the paper's ``N(n; eps ||y_hat||_inf, inf)``; for
  ``n`` large the two agree, since ``lambda_max -> ||y_hat||_inf``);
* the Szegő fractions threshold the symbol at ``eps * max_theta y_hat(theta)``
  (``eq:RANK_AS``, ``eq:AS_RANK``);
* :func:`predict_rank` thresholds each target's pulse spectrum ``|p_hat|^2`` at ``eps``
  times its peak (see its Notes).

Because ``Y`` holds squared singular values, ``eps = 1e-3`` on ``Y`` is ``sqrt(eps)``
(about -30 dB in power, 3 % in amplitude) on the singular values of ``M``.

Notes
-----
**Complex-baseband counterpart of eq:Toep1 -- eq:AS_RANK.** The library's traces are
complex baseband (see :mod:`sarmotion.core.spectral`): a unit point target at differential
delay ``dtau(s)`` (``eq:DeltaTau``) gives ``D(s, t) = p(t - dtau(s)) exp(-i w_o dtau(s))``
with ``w_o = 2 pi nu_o`` and, for the paper's Gaussian pulse, ``p(t) = exp(-B^2 t^2 / 2)``.
The Gram matrix ``Y = D D^H`` is Hermitian positive semi-definite and, as in
``eq:covar1p``, with ``a = dtau(s)``, ``a' = dtau(s')``::

    Y(s, s') = sum_l D(s, t_l) conj(D(s', t_l))
             ~ (1/dt) exp(-i w_o (a - a')) int p(t - a) p(t - a') dt
             = sqrt(pi) / (B dt) * exp(-B^2 (a - a')^2 / 4) * exp(-i w_o (a - a')),

using ``(t - a)^2 + (t - a')^2 = 2 (t - (a + a')/2)^2 + (a - a')^2 / 2``. Unlike the
cosine case nothing is dropped (``eq:Toep1`` neglects a term ``~ exp(-w_o^2/B^2)``), and
the prefactor is twice that of ``eq:Toep1`` (``cos^2`` averages to 1/2). The Riemann
sum is accurate once ``dt <~ 1/B`` (relative error ``~ exp(-pi^2 / (B dt)^2)``); the
carrier need not be resolved. Linearising ``dtau(s) ~ dtau(0) + alpha s`` (``eq:Toep2``)
gives a Hermitian Toeplitz matrix ``Y_jl ~ y_(j-l)`` with::

    y_j = sqrt(pi) / (B dt) * exp(-(b j)^2 / 4) * exp(-i w j),    y_(-j) = conj(y_j),
    b = B ds |alpha|,    w = w_o ds alpha,

``ds`` the pulse interval. Poisson summation, ``sum_j exp(-b^2 j^2/4) exp(i j phi) =
(2 sqrt(pi) / b) sum_k exp(-(phi + 2 pi k)^2 / b^2)``, gives the symbol (``eq:series``)::

    y_hat(theta) = 2 pi / (B dt b) * sum_k exp(-(theta - w + 2 pi k)^2 / b^2),

a single Gaussian bump of width ``b`` centred at ``theta = w`` (mod ``2 pi``). The cosine
model has two bumps, at ``+-w``, since ``cos = (e^{i.} + e^{-i.})/2`` (its symbol is
:func:`symbol` with ``model="passband"``). The bump exceeds ``eps`` times its maximum on
``|theta - w| <= b sqrt(log 1/eps)``, so by ``eq:RANK_AS``::

    rank(Y) / (n + 1)  ->  min(|alpha| B ds sqrt(log 1/eps) / pi, 1),

half the passband estimate ``eq:AS_RANK``: a complex trace has half the rank of the real
trace built from it. (``eq:AS_RANK`` also assumes the two passband bumps do not overlap,
i.e. ``w`` not within ``~b sqrt(log 1/eps)`` of 0 or ``pi`` mod ``2 pi``; the baseband
count has no such caveat.) The estimate is a time-bandwidth product: ``(n + 1) ds |alpha|``
is the delay migration of the trace over the aperture and ``B sqrt(log 1/eps) / pi`` is
the width (Hz) of the band where ``|p_hat|^2 = exp(-omega^2 / B^2)`` exceeds ``eps`` of
its peak. With ``Radar(pulse="gaussian")`` the simulator's spectrum is exactly
``p_hat`` on the sampled band (at GOTCHA sampling ``|p_hat|^2`` falls to ``exp(-pi^2)``
at the band edge, below ``eps = 1e-3``), so the same symbol applies to simulated data.

For several targets the Toeplitz part of ``Y`` has the sum of the targets' symbols
(``eq:seqc``); the cross terms (``eq:covar2``) are g-Toeplitz/g-Hankel and neglected, as
in the paper. That is accurate when the targets' traces are separated in fast time
(``B |beta| >> 1``) but not when they share a range cell: see :func:`predict_rank`.

References
----------
.. [1] L. Borcea, T. Callaghan, G. Papanicolaou, "Motion estimation and imaging of
   complex scenes with synthetic aperture radar", ``sect:rpcaanalysis``.
.. [2] A. Böttcher, B. Silbermann, "Introduction to large truncated Toeplitz matrices",
   Springer (1999) -- Szegő's first limit theorem.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import positive as _positive
from ..core import C, LookGeometry, Radar, Trajectory, as_point, delta_tau, target_positions
from ..simulation import PointTarget

__all__ = [
    "numerical_rank",
    "gram_eigenvalues",
    "fast_time_grid",
    "passband_traces",
    "baseband_traces",
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
    "predict_rank",
    "predict_window_ranks",
    "predict_window",
]

Model = Literal["passband", "baseband"]

#: Default carrier (Hz): the GOTCHA centre frequency of :class:`~sarmotion.core.radar.Radar`.
DEFAULT_CARRIER_HZ = Radar().carrier_hz


# --------------------------------------------------------------------------- helpers
def _kappa(eps: float) -> float:
    """``sqrt(log(1/eps))`` with validation of ``eps``."""
    if not (isinstance(eps, (int, float, np.floating)) and 0.0 < eps < 1.0):
        raise ValueError(f"eps must be a number in (0, 1), got {eps!r}")
    return float(np.sqrt(np.log(1.0 / eps)))


def _check_model(model: str) -> None:
    if model not in ("passband", "baseband"):
        raise ValueError(f"model must be 'passband' or 'baseband', got {model!r}")


def _as_velocity3(velocity: ArrayLike) -> NDArray[np.float64]:
    v = np.asarray(velocity, dtype=np.float64)
    if v.shape == (2,):
        v = np.array([v[0], v[1], 0.0])
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"velocity must be a finite (2,) or (3,) vector (m/s), got {velocity!r}")
    return v


def _normalise_targets(
    targets: Sequence[Any],
) -> list[tuple[NDArray[np.float64], NDArray[np.float64], complex]]:
    """``[(position (3,), velocity (3,), reflectivity)]`` from the accepted target forms."""
    if isinstance(targets, PointTarget):
        targets = [targets]
    out = []
    for i, item in enumerate(targets):
        if isinstance(item, PointTarget):
            out.append((item.position_m, item.velocity3_mps, item.reflectivity))
            continue
        if isinstance(item, (tuple, list)) and len(item) == 2 and np.ndim(item[0]) == 1:
            pos = as_point(item[0], name=f"targets[{i}] position")
            out.append((pos, _as_velocity3(item[1]), 1.0 + 0.0j))
            continue
        arr = np.asarray(item, dtype=np.float64)
        if arr.ndim == 1:
            out.append((as_point(arr, name=f"targets[{i}]"), np.zeros(3), 1.0 + 0.0j))
            continue
        raise TypeError(
            f"targets[{i}] must be a PointTarget, a (position, velocity) pair or a position, "
            f"got {item!r}"
        )
    if not out:
        raise ValueError("targets must hold at least one target")
    return out


def _delays(
    targets: Sequence[Any], trajectory: Trajectory, reference_point_m: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """Exact differential delays ``dtau_q(s_j)`` (s), shape (n_targets, n_pulses)."""
    rho_o = as_point(reference_point_m, name="reference_point_m")
    tg = _normalise_targets(targets)
    s = trajectory.slow_times_s
    dtau = np.stack(
        [delta_tau(trajectory.positions_m, target_positions(p, v, s), rho_o) for p, v, _ in tg]
    )
    amp = np.array([r for _, _, r in tg], dtype=np.complex128)
    return dtau, amp


# ------------------------------------------------------------------ numerical rank
def gram_eigenvalues(matrix: ArrayLike, *, gram: bool = False) -> NDArray[np.float64]:
    """Eigenvalues of ``Y = M M^H`` in decreasing order.

    Parameters
    ----------
    matrix : (n_pulses, n_samples) array_like
        Traces ``M`` (real or complex), or ``Y`` itself when ``gram=True``.
    gram : bool
        ``matrix`` is already the Hermitian Gram matrix ``Y`` (n, n).

    Returns
    -------
    (k,) ndarray
        Eigenvalues (``k = n`` if ``gram`` else ``min(n_pulses, n_samples)``), the
        non-zero ones shared by ``M M^H`` and ``M^H M``; the smaller Gram matrix is used.
    """
    m = np.asarray(matrix)
    if m.ndim != 2:
        raise ValueError(f"matrix must be 2-D (n_pulses, n_samples), got shape {m.shape}")
    if gram:
        if m.shape[0] != m.shape[1]:
            raise ValueError(f"a Gram matrix must be square, got shape {m.shape}")
        y = m
    else:
        y = m @ m.conj().T if m.shape[0] <= m.shape[1] else m.conj().T @ m
    ev = np.linalg.eigvalsh(0.5 * (y + y.conj().T))
    return ev[::-1].astype(np.float64)


def numerical_rank(
    matrix: ArrayLike,
    *,
    eps: float = 1e-3,
    gram: bool = False,
    reference: float | None = None,
) -> int:
    """Number of eigenvalues of ``Y = M M^H`` at or above ``eps * reference``.

    Parameters
    ----------
    matrix : (n_pulses, n_samples) array_like
        Traces ``M``, or the Gram matrix ``Y`` (n, n) when ``gram=True``.
    eps : float
        Relative threshold in (0, 1), on the eigenvalues of ``Y`` (squared singular values
        of ``M``).
    gram : bool
        ``matrix`` is ``Y``.
    reference : float, optional
        Threshold reference. Default: the largest eigenvalue of ``Y``. The paper's
        ``N(n; eps ||y_hat||_inf, inf)`` (``eq:RANK_AS``) is obtained with
        ``reference = max(symbol)`` in the same units as ``Y`` (``1/dt`` scaling included).

    Returns
    -------
    int
        The numerical rank.
    """
    _kappa(eps)
    ev = gram_eigenvalues(matrix, gram=gram)
    ref = float(ev[0]) if reference is None else _positive(reference, "reference")
    if ref <= 0:
        return 0
    return int(np.count_nonzero(ev >= eps * ref))


# ------------------------------------------------------------------- trace models
def fast_time_grid(
    targets: Sequence[Any],
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    *,
    carrier_hz: float,
    bandwidth_hz: float,
    model: Model = "passband",
    samples_per_cycle: float = 4.0,
    n_widths: float = 6.0,
) -> NDArray[np.float64]:
    """Fast-time grid (s) that resolves the pulses and covers every trace.

    The window is ``[min dtau - n_widths/B, max dtau + n_widths/B]`` (the Gaussian envelope
    is ``exp(-n_widths^2/2)`` at its ends). The step is ``1 / (samples_per_cycle nu_o)``
    for ``"passband"`` (well below the Nyquist step ``1 / (2 nu_o)`` so that the Riemann
    sum ``eq:covar1p`` is the integral to ``~exp(-(pi (samples_per_cycle - 2) nu_o / B)^2)``)
    and ``1 / (2 B)`` for ``"baseband"`` (relative error ``~exp(-4 pi^2)``).

    Parameters
    ----------
    targets : sequence
        Targets as accepted by :func:`passband_traces`.
    trajectory : Trajectory
        Antenna positions and slow times.
    reference_point_m : (3,) array_like
        Reference point ``rho_o`` (m).
    carrier_hz, bandwidth_hz : float
        ``nu_o`` and ``B`` (Hz).
    model : {"passband", "baseband"}
        Which traces the grid is for.
    samples_per_cycle : float
        Passband samples per carrier period; must exceed 2.
    n_widths : float
        Margin in pulse widths ``1/B`` on both sides.

    Returns
    -------
    (n_samples,) ndarray
        Fast times relative to ``tau(s, rho_o)`` (s), uniformly spaced.
    """
    _check_model(model)
    nu = _positive(carrier_hz, "carrier_hz")
    bw = _positive(bandwidth_hz, "bandwidth_hz")
    if not samples_per_cycle > 2.0:
        raise ValueError(f"samples_per_cycle must exceed 2 (Nyquist), got {samples_per_cycle!r}")
    dtau, _ = _delays(targets, trajectory, reference_point_m)
    dt = 1.0 / (samples_per_cycle * nu) if model == "passband" else 0.5 / bw
    lo = float(dtau.min()) - n_widths / bw
    hi = float(dtau.max()) + n_widths / bw
    n = int(np.ceil((hi - lo) / dt)) + 1
    return lo + dt * np.arange(n, dtype=np.float64)


def _check_grid(fast_times_s: ArrayLike) -> NDArray[np.float64]:
    t = np.asarray(fast_times_s, dtype=np.float64)
    if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)):
        raise ValueError(f"fast_times_s must be a finite 1-D array of >= 2 times, got {t.shape}")
    return t


def passband_traces(
    targets: Sequence[Any],
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    *,
    carrier_hz: float,
    bandwidth_hz: float,
    fast_times_s: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """The paper's real matrix of traces ``M(s_j, t_l)`` (``eq:MOD8``, ``eq:TWO1``).

    ``M(s, t) = sum_q |sigma_q| cos(w_o (t - dtau_q(s)) + arg sigma_q)
    exp(-B^2 (t - dtau_q(s))^2 / 2)`` with the exact differential delay
    ``dtau_q(s) = tau(s, rho_q(s)) - tau(s, rho_o)`` (``eq:DeltaTau``, float64) and
    ``rho_q(s) = rho_q(0) + s u_q`` (``eq:MOD9``). Targets given as positions or
    ``(position, velocity)`` pairs have ``sigma = 1`` (the paper's equal reflectivities).

    Parameters
    ----------
    targets : sequence
        Each a :class:`~sarmotion.simulation.scene.PointTarget`, a ``(position_m, velocity_mps)``
        pair of (2,) or (3,) vectors (m, m/s), or a position (stationary target).
    trajectory : Trajectory
        Antenna positions (m) and slow times (s).
    reference_point_m : (3,) array_like
        Reference point ``rho_o`` (m).
    carrier_hz : float
        ``nu_o = w_o / (2 pi)`` (Hz).
    bandwidth_hz : float
        ``B`` (Hz) in ``exp(-B^2 t^2 / 2)``.
    fast_times_s : (n_samples,) array_like, optional
        Uniform fast-time grid (s); its step must resolve the carrier (``< 1 / (2 nu_o)``).
        Default: :func:`fast_time_grid` with the same arguments.

    Returns
    -------
    (n_pulses, n_samples) ndarray
        ``M``, float64. ``M M^T`` approximates ``(1/dt) int M(s, t) M(s', t) dt``
        (``eq:covar1p``), so it scales like ``1/dt``; the rank does not.

    Raises
    ------
    ValueError
        If the grid step does not resolve the carrier.
    """
    nu = _positive(carrier_hz, "carrier_hz")
    bw = _positive(bandwidth_hz, "bandwidth_hz")
    if fast_times_s is None:
        fast_times_s = fast_time_grid(
            targets, trajectory, reference_point_m, carrier_hz=nu, bandwidth_hz=bw
        )
    t = _check_grid(fast_times_s)
    dt = float(np.max(np.abs(np.diff(t))))
    if dt >= 0.5 / nu:
        raise ValueError(
            f"fast_times_s step {dt:.3g} s does not resolve the carrier: it must be below "
            f"1 / (2 carrier_hz) = {0.5 / nu:.3g} s"
        )
    dtau, amp = _delays(targets, trajectory, reference_point_m)
    w0 = 2.0 * np.pi * nu
    out = np.zeros((trajectory.n_pulses, t.size), dtype=np.float64)
    for d, a in zip(dtau, amp, strict=True):
        x = t[None, :] - d[:, None]
        out += abs(a) * np.cos(w0 * x + np.angle(a)) * np.exp(-0.5 * (bw * x) ** 2)
    return out


def baseband_traces(
    targets: Sequence[Any],
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    *,
    carrier_hz: float,
    bandwidth_hz: float,
    fast_times_s: ArrayLike | None = None,
) -> NDArray[np.complex128]:
    """Complex-baseband traces ``D(s, t) = sum_q sigma_q p(t - dtau_q) exp(-i w_o dtau_q)``.

    The direct fast-time formula of :func:`sarmotion.simulation.simulate` with
    ``Radar(pulse="gaussian")``, ``p(t) = exp(-B^2 t^2 / 2)``, on any grid and without
    the spectral truncation and circular wrap of the simulator.

    Parameters
    ----------
    targets, trajectory, reference_point_m, carrier_hz, bandwidth_hz
        As in :func:`passband_traces`.
    fast_times_s : (n_samples,) array_like, optional
        Fast-time grid (s); ``dt <~ 1/B`` suffices. Default: :func:`fast_time_grid` with
        ``model="baseband"``.

    Returns
    -------
    (n_pulses, n_samples) ndarray
        ``D``, complex128.
    """
    nu = _positive(carrier_hz, "carrier_hz")
    bw = _positive(bandwidth_hz, "bandwidth_hz")
    if fast_times_s is None:
        fast_times_s = fast_time_grid(
            targets,
            trajectory,
            reference_point_m,
            carrier_hz=nu,
            bandwidth_hz=bw,
            model="baseband",
        )
    t = _check_grid(fast_times_s)
    dtau, amp = _delays(targets, trajectory, reference_point_m)
    out = np.zeros((trajectory.n_pulses, t.size), dtype=np.complex128)
    for d, a in zip(dtau, amp, strict=True):
        cycles = nu * d
        cycles = cycles - np.round(cycles)
        phase = a * np.exp(-2j * np.pi * cycles)
        out += phase[:, None] * np.exp(-0.5 * (bw * (t[None, :] - d[:, None])) ** 2)
    return out


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


# ---------------------------------------------------------------------- prediction
def _half_band(bandwidth_hz: float, eps: float, pulse: str) -> float:
    """Angular half-width (rad/s) of the band where ``|p_hat|^2 >= eps`` of its peak."""
    if pulse == "gaussian":
        return bandwidth_hz * _kappa(eps)
    if pulse == "rect":
        _kappa(eps)
        return np.pi * bandwidth_hz
    raise ValueError(f"pulse must be 'gaussian' or 'rect', got {pulse!r}")


def _half_duration(bandwidth_hz: float, eps: float, pulse: str) -> float:
    """Half-width (s) of the support where ``|p(t)|^2 >= eps``."""
    if pulse == "gaussian":
        return _kappa(eps) / bandwidth_hz
    if pulse == "rect":
        return 1.0 / (np.pi * bandwidth_hz * np.sqrt(eps))
    raise ValueError(f"pulse must be 'gaussian' or 'rect', got {pulse!r}")


def _union_components(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lengths of the connected components of the union of intervals ``[lo_i, hi_i]``."""
    if lo.size == 0:
        return np.zeros(0)
    order = np.argsort(lo)
    lo, hi = lo[order], hi[order]
    reach = np.maximum.accumulate(hi)
    start_new = np.concatenate([[True], lo[1:] > reach[:-1]])
    idx = np.flatnonzero(start_new)
    ends = np.concatenate([reach[idx[1:] - 1], [reach[-1]]])
    return ends - lo[idx]


def _circle_components(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lengths of the components of the union of arcs ``[lo_i, hi_i]`` on a circle of ``2 pi``."""
    two_pi = 2.0 * np.pi
    if lo.size == 0:
        return np.zeros(0)
    if np.any(hi - lo >= two_pi):
        return np.array([two_pi])
    start = np.mod(lo, two_pi)
    end = start + (hi - lo)
    order = np.argsort(start)
    start, end = start[order], end[order]
    reach = np.maximum.accumulate(end)
    idx = np.flatnonzero(np.concatenate([[True], start[1:] > reach[:-1]]))
    c_lo = start[idx]
    c_hi = np.concatenate([reach[idx[1:] - 1], [reach[-1]]])
    # Only the last component can pass 2 pi; it swallows the first ones it reaches.
    last_lo, last_hi = c_lo[-1], c_hi[-1]
    i = 0
    while i < c_lo.size - 1 and last_hi - two_pi >= c_lo[i]:
        last_hi = max(last_hi, c_hi[i] + two_pi)
        i += 1
    lengths = np.concatenate([c_hi[i:-1] - c_lo[i:-1], [last_hi - last_lo]])
    return np.array([two_pi]) if lengths.max() >= two_pi else lengths


class _ScenePhaseSpace:
    """Per-target Doppler arcs and delay intervals of a scene over an aperture."""

    def __init__(
        self,
        targets: Sequence[Any],
        trajectory: Trajectory,
        reference_point_m: ArrayLike,
        *,
        carrier_hz: float,
        bandwidth_hz: float,
        eps: float,
        model: str,
        pulse: str,
    ) -> None:
        _check_model(model)
        nu = _positive(carrier_hz, "carrier_hz")
        bw = _positive(bandwidth_hz, "bandwidth_hz")
        omega = _half_band(bw, eps, pulse)
        if omega >= 2 * np.pi * nu:
            raise ValueError("the pulse band must lie below the carrier (bandwidth_hz too large)")
        dtau, _ = _delays(targets, trajectory, reference_point_m)
        s = trajectory.slow_times_s
        n = trajectory.n_pulses
        ds = trajectory.pulse_interval_s
        rate = np.gradient(dtau, s, axis=1)
        w0 = 2.0 * np.pi * nu
        # theta = ds * (w0 + omega') * rate(s), omega' in [-omega, omega]: bilinear hull.
        corners = ds * np.stack(
            [
                (w0 - omega) * rate.min(axis=1),
                (w0 - omega) * rate.max(axis=1),
                (w0 + omega) * rate.min(axis=1),
                (w0 + omega) * rate.max(axis=1),
            ]
        )
        half_cell = np.pi / n  # half a slow-time frequency resolution cell 2 pi / n
        self.theta_lo = corners.min(axis=0) - half_cell
        self.theta_hi = corners.max(axis=0) + half_cell
        self.delay_lo = dtau.min(axis=1)
        self.delay_hi = dtau.max(axis=1)
        self.omega = omega
        self.n = n
        self.sides = 2 if model == "passband" else 1

    def count(
        self,
        mask: NDArray[np.bool_] | None = None,
        *,
        delays: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    ) -> float:
        """Phase-space count of the selected targets (see :func:`predict_rank` Notes).

        ``delays`` overrides the delay intervals ``(lo, hi)`` (s) of the fast-time count,
        e.g. clipped to a window.
        """
        sel = np.ones(self.theta_lo.size, bool) if mask is None else mask
        if not np.any(sel):
            return 0.0
        lo, hi = self.theta_lo[sel], self.theta_hi[sel]
        if self.sides == 2:
            lo, hi = np.concatenate([lo, -hi]), np.concatenate([hi, -lo])
        doppler = float(np.sum(np.ceil(self.n * _circle_components(lo, hi) / (2 * np.pi) - 1e-9)))
        dlo, dhi = (self.delay_lo[sel], self.delay_hi[sel]) if delays is None else delays
        half_cell = 0.5 * np.pi / self.omega  # half a delay cell pi / omega
        cells = self.omega * _union_components(dlo - half_cell, dhi + half_cell) / np.pi
        delay = self.sides * float(np.sum(np.ceil(cells - 1e-9)))
        return float(min(self.n, doppler, delay))


def _sub_trajectory(trajectory: Trajectory, n_pulses: int | None) -> Trajectory:
    if n_pulses is None:
        return trajectory
    if not (isinstance(n_pulses, (int, np.integer)) and 2 <= n_pulses <= trajectory.n_pulses):
        raise ValueError(
            f"n_pulses must be an integer in [2, {trajectory.n_pulses}], got {n_pulses!r}"
        )
    start = (trajectory.n_pulses - int(n_pulses)) // 2
    return trajectory.sub_aperture(start, start + int(n_pulses))


def predict_rank(
    targets: Sequence[Any],
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    *,
    n_pulses: int | None = None,
    bandwidth_hz: float,
    carrier_hz: float = DEFAULT_CARRIER_HZ,
    eps: float = 1e-3,
    model: Model = "baseband",
    pulse: Literal["gaussian", "rect"] = "gaussian",
) -> int:
    """Predicted numerical rank of the traces of a scene over an aperture.

    Parameters
    ----------
    targets : sequence
        Targets as accepted by :func:`passband_traces` (equal reflectivities assumed).
    trajectory : Trajectory
        Antenna positions and slow times.
    reference_point_m : (3,) array_like
        Reference point ``rho_o`` (m).
    n_pulses : int, optional
        Use the central ``n_pulses`` pulses of ``trajectory`` (a sub-aperture); default all.
    bandwidth_hz : float
        ``B`` (Hz).
    carrier_hz : float
        ``nu_o`` (Hz); default the GOTCHA carrier.
    eps : float
        Relative threshold in (0, 1) on the eigenvalues of ``Y`` (as in
        :func:`numerical_rank`).
    model : {"baseband", "passband"}
        Complex-baseband traces (the library's data) or the paper's real traces.
    pulse : {"gaussian", "rect"}
        Compressed-pulse spectrum (:class:`~sarmotion.core.radar.Radar` ``pulse``).

    Returns
    -------
    int
        Predicted rank, between 1 and the number of pulses.

    Notes
    -----
    Target ``q`` with delay ``dtau_q(s)`` (exact, over the aperture) is a 2-D signal whose
    phase-space support is counted two ways, each an approximate upper bound on the rank
    (Landau-Pollak-Slepian time-frequency counts; the Szegő count ``eq:RANK_AS`` is the
    first one for a single straight trace):

    * slow time: the trace's carrier and pulse band ``w_o + [-Omega, Omega]`` is seen in
      slow time at ``theta = ds (w_o + omega) dtau_q'(s)``; each target covers an arc
      ``Theta_q`` (the hull over the aperture, so curved traces count their Doppler
      sweep), widened by half a resolution cell ``pi / n`` on each side (``n`` pulses).
      The count is ``n |C| / (2 pi)``, rounded up, summed over the connected components
      ``C`` of ``U_q Theta_q`` on the circle (passband: with the mirror arcs
      ``-Theta_q``). For one straight trace this is ``n`` times the Szegő fraction
      (``eq:AS_RANK`` or its baseband form) plus one per bump, rounded up.
    * fast time: the delays ``U_q [min dtau_q, max dtau_q]`` (each interval widened by
      half a delay cell ``pi / (2 Omega)``) carry ``Omega |C| / pi`` band-limited degrees
      of freedom per connected component ``C``, rounded up (twice for passband).

    ``Omega`` is the angular half-width where ``|p_hat|^2 >= eps`` of its peak:
    ``B sqrt(log 1/eps)`` (Gaussian) or ``pi B`` (rect). The prediction is
    ``min(n, slow-time count, fast-time count)``, at least 1.

    Compared with the sum of per-target Szegő ranks (an upper bound by subadditivity),
    the union counts once the Doppler shared by targets of equal cross range and motion,
    and the fast-time count the delays shared by targets in the same range cell. The
    latter is where the paper's two-target argument fails: with ``B |beta| <~ 1``
    (``eq:beta``) the interaction terms of ``eq:covar2`` lower the rank by about the
    rank of the slower target, at every aperture tested (1 to 16 degrees), so the rank
    is close to that of the faster-migrating target, not to the sum given by the
    Toeplitz part ``eq:seqc``; for ``B |beta| >> 1`` the Toeplitz part is exact.
    Reflectivities are ignored, as in the paper's equal-reflectivity model (a target
    with ``|sigma|^2`` below ``eps`` times the strongest would not count numerically).
    """
    traj = _sub_trajectory(trajectory, n_pulses)
    ps = _ScenePhaseSpace(
        targets,
        traj,
        reference_point_m,
        carrier_hz=carrier_hz,
        bandwidth_hz=bandwidth_hz,
        eps=eps,
        model=model,
        pulse=pulse,
    )
    return int(max(1, np.ceil(ps.count() - 1e-9)))


def _window_starts(n_samples: int, window_samples: int) -> list[int]:
    hop = max(1, int(np.ceil(window_samples / 2)))
    starts = list(range(0, n_samples - window_samples + 1, hop))
    if starts[-1] != n_samples - window_samples:
        starts.append(n_samples - window_samples)
    return starts


class _WindowPredictor:
    """Predicted rank of the stationary traces in fast-time windows of a radar."""

    def __init__(
        self,
        stationary_positions_m: ArrayLike,
        trajectory: Trajectory,
        reference_point_m: ArrayLike,
        radar: Radar,
        eps: float,
    ) -> None:
        pos = np.asarray(stationary_positions_m, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] not in (2, 3) or pos.shape[0] == 0:
            raise ValueError(
                f"stationary_positions_m must have shape (n_targets, 2 or 3), got {pos.shape}"
            )
        if not isinstance(radar, Radar):
            raise TypeError(f"radar must be a Radar, got {type(radar).__name__}")
        self.ps = _ScenePhaseSpace(
            list(pos),
            trajectory,
            reference_point_m,
            carrier_hz=radar.carrier_hz,
            bandwidth_hz=radar.bandwidth_hz,
            eps=eps,
            model="baseband",
            pulse=radar.pulse,
        )
        self.n_samples = radar.n_samples
        self.dt = radar.sample_interval_s
        self.period = self.n_samples * self.dt
        self.half = _half_duration(radar.bandwidth_hz, eps, radar.pulse)
        # Delay intervals folded into the circular fast-time window [t0, t0 + period).
        self.t0 = float(radar.fast_times_s[0]) - 0.5 * self.dt
        mid = 0.5 * (self.ps.delay_lo + self.ps.delay_hi)
        shift = -np.floor((mid - self.t0) / self.period) * self.period
        self.d_lo = self.ps.delay_lo + shift
        self.d_hi = self.ps.delay_hi + shift

    def ranks(self, window_samples: int) -> NDArray[np.int64]:
        w = int(window_samples)
        out = []
        for k in _window_starts(self.n_samples, w):
            a, b = self.t0 + k * self.dt, self.t0 + (k + w) * self.dt
            lo, hi, inside = [], [], np.zeros(self.d_lo.size, bool)
            for sh in (-self.period, 0.0, self.period):
                hit = (self.d_lo + sh - self.half < b) & (self.d_hi + sh + self.half > a)
                inside |= hit
                lo.append(np.clip(self.d_lo[hit] + sh, a, b))
                hi.append(np.clip(self.d_hi[hit] + sh, a, b))
            r = 0.0
            if np.any(inside):
                r = self.ps.count(inside, delays=(np.concatenate(lo), np.concatenate(hi)))
            out.append(int(min(np.ceil(r - 1e-9), w)))
        return np.array(out, dtype=np.int64)


def predict_window_ranks(
    stationary_positions_m: ArrayLike,
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    radar: Radar,
    *,
    window_samples: int,
    eps: float = 1e-3,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Predicted rank of the stationary traces in each fast-time window.

    Windows of ``window_samples`` samples tile the fast-time axis of ``radar`` with hop
    ``ceil(window_samples / 2)``, the last one ending at the last sample. A target is in
    a window when its delay interval over the aperture, widened by the pulse
    half-duration where ``|p|^2 >= eps`` (``sqrt(log 1/eps) / B`` Gaussian,
    ``1 / (pi B sqrt(eps))`` rect), meets the window (circularly, as the simulator wraps
    fast time). The rank is :func:`predict_rank`'s phase-space count (baseband model) of
    those targets, with the fast-time count on their delays clipped to the window,
    capped at ``window_samples``.

    Parameters
    ----------
    stationary_positions_m : (n_targets, 2) or (n_targets, 3) array_like
        Stationary target positions (m).
    trajectory : Trajectory
        Antenna positions and slow times.
    reference_point_m : (3,) array_like
        Reference point ``rho_o`` (m).
    radar : Radar
        Carrier, bandwidth, pulse shape, ``n_samples`` and ``dt``.
    window_samples : int
        Window length ``W`` (samples), ``1 <= W <= n_samples``.
    eps : float
        Relative rank threshold in (0, 1).

    Returns
    -------
    starts : (n_windows,) ndarray of int
        First sample of each window.
    ranks : (n_windows,) ndarray of int
        Predicted rank in each window.
    """
    if not (isinstance(window_samples, (int, np.integer)) and 1 <= window_samples):
        raise ValueError(f"window_samples must be a positive integer, got {window_samples!r}")
    if window_samples > radar.n_samples:
        raise ValueError(
            f"window_samples ({window_samples}) exceeds radar.n_samples ({radar.n_samples})"
        )
    wp = _WindowPredictor(stationary_positions_m, trajectory, reference_point_m, radar, eps)
    starts = np.array(_window_starts(radar.n_samples, int(window_samples)), dtype=np.int64)
    return starts, wp.ranks(int(window_samples))


def predict_window(
    stationary_positions_m: ArrayLike,
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    radar: Radar,
    *,
    max_rank_fraction: float = 0.1,
    relative_to: Literal["pulses", "min"] = "pulses",
    eps: float = 1e-3,
) -> int:
    """Fast-time window length (samples) for a windowed robust PCA.

    Rule: windows of ``W`` samples tile fast time at hop ``ceil(W / 2)``
    (:func:`predict_window_ranks`); ``W`` is acceptable when the predicted rank ``r`` of
    the stationary traces in every window satisfies

    * ``relative_to="pulses"`` (default): ``max r(W) <= max_rank_fraction * n_pulses``
      -- the stationary part is low rank with respect to the slow-time dimension;
    * ``relative_to="min"``: ``max r(W) <= max_rank_fraction * min(n_pulses, W)`` -- the
      robust-PCA recovery condition on the smaller dimension of the ``n_pulses x W``
      window (stricter for ``W < n_pulses``).

    The largest acceptable ``W`` between one pulse length (``2 x`` the half-duration
    where ``|p|^2 >= eps``) and ``n_samples`` is returned; if none is acceptable, the
    ``W`` with the smallest worst-case ratio (ties: the longest), the best the scene
    allows. Short windows always satisfy the first form since a window of ``W`` samples
    holds at most ``~ W B dt sqrt(log 1/eps) / pi + 1`` degrees of freedom; under the
    second form the ratio is roughly the number of stationary targets per fast-time
    sample, which windowing cannot lower once ``W < n_pulses``.

    Parameters
    ----------
    stationary_positions_m : (n_targets, 2) or (n_targets, 3) array_like
        Positions of the (known or imaged) stationary targets (m).
    trajectory : Trajectory
        Antenna positions and slow times of the data.
    reference_point_m : (3,) array_like
        Reference point ``rho_o`` (m).
    radar : Radar
        Carrier, bandwidth, pulse shape and fast-time sampling ``dt`` of the data.
    max_rank_fraction : float
        Admissible rank as a fraction of ``n_pulses`` (or ``min(n_pulses, W)``), in (0, 1].
    relative_to : {"pulses", "min"}
        Which dimension the admissible rank refers to.
    eps : float
        Relative rank threshold in (0, 1).

    Returns
    -------
    int
        Window length ``W`` in fast-time samples.
    """
    if not (0.0 < max_rank_fraction <= 1.0):
        raise ValueError(f"max_rank_fraction must be in (0, 1], got {max_rank_fraction!r}")
    if relative_to not in ("pulses", "min"):
        raise ValueError(f"relative_to must be 'pulses' or 'min', got {relative_to!r}")
    wp = _WindowPredictor(stationary_positions_m, trajectory, reference_point_m, radar, eps)
    n = trajectory.n_pulses
    n_samp = wp.n_samples
    w_min = max(1, min(n_samp, int(np.ceil(2 * wp.half / wp.dt))))
    chosen, best_w, best_ratio = None, w_min, np.inf
    for w in range(w_min, n_samp + 1):
        ratio = float(wp.ranks(w).max()) / (n if relative_to == "pulses" else min(n, w))
        if ratio <= max_rank_fraction:
            chosen = w
        if ratio <= best_ratio:
            best_w, best_ratio = w, ratio
    return int(chosen if chosen is not None else best_w)
