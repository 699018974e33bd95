"""The movers' final fit on the data with a stationary estimate that does not hold them.

The movers are detected and first fitted on the moving part ``S`` of a separation
(:func:`~sarmotion.pipeline.stages.estimate_movers`). ``S`` is a distorted copy of a
mover: robust PCA keeps 15-40 % of a weak mover's amplitude in ``S`` on a GOTCHA degree,
the rest, the part of its trace that looks low rank in a fast-time window, goes to the
stationary part ``L``, and the fit on ``S`` inherits that distortion. :func:`refit_movers_on_data`
fits the movers again on ``D - L' - (other movers)``, where ``D`` is the data and ``L'``
a stationary estimate of ``D`` with the fitted movers' models removed:

1. each mover's amplitude is the matched filter on ``D`` at its fit on ``S`` (the
   full amplitude; on ``S`` it is 0.13-0.37 of the truth on GOTCHA degrees, on ``D``
   0.93-1.01, seed-11 scenes of ``benchmarks/movers_accuracy.py``);
2. ``L'`` is the image-guided point estimate (:func:`~sarmotion.separation.separate_combined`)
   of ``D - sum of the models``, on the stationary candidates of the preliminary image
   whose traces come within ``2 half_window`` fast-time samples of a mover's trace
   (the others leave only range sidelobes under a mover's matched filter);
3. every mover is re-fitted locally on ``D - L'`` with the others' models subtracted
   (:func:`~sarmotion.motion.refit_movers`); a re-fit that leaves the mover's range
   cell or moves its range speed by a range-speed resolution keeps the fit on ``S``.

Measured, tuning seed 11 of the benchmark (not the reported seed): the same refit with
``L'`` from robust PCA of ``D - models`` is a fixed point of the fit on ``S`` (cross-range
speeds within 0.004 m/s of it on 17 movers: what RPCA removes of ``D - models`` includes
the low-rank part of the difference between the mover and its model); on ``D`` itself
(no stationary estimate) the cross-range-speed RMSE is 0.15-0.20 m/s in simulated point
clutter against 0.05 on ``S``. With the point estimate ``L'`` on the scenes separated by
RPCA: cross-range-speed RMSE 0.046 m/s against 0.051 on ``S`` (28 movers: point clutter
0.007 against 0.057, slow movers 0.018 against 0.034, pairs 0.011 against 0.039, real
degrees 0.061 against 0.060), 0.041 against 0.065 on the 4 the no-separation baseline
also found (0.067 for the baseline); on the scenes separated by the combined method,
whose ``S`` holds the movers whole, within 0.025 m/s of the fit on ``S`` per mover (19).
Cost, on 2 shared cores (load average 6-9): 0.4-9.5 s per scene with movers (mean 2.5 s
on the 16 such seed-11 scenes separated by the combined method, whose separation took 4.0
s on average; 2.0 s on the 16 separated by RPCA, 1.1 s); in the same process,
``estimate_movers`` with the refit against without it (medians of 3) on the 15 scenes with
injected movers of ``--quick --seed 11``: +0.58 s per scene on average (-0.2 to +2.3 s;
the refit runs only where movers were found), for 6.7 s of preliminary image,
separation and movers.
Positions in m, speeds in m/s.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ..core import Acquisition, C, Traces
from ..imaging import Image, resolution
from ..motion import (
    MatchedFilter,
    PointFit,
    point_model,
    range_speed_resolution,
    refit_movers,
)
from ..separation import default_half_window, separate_combined, stationary_candidates

__all__ = [
    "refit_movers_on_data",
    "at_full_amplitude",
    "data_without_stationary",
    "refit_in_cell",
    "candidates_near_movers",
]

log = logging.getLogger(__name__)


def candidates_near_movers(
    traces: Acquisition | Traces,
    points_m: NDArray[np.float64],
    fits: Sequence[PointFit],
    margin_m: float,
) -> NDArray[np.float64]:
    """The stationary points whose range history comes within ``margin_m`` of a mover's.

    Parameters
    ----------
    traces : Acquisition
        Antenna positions and slow times (``s = 0`` is the fits' time).
    points_m : (k, 3) ndarray
        Stationary candidates (m).
    fits : sequence of PointFit
        The movers.
    margin_m : float
        Largest range difference kept (m).

    Returns
    -------
    (k', 3) ndarray
        The candidates kept, in their order.
    """
    pts = np.atleast_2d(np.asarray(points_m, dtype=np.float64)).reshape(-1, 3)
    if not len(pts) or not len(fits):
        return pts[:0]
    ant = traces.positions_m
    r_pts = np.linalg.norm(ant[None, :, :] - pts[:, None, :], axis=2)  # (k, n_pulses)
    keep = np.zeros(len(pts), dtype=bool)
    for f in fits:
        v3 = np.r_[np.asarray(f.velocity_mps, dtype=np.float64), 0.0]
        where = f.position_m[None, :] + traces.slow_times_s[:, None] * v3[None, :]
        r_mover = np.linalg.norm(ant - where, axis=1)
        keep |= np.min(np.abs(r_pts - r_mover[None, :]), axis=1) <= margin_m
    return pts[keep]


def refit_movers_on_data(
    sub: Traces,
    image: Image,
    fits: Sequence[PointFit],
    *,
    threshold_db: float,
    rounds: int = 1,
) -> tuple[list[PointFit], NDArray[np.complex128]]:
    """The movers re-fitted on the data minus a stationary estimate without them (notes).

    The three steps of the module notes in one call: :func:`at_full_amplitude`,
    :func:`data_without_stationary`, :func:`refit_in_cell`.

    Parameters
    ----------
    sub : Traces
        The (central sub-aperture's) data ``D``, on which ``fits`` were made from its
        moving part.
    image : Image
        Preliminary image of the acquisition: its bright points are the stationary
        candidates.
    fits : sequence of PointFit
        The fits on the moving part (jointly refined).
    threshold_db : float
        Candidate level, dB re the image's peak (the separation's
        ``candidate_threshold_db``).
    rounds : int
        Sweeps of the re-fit over the movers.

    Returns
    -------
    fits : list of PointFit
        The re-fitted movers (amplitudes on ``D - L'``), in the order of ``fits``.
    data : (n_pulses, n_samples) ndarray
        ``D - L'``: the data the re-fit was made on (the movers in it at full amplitude).
    """
    if not len(fits):
        return [], np.asarray(sub.data).astype(np.complex128)
    full = at_full_amplitude(sub, fits)
    data = data_without_stationary(sub, image, full, threshold_db=threshold_db)
    kept, _ = refit_in_cell(data, full, acquisition=sub.acquisition, rounds=rounds)
    return kept, data


def at_full_amplitude(sub: Traces, fits: Sequence[PointFit]) -> list[PointFit]:
    """Step 1: each fit with its amplitude from the matched filter on the data ``D``.

    Parameters
    ----------
    sub : Traces
        The data ``D`` (the sub-aperture the fits were made on).
    fits : sequence of PointFit
        The fits on the moving part.

    Returns
    -------
    list of PointFit
        The same fits, amplitude ``I / n_pulses`` on ``D`` (data units).
    """
    mf = MatchedFilter(sub)
    return [
        replace(
            f,
            amplitude=complex(mf.responses(f.position_m[None], f.velocity_mps[None])[0])
            / sub.n_pulses,
        )
        for f in fits
    ]


def data_without_stationary(
    sub: Traces, image: Image, fits: Sequence[PointFit], *, threshold_db: float
) -> NDArray[np.complex128]:
    """Step 2: ``D - L'``, ``L'`` a stationary estimate of ``D`` without the movers.

    ``L'`` is the image-guided point estimate (:func:`~sarmotion.separation.separate_combined`)
    of ``D`` minus the fits' models, on the candidates of ``image`` above
    ``threshold_db`` whose range history comes within ``2 half_window`` fast-time
    samples of a mover's (:func:`candidates_near_movers`); with no such candidate
    ``L' = 0``.

    Parameters
    ----------
    sub : Traces
        The data ``D``.
    image : Image
        Preliminary image of the acquisition.
    fits : sequence of PointFit
        The movers at full amplitude (:func:`at_full_amplitude`).
    threshold_db : float
        Candidate level, dB re the image's peak.

    Returns
    -------
    (n_pulses, n_samples) ndarray
        ``D - L'`` (data units).
    """
    d = np.asarray(sub.data)
    models = sum(
        (point_model(sub, f.position_m, f.velocity_mps, f.amplitude) for f in fits),
        np.zeros(sub.shape, dtype=np.complex128),
    )
    grid = image.grid
    cand = stationary_candidates(
        image.values,
        x_m=grid.x_m,
        y_m=grid.y_m,
        traces=sub,
        threshold_db=threshold_db,
        max_targets=200,
    )
    half = default_half_window(sub)
    margin = 2.0 * half * C * sub.radar.sample_interval_s / 2.0
    near = candidates_near_movers(sub, cand, fits, margin)
    log.info("refit: %d of %d stationary candidates near the movers' traces", len(near), len(cand))
    if not len(near):
        return d.astype(np.complex128)
    sep = separate_combined(sub.with_data(d - models), points_m=near, half_window=half)
    return d - sep.stationary


def refit_in_cell(
    data: NDArray[np.complexfloating],
    fits: Sequence[PointFit],
    *,
    acquisition: Acquisition,
    rounds: int = 1,
) -> tuple[list[PointFit], list[bool]]:
    """Step 3: every mover re-fitted on ``data``, kept when it stays in its cell.

    Each mover is re-fitted locally with the others' models subtracted
    (:func:`~sarmotion.motion.refit_movers`); a re-fit that moves the range position by
    a ground-range cell or the range speed by a range-speed resolution keeps the fit it
    started from.

    Parameters
    ----------
    data : (n_pulses, n_samples) ndarray
        ``D - L'`` (:func:`data_without_stationary`).
    fits : sequence of PointFit
        The movers at full amplitude.
    acquisition : Acquisition
        The acquisition of ``data`` (the sub-aperture).
    rounds : int
        Sweeps of the re-fit over the movers.

    Returns
    -------
    fits : list of PointFit
        The final fits, in the order of ``fits``.
    kept : list of bool
        Whether each re-fit was kept.
    """
    sub = acquisition
    out = refit_movers(data, list(fits), acquisition=sub, rounds=rounds)
    cells = resolution(sub)
    res_u = range_speed_resolution(sub)
    final, kept = [], []
    for first, new in zip(fits, out, strict=True):
        dx = abs(float((new.position_m[:2] - first.position_m[:2]) @ cells.range_direction))
        du = abs(new.range_speed_mps - first.range_speed_mps)
        ok = dx < cells.ground_range_m and du < res_u
        if not ok:
            log.info("refit left the mover's range cell or speed: the fit on S is kept")
        final.append(new if ok else first)
        kept.append(ok)
    return final, kept
