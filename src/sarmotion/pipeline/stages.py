"""The stages of the analysis after the movers: trajectories, images, stationary targets.

The first stages are in :mod:`sarmotion.pipeline.detection` and the mover stage in
:mod:`sarmotion.pipeline.movers`; :func:`~sarmotion.pipeline.analyze` calls them in
order, and each can also be called alone. Nothing here reads or writes files or prints;
progress goes through ``progress(stage, done, total)``. Positions in m (data frame),
speeds in m/s.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..core.acquisition import Acquisition
from ..core.progress import ProgressCallback, report
from ..core.traces import Traces
from ..errors import EstimationError
from ..imaging import Image, ImageGrid, backproject, resolution
from ..imaging.sidelobes import sidelobe_peaks
from ..motion import TrajectoryEstimate, estimate_trajectory
from ..separation import Separation
from ._timing import staged
from .options import AnalysisOptions
from .results import Mover, StationaryTarget

__all__ = [
    "estimate_trajectories",
    "stationary_image",
    "mover_images",
    "stationary_targets",
]

log = logging.getLogger(__name__)


def stationary_targets(
    image: Image, sep: Separation, options: AnalysisOptions, *, acquisition: Acquisition
) -> tuple[tuple[StationaryTarget, ...], int]:
    """Bright points of the stationary image, brightest first, and the sidelobes dropped.

    With the combined separation the points are the stationary locations it accepted
    (refined on the point response, Doppler-tested: sidelobes of bright targets are not
    listed); otherwise the local maxima of ``|I|`` at least one resolution cell apart,
    less those a brighter maximum's sidelobes can explain
    (:func:`~sarmotion.imaging.sidelobes.sidelobe_peaks`: the point-spread function's
    envelope in ground range and cross range, along the look direction at the aperture's
    centre). Each keeps its level ``20 log10(|I(rho)| / max |I|)`` (dB, nearest pixel of
    the refined position, so a point may read a fraction of a dB low) when it is above
    ``options.stationary_threshold_db``; at most ``options.max_stationary``, the brightest
    (maxima are taken brightest first until that many are not sidelobes).

    Returns
    -------
    (tuple of StationaryTarget, int)
        The targets, and how many of the local maxima above the threshold that were
        examined were dropped as sidelobes.
    """
    threshold_db, max_targets = options.stationary_threshold_db, options.max_stationary
    mag = image.magnitude
    if max_targets == 0 or not float(mag.max()) > 0.0:
        return (), 0
    if sep.method == "combined" and len(sep.stationary_points_m):
        found, _ = _above(image.grid, mag, [tuple(p[:2]) for p in sep.stationary_points_m],
                          threshold_db)  # fmt: skip
        found.sort(key=lambda t: -t.level_db)
        return tuple(found[:max_targets]), 0
    cells = resolution(acquisition)
    cell = max(cells.ground_range_m, cells.cross_range_m)
    traj = acquisition.trajectory
    n = max_targets
    while True:  # the brightest maxima until max_targets are not sidelobes, or none is left
        points = [(x, y) for x, y, _ in image.peaks(n, min_separation_m=cell)]
        found, levels = _above(image.grid, mag, points, threshold_db)
        sidelobe = sidelobe_peaks(
            [t.position_m for t in found], levels,
            antenna_m=traj.positions_m[int(np.argmin(np.abs(traj.slow_times_s)))],
            range_cell_m=cells.ground_range_m, cross_cell_m=cells.cross_range_m,
            pixel_m=max(image.grid.spacing_m), gaussian_range=acquisition.radar.pulse == "gaussian",
        )  # fmt: skip
        kept = [t for t, s in zip(found, sidelobe, strict=True) if not s]
        if len(kept) >= max_targets or len(points) < n or len(found) < len(points):
            break
        n *= 2
    kept.sort(key=lambda t: -t.level_db)
    return tuple(kept[:max_targets]), int(sidelobe.sum())


def _above(
    grid: ImageGrid,
    mag: NDArray[np.float64],
    points: Sequence[tuple[float, float]],
    threshold_db: float,
) -> tuple[list[StationaryTarget], list[float]]:
    """The points inside the grid whose level is at least ``threshold_db`` (dB re the peak).

    ``mag`` the image's ``|I|`` on ``grid``. Returns the targets (level at the nearest
    pixel) and their amplitudes ``|I|``.
    """
    peak = float(mag.max())
    left, right, bottom, top = grid.extent
    found, levels = [], []
    for x, y in points:
        if not (left <= x <= right and bottom <= y <= top):
            continue
        iy, ix = grid.nearest_index((x, y))
        db = float(20.0 * np.log10(max(mag[iy, ix], 1e-300) / peak))
        if db >= threshold_db:
            found.append(StationaryTarget(position_m=(float(x), float(y)), level_db=db))
            levels.append(float(mag[iy, ix]))
    return found, levels


def estimate_trajectories(
    movers: Sequence[Mover],
    *,
    acquisition: Acquisition,
    progress: ProgressCallback | None = None,
) -> tuple[Mover, ...]:
    """Each mover with its trajectory by the phase-space algorithm, from its own traces.

    A mover whose trajectory cannot be estimated (e.g. too close to the window edge)
    keeps ``trajectory=None``.
    """
    out = []
    for k, mover in enumerate(movers):
        trajectory: TrajectoryEstimate | None = None
        try:
            trajectory = estimate_trajectory(
                Traces(data=mover.traces, acquisition=acquisition),
                mover.position_m,
                velocity_guess_mps=mover.velocity_mps,
            )
        except EstimationError as exc:  # e.g. too few pulses, or the search past the edge
            log.warning("trajectory of mover %d not estimated: %s", k + 1, exc)
        out.append(dataclasses.replace(mover, trajectory=trajectory))
        report(progress, "trajectories", k + 1, len(movers))
    return tuple(out)


def stationary_image(
    traces: Traces,
    separation: Separation,
    movers: Sequence[Mover],
    grid: ImageGrid,
    *,
    progress: ProgressCallback | None = None,
    device: str = "cpu",
    method: str = "exact",
) -> Image:
    """``eq:image`` of the stationary traces: ``L``, or ``M`` minus the movers' traces.

    ``L`` less the traces of the movers found in the stationary band
    (:mod:`sarmotion.pipeline.defocused`), whose echoes the separation left there.

    ``device``, ``method``: where and how to backproject
    (:func:`~sarmotion.imaging.backproject`). Traces
    that are zero (a separation that found no stationary target) image to zero.
    """
    if separation.stationary is not None:
        data = separation.stationary
        # a mover found in the stationary band left its echo in L (pipeline.defocused)
        banded = [m.traces for m in movers if m.evidence.defocus is not None]
        if banded:
            data = data - sum(banded, np.zeros(traces.shape, dtype=np.complex128))
    else:
        data = traces.data - sum((m.traces for m in movers), np.zeros(traces.shape))
    if not np.any(data):
        return Image(values=np.zeros(grid.shape, np.complex128), grid=grid)
    return backproject(
        traces.with_data(data),
        grid,
        progress=staged(progress, "stationary image"),
        device=device,
        method=method,
    )


def mover_images(
    movers: Sequence[Mover],
    stationary: Image,
    options: AnalysisOptions,
    *,
    acquisition: Acquisition,
) -> tuple[Mover, ...]:
    """Each mover with its image (``eq:imagecompu`` at its velocity) and that image's peak.

    The image is a square of ``options.mover_image_size_m`` around the mover's location;
    its peak's level is relative to the brightest pixel of the ``stationary`` image.
    """
    stat_peak = float(stationary.magnitude.max()) or 1.0
    out = []
    for mover in movers:
        grid = ImageGrid.square(
            centre_m=tuple(mover.position_m[:2]),
            size_m=options.mover_image_size_m,
            spacing_m=options.spacing_m,
        )
        own = Traces(data=mover.traces, acquisition=acquisition)
        img = backproject(own, grid, velocity_mps=mover.velocity_mps, device=options.device)
        x, y, v = img.peak(refine=True)
        out.append(
            dataclasses.replace(
                mover,
                image=img,
                image_peak_m=np.array([x, y]),
                image_peak_db=float(20.0 * np.log10(max(abs(v), 1e-300) / stat_peak)),
            )
        )
    return tuple(out)
