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
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from scipy.sparse.linalg import svds
from threadpoolctl import threadpool_limits

from .._validation import positive as _positive
from ..core import ProgressCallback
from ..core.progress import report

_T = TypeVar("_T")

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

logger = logging.getLogger(__name__)

SvdMode = Literal["auto", "full", "partial"]
_SVD_MODES = ("auto", "full", "partial")
Solver = Literal["ialm", "accaltproj"]
_SOLVERS = ("ialm", "accaltproj")

#: Ratio ``mu_bar / mu_0`` of the IALM penalty cap to its initial value (Lin et al.).
_MU_BAR_FACTOR = 1e7
#: Initial number of singular values predicted by the partial-SVD heuristic (Lin et al.).
_SV_INITIAL = 10
#: Smallest Lanczos basis size given to PROPACK. scipy's default ``10 k`` fails to converge
#: for ``k <= 6`` on IALM iterates of 468 x 424 (measured); PROPACK stops as soon as the
#: ``k`` values converge, so a larger cap costs nothing when it is not needed.
_PROPACK_MIN_KMAX = 100
#: ``svd="auto"``: PROPACK only for matrices with ``min(shape) >= _AUTO_MIN_SIZE`` ...
_AUTO_MIN_SIZE = 96
#: ... and at most ``_AUTO_MAX_FRACTION * min(shape)`` singular values (see ``_use_partial``).
_AUTO_MAX_FRACTION = 0.2
#: Windows solved together by the stacked IALM (``_stacked_windows``), at most: bounds its
#: work arrays (about ten copies of the stack) on long inputs; on a GOTCHA degree all
#: 13 windows of 64 samples go in one stack.
_STACK_WINDOWS = 16
#: Smallest IALM tolerance at which full SVDs run in single precision (``_full_svd``):
#: their rounding moved ``S`` by 1.6e-6 to 2.0e-6 (relative) on a GOTCHA matrix, at
#: least five times below this tolerance.
_SINGLE_PRECISION_TOL = 1e-5


# --------------------------------------------------------------------------------------
# Result
# --------------------------------------------------------------------------------------
@dataclass(frozen=True, kw_only=True, eq=False)
class RPCAResult:
    """Low-rank + sparse decomposition ``M ~= L + S`` from :func:`rpca` / :func:`windowed_rpca`.

    Attributes
    ----------
    low_rank : (n_pulses, n_samples) ndarray
        ``L``, the stationary-target echoes. Same dtype as ``M`` for float32/64 and
        complex64/128 input (computed in float64/complex128); other input gives float64.
    sparse : (n_pulses, n_samples) ndarray
        ``S``, the moving-target echoes; same dtype as ``low_rank``.
    n_iter : int
        IALM iterations performed (windowed: the maximum over windows).
    converged : bool
        Whether the stopping rule ``||M - L - S||_F <= tol ||M||_F`` was met (windowed: in
        every window, with ``M`` the window's data).
    residuals : (n_iter,) ndarray
        Relative residual ``||M - L - S||_F / ||M||_F`` after each iteration, float64.
        Windowed: at each iteration the largest residual over the windows, a window that
        stopped early keeping its final value; the per-window histories are in
        ``window_residuals``.
    rank : int
        Rank of ``L``. Plain solver: the number of singular values kept by the last
        thresholding. Windowed: numerical rank of the reassembled ``L`` (singular values
        above ``max(n_pulses, n_samples) * eps * sigma_max``).
    eta : float
        Sparsity weight used (windowed: that of the windows, which all have one width).
    windows : tuple of (int, int)
        Half-open fast-time index ranges ``(start, stop)`` of the windows; empty for
        :func:`rpca`.
    window_n_iter : tuple of int
        Iterations per window (empty for :func:`rpca`).
    window_converged : tuple of bool
        Convergence per window (empty for :func:`rpca`).
    window_ranks : tuple of int
        Rank of ``L`` per window (empty for :func:`rpca`).
    window_residuals : tuple of ndarray
        Residual history per window (empty for :func:`rpca`).
    """

    low_rank: NDArray[np.inexact]
    sparse: NDArray[np.inexact]
    n_iter: int
    converged: bool
    residuals: NDArray[np.float64]
    rank: int
    eta: float
    windows: tuple[tuple[int, int], ...] = ()
    window_n_iter: tuple[int, ...] = ()
    window_converged: tuple[bool, ...] = ()
    window_ranks: tuple[int, ...] = ()
    window_residuals: tuple[NDArray[np.float64], ...] = ()


# --------------------------------------------------------------------------------------
# Proximal operators
# --------------------------------------------------------------------------------------
def soft_threshold(x: ArrayLike, tau: float) -> NDArray[np.inexact]:
    """Complex soft threshold (shrinkage), the proximal operator of ``tau ||.||_1``.

    ``shrink(x, tau) = x max(|x| - tau, 0) / |x|``, and 0 where ``x = 0``: the modulus is
    reduced by ``tau`` and the phase kept. For real ``x`` it is the familiar
    ``sign(x) max(|x| - tau, 0)``.

    Parameters
    ----------
    x : array_like
        Real or complex entries, any shape.
    tau : float
        Threshold, ``tau >= 0``, in the units of ``x``.

    Returns
    -------
    ndarray
        Same shape as ``x``; its floating dtype (integers give float64).
    """
    a = np.asarray(x)
    if not np.issubdtype(a.dtype, np.inexact):
        a = a.astype(np.float64)
    tau = float(tau)
    if not (math.isfinite(tau) and tau >= 0.0):
        raise ValueError(f"tau must be finite and >= 0, got {tau}")
    return _shrink(a, tau)


def _shrink(a: NDArray[np.inexact], tau: float) -> NDArray[np.inexact]:
    """:func:`soft_threshold` without validation (``a`` floating, ``tau >= 0``)."""
    mag = np.abs(a)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.divide(tau, mag)  # inf at x = 0, nan at x = 0 with tau = 0
    np.subtract(1.0, scale, out=scale)
    np.fmax(scale, 0.0, out=scale)  # fmax maps nan (0/0) to 0 and -inf to 0
    return a * scale


