"""Separation by composed travel-time annihilation filters ``Q`` (``eq:OP1``, ``eq:OP2``)."""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import ArrayLike

from ..core import Traces
from .candidates import doppler_contrast_db
from .result import Separation
from .transforms import Annihilator, annihilate

__all__ = ["separate_annihilation"]


# --------------------------------------------------------------- annihilation
def separate_annihilation(
    traces: Traces,
    points_m: ArrayLike,
    *,
    kind: Annihilator = "difference",
    contrast_db: float | None = 10.0,
) -> Separation:
    """Composed annihilation filter ``Q`` (``eq:OP2``) at the given stationary locations.

    Candidates whose Doppler contrast (:func:`doppler_contrast_db`) is below
    ``contrast_db`` are taken for movers' streaks and get no filter (``None`` keeps all).

    Parameters
    ----------
    traces : Traces
        Data ``M``.
    points_m : (k, 2|3) array_like
        Estimated stationary locations ``rho_j^e`` (m), e.g. from
        :func:`stationary_candidates`.
    kind : {"difference", "difference2", "savgol", "mean"}
        Slow-time annihilator (see :func:`sarmotion.separation.transforms.slow_time_difference`).

    Returns
    -------
    Separation
        ``moving = Q M``; ``stationary`` is None.
    """
    pts = np.atleast_2d(np.asarray(points_m, dtype=np.float64))
    if pts.size and pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    t0 = time.perf_counter()
    n_candidates = len(pts)
    if contrast_db is not None and pts.size:
        P = traces.phase_history()
        keep = [doppler_contrast_db(traces, p, phase_history=P) >= contrast_db for p in pts]
        pts = pts[np.array(keep, dtype=bool)]
    if pts.size == 0:
        out = traces.data.copy()
    else:
        out = annihilate(traces, pts, kind=kind).data
    info = {
        "kind": kind,
        "n_candidates": int(n_candidates),
        "n_filters": int(len(pts)),
        "seconds": time.perf_counter() - t0,
    }
    pts = pts.reshape(-1, 3)
    return Separation(
        moving=out, stationary=None, method="annihilation", stationary_points_m=pts, info=info
    )
