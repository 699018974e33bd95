"""The analysis of any source, of any size: one call plans, runs and merges.

:func:`analyze_source` is what :func:`sarmotion.analyze` and ``sarmotion analyze`` run
on their data once open: it plans the patches of the source's region
(:func:`~sarmotion.collection.plan_patches`) and analyses them
(:func:`~sarmotion.collection.analyze_collection`). The plan chooses, not the caller:
a region that fits one patch is analysed whole, as one
:func:`~sarmotion.pipeline.analyze` of all the traces; a larger one is cut into
patches, analysed (on Dask or in process) and merged. Either way the answer is one
:class:`~sarmotion.collection.CollectionResult` (one patch: ``single_result`` holds the
analysis), which :func:`sarmotion.documents.results.collection_document` turns into the
``sarmotion.results/3`` document.

**One smear rule for every path.** A mover's echo is spread over the stationary image
along the locus of the stationary points whose range and range rate it shares at some
pulse of the analysed aperture (:mod:`~sarmotion.collection.merge` notes). A listed
stationary point whose range and range rate are within ``ECHO_CELLS`` (2) range cells
``c / 2B`` and ``ECHO_CELLS`` Doppler cells ``lambda_o / 2T`` (``T`` the analysed
aperture's duration) of a found mover's at some pulse, and no brighter than the mover's
echo can make it there (its fitted amplitude times the mean over the pulses of the
compressed pulse's envelope at their range difference), is that smear, not a target: it
is dropped and counted in ``stationary_mover_images``. One patch: on the analysis
(:func:`~sarmotion.collection.drop_smear`); several: on the merged listing, against the
merged movers (:func:`~sarmotion.collection.merge.drop_mover_images`). The bare
:func:`~sarmotion.pipeline.analyze` is the stage below, without that rule: its listing
is each patch's, before the merge.

Nothing here reads files or prints: the source is open already
(:func:`sarmotion.open` opens a path), and what the caller says about the plan it says
in ``on_plan``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

from numpy.typing import ArrayLike

from ..core.blocks import PulseBlocks, TracesBlocks
from ..core.progress import ProgressCallback
from ..core.traces import Traces
from ..pipeline import AnalysisOptions, AnalysisResult
from .plan import CollectionOptions, PatchPlan, plan_patches
from .run import CollectionResult, analyze_collection

__all__ = ["analyze_source", "collection_options"]


def collection_options(options: AnalysisOptions | CollectionOptions | None) -> CollectionOptions:
    """``options`` as :class:`CollectionOptions` (analysis options: the patches' defaults).

    Raises
    ------
    TypeError
        ``options`` is neither.
    """
    if options is None:
        return CollectionOptions()
    if isinstance(options, CollectionOptions):
        return options
    if isinstance(options, AnalysisOptions):
        return CollectionOptions(analysis=options)
    raise TypeError(
        f"options must be an AnalysisOptions or a CollectionOptions, got {type(options).__name__}"
    )


def analyze_source(
    source: PulseBlocks | Traces,
    options: AnalysisOptions | CollectionOptions | None = None,
    *,
    region_m: ArrayLike | None = None,
    region_frame: str = "ground",
    scheduler: str | Any | None = None,
    n_workers: int | None = None,
    processes: bool = False,
    memory_mb: float = 1024.0,
    describe: Callable[[AnalysisResult], list[dict[str, Any]]] | None = None,
    progress: ProgressCallback | None = None,
    on_plan: Callable[[PatchPlan, PulseBlocks], None] | None = None,
) -> CollectionResult:
    """Plan, analyse and merge ``source``: one patch or many, as its region needs.

    Parameters
    ----------
    source : PulseBlocks or Traces
        The data: a block source (:func:`sarmotion.open`, read block by block) or
        traces in memory.
    options : AnalysisOptions or CollectionOptions, optional
        The analysis options (then the patches' defaults), or the collection's.
    region_m, region_frame
        The region and its frame (:func:`~sarmotion.collection.plan_patches`): default
        the data's declared image area within its unambiguous scene, else that scene.
    scheduler, n_workers, processes, memory_mb
        Where several patches run and how much of their traces is held at once
        (:func:`~sarmotion.collection.analyze_collection`); one patch runs in this
        process.
    describe : callable, optional
        ``describe(result)``: one JSON-ready entry per mover of each analysis
        (:func:`sarmotion.documents.results.describe_patch` for the document).
    progress : callable, optional
        ``progress(stage, done, total)``: the analysis's stages (one patch), the patches'
        traces and the patches (several).
    on_plan : callable, optional
        ``on_plan(plan, source)``, called once planned, before any analysis: to say the
        plan, or refuse it by raising.

    Returns
    -------
    CollectionResult
        The merged analysis; ``single_result`` is the whole analysis when the plan is one
        patch. The smear rule (module notes) is applied on either path.

    Raises
    ------
    TypeError
        ``options`` of another type.
    RegionError
        ``region_m`` outside the data, or a patch size below the data's resolution.
    """
    opts = collection_options(options)
    src = TracesBlocks(source) if isinstance(source, Traces) else source
    t0 = time.perf_counter()
    plan = plan_patches(src, opts, region_m=region_m, region_frame=region_frame)
    planned_s = time.perf_counter() - t0
    if on_plan is not None:
        on_plan(plan, src)
    result = analyze_collection(
        src,
        opts,
        plan=plan,
        scheduler=scheduler,
        n_workers=n_workers,
        processes=processes,
        memory_mb=memory_mb,
        describe=describe,
        progress=progress,
    )
    timings = dict(result.timings_s)  # the planning, made here, in the collection's times
    timings["total"] = timings.get("total", 0.0) + planned_s - timings.get("plan", 0.0)
    timings["plan"] = planned_s
    return dataclasses.replace(result, source=src, timings_s=timings)
