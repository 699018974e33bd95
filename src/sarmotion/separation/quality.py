"""Measures of a separation against the true traces: errors and the movers kept."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import Traces
from .result import Separation
from .transforms import annihilate

__all__ = ["separation_quality", "mover_trace_coverage", "quality_against_truth"]


class TrueMover(Protocol):
    """A mover of the true scene: what the quality measures read of it.

    :class:`sarmotion.simulation.PointTarget` is one; the measures need only its motion,
    so this layer does not import the simulator.
    """

    #: Position at slow time ``s = 0``, shape (3,) (m).
    position_m: NDArray[np.float64]
    #: Ground velocity ``(ux, uy)``, shape (2,) (m/s).
    velocity_mps: NDArray[np.float64]


# -------------------------------------------------------------------- quality
def separation_quality(
    separation: Separation,
    *,
    true_stationary: ArrayLike,
    true_moving: ArrayLike,
    operator: Callable[[NDArray], NDArray] | None = None,
) -> dict[str, float]:
    """Quality of a separation against the simulator's ground truth.

    For a split ``M = L + S`` (rpca, combined):

    - ``relative_error_moving`` = ``||S - S_true|| / ||S_true||``;
    - ``relative_error_stationary`` = ``||L - L_true|| / ||L_true||``;
    - ``mover_retained`` = ``Re<S, S_true> / ||S_true||^2``, the fraction of the movers'
      traces kept in ``S`` (projection coefficient);
    - ``stationary_leak_db`` = ``10 log10(||S - S_true||^2 / ||L_true||^2)``: what of
      ``S`` is not the movers, relative to the stationary energy in ``M``;
    - ``signal_to_clutter_db`` = ``10 log10(||S_true||^2 / ||S - S_true||^2)``.

    A measure relative to the movers (``||S_true|| = 0``: a scene without movers) or to the
    stationary targets (``||L_true|| = 0``) is left out rather than divided by zero.

    For a linear filter (annihilation) pass ``operator`` (the filter as a function of a
    trace matrix): its output is not in the units of ``M``, so the two parts are filtered
    separately and only ``signal_to_clutter_db = 10 log10(||Q S_true||^2 / ||Q L_true||^2)``
    is returned (see :func:`mover_trace_coverage` for how much of the movers' traces the
    filter keeps).
    """
    Lt = np.asarray(true_stationary)
    St = np.asarray(true_moving)
    nL2 = float(np.vdot(Lt, Lt).real)
    nS2 = float(np.vdot(St, St).real)
    tiny = np.finfo(float).tiny
    if operator is not None:
        qL = operator(Lt)
        qS = operator(St)
        eL = float(np.vdot(qL, qL).real)
        eS = float(np.vdot(qS, qS).real)
        return {"signal_to_clutter_db": 10 * np.log10(eS / max(eL, tiny))}
    S = separation.moving
    err = S - St
    e2 = float(np.vdot(err, err).real)
    out: dict[str, float] = {}
    if nS2 > 0:  # measures relative to the movers: undefined for a scene without any
        out["relative_error_moving"] = float(np.sqrt(e2 / nS2))
        out["mover_retained"] = float(np.vdot(St, S).real / nS2)
        out["signal_to_clutter_db"] = 10 * np.log10(nS2 / max(e2, tiny))
    if nL2 > 0:
        out["stationary_leak_db"] = 10 * np.log10(max(e2, tiny) / nL2)
    if separation.stationary is not None and nL2 > 0:
        eL = separation.stationary - Lt
        out["relative_error_stationary"] = float(np.sqrt(np.vdot(eL, eL).real / nL2))
    return out


def mover_trace_coverage(
    moving: ArrayLike,
    traces: Traces,
    movers: Sequence[TrueMover],
    *,
    half_width: int = 3,
    drop_db: float = 6.0,
) -> float:
    """Fraction of each mover's trace that a separation keeps, in any units.

    For every pulse ``s_j`` and mover ``q``, the energy of ``moving`` within
    ``half_width`` samples of the mover's delay ``dtau_q(s_j)`` is compared with its median
    along that mover's trace; the coverage is the fraction of (pulse, mover) pairs where it
    is at most ``drop_db`` below that median. It measures what the paper describes as a
    filter that "removes some parts of the traces from the moving targets": a separation
    that keeps the whole trace scores 1, whatever its scaling.

    Parameters
    ----------
    moving : (n_pulses, n_samples) array_like
        Separated moving traces ``S`` (or a filtered output such as ``Q M``).
    traces : Traces
        Acquisition of the data.
    movers : sequence of TrueMover
        The true movers, e.g. :class:`sarmotion.simulation.PointTarget` (positions at
        ``s = 0`` in m, velocities in m/s).
    half_width : int
        Half-width of the band around the trace (samples).
    drop_db : float
        Allowed drop below the median (dB).
    """
    from .transforms import travel_time_delays

    s = np.asarray(moving)
    n, m = s.shape
    kept = []
    for mover in movers:
        d = travel_time_delays(traces, mover.position_m, velocity_mps=mover.velocity_mps)
        idx = np.round(d / traces.radar.sample_interval_s).astype(int) + m // 2
        energy = np.array(
            [
                np.sum(np.abs(s[j, max(i - half_width, 0) : max(i + half_width + 1, 0)]) ** 2)
                for j, i in enumerate(idx)
            ]
        )
        inside = (idx >= 0) & (idx < m)
        med = np.median(energy[inside])
        kept.append(energy[inside] >= med * 10.0 ** (-drop_db / 10.0))
    return float(np.mean(np.concatenate(kept))) if kept else 1.0


def quality_against_truth(
    separation: Separation,
    traces: Traces,
    *,
    true_stationary: ArrayLike,
    true_moving: ArrayLike,
    movers: Sequence[TrueMover],
) -> dict[str, Any]:
    """:func:`separation_quality` and :func:`mover_trace_coverage` of any method.

    The annihilation filter's ``S = Q M`` is compared with ``Q`` applied to the true
    traces (the filter is linear); the other methods' ``S`` with the true moving traces.
    """
    operator = None
    if separation.stationary is None:
        points = separation.stationary_points_m

        def operator(d: NDArray[np.complexfloating]) -> NDArray[np.complexfloating]:
            return annihilate(traces.with_data(d), points).data

    quality = separation_quality(
        separation, true_stationary=true_stationary, true_moving=true_moving, operator=operator
    )
    quality["mover_trace_coverage"] = mover_trace_coverage(separation.moving, traces, movers)
    return quality