def singular_value_threshold(x: ArrayLike, tau: float) -> tuple[NDArray[np.inexact], int]:
    """Singular value thresholding, the proximal operator of ``tau ||.||_*``.

    ``D_tau(X) = U diag(max(sigma - tau, 0)) V^H`` with ``X = U diag(sigma) V^H`` the
    (complex) thin SVD, computed with LAPACK ``gesdd``.

    Parameters
    ----------
    x : (n, m) array_like
        Real or complex matrix.
    tau : float
        Threshold on the singular values, ``tau >= 0``.

    Returns
    -------
    low_rank : (n, m) ndarray
        ``D_tau(X)``, float64 or complex128.
    rank : int
        Number of singular values above ``tau`` (the rank of ``D_tau(X)``).
    """
    a = _as_work_array(x, name="x")
    tau = float(tau)
    if not (math.isfinite(tau) and tau >= 0.0):
        raise ValueError(f"tau must be finite and >= 0, got {tau}")
    u, s, vh = _full_svd(a)
    return _assemble(u, s, vh, tau)


def _assemble(
    u: NDArray, s: NDArray[np.float64], vh: NDArray, tau: float
) -> tuple[NDArray[np.inexact], int]:
    """``U_r diag(s_r - tau) V_r^H`` over the ``r`` singular values above ``tau``."""
    r = int(np.count_nonzero(s > tau))
    return (u[:, :r] * (s[:r] - tau)) @ vh[:r], r


def _full_svd(a: NDArray, *, single: bool = False) -> tuple[NDArray, NDArray[np.float64], NDArray]:
    """Thin SVD (LAPACK gesdd), singular values in decreasing order.

    A wide matrix is decomposed through its (tall) adjoint: measured 1.2x faster for a
    117 x 1024 complex matrix with 1 OpenBLAS thread (1.5-3x with 2 threads on a busy
    machine), no slower at 117 x 128 to 468 x 1024. ``single``: decomposed in single
    precision (complex64/float32) and returned in ``a``'s precision; measured 2.2x
    faster on a 469 x 424 complex matrix (78 against 171 ms, one thread, loaded machine).
    """
    work = a.astype(np.complex64 if a.dtype.kind == "c" else np.float32) if single else a
    if a.shape[1] > a.shape[0]:
        v, s, uh = scipy.linalg.svd(
            work.conj().T, full_matrices=False, lapack_driver="gesdd", check_finite=False
        )
        u, vh = uh.conj().T, v.conj().T
    else:
        u, s, vh = scipy.linalg.svd(
            work, full_matrices=False, lapack_driver="gesdd", check_finite=False
        )
    if single:
        return u.astype(a.dtype), s.astype(np.float64), vh.astype(a.dtype)
    return u, s, vh


def _partial_svd(
    a: NDArray, k: int, *, v0: NDArray | None = None
) -> tuple[NDArray, NDArray[np.float64], NDArray] | None:
    """Leading ``k`` singular triplets by Lanczos bidiagonalisation (PROPACK via ``svds``).

    ``v0`` (length ``a.shape[0]``) is the Lanczos start vector; without it a seeded random
    vector is used, so results are reproducible. Returns ``None`` when PROPACK does not
    converge (the caller then uses the full SVD).
    """
    kmax = max(10 * k, _PROPACK_MIN_KMAX)
    try:
        if v0 is None:
            u, s, vh = svds(a, k=k, solver="propack", maxiter=kmax, rng=np.random.default_rng(0))
        else:
            u, s, vh = svds(a, k=k, solver="propack", maxiter=kmax, v0=v0)
    except (np.linalg.LinAlgError, ValueError) as exc:  # no convergence / bad k
        logger.debug("PROPACK failed for k=%d on %s (%s); using full SVD", k, a.shape, exc)
        return None
    order = np.argsort(s)[::-1]
    return u[:, order], s[order], vh[order]


def _use_partial(n_min: int, k: int) -> bool:
    """The ``svd="auto"`` rule: PROPACK for ``k`` values iff ``n_min >= 96`` and ``k <= 0.2 n_min``.

    Decided by measurement on the project's 2-core machine (AMD EPYC, OpenBLAS 0.3.31,
    scipy 1.17), timing one thin SVD of a mid-run IALM iterate ``X = M - S + Y / mu`` of a
    complex rank-``(k - 1)`` + 5 %-sparse matrix: LAPACK ``gesdd`` (all values) against
    PROPACK for the ``k`` leading triplets (what the rank prediction asks for). Best of
    5 runs; gesdd in ms, then the ratio PROPACK time / gesdd time at ``k / n_min``; 2
    OpenBLAS threads (default) and, in brackets, ``OPENBLAS_NUM_THREADS=1``::

        shape       gesdd ms      k/n_min: 0.03        0.10        0.20        0.30        0.40
        117 x 32    0.29 (0.30)       2.1 (2.0)   1.8 (1.6)   1.6 (1.7)   2.0 (2.0)   2.2 (2.5)
        117 x 64    1.4  (0.95)      0.71 (0.67) 0.68 (0.95) 0.52 (0.76) 0.88 (1.3)  0.95 (1.3)
        117 x 128   3.8-7 (3.2)      0.21 (0.33) 0.22 (0.38) 0.38 (0.50) 0.32 (0.79) 1.1  (1.3)
        117 x 424   8-14 (7.5)       0.31 (0.34) 0.41 (0.35) 0.51 (0.47) 0.65 (0.59) 1.3  (0.88)
        117 x 1024  12-14 (16)       0.38 (0.36) 0.42 (0.31) 0.71 (0.39) 0.98 (0.58) 1.3  (0.82)
        468 x 424   53-58 (83)       0.13 (0.14) 0.41 (0.19) 0.85 (0.59) 1.6  (0.85) 2.4  (1.0)
        468 x 1024  144-215 (230)    0.12 (0.12) 0.22 (0.28) 0.59 (0.72) 1.3  (0.65) 2.0  (1.3)

    So for the windows of 32 samples a full SVD always wins (PROPACK has a fixed
    overhead of ~0.3 ms), at 64 the gain is marginal (end-to-end IALM on 117 x 64, rank
    5: 21.6 ms full, 21.8 ms partial) and from ~100 up PROPACK wins by 1.2-8x as long as
    ``k <= 0.2 n_min``; beyond ``~0.3 n_min`` LAPACK wins again. End-to-end IALM, rank-5
    + 5 % sparse, 1 thread, full / partial: 117 x 128 68 / 29 ms, 117 x 424 154 / 72 ms,
    117 x 1024 269 / 117 ms, 468 x 424 1780 / 320 ms, 468 x 1024 3540 / 900 ms.

    Caveat measured on the same machine: when other processes keep both cores busy, the
    2-thread OpenBLAS ``gesdd`` can slow down 10-100x (e.g. 117 x 128: 3 ms -> 0.2-1 s)
    while PROPACK degrades far less; setting ``OPENBLAS_NUM_THREADS=1`` avoids it.
    """
    return n_min >= _AUTO_MIN_SIZE and k <= _AUTO_MAX_FRACTION * n_min


