"""Follow the movers of a long acquisition: sub-apertures, Dask, Stone Soup, roads.

:func:`track` reads as its stages:

1. cut the acquisition into overlapping sub-apertures
   (:func:`~sarmotion.tracking.sub_apertures.sub_aperture_slices`);
2. analyse each on its own, on Dask (:func:`~sarmotion.tracking.scale.map_sub_apertures`):
   its movers' positions, velocities and cross-range families (the paper's second
   scenario);
3. as the results come back in slow-time order, associate them into tracks and use each
   track's prediction, or the road the mover is on, as the known position of the next
   detection (the first scenario; :class:`~sarmotion.tracking.tracker.Tracker`);
4. the stationary scene: the incoherent mean of the sub-apertures' stationary images.

Nothing here reads or writes files or prints; progress through ``progress(stage, done,
total)``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from contextlib import closing
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import Traces
from ..core.progress import ProgressCallback, report
from ..imaging import ImageGrid
from .roads import Road
from .scale import check_workers, map_sub_apertures
from .sub_apertures import SubApertureDetections, check_sub_apertures, sub_aperture_slices
from .tracker import Track, Tracker, TrackingOptions

__all__ = ["TrackingResult", "track"]


@dataclass(frozen=True, kw_only=True, eq=False)
class TrackingResult:
    """What :func:`track` found.

    Attributes
    ----------
    tracks : tuple of Track
        The movers followed, in order of first detection.
    sub_apertures : tuple of SubApertureDetections
        Each sub-aperture's analysis, in slow-time order.
    stationary_db : (ny, nx) ndarray
        Incoherent mean of the sub-apertures' stationary images (dB re its brightest
        pixel).
    grid : ImageGrid
        Its grid.
    options : TrackingOptions
        The options used.
    roads : tuple of Road
        The roads used (empty: none).
    timings_s : dict of str to float
        ``"total"`` wall-clock time and ``"analysis"``, the sum of the sub-apertures'
        analysis times (s).
    """

    tracks: tuple[Track, ...]
    sub_apertures: tuple[SubApertureDetections, ...]
    stationary_db: NDArray[np.float64]
    grid: ImageGrid
    options: TrackingOptions
    roads: tuple[Road, ...]
    timings_s: dict[str, float]


def track(
    traces: Traces,
    options: TrackingOptions | None = None,
    *,
    roads: Sequence[Road] = (),
    scheduler: str | Any | None = None,
    n_workers: int | None = None,
    processes: bool = False,
    dashboard_address: str | None = None,
    progress: ProgressCallback | None = None,
) -> TrackingResult:
    """Follow the movers of ``traces`` across sub-apertures (module notes).

    Parameters
    ----------
    traces : Traces
        The whole acquisition (slow time ``s = 0`` at its centre).
    options : TrackingOptions, optional
        Sub-apertures, analysis and tracking choices.
    roads : sequence of Road
        Road centre lines in the scene's ground coordinates (m); each detection is then
        placed on the member of its cross-range family on the nearest road.
    scheduler : str or distributed.Client, optional
        A Dask scheduler's address or a client; default a local cluster.
    n_workers : int, optional
        Local workers (default one per core; 0: no Dask; at most 4 per core,
        :data:`~sarmotion.tracking.scale.MAX_WORKERS_PER_CORE`).
    processes : bool
        Local workers as processes, or threads of this process (default: no pickled
        traces and numba's kernels loaded once, :mod:`sarmotion.tracking.scale`).
    dashboard_address : str, optional
        ``"host:port"`` of the local cluster's dashboard; default none.
    progress : callable, optional
        ``progress("sub-apertures", done, total)``.

    Returns
    -------
    TrackingResult

    Raises
    ------
    ValueError
        Before any worker starts: an overlap above 0.9, sub-apertures too short to
        resolve their image (:func:`~sarmotion.tracking.sub_apertures.check_sub_apertures`),
        too many local workers.
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a sarmotion Traces, got {type(traces).__name__}")
    opts = options or TrackingOptions()
    start = time.perf_counter()
    slices = sub_aperture_slices(traces, opts.sub_aperture_deg, opts.overlap)
    analysis = opts.analysis.resolved(traces)
    check_sub_apertures(traces, slices, opts.sub_aperture_deg, float(analysis.image_size_m))
    if scheduler is None and n_workers:
        check_workers(int(n_workers))
    tracker = Tracker(traces, opts, roads=roads)
    subs: list[SubApertureDetections] = []
    power: NDArray[np.float64] | None = None
    grid: ImageGrid | None = None
    # closing: an exception here (Ctrl-C) stops the cluster before it leaves the call
    with closing(
        map_sub_apertures(
            traces,
            slices,
            analysis,
            scheduler=scheduler,
            n_workers=n_workers,
            processes=processes,
            dashboard_address=dashboard_address,
        )
    ) as results:
        for sub in results:
            tracker.step(sub)
            # Incoherent mean of the stationary images on the first one's grid; only the
            # light record of each sub-aperture is kept (a whole pass would hold GBs).
            if grid is None:
                grid, power = sub.grid, np.zeros(sub.grid.shape)
            if sub.grid.shape == grid.shape and sub.stationary_db is not None:
                power += 10.0 ** (np.asarray(sub.stationary_db, dtype=np.float64) / 10.0)
            subs.append(sub.light())
            report(progress, "sub-apertures", len(subs), len(slices))
    assert grid is not None and power is not None
    top = float(power.max())
    with np.errstate(divide="ignore"):
        stationary_db = 10.0 * np.log10(power / top) if top > 0 else np.full(power.shape, -np.inf)
    return TrackingResult(
        tracks=tracker.tracks(),
        sub_apertures=tuple(subs),
        stationary_db=stationary_db,
        grid=grid,
        options=opts,
        roads=tuple(roads),
        timings_s={
            "total": time.perf_counter() - start,
            "analysis": float(sum(s.seconds for s in subs)),
        },
    )
