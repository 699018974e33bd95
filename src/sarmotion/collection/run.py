"""A whole collection: plan, extract, analyse every patch (on Dask), merge.

:func:`analyze_collection` reads the data block by block into the traces of a group of
patches (:func:`~sarmotion.collection.extract.extract_patches`; a group is as many
patches as fit in ``memory_mb``), submits each patch as a task running
:func:`~sarmotion.pipeline.analyze` on its traces (its image: its halo, the ground its
traces hold; its stationary image only its core's box, where its stationary targets are
listed, :func:`stationary_box`; its share of the false-alarm
rate, :mod:`~sarmotion.collection.plan` notes; only the movers whose echoes its band
passes estimated beyond a first fit, :func:`in_band`), and gathers the results as
they complete. Then one mover per range history, stationary targets de-duplicated and
their sidelobes dropped, and the stationary mosaic (:mod:`~sarmotion.collection.merge`).

Memory: a block's phase history, one group's traces (at most ``memory_mb``; each
patch's are let go once analysed), one patch's analysis per task in flight, the mosaic
(at most ``MOSAIC_MAX_PIXELS`` squared float32, each patch's image pasted in as it
arrives, at the mosaic's pixels) and every patch's slim result (movers and stationary
records): not the file, nor every patch's image.

Where the tasks run (as for ``track``, :mod:`sarmotion.tracking.scale`):

- ``scheduler=None``: a local ``distributed.LocalCluster`` of ``n_workers`` workers
  (default one per core), one thread each, threads of this process by default: measured
  faster than processes (``processes=True``), which each load numba's kernels again and
  receive their patches' traces pickled (``benchmarks/bench_collection.py`` notes); inside
  a task numba's and BLAS's pools are limited to the worker's share of the cores;
- ``scheduler="tcp://host:8786"`` or a ``distributed.Client``: that cluster's workers,
  which need sarmotion importable but not the input file (each task carries its
  patch's traces);
- ``n_workers=0``: no Dask, the patches one after the other in this process (BLAS on
  one thread, as in a task: a patch's matrices are too small for its threads to gain).

Nothing here reads files or prints; progress goes through ``progress(stage, done,
total)`` ("patch traces" over pulses read, "patches" over patches analysed).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import time
import warnings
from collections.abc import Callable, Iterator
from contextlib import ExitStack, closing
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.blocks import PulseBlocks, TracesBlocks
from ..core.constants import C
from ..core.geometry import Trajectory, look_geometry
from ..core.progress import ProgressCallback, report
from ..core.traces import Traces
from ..imaging import resolution
from ..imaging.grid import Image
from ..motion import PointFit
from ..pipeline import AnalysisOptions, AnalysisResult, NotEstimated, analyze
from ..separation import default_method
from .extract import extract_patches
from .merge import (
    ECHO_CELLS,
    MoverRecord,
    PatchImage,
    StationaryRecord,
    coarsen,
    drop_mover_images,
    drop_sidelobes,
    echo_offsets,
    merge_movers,
    merge_stationary,
    mosaic,
    mosaic_grid,
    paste,
)
from .plan import CollectionOptions, Patch, PatchPlan, _analysed_pulses, plan_patches

__all__ = [
    "PatchResult",
    "CollectionResult",
    "analyze_patch",
    "analyze_collection",
    "patch_false_alarm",
    "drop_smear",
    "stationary_box",
]

log = logging.getLogger(__name__)

#: Most pixels a side of the stationary mosaic (it is coarsened beyond).
MOSAIC_MAX_PIXELS = 4096

#: Resolution cells (the larger of ground range and cross range) by which a patch's
#: stationary image extends beyond its core's box (:func:`stationary_box`): a target of
#: the core has its main lobe (two cells either side, null to null) and the side lobes
#: next to it in the image, so that its peak is a local maximum of the image and is not
#: cut at the image's edge.
CORE_IMAGE_MARGIN_CELLS = 4.0


@dataclass(frozen=True, kw_only=True)
class PatchResult:
    """What one patch's analysis returns to the collection (no traces, no matrices).

    Attributes
    ----------
    index : int
        Patch index.
    movers : tuple of MoverRecord
        Its movers.
    stationary : tuple of StationaryRecord
        Its stationary targets inside its core.
    listed : int
        Stationary targets the analysis listed (inside and outside the core).
    capped : bool
        The analysis listed ``max_stationary`` targets: more may have been dropped.
    image : PatchImage or None
        Its stationary image on the core, on the mosaic's pixels; ``None`` in a
        :class:`CollectionResult` of several patches, once pasted into the mosaic.
    method : str
        Separation method.
    n_pulses, n_samples : int
        Size of its traces.
    timings_s : dict
        Stage times of its analysis (s).
    not_estimated : tuple of NotEstimated
        The candidates that passed its detector after ``max_movers`` movers were
        estimated (:attr:`~sarmotion.pipeline.AnalysisResult.movers_not_estimated`).
    """

    index: int
    movers: tuple[MoverRecord, ...]
    stationary: tuple[StationaryRecord, ...]
    listed: int
    capped: bool
    image: PatchImage | None
    method: str
    n_pulses: int
    n_samples: int
    timings_s: dict[str, float]
    not_estimated: tuple[NotEstimated, ...] = ()


@dataclass(frozen=True, kw_only=True)
class CollectionResult:
    """The merged analysis of a collection.

    Attributes
    ----------
    plan : PatchPlan
        The patches.
    patches : tuple of PatchResult
        Every patch's result, by index.
    movers : tuple of (MoverRecord, tuple of int)
        One per mover: the best-determined report and every patch that reported it.
    stationary : tuple of StationaryRecord
        De-duplicated stationary targets within ``stationary_threshold_db`` of the
        brightest, brightest first, at most ``max_stationary`` per patch in all.
    stationary_dropped : int
        Stationary targets beyond that cap, not listed.
    stationary_sidelobes : int
        Listings the merge took for a brighter target's sidelobes and dropped
        (:func:`~sarmotion.collection.merge.drop_sidelobes`); each patch's analysis drops
        its own image's first (not counted here). One patch: the analysis's count
        (:attr:`~sarmotion.pipeline.AnalysisResult.stationary_sidelobes`).
    stationary_mover_images : int
        Listings that lie on a found mover's echo and were dropped
        (:func:`~sarmotion.collection.merge.drop_mover_images`).
    range_direction : (2,) ndarray or None
        Ground range direction ``e_r`` at the reference point at ``s = 0``: the ground
        projection of the line of sight, normalised, pointing towards the antenna (the
        results document's ``frame.range_direction``); the radar looks along ``-e_r``.
    mosaic : (ny, nx) ndarray
        Stationary image ``|I| / n_pulses`` over the region (float32).
    mosaic_extent_m : (float, float, float, float)
        Its ``(left, right, bottom, top)`` (m).
    options : CollectionOptions
        The options used.
    timings_s : dict
        Wall-clock time of the stages ("plan", "patches", "merge", "total") (s).
    single_result : AnalysisResult or None
        The whole analysis when the region is one patch (today's analysis, unchanged).
    source : PulseBlocks or None
        The data analysed, when the caller kept them
        (:func:`~sarmotion.collection.analysis.analyze_source` does): the document's axes.
    """

    plan: PatchPlan
    patches: tuple[PatchResult, ...]
    movers: tuple[tuple[MoverRecord, tuple[int, ...]], ...]
    stationary: tuple[StationaryRecord, ...]
    stationary_dropped: int
    mosaic: NDArray[np.float32]
    mosaic_extent_m: tuple[float, float, float, float]
    options: CollectionOptions
    timings_s: dict[str, float] = field(default_factory=dict)
    single_result: AnalysisResult | None = None
    stationary_sidelobes: int = 0
    stationary_mover_images: int = 0
    range_direction: NDArray[np.float64] | None = None
    source: PulseBlocks | None = field(default=None, repr=False, compare=False)


# ------------------------------------------------------------------ one patch
def _patch_options(
    patch: Patch,
    options: AnalysisOptions,
    single: bool,
    trajectory: Trajectory | None = None,
    *,
    halo: bool = True,
) -> AnalysisOptions:
    """The analysis options of ``patch`` (unless one patch): its image, speeds and rate.

    - **Image**: where no ``image_size_m`` is given, the square that holds the patch's
      halo (``patch.halo_m``: the ground whose stationary echoes its traces hold, and
      its outline ``patch.halo_outline_m`` where there is one, outside which
      :func:`analyze_patch` forms no pixel) when
      ``halo`` (a separation that models the stationary scene from the preliminary
      image, ``combined`` or ``annihilation``), else the core's box. A stationary
      target inside the window and band but outside the image is no candidate of such a
      separation: its whole echo stays in ``S`` and lifts the local floor of ``g(u)``
      (by 1.3-1.5 dB at 4 m/s for the unit points of ``benchmarks/look_azimuth.py``),
      where the whole-trace analysis, whose image holds it, takes it out. Only the
      core's targets are listed and pasted (:func:`analyze_patch`).
    - **Stationary band**: with ``trajectory`` (the patch's pulses) and no
      ``stationary_speed_mps`` given, the range speeds ``g(u)`` leaves untested are
      those of the core's own stationary points (:func:`core_stationary_speed`), not an
      image's generic band (two range-speed resolutions, or ``V (P / sqrt 2) / R``): a
      mover of slow range rate that mimics a stationary point of one core is tested by
      the next patch, whose reference is two core bands away and whose pass band
      reaches it (:mod:`~sarmotion.collection.merge` notes).
    - **False-alarm rate**: its share of the collection's (:func:`patch_false_alarm`).
    - **Stationary explanations**: a candidate may be a stationary point's echo
      anywhere in the data's alias-free extent about the data's reference point
      (``patch.alias_free_m``; ``alias_free_extent_m``, ``alias_free_centre_m``), as in
      the analysis of the whole data, not only in the traces' own (``p / q`` of it): the
      data's pulse rate wraps the Doppler of a stationary point beyond the band into it
      when the scene is wider in cross range than that rate covers.
    - **Images**: where ``image_method`` is not given, on the CPU, the halo's images
      (preliminary and stationary: about 300 m a side for a 75 m core) are formed by fast
      factorised backprojection (:mod:`sarmotion.imaging.ffbp`, to its error budget;
      exact where it predicts no gain): they were half of a patch's time.
    """
    if single:
        return options
    out = patch_false_alarm(options, patch)
    if options.image_method is None and options.device == "cpu":
        out = dataclasses.replace(out, image_method="ffbp")
    if options.image_size_m is None:
        size = patch.halo_m if halo and patch.halo_m is not None else patch.size_m
        if halo and patch.halo_outline_m is not None:  # the square holds the outline
            reach = np.abs(np.asarray(patch.halo_outline_m) - patch.centre_m[:2]).max()
            size = max(size, 2.0 * float(reach))
        out = dataclasses.replace(out, image_size_m=max(size, patch.size_m))
    if trajectory is not None and options.stationary_speed_mps is None:
        out = dataclasses.replace(
            out, stationary_speed_mps=core_stationary_speed(trajectory, patch)
        )
    if patch.alias_free_m is not None and options.alias_free_extent_m is None:
        # the data's, not the traces' (one pulse in q kept): the band holds the echoes of
        # stationary points the data's pulse rate wraps into it, over the data's extent
        x, y, extent = patch.alias_free_m
        out = dataclasses.replace(out, alias_free_extent_m=extent, alias_free_centre_m=(x, y))
    return out


def patch_false_alarm(options: AnalysisOptions, patch: Patch) -> AnalysisOptions:
    """The options ``patch`` is tested with: its share of the collection's false-alarm rate.

    ``options.false_alarm_rate`` ``alpha`` is the collection's: the probability of a
    false mover anywhere in it. A patch's ``g(u)`` test at ``alpha_p`` finds a null
    candidate somewhere in the data its traces hold (``H_p``, in ground range and cross
    range); it reports it only where its fit lies in the patch's band (:func:`in_band`:
    its keep box ``K_p``). Patches holding the same echoes (every Doppler, one range
    window) are one test whose keeps count once (``K_g``, their union). With the null
    candidate as likely anywhere in ``H_p``, ``alpha_p = alpha min(1, |H_p| / sum_g
    |K_g|)`` (``patch.false_alarm_share``,
    :func:`~sarmotion.collection.plan.false_alarm_shares`) makes the sum over the groups
    at most ``alpha`` (the union bound). Patches that hold disjoint data test at about
    ``alpha / n``; patches that hold the same data test each near ``alpha``, as the
    whole-trace analysis of those data does. The ``g(u)`` threshold rises by the null
    tail's scale times ``ln(1 / share)`` (:func:`~sarmotion.motion.threshold_db`). A
    share of 1 (one patch): unchanged.
    """
    share = float(patch.false_alarm_share)
    if share >= 1.0:
        return options
    return dataclasses.replace(options, false_alarm_rate=options.false_alarm_rate * share)


def core_stationary_speed(trajectory: Trajectory, patch: Patch) -> float:
    """Largest ``|R_x'(0) - R_p'(0)|`` (m/s) of a stationary point ``x`` of the core.

    The range rate relative to the centre ``rho_p`` at the aperture centre
    (:func:`~sarmotion.collection.merge.echo_offsets`, not aliased); linear in ``x``
    to first order, so its largest magnitude over the core is at a corner.
    """
    return max(
        abs(echo_offsets(trajectory, c, np.zeros(2), patch.centre_m, np.inf)[1])
        for c in _core_corners(patch)
    )


def _core_corners(patch: Patch) -> list[NDArray[np.float64]]:
    """The four corners of the patch's core (turned to the look), at the centre's height (m)."""
    z = float(patch.centre_m[2])
    return [np.array([x, y, z]) for x, y in patch.corners_m]


def in_band(traces: Traces, patch: Patch) -> Callable[[PointFit], bool]:
    """Whether a mover fitted on ``patch``'s traces has its echoes in the patch's band.

    Range within the core's span plus ``ECHO_CELLS`` range cells, Doppler within the
    pass band (:mod:`~sarmotion.collection.merge` notes); the data's pulse rate is
    ``decimation / interpolation`` times the traces'.
    """
    traj = traces.trajectory
    prf = patch.decimation / (patch.interpolation * traj.pulse_interval_s)
    period = 0.5 * traces.radar.wavelength_m * prf
    to_hz = 2.0 * traces.radar.carrier_hz / C
    span = max(
        abs(echo_offsets(traj, c, np.zeros(2), patch.centre_m, period)[0])
        for c in _core_corners(patch)
    )
    span += ECHO_CELLS * traces.radar.range_resolution_m

    def keep(fit: PointFit) -> bool:
        dr, rate = echo_offsets(traj, fit.position_m, fit.velocity_mps, patch.centre_m, period)
        return bool(abs(dr) <= span and abs(rate) * to_hz <= patch.passband_hz)

    return keep


def analyze_patch(
    traces: Traces,
    patch: Patch,
    options: AnalysisOptions,
    *,
    single: bool = False,
    describe: Callable[[AnalysisResult], list[dict[str, Any]]] | None = None,
    mosaic_m: tuple[float, float, float] | None = None,
    progress: ProgressCallback | None = None,
) -> tuple[PatchResult, AnalysisResult]:
    """Analyse one patch's traces with :func:`~sarmotion.pipeline.analyze` and slim it.

    Of a patch of several, only the movers whose echoes lie in its band
    (:func:`in_band`) are estimated beyond their first fit.

    Parameters
    ----------
    traces : Traces
        The patch's traces (:func:`~sarmotion.collection.extract_patches`).
    patch : Patch
        The patch.
    options : AnalysisOptions
        Analysis options (the image is set to the core).
    single : bool
        The patch is the whole region (today's analysis: options unchanged).
    describe : callable, optional
        ``describe(result)``: one JSON-ready entry per mover (the document layer's
        ``sarmotion.results/2`` mover entries), kept as each record's ``document``.
    mosaic_m : (x0, y0, spacing), optional
        The mosaic's origin and pixel (m): the core image is reduced to its pixels
        (:func:`~sarmotion.collection.merge.coarsen`); default the analysis's pixels.
    progress : callable, optional
        ``progress(stage, done, total)`` of the analysis's stages.

    Returns
    -------
    (PatchResult, AnalysisResult)
    """
    keep = None if single else in_band(traces, patch)
    method = options.separation.method or default_method(traces)
    opts = _patch_options(patch, options, single, traces.trajectory, halo=method != "rpca")
    box = None if single else stationary_box(traces, patch)
    outline = None if single or method == "rpca" else patch.halo_outline_m
    result = analyze(
        traces,
        opts,
        keep=keep,
        image_outline_m=outline,
        stationary_box_m=box,
        progress=progress,
    )
    if single:  # the merge drops a collection's smear (one smear rule for every size)
        result = drop_smear(result)
    entries = describe(result) if describe is not None else [{} for _ in result.movers]
    movers = []
    for m, entry in zip(result.movers, entries, strict=True):
        b = m.bound
        movers.append(
            MoverRecord(
                patch=patch.index,
                position_m=np.asarray(m.position_m, float),
                velocity_mps=np.asarray(m.velocity_mps, float),
                sigma_range_m=float(b.range_position_m) if b is not None else math.inf,
                sigma_range_speed_mps=float(b.range_speed_mps) if b is not None else math.inf,
                snr_db=float(b.snr_db) if b is not None else -math.inf,
                document=entry,
                amplitude=abs(complex(m.fit.amplitude)),
            )
        )
    img = result.stationary_image
    mag = img.magnitude / traces.n_pulses
    peak = float(mag.max()) if mag.size else 0.0
    stationary = []
    for t in result.stationary:
        if single or (not patch.movers_only and patch.contains(t.position_m)):
            stationary.append(
                StationaryRecord(
                    patch=patch.index,
                    position_m=(float(t.position_m[0]), float(t.position_m[1])),
                    level=peak * 10.0 ** (t.level_db / 20.0),
                )
            )
    image = None if patch.movers_only else _core_image(img, mag, patch, single, mosaic_m)
    opts = result.options
    slim = PatchResult(
        index=patch.index,
        movers=tuple(movers),
        stationary=tuple(stationary),
        listed=len(result.stationary),
        capped=len(result.stationary) >= opts.max_stationary,
        image=image,
        method=result.method,
        n_pulses=traces.n_pulses,
        n_samples=traces.n_samples,
        timings_s=dict(result.timings_s),
        not_estimated=tuple(result.movers_not_estimated),
    )
    return slim, result


def stationary_box(traces: Traces, patch: Patch) -> tuple[float, float, float, float]:
    """The box ``(x0, y0, x1, y1)`` (m) of a patch's stationary image: its core's.

    The core's box widened by ``CORE_IMAGE_MARGIN_CELLS`` resolution cells of its
    traces either side. The separation still models the halo's stationary targets on
    the preliminary image of the halo (:func:`_patch_options`); only the image that lists
    the core's targets and fills the mosaic is cut to the core, whose pixels are all the
    patch reports. Its levels are relative to the brightest pixel of that box (the
    collection's listing rule then applies the threshold to the brightest target of the
    mosaic, :func:`_merge`), and so is a mover's ``image_peak_db``.
    """
    cells = resolution(traces)
    margin = CORE_IMAGE_MARGIN_CELLS * max(cells.ground_range_m, cells.cross_range_m)
    x0, y0, x1, y1 = patch.core_m
    return (x0 - margin, y0 - margin, x1 + margin, y1 + margin)


def _core_image(
    img: Image,
    mag: NDArray,
    patch: Patch,
    single: bool,
    mosaic_m: tuple[float, float, float] | None,
) -> PatchImage:
    """The core's pixels of a patch's stationary image ``mag`` (the others zero).

    On the mosaic's pixels when ``mosaic_m`` is given. A patch beyond the region (movers
    only) has none: :func:`analyze_patch` does not call this.
    """
    x0, y0, x1, y1 = patch.core_m
    gx, gy = img.grid.x_m, img.grid.y_m
    okx = np.ones(gx.size, bool) if single else (gx >= x0) & (gx < x1)
    oky = np.ones(gy.size, bool) if single else (gy >= y0) & (gy < y1)
    cut = mag[np.ix_(oky, okx)].astype(np.float32)
    if not single:  # the core is turned to the look: its box's pixels outside it are not its
        xx, yy = np.meshgrid(gx[okx], gy[oky])
        own = patch.inside(np.stack([xx.ravel(), yy.ravel()], axis=1)).reshape(cut.shape)
        cut[~own] = 0.0
    image = PatchImage(x_m=gx[okx], y_m=gy[oky], magnitude=cut)
    if mosaic_m is not None:
        image = coarsen(image, (mosaic_m[0], mosaic_m[1]), mosaic_m[2])
    return image


def _task(
    traces: Traces,
    patch: Patch,
    options: AnalysisOptions,
    single: bool,
    threads: int | None,
    describe: Callable[[AnalysisResult], list[dict[str, Any]]] | None,
    mosaic_m: tuple[float, float, float] | None = None,
) -> PatchResult:
    """One patch's analysis, numba's and BLAS's pools limited to ``threads``."""
    # traces of the task's own (the same array): imaging caches tables per traces object
    # while it lives, and the cluster may keep a task's arguments after it ran
    traces = traces.with_data(traces.data)
    kw: dict[str, Any] = {"single": single, "describe": describe, "mosaic_m": mosaic_m}
    if threads is None:
        return analyze_patch(traces, patch, options, **kw)[0]
    import numba
    from threadpoolctl import threadpool_limits

    previous = numba.get_num_threads()
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    try:
        with threadpool_limits(limits=threads):
            return analyze_patch(traces, patch, options, **kw)[0]
    finally:
        numba.set_num_threads(previous)


def drop_smear(result: AnalysisResult) -> AnalysisResult:
    """``result`` without the stationary listings that lie on a found mover's echo.

    The collection's rule (:func:`~sarmotion.collection.merge.drop_mover_images`) on one
    analysis: a mover's echo smeared over the stationary image is not listed as
    stationary points. The count goes to ``stationary_mover_images``.
    """
    if not result.movers or not result.stationary:
        return result
    tr = result.traces
    sl = _analysed_pulses(TracesBlocks(tr), result.options.sub_aperture_deg)
    analysed = Trajectory(
        positions_m=tr.trajectory.positions_m[sl], slow_times_s=tr.trajectory.slow_times_s[sl]
    )
    wavelength = tr.radar.wavelength_m
    magnitude = result.stationary_image.magnitude
    peak = float(magnitude.max()) / tr.n_pulses if magnitude.size else 0.0
    records = [
        StationaryRecord(
            patch=0, position_m=tuple(t.position_m), level=peak * 10.0 ** (t.level_db / 20.0)
        )
        for t in result.stationary
    ]
    movers = [
        MoverRecord(
            patch=0,
            position_m=np.asarray(m.position_m, float),
            velocity_mps=np.asarray(m.velocity_mps, float),
            sigma_range_m=math.inf,
            sigma_range_speed_mps=math.inf,
            snr_db=-math.inf,
            document={},
            amplitude=abs(complex(m.fit.amplitude)),
        )
        for m in result.movers
    ]
    kept, dropped = drop_mover_images(
        records,
        movers,
        trajectory=analysed,
        range_resolution_m=tr.radar.range_resolution_m,
        wavelength_m=wavelength,
        rate_period_mps=0.5 * wavelength / tr.trajectory.pulse_interval_s,
        height_m=float(tr.reference_point_m[2]),
        gaussian_range=tr.radar.pulse == "gaussian",
    )
    if not dropped:
        return result
    keep = {id(r) for r in kept}
    stationary = tuple(t for t, r in zip(result.stationary, records, strict=True) if id(r) in keep)
    return dataclasses.replace(
        result,
        stationary=stationary,
        stationary_mover_images=result.stationary_mover_images + dropped,
    )


# ---------------------------------------------------------------- collection
def _groups(plan: PatchPlan, memory_mb: float) -> Iterator[list[Patch]]:
    """Consecutive groups of patches whose traces (complex64) fit in ``memory_mb``."""
    group: list[Patch] = []
    used = 0.0
    for p in plan.patches:
        size = 8.0 * p.pulses.size * p.n_samples / 2**20
        if group and used + size > memory_mb:
            yield group
            group, used = [], 0.0
        group.append(p)
        used += size
    if group:
        yield group


def analyze_collection(
    source: PulseBlocks | Traces,
    options: CollectionOptions | None = None,
    *,
    region_m: ArrayLike | None = None,
    region_frame: str = "ground",
    plan: PatchPlan | None = None,
    scheduler: str | Any | None = None,
    n_workers: int | None = None,
    processes: bool = False,
    memory_mb: float = 1024.0,
    describe: Callable[[AnalysisResult], list[dict[str, Any]]] | None = None,
    progress: ProgressCallback | None = None,
) -> CollectionResult:
    """Analyse a whole collection patch by patch and merge the answers.

    Parameters
    ----------
    source : PulseBlocks or Traces
        The data (in-memory traces are served by :class:`~sarmotion.core.blocks.TracesBlocks`).
    options : CollectionOptions, optional
        Patch sizing, movers' speed, slow-time filter, block size, analysis options.
    region_m, region_frame
        The region and its frame, as for :func:`~sarmotion.collection.plan_patches`;
        default the data's declared image area, else its unambiguous scene.
    plan : PatchPlan, optional
        A plan already made by :func:`plan_patches` (then ``region_m`` is ignored).
    scheduler, n_workers, processes
        Where the patches run (module notes).
    memory_mb : float
        Most memory (MiB) for the traces of the patches extracted in one pass.
    describe : callable, optional
        ``describe(result)``: one JSON-ready entry per mover of a patch's analysis
        (:func:`analyze_patch`).
    progress : callable, optional
        ``progress(stage, done, total)``.

    Returns
    -------
    CollectionResult
    """
    opts = options or CollectionOptions()
    src = TracesBlocks(source) if isinstance(source, Traces) else source
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    if plan is None:
        plan = plan_patches(src, opts, region_m=region_m, region_frame=region_frame)
    timings["plan"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    results: dict[int, PatchResult] = {}
    single_result: AnalysisResult | None = None
    if plan.single:
        traces = src.traces if isinstance(src, TracesBlocks) else _read_all(src, opts.block_pulses)
        slim, single_result = analyze_patch(
            traces,
            plan.patches[0],
            opts.analysis,
            single=True,
            describe=describe,
            progress=progress,
        )
        results[0] = slim
        report(progress, "patches", 1, 1)
        canvas = None
    else:
        spacing = _mosaic_spacing(plan, opts)
        canvas = mosaic_grid(plan.extent_m, spacing)
        origin = (plan.extent_m[0], plan.extent_m[1], spacing)
        # closing: an exception here (Ctrl-C) stops the cluster before it leaves the call
        with closing(
            _run(
                src,
                plan,
                opts,
                scheduler,
                n_workers,
                processes,
                memory_mb,
                describe,
                progress,
                origin,
            )
        ) as patches:
            for r in patches:
                if r.image is not None:
                    paste(canvas[0], r.image, origin[:2], spacing)
                results[r.index] = dataclasses.replace(r, image=None)
    timings["patches"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    merged = _merge(src, plan, opts, [results[k] for k in sorted(results)], canvas)
    timings["merge"] = time.perf_counter() - t2
    timings["total"] = time.perf_counter() - t0
    if single_result is not None:  # one patch: the analysis's own listing and its counts
        merged = dataclasses.replace(
            merged,
            stationary_sidelobes=single_result.stationary_sidelobes,
            stationary_mover_images=single_result.stationary_mover_images,
        )
    return dataclasses.replace(merged, timings_s=timings, single_result=single_result)


def _read_all(src: PulseBlocks, block_pulses: int) -> Traces:
    data = np.empty((src.n_pulses, src.radar.n_samples), np.complex128)
    for start, stop, block in src.blocks(block_pulses):
        data[start:stop] = block
    return Traces(
        data=data,
        trajectory=src.trajectory,
        radar=src.radar,
        reference_point_m=src.reference_point_m,
        metadata=dict(src.metadata),
    )


def _run(
    src: PulseBlocks,
    plan: PatchPlan,
    opts: CollectionOptions,
    scheduler: str | Any | None,
    n_workers: int | None,
    processes: bool,
    memory_mb: float,
    describe: Callable[[AnalysisResult], list[dict[str, Any]]] | None,
    progress: ProgressCallback | None,
    mosaic_m: tuple[float, float, float],
) -> Iterator[PatchResult]:
    """Extract the patches group by group and analyse them; yield as they complete."""
    total = len(plan.patches)
    done = 0
    report(progress, "patches", 0, total)  # the bar from the start, not the first patch
    if scheduler is None and n_workers == 0:
        from threadpoolctl import threadpool_limits

        # BLAS on one thread, as in a task: a patch's matrices are a few hundred on a
        # side, too small for BLAS's threads to gain, and an OpenBLAS pool spinning
        # beside numba's threads (or other work on the machine) slows every product
        limit = threadpool_limits(limits=1, user_api="blas")
        try:
            yield from _serial(src, plan, opts, memory_mb, describe, progress, mosaic_m)
        finally:
            limit.restore_original_limits()
        return
    from distributed import as_completed

    from .._cluster import connect_scheduler, local_client, raise_if_interrupted

    cores = os.cpu_count() or 1
    with ExitStack() as stack:
        if scheduler is None:
            workers = cores if n_workers is None else int(n_workers)
            if workers < 1:
                raise ValueError(f"n_workers must be >= 0, got {n_workers!r}")
            client = stack.enter_context(local_client(workers, processes=processes))
            threads: int | None = max(1, cores // workers)
        elif isinstance(scheduler, str):  # within a timeout, with a worker (or refused)
            client = stack.enter_context(connect_scheduler(scheduler))
            threads = None
        else:
            client = scheduler
            threads = None
        log.info("patches on %s", client)
        pending = as_completed(loop=client.loop)  # not the default client: ours
        futures: set[Any] = set()
        try:
            for group in _groups(plan, memory_mb):
                # a Ctrl-C that a callback swallowed while the patches were submitted is
                # seen here, not once every group is on the cluster
                raise_if_interrupted()
                traces = extract_patches(src, group, block_pulses=opts.block_pulses)
                raise_if_interrupted()
                for patch, tr in zip(group, traces, strict=True):
                    f = _submit(
                        client,
                        _task,
                        tr,
                        patch,
                        opts.analysis,
                        False,
                        threads,
                        describe,
                        mosaic_m,
                        pure=False,
                        key=f"sarmotion-patch-{patch.index}-{id(plan)}",
                    )
                    futures.add(f)
                    pending.add(f)
                del traces
                raise_if_interrupted()
                for f in _ready(pending):
                    done += 1
                    report(progress, "patches", done, total)
                    yield _collect(f, futures)
            while not pending.is_empty():
                # a short poll, not a blocking wait: a Ctrl-C lost in a callback of Dask's
                # is seen here (``_cluster.INTERRUPTED``)
                raise_if_interrupted()
                for f in _ready(pending) or _wait():
                    done += 1
                    report(progress, "patches", done, total)
                    yield _collect(f, futures)
        finally:
            client.cancel([f for f in futures if not f.done()])


def _serial(
    src: PulseBlocks,
    plan: PatchPlan,
    opts: CollectionOptions,
    memory_mb: float,
    describe: Callable[[AnalysisResult], list[dict[str, Any]]] | None,
    progress: ProgressCallback | None,
    mosaic_m: tuple[float, float, float],
) -> Iterator[PatchResult]:
    """The patches one after the other in this process."""
    done, total = 0, len(plan.patches)
    for group in _groups(plan, memory_mb):
        pending = extract_patches(src, group, block_pulses=opts.block_pulses)
        pending.reverse()
        for patch in group:
            # each patch's traces are let go once analysed, and with them the
            # backprojection tables cached for them (imaging's table cache holds a
            # table while its traces live)
            traces = pending.pop()
            slim = analyze_patch(
                traces, patch, opts.analysis, describe=describe, mosaic_m=mosaic_m
            )[0]
            del traces
            yield slim
            done += 1
            report(progress, "patches", done, total)


def _collect(future: Any, futures: set[Any]) -> PatchResult:
    """A finished patch's result, its future released (the cluster forgets the result)."""
    result: PatchResult = future.result()
    futures.discard(future)
    future.release()
    return result


def _submit(client: Any, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """``client.submit(fn, *args, **kwargs)``, without Dask's warning on large arguments.

    A patch's traces travel as its task's argument by design (the workers never open the
    input), so Dask's advice to load large data on the workers does not apply.
    """
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Sending large graph")
        return client.submit(fn, *args, **kwargs)


def _ready(pending: Any) -> list[Any]:
    """The futures of ``pending`` already finished (without waiting)."""
    return list(pending.next_batch(block=False)) if pending.has_ready() else []


def _wait(poll_s: float = 0.1) -> list[Any]:
    """Nothing, after ``poll_s`` seconds: the pause between two looks at the queue.

    (``distributed.wait`` and a blocking ``as_completed`` wait on Dask's default client,
    which a scheduler given by its address does not set, and without a timeout.)
    """
    time.sleep(poll_s)
    return []


def _mosaic_spacing(plan: PatchPlan, opts: CollectionOptions) -> float:
    """The mosaic's pixel (m): the analysis's, or coarser to keep ``MOSAIC_MAX_PIXELS``."""
    x0, y0, x1, y1 = plan.extent_m
    return max(opts.analysis.spacing_m, max(x1 - x0, y1 - y0) / MOSAIC_MAX_PIXELS)


def _merge(
    src: PulseBlocks,
    plan: PatchPlan,
    opts: CollectionOptions,
    results: list[PatchResult],
    canvas: tuple[NDArray[np.float32], tuple[float, float, float, float]] | None,
) -> CollectionResult:
    traj = src.trajectory
    geom = look_geometry(traj, src.reference_point_m)
    b = geom.ground_m_o
    e_r = b / np.linalg.norm(b)
    slant = src.radar.range_resolution_m
    range_cell = slant / math.cos(geom.elevation_rad)
    cross_cell = src.radar.wavelength_m * geom.range_m / (2.0 * traj.aperture_length_m)
    analysed = _analysed(src, opts.analysis.sub_aperture_deg)
    movers = merge_movers([m for r in results for m in r.movers], analysed, slant)
    stationary = merge_stationary(
        [t for r in results for t in r.stationary],
        range_direction=e_r,
        range_cell_m=range_cell,
        cross_cell_m=cross_cell,
    )
    # today's listing rule on the whole scene: within stationary_threshold_db of the
    # brightest target of the mosaic (each patch applied it to its own brightest)
    floor = max((t.level for t in stationary), default=0.0) * 10.0 ** (
        opts.analysis.stationary_threshold_db / 20.0
    )
    stationary = [t for t in stationary if t.level >= floor]
    sidelobes = 0
    if not plan.single:  # one patch: the analysis dropped its sidelobes itself
        stationary, sidelobes = drop_sidelobes(
            stationary,
            antenna_m=traj.positions_m[int(np.argmin(np.abs(traj.slow_times_s)))],
            range_cell_m=range_cell,
            cross_cell_m=cross_cell,
            pixel_m=opts.analysis.spacing_m,
            gaussian_range=src.radar.pulse == "gaussian",
        )
    images = 0
    if not plan.single:
        prf = 1.0 / traj.pulse_interval_s
        stationary, images = drop_mover_images(
            stationary,
            [m for m, _ in movers],
            trajectory=analysed,
            range_resolution_m=slant,
            wavelength_m=src.radar.wavelength_m,
            rate_period_mps=0.5 * src.radar.wavelength_m * prf,
            height_m=float(src.reference_point_m[2]),
            gaussian_range=src.radar.pulse == "gaussian",
        )
    cap = opts.analysis.max_stationary * len(plan.patches)
    dropped = max(0, len(stationary) - cap)
    if canvas is None:  # one patch: its image, as today's analysis made it
        im = results[0].image
        assert im is not None
        spacing = opts.analysis.spacing_m
        x0, x1, y0, y1 = im.x_m[0], im.x_m[-1] + spacing, im.y_m[0], im.y_m[-1] + spacing
        spacing = max(spacing, max(x1 - x0, y1 - y0) / MOSAIC_MAX_PIXELS)
        image, extent = mosaic([im], (x0, y0, x1, y1), spacing)
    else:
        image, extent = canvas
    return CollectionResult(
        plan=plan,
        patches=tuple(results),
        movers=tuple((m, tuple(p)) for m, p in movers),
        stationary=tuple(stationary[:cap]),
        stationary_dropped=dropped,
        stationary_sidelobes=sidelobes,
        stationary_mover_images=images,
        mosaic=image,
        mosaic_extent_m=extent,
        options=opts,
        range_direction=e_r,
    )


def _analysed(src: PulseBlocks, sub_aperture_deg: float) -> Trajectory:
    """The analysed pulses (original slow times: ``s = 0`` stays the aperture centre)."""
    sl = _analysed_pulses(src, sub_aperture_deg)
    traj = src.trajectory
    return Trajectory(positions_m=traj.positions_m[sl], slow_times_s=traj.slow_times_s[sl])
