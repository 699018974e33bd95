"""``sarmotion analyze`` on a scene of any size: the library plans and analyses, this writes."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import click

from ..collection import CollectionOptions, RegionError, analyze_source
from ..core.blocks import TracesBlocks
from ..documents.results import describe_patch
from ..io.staging import claimed
from ..report.analysis import COLLECTION_OUTPUTS, save_collection
from ..sources import is_scene_reference, open_source
from .autofocus import ReadOptions
from .common import InputError, Progress, as_flags, check_out, say
from .describe import document_lines, stationary_note
from .main import elapsed_s

__all__ = ["COLLECTION_OUTPUTS", "open_inputs", "run_collection", "write_collection"]


def _quiet_dask() -> None:
    """Dask's own scheduler and worker messages are not the analysis's: warnings only."""
    import distributed  # noqa: F401  (configures its loggers on import)

    for name in list(logging.root.manager.loggerDict):
        if name == "distributed" or name.startswith("distributed."):
            logging.getLogger(name).setLevel(logging.WARNING)


def open_inputs(inputs: Sequence[str], reading: ReadOptions) -> tuple[Any, Any, Any]:
    """``(source, simulation, autofocus result)`` of ``inputs``, opened for the analysis.

    Through :func:`sarmotion.sources.open_source`, which tells the kinds apart: a CPHD or
    native file is read block by block. A scene is simulated (its truth kept) and an
    input to be focused is read whole first (:meth:`ReadOptions.read`).
    """
    if reading.autofocus or (len(inputs) == 1 and is_scene_reference(inputs[0])):
        traces, sim, focus = reading.read(inputs)
        return TracesBlocks(traces), sim, focus
    with as_flags(speed_mps="--speed"):
        source = open_source(inputs, lenient=reading.lenient, speed_mps=reading.speed_mps)
    return source, None, None


def run_collection(
    inputs: Sequence[str],
    out: Path,
    copts: CollectionOptions,
    *,
    region: tuple[float, float, float, float] | None,
    region_frame: str = "ground",
    scheduler: str | None,
    n_workers: int | None,
    single: Any,
    reading: ReadOptions | None = None,
    progress: bool = False,
    force: bool = False,
    refuse_patches: str | None = None,
) -> None:
    """Analyse ``inputs`` (:func:`~sarmotion.collection.analyze_source`) and write ``out``.

    The library plans the patches and analyses one or many; here the plan is said (and
    refused with ``refuse_patches``, its ``{n}`` the patches, when it is more than one
    patch or a region is given) and the result written: a region of one patch, no
    ``region`` given, by ``single(result, simulation, autofocus result)`` (the one
    analysis's outputs); else the merged document, the report and the mosaic. Either way
    one ``sarmotion.results/3`` document, one report and one console account.
    ``reading``: how the inputs are read, as for :func:`~sarmotion.cli.analyze.run_analyze`.
    """
    reading = ReadOptions() if reading is None else reading
    if n_workers is not None and n_workers < 0:
        raise InputError(f"--workers must be >= 0, got {n_workers}")
    source, sim, focus = open_inputs(inputs, reading)
    whole = {"single": False}

    def on_plan(plan: Any, src: Any) -> None:
        if plan.declared_outside_m2 > 0.0:
            click.echo(
                f"the declared image area: {plan.declared_outside_m2:.4g} m^2 "
                f"({100.0 * plan.declared_outside_share:.1f} %) outside the data's "
                "unambiguous scene, not analysed"
            )
        _say_plan(plan, src, n_workers, scheduler)
        whole["single"] = plan.single and region is None
        if refuse_patches and not whole["single"]:
            # an option the patches cannot honour: refused from the plan, before any analysis
            raise InputError(refuse_patches.format(n=len(plan.patches)))
        if plan.single and scheduler is not None:
            logging.getLogger(__name__).info(
                "one patch: analysed in this process (--scheduler is used for patches)"
            )
        if not plan.single:
            _quiet_dask()

    with Progress(enabled=progress) as bar:

        def said(stage: str, done: int, total: int) -> None:
            if not (whole["single"] and stage == "patches"):  # one analysis: no patch count
                bar(stage, done, total)

        try:
            result = analyze_source(
                source,
                copts,
                region_m=region,
                region_frame=region_frame,
                scheduler=scheduler,
                n_workers=n_workers,
                describe=describe_patch,
                progress=said,
                on_plan=on_plan,
            )
        except RegionError as exc:
            text = str(exc).replace("patch size", "--patch-size").replace("region", "--region", 1)
            raise InputError(text) from None
    if whole["single"]:
        single(result, sim, focus)
        return
    write_collection(
        result,
        out,
        inputs,
        scene=sim.scene if sim is not None else None,
        autofocus=focus,
        force=force,
    )


def write_collection(
    result: Any,
    out: Path,
    inputs: Sequence[str],
    *,
    scene: Any = None,
    autofocus: Any = None,
    force: bool = False,
) -> None:
    """``out``/results.json, report.html and mosaic.png of a collection, and the console."""
    if claimed(out) is None:  # the analyze command claims it before reading
        check_out(out, force=force, names=COLLECTION_OUTPUTS)
    doc = save_collection(
        result,
        out,
        force=force,
        scene=scene,
        inputs=inputs,
        autofocus=None if autofocus is None else autofocus.to_dict(),
    )
    echo_document(out, doc, result.timings_s["total"])


def echo_document(out: Path, doc: dict[str, Any], analysis_s: float) -> None:
    """The console's account of an analysis of any size: what was written and found."""
    n = len(doc["plan"]["patches"])
    patches = f"{n} patches, " if n > 1 else ""
    click.echo(
        f"wrote {out}/results.json, report.html and figures: {patches}"
        f"{len(doc['movers'])} mover(s), {len(doc['stationary'])} stationary target(s)"
        + stationary_note(doc)
        + f"; analysis {analysis_s:.1f} s, {elapsed_s():.1f} s in all "
        "(start-up, reading and figures included)"
    )
    for line in document_lines(doc):
        click.echo(line)


def _say_plan(plan: Any, source: Any, n_workers: int | None, scheduler: str | None) -> None:
    """The plan in one line (stderr, not under ``-q``): data, patches, workers."""
    x0, y0, x1, y1 = plan.region_m
    data = f"{source.n_pulses} pulses x {source.radar.n_samples} samples"
    if plan.single and len(plan.patches) == 1:
        what = f"one analysis of {x1 - x0:.0f} x {y1 - y0:.0f} m"
    else:
        where = (
            f"on {scheduler}"
            if scheduler
            else (
                "in this process"
                if n_workers == 0
                else f"on {n_workers or 'one per core'} worker(s)"
            )
        )
        beyond = sum(p.movers_only for p in plan.patches)
        widened = (
            f" ({beyond} beyond it for the movers' images, up to "
            f"{plan.image_shift_m:.0f} m off in cross range)"
            if beyond
            else ""
        )
        what = (
            f"{len(plan.patches)} patches of {plan.patch_size_m:.0f} m over "
            f"{x1 - x0:.0f} x {y1 - y0:.0f} m{widened}, {where}"
        )
    say(click.get_current_context(silent=True), f"analyze: {data}: {what}")
