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
    collection_document,
    plan_patches,
)
from ..core.blocks import TracesBlocks
from ..core.text import fixed
from ..documents.results import results_document
from ..io import open_cphd_blocks, open_native_blocks, staged_directory, write_json
from ..io.staging import claimed
from ..report.collection import write_collection_report
from .autofocus import ReadOptions
from .common import InputError, Progress, check_out
from .describe import mover_lines
from .main import elapsed_s

__all__ = ["COLLECTION_OUTPUTS", "run_collection"]

#: What the collection path writes into --out.
COLLECTION_OUTPUTS = ("results.json", "report.html", "mosaic.png")


def _quiet_dask() -> None:
    """Dask's own scheduler and worker messages are not the analysis's: warnings only."""
    import distributed  # noqa: F401  (configures its loggers on import)

    for name in list(logging.root.manager.loggerDict):
        if name == "distributed" or name.startswith("distributed."):
            logging.getLogger(name).setLevel(logging.WARNING)


def mover_entries(result: Any) -> list[dict[str, Any]]:
    """The ``sarmotion.results`` entries of an analysis's movers."""
    return results_document(result)["movers"]


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
    scheduler: str | None,
    n_workers: int | None,
    single: Any,
    reading: ReadOptions | None = None,
    progress: bool = False,
    force: bool = False,
    refuse_patches: str | None = None,
) -> None:
    """Plan the patches of ``inputs``; one patch: ``single(read)``; else the collection.

    ``single`` is today's analysis of the inputs already read (``read = (traces,
    simulation, autofocus result)``); it writes its own outputs, with options of its own
    (the patches' are ``copts.analysis``). ``reading``: how the inputs are read, as for
    :func:`~sarmotion.cli.analyze.run_analyze`.
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
        plan = plan_patches(source, copts, region_m=region)
    except RegionError as exc:
        text = str(exc).replace("patch size", "--patch-size").replace("region", "--region", 1)
        raise InputError(text) from None
    if refuse_patches and not (plan.single and region is None):
        # an option the patches cannot honour: refused from the plan, before any analysis
        raise InputError(refuse_patches.format(n=len(plan.patches)))
    if plan.single and region is None and scheduler is not None:
        logging.getLogger(__name__).info(
            "one patch: analysed in this process (--scheduler is used for patches)"
        )
    if plan.single and region is None:
        single(read_first if read_first is not None else read())
        return
    focus = read_first[2] if read_first is not None else None
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
            describe=mover_entries,
            progress=bar,
        )
    doc = collection_document(result, source)
    doc["inputs"] = list(inputs)
    if focus is not None:
        doc["autofocus"] = focus.to_dict()
    with staged_directory(out) as stage:
        write_json(stage / "results.json", doc)
        write_collection_report(
            result,
            stage,
            document=doc,
            title=f"sarmotion collection: {', '.join(Path(i).name for i in inputs)}",
        )
    click.echo(
        f"wrote {out}/results.json, report.html and mosaic.png: {len(plan.patches)} patch(es), "
        f"{len(result.movers)} mover(s), {len(result.stationary)} stationary target(s)"
        + _stationary_note(doc)
        + f"; analysis {result.timings_s['total']:.1f} s, {elapsed_s():.1f} s in all "
        "(start-up, reading and figures included)"
    )
    for k, m in enumerate(doc["movers"]):
        centre = doc["plan"]["patches"][m["patch"]]["centre_m"]
        where = f"patch {m['patch']}'s centre ({centre[0]:.1f}, {centre[1]:.1f}) m"
        for line in mover_lines(m, f"mover {k + 1} (patch {m['patch']})", where):
            click.echo(line)
    for line in _not_estimated_lines(doc):
        click.echo(line)


def _stationary_note(doc: dict[str, Any]) -> str:
    """The stationary listings left out: beyond the cap, sidelobes, on a mover's echo."""
    notes = []
    if doc["stationary_dropped"]:
        notes.append(f"{doc['stationary_dropped']} beyond the cap not listed")
    if doc["stationary_sidelobes_dropped"]:
        notes.append(
            f"{doc['stationary_sidelobes_dropped']} dropped as a brighter target's sidelobes"
        )
    if doc.get("stationary_mover_images_dropped"):
        notes.append(f"{doc['stationary_mover_images_dropped']} dropped as lying on a mover's echo")
    return f" ({', '.join(notes)})" if notes else ""


def _not_estimated_lines(doc: dict[str, Any]) -> list[str]:
    """Lines for the candidates each patch left unestimated by ``--max-movers``."""
    extra = doc.get("movers_not_estimated") or []
    if not extra:
        return []
    cap = doc["options"]["analysis"].get("max_movers")
    lines = [
        f"  {len(extra)} more candidate(s) passed a patch's detector, not estimated "
        f"(--max-movers {cap} per patch):"
    ]
    for k, c in enumerate(extra):
        lines.append(
            f"    candidate {k + 1} (patch {c['patch']}): statistic {fixed(c['statistic_db'], 1)} "
            f"dB, range {fixed(c['range_m'], 1)} m from the patch centre (aligned trace, not "
            f"fitted), range speed {fixed(c['range_speed_mps'], 2)} m/s"
        )
    return lines
