"""IALM on a stack of equal-shape matrices at once, thresholding through Gram matrices.

The windows of :func:`sarmotion.separation.rpca.windowed_rpca` all have one shape
(117 x 64 on a GOTCHA degree). :func:`stacked_ialm` runs the inexact ALM of
:func:`sarmotion.separation.rpca.rpca` on all of them in lock-step, so every step is one
NumPy call on a ``(n_windows, n, m)`` array instead of ``n_windows`` calls on small
matrices, and a window leaves the stack when it meets its stopping rule. The iterates
are those of the per-window IALM up to rounding (same ``mu`` schedule, same stopping
rule); only the way the singular value thresholding is computed changes.

Singular value thresholding through the Gram matrix
---------------------------------------------------
For ``A`` of shape ``(n, m)`` with ``n >= m`` and ``G = A^H A = V diag(sigma^2) V^H``::

    D_tau(A) = U diag(max(sigma - tau, 0)) V^H = A V diag(f(sigma^2)) V^H,
    f(w) = max(1 - tau / sqrt(w), 0),

since ``A V = U diag(sigma)``. One Hermitian eigen-decomposition of the ``m x m`` Gram
matrix (LAPACK ``heevd``) and two products replace the SVD of ``A`` (``gesdd``), and
the batched elementwise steps save most of the per-call overhead of the rest of the
iteration (timings: ``docs/notes/rpca.md``, from ``benchmarks/bench_rpca.py -k gotcha``).

Accuracy and the rule that guards it. The computed eigen-decomposition is exact for
a Gram matrix perturbed by ``E`` with ``||E|| ~ m eps sigma_max^2`` (backward stability
of the product and of ``heevd``). The thresholded matrix moves by the Daleckii-Krein
sum ``A V (f^[1] o (V^H E V)) V^H``, whose entries carry ``sigma_i f^[1](w_i, w_j)``
(``f^[1]`` the divided difference of ``f``); that factor is at most about ``1 / tau``
whatever the two eigenvalues (``1 / sigma_i`` when ``sigma_i`` is large, ``sigma_i /
(2 tau^2) ~ 1 / (2 tau)`` at the threshold, smaller below it). So::

    ||D_tau(A)_Gram - D_tau(A)|| <~ m eps sigma_max^2 / tau,

relative to ``sigma_max`` that is ``m eps sigma_max / tau``: the condition number is
not squared where it matters (``tests/separation/test_rpca_stacked.py`` holds the route to this
bound on matrices with singular values clustered at ``tau``). The Gram route is used for
a window while::

    m eps sigma_max / tau <= _GRAM_ACCURACY * tol,

keeping the thresholding error a hundred times below the stopping tolerance; past that
(``tau`` tiny against ``sigma_max``) the window is thresholded by ``gesdd``. With
``m = 64``: ``sigma_max / tau`` up to 7e6 at ``tol = 1e-5`` (IALM's ``1 / tau = mu``
starts at ``1.25 / ||M||_2`` and grows 1.5x per iteration: about 37 iterations;
GOTCHA windows stop after 13-15), 7e4 at ``tol = 1e-7`` (about 27 iterations).

The cost
--------
Per window and iteration: one ``heevd`` of the ``m x m`` Gram matrix, the Gram matrix and
two products, and two fused elementwise kernels (compiled with numba and cached on disk).
An exact thresholding per iteration along the IALM's own path cannot cost less than the
eigen-decompositions; the timings and the alternatives considered are in
``docs/notes/rpca.md``.
"""

from __future__ import annotations

import logging

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["stacked_ialm", "gram_threshold"]

logger = logging.getLogger(__name__)

#: Thresholding error allowed on the Gram route, as a fraction of the stopping tolerance.
_GRAM_ACCURACY = 1e-2
#: Ratio ``mu_bar / mu_0`` of the IALM penalty cap (as in :mod:`.rpca`).
_MU_BAR_FACTOR = 1e7