# --------------------------------------------------------------------------------------
# Validation helpers
# --------------------------------------------------------------------------------------
def _as_work_array(m: ArrayLike, *, name: str = "M") -> NDArray[np.inexact]:
    """``m`` as a finite 2-D float64 or complex128 array (may share memory with ``m``)."""
    a = np.asarray(m)
    if a.dtype.kind not in "biufc":
        raise TypeError(f"{name} must be a numeric (real or complex) array, got dtype {a.dtype}")
    if a.ndim != 2:
        raise ValueError(f"{name} must be 2-D (n_pulses, n_samples), got shape {a.shape}")
    if a.size == 0:
        raise ValueError(f"{name} must be non-empty, got shape {a.shape}")
    a = a.astype(np.complex128 if a.dtype.kind == "c" else np.float64, copy=False)
    if not np.isfinite(a).all():
        bad = int(a.size - np.count_nonzero(np.isfinite(a)))
        raise ValueError(f"{name} must be finite, got {bad} NaN/inf entries of {a.size}")
    return a


def _output_dtype(dtype: np.dtype) -> np.dtype:
    """Input precision and kind kept for float32/64 and complex64/128, else float64."""
    if dtype in (np.float32, np.float64, np.complex64, np.complex128):
        return np.dtype(dtype)
    return np.dtype(np.float64)


def _check_options(
    *, eta: float | None, tol: float, max_iter: int, svd: str
) -> tuple[float | None, float, int]:
    if eta is not None:
        eta = _positive(eta, "eta")
    tol = _positive(tol, "tol")
    if isinstance(max_iter, bool) or not isinstance(max_iter, int | np.integer):
        raise TypeError(f"max_iter must be an int, got {max_iter!r}")
    if max_iter < 1:
        raise ValueError(f"max_iter must be >= 1, got {max_iter}")
    if svd not in _SVD_MODES:
        raise ValueError(f"svd must be one of {_SVD_MODES}, got {svd!r}")
    return eta, tol, int(max_iter)


def default_eta(shape: tuple[int, int]) -> float:
    """Default sparsity weight ``eta = 1 / sqrt(max(n_rows, n_cols))`` (Candes et al.).

    Parameters
    ----------
    shape : (int, int)
        Shape ``(n_pulses, n_samples)`` of the matrix (or window) decomposed.

    Returns
    -------
    float
    """
    return 1.0 / math.sqrt(max(shape))


