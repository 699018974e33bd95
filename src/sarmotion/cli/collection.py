"""``sarmotion analyze`` on a scene of any size: patches when the scene needs more than one."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import click

from ..collection import (
    CollectionOptions,
    RegionError,
    analyze_collection,
    plan_patches,
)
from ..core.blocks import TracesBlocks
from ..documents.results import collection_document, describe_patch
from ..io import open_cphd_blocks, open_native_blocks, staged_directory, write_json
from ..io.staging import claimed
from ..report.collection import write_collection_report
from .autofocus import ReadOptions
from .common import InputError, Progress, check_out, say
from .describe import document_lines, stationary_note
from .main import elapsed_s

__all__ = ["COLLECTION_OUTPUTS", "run_collection"]

#: What the collection path writes into --out.
COLLECTION_OUTPUTS = (
    "results.json",
    "report.html",
    "mosaic.png",
    "movers.png",
    "trajectories.png",
    "autofocus.png",
)


def _quiet_dask() -> None:
    """Dask's own scheduler and worker messages are not the analysis's: warnings only."""
    import distributed  # noqa: F401  (configures its loggers on import)

    for name in list(logging.root.manager.loggerDict):
        if name == "distributed" or name.startswith("distributed."):
            logging.getLogger(name).setLevel(logging.WARNING)


def _block_source(inputs: Sequence[str], lenient: bool) -> Any:
    """A block reader for one CPHD or native traces file, else None."""
    if len(inputs) != 1:
        return None
    path = Path(inputs[0])
    suffix = path.suffix.lower()
    if not path.exists() or suffix not in (".cphd", ".h5", ".hdf5"):
        return None
    if suffix == ".cphd":
        return open_cphd_blocks(path, lenient=lenient)
    return open_native_blocks(path, lenient=lenient)


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
    """Plan the patches of ``inputs``; one patch: ``single(read, plan)``; else the collection.

    ``single`` is the analysis of the inputs already read (``read = (traces, simulation,
    autofocus result)``) as the one patch of ``plan``; it writes its own outputs, with
    options of its own (the patches' are ``copts.analysis``). Either way the output is
    one ``sarmotion.results/3`` document, one report and one console account.
    ``reading``: how the inputs are read, as for :func:`~sarmotion.cli.analyze.run_analyze`.
    """
    reading = ReadOptions() if reading is None else reading
    if n_workers is not None and n_workers < 0:
        raise InputError(f"--workers must be >= 0, got {n_workers}")

    def read() -> tuple[Any, Any, Any]:
        return reading.read(inputs)

    # a CPHD or native traces file is read block by block (unless autofocus needs it all)
    source: Any = _block_source(inputs, reading.lenient) if not reading.autofocus else None
    read_first = None if source is not None else read()
    if source is None:
        source = TracesBlocks(read_first[0])
    try:
        plan = plan_patches(source, copts, region_m=region, region_frame=region_frame)
    except RegionError as exc:
        text = str(exc).replace("patch size", "--patch-size").replace("region", "--region", 1)
        raise InputError(text) from None
    if plan.declared_outside_m2 > 0.0:
        click.echo(
            f"the declared image area: {plan.declared_outside_m2:.4g} m^2 "
            f"({100.0 * plan.declared_outside_share:.1f} %) outside the data's unambiguous "
            "scene, not analysed"
        )
    _say_plan(plan, source, n_workers, scheduler)
    if refuse_patches and not (plan.single and region is None):
        # an option the patches cannot honour: refused from the plan, before any analysis
        raise InputError(refuse_patches.format(n=len(plan.patches)))
    if plan.single and region is None and scheduler is not None:
        logging.getLogger(__name__).info(
            "one patch: analysed in this process (--scheduler is used for patches)"
        )
    if plan.single and region is None:
        single(read_first if read_first is not None else read(), plan)
        return
    focus = read_first[2] if read_first is not None else None
    sim = read_first[1] if read_first is not None else None
    if claimed(out) is None:  # the analyze command claims it before reading
        check_out(out, force=force, names=COLLECTION_OUTPUTS)
    _quiet_dask()
    with Progress(enabled=progress) as bar:
        result = analyze_collection(
            source,
            copts,
            plan=plan,
            scheduler=scheduler,
            n_workers=n_workers,
            describe=describe_patch,
            progress=bar,
        )
    doc = collection_document(result, source, scene=sim.scene if sim is not None else None)
    doc["inputs"] = list(inputs)
    if focus is not None:
        doc["autofocus"] = focus.to_dict()
    images = "movers.png" if len(plan.patches) > 1 else None
    for m, im in zip(doc["movers"], _images(result), strict=True):
        m["image"] = images if im else m.get("image")
    with staged_directory(out) as stage:
        write_json(stage / "results.json", doc)
        write_collection_report(
            result,
            stage,
            document=doc,
            title=f"sarmotion analysis: {', '.join(Path(i).name for i in inputs)}",
            inputs=inputs,
        )
    echo_document(out, doc, result.timings_s["total"])


def _images(result: Any) -> list[bool]:
    """Whether each merged mover kept its image."""
    from ..documents.results import collection_mover_images

    return [im is not None for im in collection_mover_images(result)]


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
        what = (
            f"{len(plan.patches)} patches of {plan.patch_size_m:.0f} m over "
            f"{x1 - x0:.0f} x {y1 - y0:.0f} m, {where}"
        )
    say(click.get_current_context(silent=True), f"analyze: {data}: {what}")
