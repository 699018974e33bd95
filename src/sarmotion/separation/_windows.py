"""Windowed robust PCA: overlapping fast-time windows blended by a partition of unity.

:func:`windowed_rpca` cuts the fast-time axis into windows (:func:`window_bounds`),
decomposes each by :func:`sarmotion.separation.rpca.rpca`'s solvers -- all together by
the stacked IALM of :mod:`sarmotion.separation._stacked_ialm` where that is the faster
path (:func:`_stacked`) -- and blends the pieces with :func:`window_weights`.
:func:`choose_window` is the data-driven default window length.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from threadpoolctl import threadpool_limits

from ..core import ProgressCallback
from ..core.progress import report
from ._ialm import (
    RPCAResult,
    Solver,
    _check_options,
    _check_solver,
    _output_dtype,
    _solve,
    default_eta,
)
from ._thresholding import _AUTO_MIN_SIZE, SvdMode, _as_work_array, _single_threaded_blas
from .result import Decomposition

__all__ = ["choose_window", "window_bounds", "window_weights", "windowed_rpca"]

logger = logging.getLogger("sarmotion.separation.rpca")  # one name for the robust-PCA modules

#: Windows solved together by the stacked IALM (``_stacked_windows``), at most: bounds its
#: work arrays (about ten copies of the stack) on long inputs; on a GOTCHA degree all
#: 13 windows of 64 samples go in one stack.
_STACK_WINDOWS = 16


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
    scales and ``f`` no longer discriminates (as on the built-in scenes); the rule then
    returns the largest candidate ``w <= n_pulses`` (or ``min_window``): the widest
    window whose default ``eta`` keeps the value ``1 / sqrt(n_pulses)``, since a wider
    window lowers ``eta`` and pushes stationary echoes into ``S``. A zero matrix returns
    ``max_window``.

    The rule is empirical. Checked on rank-5 + 5 %-sparse 200 x 300 data (returns 300,
    the whole matrix), on column blocks of rank 2-3 with 5 % spikes (returns 64-128,
    where windowed RPCA recovers ``S``), and on the built-in ``example1``, ``example2``
    and ``scene1`` simulations with and without noise (returns 64, at or next to the
    window of least error in ``S``; ``tests/separation/test_rpca.py``, errors per window in
    ``docs/notes/rpca.md``). A window length predicted
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
    hence the same clutter left in ``S`` and mover coverage, faster (timings against it,
    with one and with two BLAS threads, in ``docs/notes/rpca.md``); the floor of this
    path is in that module's notes.

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
            piece = pieces[i]
        else:
            piece = _solve(
                block, solver=solver, rank=rank, eta=eta_i, tol=tol, max_iter=max_iter,
                mu=None, rho=1.5, svd=svd,
            )  # fmt: skip
        w = weights[i, a:b]
        low[:, a:b] += piece.low * w
        sparse[:, a:b] += piece.sparse * w
        n_iters.append(piece.n_iter)
        convs.append(piece.converged)
        ranks.append(piece.rank)
        histories.append(piece.residuals)
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
) -> list[Decomposition]:
    """Every window of ``m`` by :func:`._stacked_ialm.stacked_ialm`, in window order."""
    from ._stacked_ialm import stacked_ialm

    out: list[Decomposition] = []
    for first in range(0, len(bounds), _STACK_WINDOWS):
        chunk = bounds[first : first + _STACK_WINDOWS]
        blocks = np.stack([m[:, a:b] for a, b in chunk])
        low, sparse, n_iter, conv, hist, ranks = stacked_ialm(
            blocks, eta=eta, tol=tol, max_iter=max_iter, rho=1.5
        )
        out += [Decomposition(*d) for d in zip(low, sparse, n_iter, conv, hist, ranks, strict=True)]
    return out