# --------------------------------------------------------------------------------------
# IALM
# --------------------------------------------------------------------------------------
def rpca(
    M: ArrayLike,
    *,
    eta: float | None = None,
    tol: float = 1e-7,
    max_iter: int = 1000,
    mu: float | None = None,
    rho: float = 1.5,
    svd: SvdMode = "auto",
    solver: Solver = "ialm",
    rank: int | None = None,
) -> RPCAResult:
    r"""Principal component pursuit ``M = L + S`` by the inexact ALM method.

    Solves ``min ||L||_* + eta ||S||_1  s.t.  L + S = M`` (``eq:OPTIMIZATION``) with
    Algorithm 5 of Lin, Chen & Ma (2010). With ``Y`` the multiplier and ``mu`` the
    penalty, each iteration ``k`` does::

        S <- shrink(M - L + Y / mu, eta / mu)           (complex soft threshold)
        L <- D_{1/mu}(M - S + Y / mu)                   (singular value threshold)
        Y <- Y + mu (M - L - S)
        mu <- min(rho mu, mu_bar)

    starting from ``L = S = 0``, ``Y = M / max(||M||_2, ||M||_inf / eta)`` (``||M||_inf``
    the largest modulus), ``mu = 1.25 / ||M||_2`` and ``mu_bar = 1e7 mu``.

    Stopping rule: stop after the first iteration ``k`` with

    .. math:: \|M - L_k - S_k\|_F \le \mathrm{tol}\, \|M\|_F,

    or after ``max_iter`` iterations (then ``converged`` is False).

    Parameters
    ----------
    M : (n_pulses, n_samples) array_like
        Traces, real or complex (complex64/128 baseband data), finite.
    eta : float, optional
        Weight of ``||S||_1``, > 0. Default ``1 / sqrt(max(n_pulses, n_samples))``.
    tol : float
        Relative residual tolerance of the stopping rule, > 0.
    max_iter : int
        Maximum number of iterations, >= 1.
    mu : float, optional
        Initial penalty, > 0 (units of 1 / ``M``). Default ``1.25 / ||M||_2``.
    rho : float
        Growth factor of the penalty per iteration, >= 1.
    svd : {"auto", "full", "partial"}
        Singular value thresholding by a full LAPACK SVD (``"full"``), by a partial
        PROPACK SVD of the predicted number of singular values above the threshold
        (``"partial"``; grows the prediction until one computed value falls below the
        threshold, so the thresholding is exact), or the faster of the two as measured
        on the target sizes (``"auto"``, see Notes). All three give the same iterates up
        to rounding.
    solver : {"ialm", "accaltproj"}
        ``"ialm"``: principal component pursuit as above. ``"accaltproj"``: accelerated
        alternating projections (:mod:`sarmotion.separation.accaltproj`), a non-convex
        fixed-rank solver: ``eta`` scales its threshold (``beta = default_beta * eta /
        default_eta``), ``mu``, ``rho`` and ``svd`` are unused. On low-rank + sparse data
        it recovers the same ``L`` and ``S`` 10-50x faster than the full-SVD IALM; on real
        GOTCHA clutter (far from low rank, IALM's ``L`` has full rank) it leaves more
        clutter in ``S`` (measured on a degree with two injected movers, windows of 64,
        ``eta`` x 2: 4 dB of clutter reduction against IALM's 14 dB), so IALM stays the
        default.
    rank : int, optional
        ``solver="accaltproj"``: rank of ``L``; default estimated from the data
        (:func:`sarmotion.separation.accaltproj.estimate_rank`). Ignored by IALM.

    Returns
    -------
    RPCAResult
        ``low_rank`` and ``sparse`` (n_pulses, n_samples), ``n_iter``, ``converged``,
        ``residuals`` (relative, per iteration), ``rank`` of ``L`` and ``eta``.

    Raises
    ------
    ValueError
        ``M`` not 2-D, empty or not finite; ``eta``, ``tol``, ``mu`` not > 0; ``rho < 1``;
        ``max_iter < 1``; unknown ``svd``.
    TypeError
        ``M`` not numeric.

    Notes
    -----
    The partial SVD follows Lin et al.: it asks PROPACK for ``sv`` triplets, ``sv`` being
    predicted from the previous iteration (``r + 1`` after ``r`` values survived the
    threshold, ``r + round(0.05 min(n_pulses, n_samples))`` after a miss), starts 10.
    ``svd="auto"`` uses it iff ``min(n_pulses, n_samples) >= 96`` and
    ``sv <= 0.2 min(n_pulses, n_samples)``, and the full LAPACK SVD otherwise. Measured on
    the project's 2-core machine (per-SVD table in ``_use_partial``): LAPACK always wins
    on 117 x 32 windows, the two tie at 117 x 64, and PROPACK wins 1.2-8x per SVD from
    117 x 128 up while ``sv <= 0.2 min``. End-to-end IALM on rank-5 + 5 %-sparse complex
    data, full / auto: 117 x 424 154 / 72 ms, 117 x 1024 269 / 117 ms, 468 x 424
    1780 / 320 ms, 468 x 1024 3540 / 900 ms (1 OpenBLAS thread).

    With ``tol >= 1e-5`` the full SVDs run in single precision: on the 4 GOTCHA degrees
    with two injected movers (469 x 424, ``tol = 1e-4`` as in the analysis) the same 13
    iterations, ``S`` within 1.6e-6 of the double-precision run (relative), the clutter
    left in ``S`` the same to 1e-6 dB, 1.44x faster end to end on a loaded machine (the
    partial SVDs stay in double precision). Smaller tolerances keep double precision.
    """
    eta, tol, max_iter = _check_options(eta=eta, tol=tol, max_iter=max_iter, svd=svd)
    if mu is not None:
        mu = _positive(mu, "mu")
    rho = float(rho)
    if not (math.isfinite(rho) and rho >= 1.0):
        raise ValueError(f"rho must be finite and >= 1, got {rho}")
    _check_solver(solver, rank)
    out_dtype = _output_dtype(np.asarray(M).dtype)
    m = _as_work_array(M)
    if eta is None:
        eta = default_eta(m.shape)
    low, sparse, n_iter, converged, residuals, rank = _solve(
        m, solver=solver, rank=rank, eta=eta, tol=tol, max_iter=max_iter, mu=mu, rho=rho,
        svd=svd,
    )  # fmt: skip
    return RPCAResult(
        low_rank=low.astype(out_dtype, copy=False),
        sparse=sparse.astype(out_dtype, copy=False),
        n_iter=n_iter,
        converged=converged,
        residuals=residuals,
        rank=rank,
        eta=eta,
    )


def _check_solver(solver: str, rank: int | None) -> None:
    if solver not in _SOLVERS:
        raise ValueError(f"solver must be one of {_SOLVERS}, got {solver!r}")
    if rank is not None:
        if isinstance(rank, bool) or not isinstance(rank, int | np.integer):
            raise TypeError(f"rank must be an int, got {rank!r}")
        if rank < 1:
            raise ValueError(f"rank must be >= 1, got {rank}")


def _solve(
    m: NDArray[np.inexact],
    *,
    solver: str,
    rank: int | None,
    eta: float,
    tol: float,
    max_iter: int,
    mu: float | None,
    rho: float,
    svd: str,
) -> tuple[NDArray, NDArray, int, bool, NDArray[np.float64], int]:
    """One matrix by the chosen solver: ``(L, S, n_iter, converged, residuals, rank)``."""
    if solver == "ialm":
        return _ialm(m, eta=eta, tol=tol, max_iter=max_iter, mu=mu, rho=rho, svd=svd)
    return _accaltproj(m, rank=rank, eta=eta, tol=tol, max_iter=max_iter)


def _largest_singular_value(m: NDArray) -> float:
    """``||m||_2`` by PROPACK (k = 1), or LAPACK when PROPACK fails or ``m`` is small."""
    if min(m.shape) > 2:
        res = _partial_svd(m, 1)
        if res is not None:
            return float(res[1][0])
    return float(scipy.linalg.svd(m, compute_uv=False, check_finite=False)[0])


def _single_threaded_blas(func: Callable[..., _T]) -> Callable[..., _T]:
    """Run ``func`` with one BLAS thread.

    The SVDs here are small (117 x 32 to 468 x 1024). With OpenBLAS's default two
    threads on the 2-core machines this project targets, windowed RPCA of Scene 1
    (window 64) took 3.1-18 s right after a numba-parallel backprojection or beside another
    busy process, against 0.43 s with one thread (measured in one process); a single
    thread is also as fast on an idle machine at these sizes.
    """

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> _T:
        with threadpool_limits(limits=1, user_api="blas"):
            return func(*args, **kwargs)

    return wrapper


