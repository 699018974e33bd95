"""Robust PCA (principal component pursuit) of complex traces, whole-matrix and windowed.

Separates the echoes of stationary targets (low rank ``L``) from those of moving targets
(sparse ``S``) in a matrix of traces ``M`` of shape ``(n_pulses, n_samples)`` (slow time
first, fast time last); paper section ``sect:RPCA``, ``eq:OPTIMIZATION``::

    min ||L||_* + eta ||S||_1   subject to   L + S = M,   eta = 1 / sqrt(max(n_rows, n_cols)),

solved with the inexact augmented Lagrange multiplier method (IALM) of Lin, Chen & Ma,
"The augmented Lagrange multiplier method for exact recovery of corrupted low-rank
matrices" (2010, arXiv:1009.5055, Algorithm 5).

For complex data ``||S||_1 = sum_jl |S_jl|`` (sum of moduli), so its proximal operator
shrinks the modulus and keeps the phase (:func:`soft_threshold`); the nuclear-norm
proximal operator thresholds the singular values of the complex SVD,
``U diag(max(sigma - tau, 0)) V^H`` (:func:`singular_value_threshold`).

:func:`windowed_rpca` applies :func:`rpca` to overlapping fast-time windows and blends the
pieces with a partition of unity (:func:`window_weights`): the windowing that the paper
calls "a key step to successful data separation with robust PCA". :func:`choose_window`
is the (replaceable) data-driven default for the window length.

One algorithm per module, their public names re-exported here:
:mod:`~sarmotion.separation._thresholding` (the proximal operators and the SVD policy),
:mod:`~sarmotion.separation._ialm` (:func:`rpca`: IALM and the solver dispatch),
:mod:`~sarmotion.separation._windows` (windows, :func:`choose_window`,
:func:`windowed_rpca`) and :mod:`~sarmotion.separation._stacked_ialm` (the windows in
lock-step). Every solver returns a :class:`~sarmotion.separation.result.Decomposition`.
"""

from ._ialm import RPCAResult, default_eta, rpca
from ._thresholding import singular_value_threshold, soft_threshold
from ._windows import choose_window, window_bounds, window_weights, windowed_rpca

__all__ = [
    "RPCAResult",
    "rpca",
    "windowed_rpca",
    "choose_window",
    "window_bounds",
    "window_weights",
    "soft_threshold",
    "singular_value_threshold",
    "default_eta",
]
