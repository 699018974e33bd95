"""Numerical rank of a matrix of traces: eigenvalues of its Gram matrix above a threshold."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._validation import positive as _positive

__all__ = ["numerical_rank", "gram_eigenvalues"]


# --------------------------------------------------------------------------- helpers
def _kappa(eps: float) -> float:
    """``sqrt(log(1/eps))`` with validation of ``eps``."""
    if not (isinstance(eps, (int, float, np.floating)) and 0.0 < eps < 1.0):
        raise ValueError(f"eps must be a number in (0, 1), got {eps!r}")
    return float(np.sqrt(np.log(1.0 / eps)))


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