@_single_threaded_blas
def _ialm(
    m: NDArray[np.inexact],
    *,
    eta: float,
    tol: float,
    max_iter: int,
    mu: float | None,
    rho: float,
    svd: str,
) -> tuple[NDArray, NDArray, int, bool, NDArray[np.float64], int]:
    """IALM on a validated float64/complex128 matrix (see :func:`rpca`)."""
    norm_fro = float(np.linalg.norm(m))
    if norm_fro == 0.0:
        z = np.zeros_like(m)
        return z, z.copy(), 0, True, np.zeros(0), 0
    norm_two = _largest_singular_value(m)
    norm_inf = float(np.abs(m).max())
    y = m / max(norm_two, norm_inf / eta)
    if mu is None:
        mu = 1.25 / norm_two
    mu_bar = mu * _MU_BAR_FACTOR
    threshold = _Thresholder(m.shape, svd, single=tol >= _SINGLE_PRECISION_TOL)
    low = np.zeros_like(m)
    residuals = np.empty(max_iter)
    converged = False
    rank = 0
    k = 0
    for k in range(1, max_iter + 1):
        m_y = m + y / mu
        sparse = _shrink(m_y - low, eta / mu)
        low, rank = threshold(m_y - sparse, 1.0 / mu)
        z = m - low - sparse
        y += mu * z
        mu = min(mu * rho, mu_bar)
        residuals[k - 1] = float(np.linalg.norm(z)) / norm_fro
        if residuals[k - 1] <= tol:
            converged = True
            break
    logger.debug(
        "IALM %s: %d iterations, converged=%s, residual %.3g, rank %d, SVDs %d partial %d full",
        m.shape,
        k,
        converged,
        residuals[k - 1],
        rank,
        threshold.n_partial,
        threshold.n_full,
    )
    return low, sparse, k, converged, residuals[:k].copy(), rank


@_single_threaded_blas
def _accaltproj(
    m: NDArray[np.inexact], *, rank: int | None, eta: float, tol: float, max_iter: int
) -> tuple[NDArray, NDArray, int, bool, NDArray[np.float64], int]:
    """:func:`sarmotion.separation.accaltproj.accaltproj` with ``beta`` scaled by ``eta``."""
    from .accaltproj import accaltproj, default_beta

    beta = default_beta(m.shape) * eta / default_eta(m.shape)
    out = accaltproj(m, rank=rank, tol=tol, max_iter=max_iter, beta=beta)
    logger.debug("AccAltProj %s: %d iterations, converged=%s, rank %d", m.shape, out[2],
                 out[3], out[5])  # fmt: skip
    return out


def _stacked(solver: str, svd: str, n_min: int) -> bool:
    """Whether :func:`windowed_rpca` runs its windows through the stacked IALM.

    Yes for IALM whenever the per-window IALM would threshold with full SVDs
    (``svd="full"``, or ``"auto"`` on windows with ``min(n_pulses, window) < 96``, where
    the rule of ``_use_partial`` never picks PROPACK); the partial-SVD path is kept
    where it is the faster one.
    """
    return solver == "ialm" and (svd == "full" or (svd == "auto" and n_min < _AUTO_MIN_SIZE))


@_single_threaded_blas
def _stacked_windows(
    m: NDArray[np.inexact],
    bounds: tuple[tuple[int, int], ...],
    *,
    eta: float,
    tol: float,
    max_iter: int,
) -> list[tuple[NDArray, NDArray, int, bool, NDArray[np.float64], int]]:
    """Every window of ``m`` by :func:`._stacked_ialm.stacked_ialm`, one tuple per window."""
    from ._stacked_ialm import stacked_ialm

    out: list[tuple[NDArray, NDArray, int, bool, NDArray[np.float64], int]] = []
    for first in range(0, len(bounds), _STACK_WINDOWS):
        chunk = bounds[first : first + _STACK_WINDOWS]
        blocks = np.stack([m[:, a:b] for a, b in chunk])
        low, sparse, n_iter, conv, hist, ranks = stacked_ialm(
            blocks, eta=eta, tol=tol, max_iter=max_iter, rho=1.5
        )
        out += list(zip(low, sparse, n_iter, conv, hist, ranks, strict=True))
    return out


class _Thresholder:
    """Singular value thresholding for one IALM run, with the partial-SVD bookkeeping.

    Holds the predicted number ``sv`` of singular values above the next threshold (Lin et
    al.: ``sv = r + 1`` after ``r`` values survived, ``sv = r + round(0.05 n_min)`` when
    the prediction was too small) and the last left singular vectors, whose sum (plus a
    fixed seeded perturbation) starts the next Lanczos run: measured 20-30 % fewer
    PROPACK seconds on 117 x 424 to 468 x 1024 iterates than a random start.
    """

    def __init__(self, shape: tuple[int, int], mode: str, *, single: bool = False) -> None:
        self.n_min = min(shape)
        self.mode = mode
        self.single = single
        self.step = max(round(0.05 * self.n_min), 1)
        self.sv = min(_SV_INITIAL, self.n_min)
        self.u_prev: NDArray | None = None
        w = np.random.default_rng(0).standard_normal(shape[0])
        self.perturbation = w / np.linalg.norm(w)
        self.n_partial = 0
        self.n_full = 0

    def _partial_ok(self, k: int) -> bool:
        if k >= self.n_min:
            return False
        return self.mode == "partial" or (self.mode == "auto" and _use_partial(self.n_min, k))

    def __call__(self, x: NDArray, tau: float) -> tuple[NDArray, int]:
        """Return ``(D_tau(x), rank)`` and update the prediction."""
        k = self.sv
        grew = False
        while self._partial_ok(k):
            v0 = None
            if self.u_prev is not None and self.u_prev.shape[1] > 0:
                r = self.u_prev.shape[1]
                v0 = self.u_prev.sum(axis=1) + 0.1 * math.sqrt(r) * self.perturbation
            res = _partial_svd(x, k, v0=v0)
            if res is None:
                break
            self.n_partial += 1
            u, s, vh = res
            if s[-1] <= tau:  # the k-th value is below the threshold: nothing is missing
                return self._done(u, s, vh, tau, grew)
            grew = True
            k = min(k + self.step, self.n_min)
        self.n_full += 1
        u, s, vh = _full_svd(x, single=self.single)
        return self._done(u, s, vh, tau, grew)

    def _done(
        self, u: NDArray, s: NDArray[np.float64], vh: NDArray, tau: float, grew: bool
    ) -> tuple[NDArray, int]:
        low, r = _assemble(u, s, vh, tau)
        self.u_prev = u[:, :r]
        self.sv = min(r + (self.step if grew or r >= len(s) else 1), self.n_min)
        self.sv = max(self.sv, 1)
        return low, r


