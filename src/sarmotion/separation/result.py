"""The results of a stationary/moving separation, ``M = L + S``, and of its solvers."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["Decomposition", "Separation"]


class Decomposition(NamedTuple):
    """One matrix (or window) decomposed by a robust-PCA solver, ``M ~= low + sparse``.

    What the IALM (whole, windowed or stacked) and the accelerated alternating
    projections return for each matrix they decompose.
    """

    #: ``L``, float64 or complex128.
    low: NDArray[np.inexact]
    #: ``S``, same dtype as ``low``.
    sparse: NDArray[np.inexact]
    #: Iterations performed.
    n_iter: int
    #: Whether the stopping rule was met.
    converged: bool
    #: Relative residual ``||M - L - S||_F / ||M||_F`` after each iteration, (n_iter,).
    residuals: NDArray[np.float64]
    #: Rank of ``L`` (singular values kept by the last thresholding).
    rank: int


@dataclass(frozen=True, kw_only=True, eq=False)
class Separation:
    """Result of a separation.

    Attributes
    ----------
    moving : (n_pulses, n_samples) ndarray
        ``S``: the traces attributed to moving targets.
    stationary : (n_pulses, n_samples) ndarray or None
        ``L``: the traces attributed to stationary targets (None for the annihilation
        filter, whose output is a filtered version of the data, not a split of it).
    method : str
        ``"annihilation"``, ``"rpca"`` or ``"combined"``.
    stationary_points_m : (k, 3) ndarray
        Stationary locations used (annihilation, combined), m.
    info : dict
        Method details (iterations, windows, timings in s).
    """

    moving: NDArray[np.complexfloating]
    stationary: NDArray[np.complexfloating] | None
    method: str
    stationary_points_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    info: dict[str, Any] = field(default_factory=dict)
