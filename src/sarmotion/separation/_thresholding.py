"""Proximal operators and the SVD policy of robust PCA.

The two proximal operators of principal component pursuit: the complex soft threshold
(:func:`soft_threshold`, of ``tau ||.||_1``) and singular value thresholding
(:func:`singular_value_threshold`, of ``tau ||.||_*``); and how the thresholding SVDs are
computed inside the IALM iterations (:class:`_Thresholder`): a full LAPACK SVD, or a
partial PROPACK SVD of the predicted number of singular values above the threshold, by
the rule of :func:`_use_partial`, with one BLAS thread (:func:`_single_threaded_blas`).
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Callable
from typing import Any, Literal, TypeVar

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from scipy.sparse.linalg import svds
from threadpoolctl import threadpool_limits

_T = TypeVar("_T")

__all__ = ["SvdMode", "singular_value_threshold", "soft_threshold"]

logger = logging.getLogger("sarmotion.separation.rpca")  # one name for the robust-PCA modules

SvdMode = Literal["auto", "full", "partial"]
_SVD_MODES = ("auto", "full", "partial")

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


def _largest_singular_value(m: NDArray) -> float:
    """``||m||_2`` by PROPACK (k = 1), or LAPACK when PROPACK fails or ``m`` is small."""
    if min(m.shape) > 2:
        res = _partial_svd(m, 1)
        if res is not None:
            return float(res[1][0])
    return float(scipy.linalg.svd(m, compute_uv=False, check_finite=False)[0])


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