# --------------------------------------------------------------------------------------
# Windowing
# --------------------------------------------------------------------------------------
def _check_window(window: int, name: str = "window") -> int:
    if isinstance(window, bool) or not isinstance(window, int | np.integer):
        raise TypeError(f"{name} must be an int (fast-time samples), got {window!r}")
    if window < 1:
        raise ValueError(f"{name} must be >= 1 fast-time samples, got {window}")
    return int(window)


def window_bounds(n_samples: int, window: int, overlap: float) -> tuple[tuple[int, int], ...]:
    """Fast-time windows of ``window`` samples covering ``[0, n_samples)``.

    The nominal hop is ``max(1, round(window (1 - overlap)))``; the
    ``n = ceil((n_samples - window) / hop) + 1`` windows are then spread evenly, the first
    starting at 0 and the last ending at ``n_samples`` (start ``j`` is
    ``round(j (n_samples - window) / (n - 1))``), so every window has exactly ``window``
    samples and consecutive windows overlap by *at least* the requested fraction.

    Parameters
    ----------
    n_samples : int
        Number of fast-time samples, >= 1.
    window : int
        Window length (samples), >= 1; ``window >= n_samples`` gives the single window
        ``(0, n_samples)``.
    overlap : float
        Requested overlap of consecutive windows as a fraction of ``window``, in [0, 1).

    Returns
    -------
    tuple of (int, int)
        Half-open ``(start, stop)`` index ranges, increasing.
    """
    n_samples = _check_window(n_samples, "n_samples")
    window = _check_window(window)
    overlap = float(overlap)
    if not (0.0 <= overlap < 1.0):
        raise ValueError(f"overlap must be in [0, 1), got {overlap}")
    if window >= n_samples:
        return ((0, n_samples),)
    hop = max(1, round(window * (1.0 - overlap)))
    n_windows = math.ceil((n_samples - window) / hop) + 1
    starts = np.rint(np.linspace(0, n_samples - window, n_windows)).astype(int)
    return tuple((int(a), int(a) + window) for a in starts)


def window_weights(windows: tuple[tuple[int, int], ...], n_samples: int) -> NDArray[np.float64]:
    """Partition-of-unity blending weights of overlapping fast-time windows.

    Window ``i`` gets a raw taper ``g_i`` equal to 1 on its samples, times a rising
    squared-sine ramp ``sin^2(pi/2 (j + 1/2) / n_o)`` over the ``n_o`` samples it shares
    with window ``i - 1`` and a falling squared-cosine ramp over the samples it shares
    with window ``i + 1`` (no ramp at the ends of ``[0, n_samples)``). The weights are
    ``w_i = g_i / sum_k g_k``, so ``sum_i w_i = 1`` at every sample (to rounding),
    edges included. When each sample lies in at most two windows (overlap <= 1/2) the
    ramps of two neighbours are ``sin^2`` and ``cos^2`` of the same argument, already
    summing to 1, and the normalisation changes nothing.

    Parameters
    ----------
    windows : sequence of (int, int)
        Half-open ``(start, stop)`` ranges with increasing starts and stops (e.g. from
        :func:`window_bounds`) covering ``[0, n_samples)``.
    n_samples : int
        Number of fast-time samples.

    Returns
    -------
    (n_windows, n_samples) ndarray
        ``w[i, t]``, zero outside window ``i``, float64.

    Raises
    ------
    ValueError
        Windows out of range, not increasing, or leaving samples uncovered.
    """
    n_samples = _check_window(n_samples, "n_samples")
    wins = [(int(a), int(b)) for a, b in windows]
    if not wins:
        raise ValueError("windows must contain at least one (start, stop) pair, got none")
    for i, (a, b) in enumerate(wins):
        if not (0 <= a < b <= n_samples):
            raise ValueError(f"window {i} = ({a}, {b}) is not inside [0, {n_samples})")
        if i and not (a > wins[i - 1][0] and b > wins[i - 1][1]):
            raise ValueError(f"windows must be increasing, got {wins[i - 1]} then {(a, b)}")
    g = np.zeros((len(wins), n_samples))
    for i, (a, b) in enumerate(wins):
        g[i, a:b] = 1.0
        if i > 0 and wins[i - 1][1] > a:  # rising ramp over the overlap with the previous
            n_o = wins[i - 1][1] - a
            g[i, a : a + n_o] *= np.sin(0.5 * np.pi * (np.arange(n_o) + 0.5) / n_o) ** 2
        if i + 1 < len(wins) and wins[i + 1][0] < b:  # falling ramp over the next overlap
            c = wins[i + 1][0]
            n_o = b - c
            g[i, c:b] *= np.cos(0.5 * np.pi * (np.arange(n_o) + 0.5) / n_o) ** 2
    total = g.sum(axis=0)
    if not np.all(total > 0):
        gap = int(np.flatnonzero(total <= 0)[0])
        raise ValueError(f"windows must cover [0, {n_samples}); sample {gap} is in none")
    return g / total


def _gavish_donoho_omega(beta: float) -> float:
    """``omega(beta)`` of Gavish & Donoho's hard threshold ``omega(beta) * median(sigma)``."""
    return 0.56 * beta**3 - 0.95 * beta**2 + 1.82 * beta + 1.43