def gram_threshold(
    a: NDArray[np.inexact], tau: NDArray[np.float64], *, max_error: float = np.inf
) -> tuple[NDArray[np.inexact], NDArray[np.int_], NDArray[np.bool_]]:
    """Singular value thresholding ``D_tau`` of a stack of tall matrices via their Gram matrices.

    Parameters
    ----------
    a : (k, n, m) ndarray
        Stack of real or complex matrices with ``n >= m``.
    tau : (k,) ndarray
        Threshold of each matrix, > 0, in the units of ``a``.
    max_error : float
        Matrices with ``m eps sigma_max / tau > max_error`` (the bound of the Gram
        route's error relative to ``sigma_max``, see the module notes) are thresholded
        by ``gesdd`` instead.

    Returns
    -------
    low : (k, n, m) ndarray
        ``D_tau(a[i])`` for each ``i``; ``a``'s dtype.
    rank : (k,) ndarray of int
        Number of singular values above ``tau`` for each matrix.
    gram : (k,) ndarray of bool
        Whether each matrix went the Gram route (False: ``gesdd``).
    """
    k, n, m = a.shape
    if n < m:
        raise ValueError(f"a must be a stack of tall matrices (n >= m), got shape {a.shape}")
    ah = a.conj().swapaxes(1, 2)
    w, v = np.linalg.eigh(ah @ a)  # ascending eigenvalues
    np.maximum(w, 0.0, out=w)
    sigma = np.sqrt(w)
    t = tau[:, None]
    eps = np.finfo(w.dtype).eps
    gram = m * eps * (sigma[:, -1] / tau) <= max_error
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(sigma > t, 1.0 - t / sigma, 0.0)
    rank = np.count_nonzero(sigma > t, axis=1)
    low = a @ ((v * f[:, None, :]) @ v.conj().swapaxes(1, 2))
    if not gram.all():
        bad = np.flatnonzero(~gram)
        u, s, vh = np.linalg.svd(a[bad], full_matrices=False)
        tb = tau[bad][:, None]
        s_thr = np.maximum(s - tb, 0.0)
        low[bad] = (u * s_thr[:, None, :]) @ vh
        rank[bad] = np.count_nonzero(s > tb, axis=1)
    return low, rank, gram


def stacked_ialm(
    blocks: NDArray[np.inexact],
    *,
    eta: float,
    tol: float,
    max_iter: int,
    rho: float = 1.5,
) -> tuple[
    NDArray[np.inexact],
    NDArray[np.inexact],
    list[int],
    list[bool],
    list[NDArray[np.float64]],
    list[int],
]:
    """Inexact ALM (Lin, Chen & Ma, Algorithm 5) on every matrix of a stack, in lock-step.

    Same iteration, initialisation and stopping rule as
    :func:`sarmotion.separation.rpca.rpca` with ``mu`` left at its default, applied to
    each ``blocks[i]`` independently::

        S <- shrink(M + Y / mu - L, eta / mu);   L <- D_{1/mu}(M + Y / mu - S);
        Y <- Y + mu (M - L - S);                 mu <- min(rho mu, 1e7 mu_0),

    ``mu_0 = 1.25 / ||M_i||_2``, ``Y_0 = M_i / max(||M_i||_2, max|M_i| / eta)``; matrix
    ``i`` stops after the first iteration with ``||M_i - L_i - S_i||_F <= tol ||M_i||_F``
    (or after ``max_iter``). ``D_tau`` goes through :func:`gram_threshold`.

    Parameters
    ----------
    blocks : (k, n, m) ndarray
        Stack of finite float64 or complex128 matrices (e.g. the fast-time windows,
        ``(n_windows, n_pulses, window)``).
    eta : float
        Weight of ``||S||_1``, > 0 (one for all matrices).
    tol : float
        Relative residual tolerance, > 0.
    max_iter : int
        Maximum iterations per matrix, >= 1.
    rho : float
        Growth factor of ``mu`` per iteration, >= 1.

    Returns
    -------
    low, sparse : (k, n, m) ndarray
        ``L_i`` and ``S_i``, ``blocks``' dtype.
    n_iter : list of int
        Iterations per matrix (0 for a zero matrix).
    converged : list of bool
        Whether each matrix met the stopping rule.
    residuals : list of (n_iter_i,) ndarray
        Relative residual history per matrix.
    rank : list of int
        Singular values kept by each matrix's last thresholding.
    """
    transpose = blocks.shape[1] < blocks.shape[2]
    m = blocks.swapaxes(1, 2) if transpose else blocks  # tall: Gram on the short side
    k = m.shape[0]
    norm_fro = np.linalg.norm(m, axis=(1, 2))
    low = np.zeros_like(m)
    sparse = np.zeros_like(m)
    n_iter = np.zeros(k, dtype=int)
    converged = norm_fro == 0.0  # zero matrices: L = S = 0 after no iteration
    rank = np.zeros(k, dtype=int)
    hist = np.zeros((k, max_iter))
    active = np.flatnonzero(~converged)
    if active.size:
        ma = np.ascontiguousarray(m[active])
        g = ma.conj().swapaxes(1, 2) @ ma
        norm_two = np.sqrt(np.maximum(np.linalg.eigvalsh(g)[:, -1], 0.0))
        norm_inf = np.abs(ma).max(axis=(1, 2))
        y = ma / np.maximum(norm_two, norm_inf / eta)[:, None, None]
        mu = 1.25 / norm_two
        mu_bar = mu * _MU_BAR_FACTOR
        la = np.zeros_like(ma)
        sa = np.empty_like(ma)
        xa = np.empty_like(ma)
        fro = norm_fro[active]
        max_error = _GRAM_ACCURACY * tol
        n_gram = n_svd = 0
        for it in range(1, max_iter + 1):
            _sparse_step(ma, y, la, 1.0 / mu, eta / mu, sa, xa)
            la, ra, gram = gram_threshold(xa, 1.0 / mu, max_error=max_error)
            n_gram += int(gram.sum())
            n_svd += int(gram.size - gram.sum())
            res = np.sqrt(_dual_step(ma, la, sa, y, mu)) / fro
            mu = np.minimum(mu * rho, mu_bar)
            hist[active, it - 1] = res
            n_iter[active] = it
            rank[active] = ra
            done = res <= tol
            if it == max_iter:
                done[:] = True
            if done.any():
                converged[active[done]] = res[done] <= tol
                low[active[done]] = la[done]
                sparse[active[done]] = sa[done]
                keep = ~done
                active = active[keep]
                if not active.size:
                    break
                ma, la, y = ma[keep], la[keep], y[keep]
                sa, xa = sa[keep], xa[keep]
                mu, mu_bar, fro = mu[keep], mu_bar[keep], fro[keep]
        logger.debug(
            "stacked IALM %s: iterations %d..%d, thresholdings %d Gram, %d gesdd",
            blocks.shape,
            int(n_iter.min()),
            int(n_iter.max()),
            n_gram,
            n_svd,
        )
    if transpose:
        low, sparse = low.swapaxes(1, 2), sparse.swapaxes(1, 2)
    return (
        low,
        sparse,
        [int(i) for i in n_iter],
        [bool(c) for c in converged],
        [hist[i, : n_iter[i]].copy() for i in range(k)],
        [int(r) for r in rank],
    )


