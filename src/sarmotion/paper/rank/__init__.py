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

from .model import (
    DEFAULT_CARRIER_HZ,
    baseband_traces,
    fast_time_grid,
    passband_traces,
)
from .numerical import (
    gram_eigenvalues,
    numerical_rank,
)
from .prediction import (
    predict_rank,
    predict_window,
    predict_window_ranks,
)
from .symbols import (
    alpha,
    alpha_j,
    baseband_rank_fraction,
    baseband_symbol,
    beta,
    hankel_sequence,
    symbol,
    symbol_rank_fraction,
    szego_rank_fraction,
    toeplitz_symbol_sequence,
    two_target_gram,
    two_target_sequence,
)

__all__ = [
    "DEFAULT_CARRIER_HZ",
    "alpha",
    "alpha_j",
    "baseband_rank_fraction",
    "baseband_symbol",
    "baseband_traces",
    "beta",
    "fast_time_grid",
    "gram_eigenvalues",
    "hankel_sequence",
    "numerical_rank",
    "passband_traces",
    "predict_rank",
    "predict_window",
    "predict_window_ranks",
    "symbol",
    "symbol_rank_fraction",
    "szego_rank_fraction",
    "toeplitz_symbol_sequence",
    "two_target_gram",
    "two_target_sequence",
]