@_single_threaded_blas
def choose_window(
    M: ArrayLike,
    *,
    min_window: int = 16,
    max_window: int | None = None,
    max_rank_fraction: float = 0.1,
    rank_rtol: float = 1e-3,
) -> int:
    """Data-driven fast-time window length for :func:`windowed_rpca`.

    Rule: for each candidate length ``w`` (the powers of two in ``[min_window,
    max_window)`` and ``max_window`` itself; ``max_window`` defaults to ``n_samples``),
    tile the fast-time axis with non-overlapping windows of length ``w``
    (:func:`window_bounds` with overlap 0) and estimate each window's rank as the number
    of its singular values above::

        max(omega(beta) * median(sigma), rank_rtol * sigma_top),

    where ``omega(beta) * median(sigma)`` is the Gavish-Donoho optimal hard threshold
    for a low-rank matrix in white noise of unknown level (``beta = min/max`` aspect
    ratio of the window; "The optimal hard threshold for singular values is 4/sqrt(3)",
    IEEE Trans. Inf. Theory 60, 2014), which also sits above the bulk of singular values
    spread by sparse spikes, and ``sigma_top`` is the largest singular value over all
    windows of length ``w`` (so empty windows count as rank 0). The fraction of window
    ``w`` is ``f(w) = max_i rank_i / min(n_pulses, w)``. Return the *largest* ``w`` with
    ``f(w) <= max_rank_fraction`` (every window low-rank relative to its size, the regime
    of exact recovery). If there is none, the data are not low-rank at any of these
    scales and ``f`` no longer discriminates (it was 0.34-0.47 for every ``w`` on the
    built-in scenes); the rule then returns the largest candidate ``w <= n_pulses`` (or
    ``min_window``): the widest window whose default ``eta`` keeps the value
    ``1 / sqrt(n_pulses)``, since a wider window lowers ``eta`` and, measured on those
    scenes, pushes stationary echoes into ``S``. A zero matrix returns ``max_window``.

    The rule is empirical. Checked on rank-5 + 5 %-sparse 200 x 300 data (returns 300,
    the whole matrix), on column blocks of rank 2-3 with 5 % spikes (returns 64-128,
    where windowed RPCA recovers ``S``), and on the built-in ``example1``, ``example2``
    and ``scene1`` simulations with and without noise (returns 64; relative errors of
    ``S`` over windows of 16/32/64/128/424 samples were 0.46/0.35/0.24/0.28/1.4,
    0.86/0.86/0.79/0.89/4.6 and 0.59/0.58/0.56/0.55/2.5). A window length predicted
    from the scene geometry (the paper's rank analysis) can be passed to
    :func:`windowed_rpca` instead.

    Parameters
    ----------
    M : (n_pulses, n_samples) array_like
        Traces.
    min_window : int
        Smallest candidate length (samples), >= 1.
    max_window : int, optional
        Largest candidate length (samples); default (and at most) ``n_samples``.
    max_rank_fraction : float
        Largest accepted ``rank / min(n_pulses, w)``, in (0, 1].
    rank_rtol : float
        Floor of the rank threshold relative to ``sigma_top``, in [0, 1).

    Returns
    -------
    int
        Window length in fast-time samples, in ``[min(min_window, n_samples), max_window]``.
    """
    m = _as_work_array(M)
    n_pulses, n_samples = m.shape
    min_window = _check_window(min_window, "min_window")
    max_window = n_samples if max_window is None else _check_window(max_window, "max_window")
    max_window = min(max_window, n_samples)
    min_window = min(min_window, max_window)
    max_rank_fraction = float(max_rank_fraction)
    if not (0.0 < max_rank_fraction <= 1.0):
        raise ValueError(f"max_rank_fraction must be in (0, 1], got {max_rank_fraction}")
    rank_rtol = float(rank_rtol)
    if not (0.0 <= rank_rtol < 1.0):
        raise ValueError(f"rank_rtol must be in [0, 1), got {rank_rtol}")
    candidates = [2**j for j in range(max_window.bit_length()) if min_window <= 2**j < max_window]
    candidates.append(max_window)
    fractions = []
    for w in candidates:
        svals = [
            scipy.linalg.svd(m[:, a:b], compute_uv=False, check_finite=False)
            for a, b in window_bounds(n_samples, w, 0.0)
        ]
        top = max(float(s[0]) for s in svals)
        if top == 0.0:
            return max_window
        omega = _gavish_donoho_omega(min(n_pulses, w) / max(n_pulses, w))
        worst = max(
            int(np.count_nonzero(s > max(omega * float(np.median(s)), rank_rtol * top)))
            for s in svals
        )
        fractions.append(worst / min(n_pulses, w))
    logger.debug(
        "choose_window: rank fractions %s",
        ", ".join(f"{w}: {f:.3f}" for w, f in zip(candidates, fractions, strict=True)),
    )
    ok = [w for w, f in zip(candidates, fractions, strict=True) if f <= max_rank_fraction]
    if ok:
        return max(ok)
    return max([w for w in candidates if w <= n_pulses] or [candidates[0]])