@numba.njit(nogil=True, cache=True)
def _sparse_step(ma, y, la, inv_mu, thr, sa, xa):  # pragma: no cover - compiled
    """``S = shrink(M + Y / mu - L, eta / mu)`` and ``X = M + Y / mu - S``, in one pass.

    All arrays ``(k, n, m)`` except ``inv_mu = 1 / mu`` and ``thr = eta / mu``, ``(k,)``;
    ``sa`` and ``xa`` are written. The soft threshold is that of
    :func:`.rpca.soft_threshold` (modulus reduced by ``thr``, phase kept, 0 at 0).
    """
    k, n, m = ma.shape
    for i in range(k):
        im = inv_mu[i]
        t = thr[i]
        t2 = t * t
        for j in range(n):
            for c in range(m):
                my = ma[i, j, c] + y[i, j, c] * im
                v = my - la[i, j, c]
                a2 = v.real * v.real + v.imag * v.imag
                if a2 > t2:
                    s = v * (1.0 - t / np.sqrt(a2))
                    sa[i, j, c] = s
                    xa[i, j, c] = my - s
                else:
                    sa[i, j, c] = 0.0
                    xa[i, j, c] = my


@numba.njit(nogil=True, cache=True)
def _dual_step(ma, la, sa, y, mu):  # pragma: no cover - compiled
    """``Z = M - L - S``, ``Y += mu Z`` in place; returns ``||Z_i||_F^2`` per matrix ``(k,)``."""
    k, n, m = ma.shape
    out = np.zeros(k)
    for i in range(k):
        mi = mu[i]
        acc = 0.0
        for j in range(n):
            for c in range(m):
                z = ma[i, j, c] - la[i, j, c] - sa[i, j, c]
                y[i, j, c] += mi * z
                acc += z.real * z.real + z.imag * z.imag
        out[i] = acc
    return out
