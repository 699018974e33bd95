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
#: Smallest Lanczos basis size given to PROPACK. scipy's default ``10 k`` can fail to
#: converge for small ``k`` on IALM iterates (seen at 468 x 424, ``k <= 6``); PROPACK
#: stops as soon as the ``k`` values converge, so a larger cap costs nothing when it is
#: not needed.
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

    A wide matrix is decomposed through its (tall) adjoint, which LAPACK handles faster
    and never slower at the sizes of windowed RPCA. ``single``: decomposed in single
    precision (complex64/float32) and returned in ``a``'s precision, about twice as fast
    (timings in ``docs/notes/rpca.md``).
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

    A Lanczos run (PROPACK) for the ``k`` leading triplets has a fixed overhead and a cost
    that grows with ``k``; LAPACK ``gesdd`` computes all values at a cost that grows with
    the matrix. So a full SVD wins on narrow windows (32 samples), the two tie near 64,
    and PROPACK wins from about 100 up while ``k`` is a small fraction of ``n_min``;
    beyond about a third of ``n_min`` LAPACK wins again. The thresholds sit inside those
    regions: timings of one thin SVD of mid-run IALM iterates per shape and ``k / n_min``,
    and end-to-end IALM, are in ``docs/notes/rpca.md`` (``benchmarks/bench_rpca.py``).
    A multi-threaded BLAS ``gesdd`` can slow down by orders of magnitude when other
    processes keep the cores busy, while PROPACK degrades far less: the callers run with
    one BLAS thread (:func:`_single_threaded_blas`).
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
    fixed seeded perturbation) starts the next Lanczos run: consecutive iterates share
    their leading subspace, so Lanczos converges in fewer steps than from a random start
    (``docs/notes/rpca.md``).
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

    The SVDs here are small (117 x 32 to 468 x 1024): BLAS threads gain nothing at these
    sizes on an idle machine, and on a busy one (or right after a numba-parallel region)
    their barriers wait for descheduled threads and multiply the time several-fold
    (``docs/notes/rpca.md``).
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
