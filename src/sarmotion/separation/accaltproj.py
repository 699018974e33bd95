"""Accelerated alternating projections (AccAltProj) for complex robust PCA.

H. Cai, J.-F. Cai, K. Wei, "Accelerated alternating projections for robust principal
component analysis", JMLR 20 (2019). Non-convex: it looks for ``M = L + S`` with
``rank(L) = r`` and ``S`` sparse by alternating

    L_{k+1} = H_r(P_{T_k}(M - S_k))        (rank-r truncation of the projection of M - S_k
                                             on the tangent space of the rank-r matrices at L_k)
    zeta    = beta (sigma_{r+1} + gamma^{k+1} sigma_1)   (of P_{T_k}(M - S_k))
    S_{k+1} = HT_zeta(M - L_{k+1})            (keep the entries of modulus > zeta)

The tangent-space projection makes the rank-r truncation a ``2r x 2r`` SVD plus two thin QR
factorisations, so an iteration costs a few ``n x m x r`` products instead of the full SVD
of an IALM iteration. Complex data: conjugate transposes throughout, thresholds on moduli.

Initialisation (the paper's): ``S_0 = HT_{beta_init sigma_1(M)}(M)``, ``L_0`` the rank-r
truncated SVD of ``M - S_0``, then ``S`` thresholded at ``beta sigma_1(L_0)``.

Defaults: ``beta = 1 / (2 (n m)^{1/4})`` (the paper's ``mu r / (2 sqrt(n m))`` with the
incoherence ``mu r`` replaced by ``sqrt(sqrt(n m))``, tuned on the benchmark matrices),
``beta_init = 4 beta``, ``gamma = 0.5``. The principal-component-pursuit weight ``eta``
of :func:`sarmotion.separation.rpca.rpca` scales ``beta`` by ``eta / default_eta``: a
heavier penalty on ``S`` is a higher threshold for entering it. The rank, when not given,
is the number of singular values of ``M - S_0`` above the Gavish-Donoho threshold
``omega(beta) median(sigma)`` (at least 1), as in
:func:`sarmotion.separation.rpca.choose_window`.

On low-rank + sparse complex matrices it recovers the same ``L`` and ``S`` as IALM at
the same tolerance, much faster (``benchmarks/bench_rpca.py``, ``docs/notes/rpca.md``). On
real GOTCHA clutter, which is far from low rank, it is not a substitute for principal
component pursuit: see :func:`sarmotion.separation.rpca.rpca` (``solver``).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from .result import Decomposition

__all__ = ["accaltproj", "default_beta", "estimate_rank"]

#: Decay of the threshold's second term per iteration.
GAMMA = 0.5
#: Stop (not converged) when five iterations reduce the residual by less than 1 %.
STALL = 0.99


def default_beta(shape: tuple[int, int]) -> float:
    """Threshold scale ``beta = 1 / (2 (n m)^{1/4})`` for an ``n x m`` matrix."""
    n, m = shape
    return 1.0 / (2.0 * (n * m) ** 0.25)


def _hard_threshold(x: NDArray, zeta: float) -> NDArray:
    """Entries of modulus > ``zeta`` kept, others zero."""
    out = np.empty_like(x)
    _split(x, np.zeros_like(x), zeta * zeta, out)
    return out


@numba.njit(nogil=True, cache=True)
def _split(m, low, zeta2, sparse):  # pragma: no cover - compiled
    """``sparse = HT_zeta(m - low)``; returns ``||m - low - sparse||_F^2``. One pass."""
    n, k = m.shape
    acc = 0.0
    for i in range(n):
        for j in range(k):
            d = m[i, j] - low[i, j]
            a2 = d.real * d.real + d.imag * d.imag
            if a2 > zeta2:
                sparse[i, j] = d
            else:
                sparse[i, j] = 0.0
                acc += a2
    return acc


def estimate_rank(singular_values: NDArray[np.float64], shape: tuple[int, int]) -> int:
    """Gavish-Donoho hard-threshold rank (noise level unknown), at least 1.

    Parameters
    ----------
    singular_values : (k,) ndarray
        All singular values, decreasing.
    shape : (int, int)
        Matrix shape.
    """
    n, m = shape
    b = min(n, m) / max(n, m)
    omega = 0.56 * b**3 - 0.95 * b**2 + 1.82 * b + 1.43
    threshold = omega * float(np.median(singular_values))
    return max(1, int(np.count_nonzero(singular_values > threshold)))


def _largest_singular_value(m: NDArray, rng: np.random.Generator) -> float:
    """``||m||_2`` by 12 steps of block power iteration (block of 4), ~1e-3 relative.

    It only sets the first threshold.
    """
    x = rng.standard_normal((m.shape[1], 4))
    if np.iscomplexobj(m):
        x = x + 1j * rng.standard_normal((m.shape[1], 4))
    for _ in range(12):
        x, _ = np.linalg.qr(m.conj().T @ (m @ x))
    return float(np.linalg.norm(m @ x, 2))


def _singular_values(a: NDArray) -> NDArray[np.float64]:
    """All singular values, decreasing, from the eigenvalues of the smaller Gram matrix.

    Cheaper than LAPACK's values-only SVD (one Hermitian eigenproblem of the smaller side,
    ``docs/notes/rpca.md``); squaring the condition number only blurs values below ~1e-8
    sigma_1, which the rank rule does not look at.
    """
    g = a.conj().T @ a if a.shape[0] >= a.shape[1] else a @ a.conj().T
    lam = np.linalg.eigvalsh(g)[::-1]
    return np.sqrt(np.maximum(lam, 0.0))


def _truncated_svd(
    a: NDArray, r: int, rng: np.random.Generator, power: int = 3
) -> tuple[NDArray, NDArray[np.float64], NDArray]:
    """Rank-``r`` SVD ``(U, sigma, V)`` by a randomised range finder.

    ``r + 10`` columns, ``power`` subspace iterations (Halko, Martinsson & Tropp 2011):
    enough to start the iteration, which refines it.
    """
    k = min(r + 10, min(a.shape))
    x = rng.standard_normal((a.shape[1], k))
    if np.iscomplexobj(a):
        x = x + 1j * rng.standard_normal((a.shape[1], k))
    q, _ = np.linalg.qr(a @ x)
    for _ in range(power):
        w, _ = np.linalg.qr(a.conj().T @ q)
        q, _ = np.linalg.qr(a @ w)
    ub, sig, vh = np.linalg.svd(q.conj().T @ a, full_matrices=False)
    return (q @ ub)[:, :r], sig[:r], vh[:r].conj().T


def accaltproj(
    m: NDArray[np.inexact],
    *,
    rank: int | None = None,
    tol: float = 1e-7,
    max_iter: int = 1000,
    beta: float | None = None,
    beta_init: float | None = None,
    gamma: float = GAMMA,
) -> Decomposition:
    """AccAltProj on a finite float64/complex128 matrix.

    Parameters
    ----------
    m : (n, m) ndarray
        Data ``M``.
    rank : int, optional
        Rank of ``L``; default :func:`estimate_rank` of ``M - S_0``.
    tol : float
        Stop when ``||M - L - S||_F <= tol ||M||_F``.
    max_iter : int
        Iteration cap. The iteration also stops, unconverged, when five iterations reduce
        the residual by less than 1 % (a residual floor: data not low rank plus sparse).
    beta, beta_init : float, optional
        Threshold scales (default :func:`default_beta` and ``4 beta``).
    gamma : float
        Decay of the threshold's ``sigma_1`` term, in (0, 1).

    Returns
    -------
    Decomposition
        ``low`` and ``sparse`` (``L`` and ``S``, the dtype of ``m``), ``n_iter``,
        ``converged``, ``residuals`` (relative residual after each iteration, (n_iter,))
        and ``rank``.
    """
    norm_m = float(np.linalg.norm(m))
    if norm_m == 0.0:
        z = np.zeros_like(m)
        return Decomposition(z, z.copy(), 0, True, np.zeros(0), 0)
    beta = default_beta(m.shape) if beta is None else float(beta)
    beta_init = 4.0 * beta if beta_init is None else float(beta_init)
    rng = np.random.default_rng(0)
    s = _hard_threshold(m, beta_init * _largest_singular_value(m, rng))
    d = m - s
    r = estimate_rank(_singular_values(d), m.shape) if rank is None else int(rank)
    r = max(1, min(r, min(m.shape) // 2))
    u, sig, v = _truncated_svd(d, r, rng)
    low = (u * sig) @ v.conj().T
    s = np.empty_like(m)
    _split(m, low, (beta * sig[0]) ** 2, s)
    residuals = np.empty(max_iter)
    converged = False
    k = 0
    core = np.zeros((2 * r, 2 * r), dtype=m.dtype)
    for k in range(1, max_iter + 1):
        z = m - s
        zv = z @ v
        uhz = u.conj().T @ z
        uzv = uhz @ v
        q1, r1 = np.linalg.qr(uhz.conj().T - v @ uzv.conj().T)
        q2, r2 = np.linalg.qr(zv - u @ uzv)
        core[:r, :r] = uzv
        core[:r, r:] = r1.conj().T
        core[r:, :r] = r2
        uc, sc, vch = np.linalg.svd(core)
        u = np.hstack([u, q2]) @ uc[:, :r]
        v = np.hstack([v, q1]) @ vch[:r].conj().T
        low = (u * sc[:r]) @ v.conj().T
        zeta = beta * (sc[r] + gamma**k * sc[0])
        residuals[k - 1] = math.sqrt(_split(m, low, zeta * zeta, s)) / norm_m
        if residuals[k - 1] <= tol:
            converged = True
            break
        # Data that are not low rank plus sparse leave a residual floor (the tail of the
        # spectrum below the threshold): stop when 5 iterations gained less than 1 %.
        if not math.isfinite(residuals[k - 1]) or (
            k > 5 and residuals[k - 1] > STALL * residuals[k - 6]
        ):
            break
    return Decomposition(low, s, k, converged, residuals[:k].copy(), r)