def windowed_rpca(
    M: ArrayLike,
    *,
    window: int | None = None,
    overlap: float = 0.5,
    eta: float | None = None,
    tol: float = 1e-7,
    max_iter: int = 1000,
    svd: SvdMode = "auto",
    progress: ProgressCallback | None = None,
    solver: Solver = "ialm",
    rank: int | None = None,
) -> RPCAResult:
    r"""Robust PCA on overlapping fast-time windows, blended into one ``L + S``.

    The fast-time axis (axis 1) is cut into windows of ``window`` samples overlapping by
    at least ``overlap`` (:func:`window_bounds`); :func:`rpca` separates each window
    ``M_i = M[:, a_i:b_i]`` into ``L_i + S_i``, and the pieces are blended with the
    partition of unity ``w_i`` of :func:`window_weights`::

        L = sum_i w_i L_i,   S = sum_i w_i S_i,   so   M - L - S = sum_i w_i (M_i - L_i - S_i).

    Stopping rule, per window: :math:`\|M_i - L_i - S_i\|_F \le \mathrm{tol}\,\|M_i\|_F`
    or ``max_iter`` iterations; hence ``||M - L - S||_F <= tol sum_i ||M_i||_F``.

    Parameters
    ----------
    M : (n_pulses, n_samples) array_like
        Traces, real or complex, finite.
    window : int, optional
        Window length (fast-time samples), >= 1. Default :func:`choose_window` ``(M)``.
        ``window >= n_samples`` is one window, the same as :func:`rpca`.
    overlap : float
        Overlap fraction of consecutive windows, in [0, 1).
    eta : float, optional
        Sparsity weight for every window. Default per window
        ``1 / sqrt(max(n_pulses, window))``.
    tol, max_iter, svd, solver, rank
        As in :func:`rpca`, for each window.
    progress : callable, optional
        ``progress("rpca", n_done, n_windows)`` after each window, ``n_done`` = 1, ...,
        ``n_windows`` (e.g. to advance a progress bar).

    Returns
    -------
    RPCAResult
        ``low_rank``, ``sparse`` (n_pulses, n_samples); ``n_iter`` the largest and
        ``converged`` the conjunction over windows; ``residuals`` the worst window's
        relative residual per iteration; ``rank`` the numerical rank of the blended
        ``L``; ``windows`` and the per-window ``window_*`` fields.

    Notes
    -----
    With ``solver="ialm"``, two or more windows and full SVDs (``svd="full"``, or
    ``"auto"`` with ``min(n_pulses, window) < 96``), the windows are solved together
    by :func:`sarmotion.separation._stacked_ialm.stacked_ialm`: the same IALM iterates
    and stopping rule per window, computed on the ``(n_windows, n_pulses, window)``
    stack, with the singular value thresholding taken from the eigen-decomposition of
    each window's Gram matrix (exact to ``window eps sigma_max / tau``, kept below
    ``tol / 100`` by falling back to ``gesdd``). On the four GOTCHA degrees with two
    injected movers (117 x 424, windows of 64, ``eta`` x 2, ``tol = 1e-5``) it gives the
    per-window iterations and ``S`` of the textbook full-SVD IALM to 3e-14 (relative),
    hence the same clutter left in ``S`` and mover coverage, 1.6-1.7x faster than it
    with one BLAS thread (2.8-28x against it on OpenBLAS's default two threads, a
    spread due to those threads on a busy 2-core machine); the floor of this path is in
    that module's notes.

    Principal component pursuit's minimiser on those windows has a full-rank ``L``
    (``sigma_min / sigma_max`` 0.016-0.15 in every window), as has IALM's last iterate;
    but IALM stopped at ``tol = 1e-5`` is not at the minimiser: the minimiser leaves
    -0.09, +0.07, +0.25 and +0.22 dB of clutter in ``S`` relative to it on the four
    degrees. A solver converging to the minimiser (accelerated proximal gradient on
    ``S`` with the nuclear norm's gradient ``-U V^H``, 73-87 thresholdings per degree
    against IALM's 179-183) therefore does not reproduce IALM's separation to 0.2 dB
    and is not used.
    """
    eta, tol, max_iter = _check_options(eta=eta, tol=tol, max_iter=max_iter, svd=svd)
    _check_solver(solver, rank)
    out_dtype = _output_dtype(np.asarray(M).dtype)
    m = _as_work_array(M)
    n_pulses, n_samples = m.shape
    if window is None:
        window = choose_window(m)
        logger.debug("windowed_rpca: chose window %d of %d samples", window, n_samples)
    window = _check_window(window)
    bounds = window_bounds(n_samples, window, overlap)
    weights = window_weights(bounds, n_samples)
    low = np.zeros_like(m)
    sparse = np.zeros_like(m)
    n_iters: list[int] = []
    convs: list[bool] = []
    ranks: list[int] = []
    histories: list[NDArray[np.float64]] = []
    etas: list[float] = []
    width = bounds[0][1] - bounds[0][0]
    if len(bounds) > 1 and _stacked(solver, svd, min(n_pulses, width)):
        eta_w = eta if eta is not None else default_eta((n_pulses, width))
        pieces = _stacked_windows(m, bounds, eta=eta_w, tol=tol, max_iter=max_iter)
    else:
        pieces = None
    for i, (a, b) in enumerate(bounds):
        block = m[:, a:b]
        eta_i = eta if eta is not None else default_eta(block.shape)
        etas.append(eta_i)
        if pieces is not None:
            l_i, s_i, it, conv, hist, rank_i = pieces[i]
        else:
            l_i, s_i, it, conv, hist, rank_i = _solve(
                block, solver=solver, rank=rank, eta=eta_i, tol=tol, max_iter=max_iter,
                mu=None, rho=1.5, svd=svd,
            )  # fmt: skip
        w = weights[i, a:b]
        low[:, a:b] += l_i * w
        sparse[:, a:b] += s_i * w
        n_iters.append(it)
        convs.append(conv)
        ranks.append(rank_i)
        histories.append(hist)
        report(progress, "rpca", i + 1, len(bounds))
    n_iter = max(n_iters)
    worst = np.zeros(n_iter)
    for hist in histories:
        if hist.size:
            padded = np.concatenate([hist, np.full(n_iter - hist.size, hist[-1])])
            np.maximum(worst, padded, out=worst)
    if len(bounds) == 1:
        rank = ranks[0]
    else:
        with threadpool_limits(limits=1, user_api="blas"):
            s_low = scipy.linalg.svd(low, compute_uv=False, check_finite=False)
        rank = int(np.count_nonzero(s_low > max(low.shape) * np.finfo(float).eps * s_low[0]))
    logger.debug(
        "windowed_rpca: %d windows of %d samples, iterations %d..%d, all converged=%s",
        len(bounds),
        bounds[0][1] - bounds[0][0],
        min(n_iters),
        n_iter,
        all(convs),
    )
    return RPCAResult(
        low_rank=low.astype(out_dtype, copy=False),
        sparse=sparse.astype(out_dtype, copy=False),
        n_iter=n_iter,
        converged=all(convs),
        residuals=worst,
        rank=rank,
        eta=min(etas),
        windows=bounds,
        window_n_iter=tuple(n_iters),
        window_converged=tuple(convs),
        window_ranks=tuple(ranks),
        window_residuals=tuple(histories),
    )
