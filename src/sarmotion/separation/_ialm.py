"""Robust PCA of one matrix: the inexact augmented Lagrange multiplier method (IALM).

:func:`rpca` validates its options and dispatches to the IALM of Lin, Chen & Ma (2010,
Algorithm 5; :func:`_ialm`) or to accelerated alternating projections
(:mod:`sarmotion.separation.accaltproj`). Every solver returns one
:class:`Decomposition`; :class:`RPCAResult` is what the caller gets.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import positive as _positive
from ._thresholding import (
    _SVD_MODES,
    SvdMode,
    _as_work_array,
    _largest_singular_value,
    _shrink,
    _single_threaded_blas,
    _Thresholder,
)
from .result import Decomposition

__all__ = ["RPCAResult", "default_eta", "rpca"]

logger = logging.getLogger("sarmotion.separation.rpca")  # one name for the robust-PCA modules

Solver = Literal["ialm", "accaltproj"]
_SOLVERS = ("ialm", "accaltproj")

#: Ratio ``mu_bar / mu_0`` of the IALM penalty cap to its initial value (Lin et al.).
_MU_BAR_FACTOR = 1e7
#: Smallest IALM tolerance at which full SVDs run in single precision (``_full_svd``):
#: their rounding moved ``S`` by 1.6e-6 to 2.0e-6 (relative) on a GOTCHA matrix, at
#: least five times below this tolerance.
_SINGLE_PRECISION_TOL = 1e-5


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
        threshold, so the thresholding is exact), or the one expected faster at this
        size and predicted rank (``"auto"``, see Notes). All three give the same iterates up
        to rounding.
    solver : {"ialm", "accaltproj"}
        ``"ialm"``: principal component pursuit as above. ``"accaltproj"``: accelerated
        alternating projections (:mod:`sarmotion.separation.accaltproj`), a non-convex
        fixed-rank solver: ``eta`` scales its threshold (``beta = default_beta * eta /
        default_eta``), ``mu``, ``rho`` and ``svd`` are unused. On low-rank + sparse data
        it recovers the same ``L`` and ``S`` much faster than the full-SVD IALM; on real
        GOTCHA clutter (far from low rank, IALM's ``L`` has full rank) its fixed rank
        leaves much more clutter in ``S`` (``docs/notes/rpca.md``), so IALM stays the
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
    ``sv <= 0.2 min(n_pulses, n_samples)``, and the full LAPACK SVD otherwise: a Lanczos
    run pays off only when few singular values are sought from a matrix large enough
    (timings per size in ``docs/notes/rpca.md``, ``benchmarks/bench_rpca.py``).

    With ``tol >= 1e-5`` the full SVDs run in single precision: its rounding, ~1e-7
    relative, stays two orders below the stopping tolerance, so the iterates and ``S``
    agree with the double-precision run to about a hundredth of the tolerance
    (``tests/separation/test_rpca.py::test_single_precision_svds_keep_the_decomposition``;
    figures in ``docs/notes/rpca.md``). The partial SVDs stay in
    double precision; smaller tolerances keep double precision.
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
    d = _solve(
        m, solver=solver, rank=rank, eta=eta, tol=tol, max_iter=max_iter, mu=mu, rho=rho,
        svd=svd,
    )  # fmt: skip
    return RPCAResult(
        low_rank=d.low.astype(out_dtype, copy=False),
        sparse=d.sparse.astype(out_dtype, copy=False),
        n_iter=d.n_iter,
        converged=d.converged,
        residuals=d.residuals,
        rank=d.rank,
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
) -> Decomposition:
    """One matrix by the chosen solver."""
    if solver == "ialm":
        return _ialm(m, eta=eta, tol=tol, max_iter=max_iter, mu=mu, rho=rho, svd=svd)
    return _accaltproj(m, rank=rank, eta=eta, tol=tol, max_iter=max_iter)


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
) -> Decomposition:
    """IALM on a validated float64/complex128 matrix (see :func:`rpca`)."""
    norm_fro = float(np.linalg.norm(m))
    if norm_fro == 0.0:
        z = np.zeros_like(m)
        return Decomposition(z, z.copy(), 0, True, np.zeros(0), 0)
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
    return Decomposition(low, sparse, k, converged, residuals[:k].copy(), rank)


@_single_threaded_blas
def _accaltproj(
    m: NDArray[np.inexact], *, rank: int | None, eta: float, tol: float, max_iter: int
) -> Decomposition:
    """:func:`sarmotion.separation.accaltproj.accaltproj` with ``beta`` scaled by ``eta``."""
    from .accaltproj import accaltproj, default_beta

    beta = default_beta(m.shape) * eta / default_eta(m.shape)
    out = accaltproj(m, rank=rank, tol=tol, max_iter=max_iter, beta=beta)
    logger.debug("AccAltProj %s: %d iterations, converged=%s, rank %d", m.shape, out.n_iter,
                 out.converged, out.rank)  # fmt: skip
    return out


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
