"""The ``sarmotion.separation/1`` document: what ``sarmotion separate`` did.

Keys: ``schema``, ``method`` (the separation used), ``inputs`` (as given), ``n_pulses``,
``n_samples``, ``seconds`` (wall-clock of the preliminary image and the separation),
``stationary_points_m`` (the stationary points the method used, m), ``info`` (the
method's details, :attr:`sarmotion.separation.Separation.info` without its candidate
list); for simulated inputs also ``quality``
(:func:`sarmotion.separation.quality_against_truth`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from ..separation import Separation, quality_against_truth
from .schema import stamped

if TYPE_CHECKING:
    from ..core.traces import Traces
    from ..simulation import Simulation

__all__ = ["SEPARATION_SCHEMA", "separation_document"]

#: Schema name of the separation document.
SEPARATION_SCHEMA = "sarmotion.separation/1"


def separation_document(
    separation: Separation,
    traces: Traces,
    *,
    inputs: Sequence[str],
    seconds: float,
    simulation: Simulation | None = None,
) -> dict[str, Any]:
    """The ``sarmotion.separation/1`` document of ``separation`` (module notes).

    Parameters
    ----------
    separation : Separation
        The separation of ``traces``.
    traces : Traces
        The separated traces.
    inputs : sequence of str
        The inputs as the user named them.
    seconds : float
        Wall-clock time of the preliminary image and the separation (s).
    simulation : Simulation, optional
        The simulation ``traces`` came from; adds ``quality`` against its truth.
    """
    doc: dict[str, Any] = {
        "method": separation.method,
        "inputs": list(inputs),
        "n_pulses": traces.n_pulses,
        "n_samples": traces.n_samples,
        "seconds": seconds,
        "stationary_points_m": separation.stationary_points_m,
        "info": {k: v for k, v in separation.info.items() if k != "candidates"},
    }
    if simulation is not None:
        doc["quality"] = quality_against_truth(
            separation,
            traces,
            true_stationary=simulation.stationary,
            true_moving=simulation.moving,
            movers=simulation.scene.moving,
        )
    return stamped(SEPARATION_SCHEMA, doc)
