"""Pulses in blocks: the protocol by which a whole collection is read a block at a time.

A :class:`PulseBlocks` source holds the acquisition's axes (radar, reference point,
every pulse's position and slow time) and hands out its data in consecutive blocks of
pulses, each in the :class:`~sarmotion.core.traces.Traces` convention (complex
baseband, fast time relative to ``tau(s, rho_o)``, ``t = 0`` at sample
``n_samples // 2``). Whatever consumes the blocks (the patch extraction of
:mod:`sarmotion.collection`) holds a block and its own outputs, never the whole data,
so peak memory is set by the block size, not by the file.

:class:`TracesBlocks` serves in-memory :class:`Traces`; file readers implement the same
protocol (a CPHD or native traces file read block by block).

The image area an input declares (a CPHD's ``SceneCoordinates/ImageArea``) travels in
its ``metadata["image_area_m"]``: the polygon's vertices ``[[x, y], ...]`` on the ground
of the scene frame (m), as the reader found them; :func:`declared_area` reads it back.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from .geometry import Trajectory
from .radar import Radar
from .traces import Traces

__all__ = ["PulseBlocks", "TracesBlocks", "check_block_pulses", "declared_area"]

#: Metadata key of the image area an input declares (module notes).
IMAGE_AREA_KEY = "image_area_m"


@runtime_checkable
class PulseBlocks(Protocol):
    """A source of pulses read block by block.

    Attributes
    ----------
    radar : Radar
        Carrier, bandwidth and fast-time sampling of every pulse.
    reference_point_m : (3,) ndarray
        Range-compression reference point ``rho_o`` of the data (m).
    trajectory : Trajectory
        Positions (m) and slow times (s) of *all* pulses.
    n_pulses : int
        Number of pulses (``trajectory.n_pulses``).
    metadata : dict
        Provenance of the data (JSON-serialisable values); ``metadata["image_area_m"]``,
        where present, is the image area the input declares (module notes).
    """

    radar: Radar
    reference_point_m: NDArray[np.float64]
    trajectory: Trajectory
    n_pulses: int
    metadata: dict[str, Any]

    def blocks(self, block_pulses: int) -> Iterator[tuple[int, int, NDArray[np.complexfloating]]]:
        """Yield ``(start, stop, data[start:stop])`` for consecutive blocks of pulses.

        Parameters
        ----------
        block_pulses : int
            Pulses per block (>= 1); the last block may be shorter.

        Yields
        ------
        (int, int, (stop - start, n_samples) ndarray)
            The block's first pulse, one past its last, and its complex traces.
        """
        ...


def declared_area(source: Any) -> NDArray[np.float64] | None:
    """The image area ``source`` declares, ``(n, 2)`` ground ``x, y`` (m), or None.

    Read from ``source.metadata["image_area_m"]`` (module notes); None where the input
    declares none (GOTCHA files, native traces, simulations that do not set it).
    Validating the polygon is the caller's (:mod:`sarmotion.collection.plan`).
    """
    meta = getattr(source, "metadata", None) or {}
    area = meta.get(IMAGE_AREA_KEY) if isinstance(meta, dict) else None
    if area is None:
        return None
    return np.asarray(area, dtype=np.float64)


def check_block_pulses(block_pulses: int) -> int:
    """``block_pulses`` as a positive int, or ``ValueError`` naming it."""
    if isinstance(block_pulses, bool) or not isinstance(block_pulses, (int, np.integer)):
        raise TypeError(f"block_pulses must be an integer, got {block_pulses!r}")
    if block_pulses < 1:
        raise ValueError(f"block_pulses must be >= 1, got {block_pulses}")
    return int(block_pulses)


class TracesBlocks:
    """:class:`PulseBlocks` over in-memory :class:`Traces` (blocks are views, no copy).

    Parameters
    ----------
    traces : Traces
        The acquisition.
    """

    def __init__(self, traces: Traces) -> None:
        if not isinstance(traces, Traces):
            raise TypeError(f"traces must be a sarmotion Traces, got {type(traces).__name__}")
        self.traces = traces
        self.radar = traces.radar
        self.reference_point_m = traces.reference_point_m
        self.trajectory = traces.trajectory
        self.n_pulses = traces.n_pulses
        self.metadata = dict(traces.metadata)

    def blocks(self, block_pulses: int) -> Iterator[tuple[int, int, NDArray[np.complexfloating]]]:
        """Yield ``(start, stop, traces.data[start:stop])``; see :class:`PulseBlocks`."""
        step = check_block_pulses(block_pulses)
        for start in range(0, self.n_pulses, step):
            stop = min(start + step, self.n_pulses)
            yield start, stop, self.traces.data[start:stop]
