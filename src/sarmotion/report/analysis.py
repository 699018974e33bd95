"""An analysis written to a directory: what ``sarmotion analyze --out DIR`` writes.

:func:`save` writes ``results.json`` (the ``sarmotion.results/3`` document with the
point-target quality of the brightest stationary targets), ``report.html`` and the
report's figures as PNG; :func:`save_report` writes the report and its figures alone.
The command line calls :func:`save` after claiming ``--out``; called from Python, they
claim the directory themselves (:mod:`sarmotion.io.staging`): an existing output is
replaced only with ``force``, a concurrent writer of the same directory is refused at
once, and the directory holds the old output or the whole new one, never a mix.

Both are re-exported by the top-level package (``sarmotion.save``,
``sarmotion.save_report``). They are functions of the result, not methods of
:class:`~sarmotion.pipeline.AnalysisResult`, because the pipeline sits below the
documents and figures it would need (``tests/test_layering.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..collection import CollectionResult
from ..documents.results import results_document
from ..imaging.quality import point_quality
from ..io import staged_directory, write_json
from ..io.staging import claim_output, claimed
from ..pipeline import AnalysisResult, compare_with_truth
from ..simulation import Scene
from .analysis_figures import write_report

__all__ = [
    "ANALYSIS_OUTPUTS",
    "COLLECTION_OUTPUTS",
    "REPORT_OUTPUTS",
    "analysis_document",
    "save",
    "save_collection",
    "save_report",
]

#: The report's files: the HTML page and the PNG of each figure it embeds.
REPORT_OUTPUTS = (
    "report.html",
    "traces.png",
    "objectives.png",
    "images.png",
    "movers.png",
    "trajectories.png",
    "autofocus.png",
)

#: Everything :func:`save` and ``sarmotion analyze`` may write into their directory
#: (``stationary.nitf`` and ``mover-K.nitf`` only with the command's ``--sicd``).
ANALYSIS_OUTPUTS = ("results.json", *REPORT_OUTPUTS, "stationary.nitf")

#: What :func:`save_collection` (an analysis of several patches) writes into its directory.
COLLECTION_OUTPUTS = (
    "results.json",
    "report.html",
    "mosaic.png",
    "movers.png",
    "trajectories.png",
    "autofocus.png",
)

#: Brightest stationary targets whose point-target quality the document and report list.
QUALITY_TARGETS = 3


def analysis_document(
    result: AnalysisResult,
    *,
    scene: Scene | None = None,
    inputs: Sequence[str] = (),
    autofocus: dict[str, Any] | None = None,
    plan: Any = None,
    collection_options: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The ``results.json`` document of ``result``, as ``sarmotion analyze`` writes it.

    :func:`~sarmotion.documents.results_document` with the comparison with ``scene``'s
    truth (simulated inputs), the input names, the point-target quality of the
    :data:`QUALITY_TARGETS` brightest stationary targets and the autofocus record.

    Parameters
    ----------
    result : AnalysisResult
        The analysis.
    scene : Scene, optional
        The simulated scene the traces came from: adds ``truth`` and per-mover ``errors``.
    inputs : sequence of str
        The input names (``inputs``).
    autofocus : dict, optional
        The autofocus record (``PgaResult.to_dict()`` or the GOTCHA corrections' record).
    plan : PatchPlan, optional
        The plan that made the scene one patch; default the analysis's own image.
    collection_options : dict, optional
        The patches' options (``CollectionOptions.to_dict()``).
    """
    truth = compare_with_truth(result, scene) if scene is not None else None
    doc = results_document(result, truth=truth, plan=plan, collection_options=collection_options)
    for entry, m in zip(doc["movers"], result.movers, strict=True):
        entry["image"] = "movers.png" if m.image is not None else None  # its panel there
    doc["inputs"] = list(inputs)
    doc["point_quality"] = stationary_quality(result)
    if autofocus is not None:
        doc["autofocus"] = autofocus
    return doc


def stationary_quality(result: AnalysisResult) -> list[dict[str, Any]]:
    """IRW, PSLR and ISLR of the brightest stationary targets, on the stationary traces."""
    stationary = result.traces.with_data(result.stationary_traces)
    out = []
    for target in result.stationary[:QUALITY_TARGETS]:
        try:
            out.append(point_quality(stationary, target.position_m).to_dict())
        except ValueError as exc:
            out.append({"position_m": list(target.position_m), "error": str(exc)})
    return out


@contextmanager
def _claimed_stage(directory: Path, *, force: bool, names: Sequence[str]) -> Iterator[Path]:
    """A staging directory for ``directory``, claimed here unless this process holds it."""
    own = None
    if claimed(directory) is None:
        own = claim_output(directory, kind="directory", force=force, names=names)
    try:
        with staged_directory(directory) as stage:
            yield stage
    finally:
        if own is not None:
            own.release()


def save(
    result: AnalysisResult | CollectionResult,
    directory: str | Path,
    *,
    force: bool = False,
    scene: Scene | None = None,
    inputs: Sequence[str] = (),
    autofocus: dict[str, Any] | None = None,
    title: str | None = None,
    also: Callable[[Path], None] | None = None,
    plan: Any = None,
    collection_options: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Write ``directory``/results.json, report.html and the report's figures (PNG).

    The files ``sarmotion analyze --out DIRECTORY`` writes, from an analysis made in
    Python (:func:`sarmotion.analyze`).

    Parameters
    ----------
    result : AnalysisResult or CollectionResult
        The analysis: one patch's, or what :func:`sarmotion.analyze` returns. A
        collection of one patch is written as its ``single_result`` with its plan and
        options; one of several patches by :func:`save_collection` (``also`` must then
        be None, ``plan`` and ``collection_options`` are the result's own).
    directory : path
        Output directory; created with its parents if missing.
    force : bool
        Replace an earlier output in ``directory`` (all of its output files; other files
        are kept). Without it, a directory already holding one of :data:`ANALYSIS_OUTPUTS`
        is refused before anything is written.
    scene : Scene, optional
        The simulated scene of the traces: the document and report compare with its truth.
    inputs : sequence of str
        Input names, for the document and the report's header.
    autofocus : dict, optional
        Autofocus record for the document and the report's autofocus section.
    title : str, optional
        The report's title; default ``"sarmotion analysis"`` and the input names.
    also : callable, optional
        Called with the staging directory to write more files into the same output
        (the command line's ``--sicd`` images); what it raises aborts the whole output.
    plan, collection_options
        The patch plan of one patch and its options, for the document
        (:func:`analysis_document`).

    Returns
    -------
    dict
        The document written to ``results.json``.

    Raises
    ------
    sarmotion.io.staging.OutputError
        ``directory`` is a file, a link, holds an earlier output without ``force``, or
        another process is writing it (a ``ValueError``; one line).
    """
    if isinstance(result, CollectionResult):
        if result.single_result is None:
            if also is not None:
                raise ValueError("save: 'also' is for one patch's analysis, not a collection's")
            return save_collection(
                result,
                directory,
                force=force,
                scene=scene,
                inputs=inputs,
                autofocus=autofocus,
                title=title,
            )
        plan, collection_options = result.plan, result.options.to_dict()
        result = result.single_result
    out = Path(directory)
    with _claimed_stage(out, force=force, names=ANALYSIS_OUTPUTS) as stage:
        doc = analysis_document(
            result,
            scene=scene,
            inputs=inputs,
            autofocus=autofocus,
            plan=plan,
            collection_options=collection_options,
        )
        write_json(stage / "results.json", doc)
        write_report(result, stage, document=doc, title=_title(title, inputs), inputs=inputs)
        if also is not None:
            also(stage)
    return doc


def save_collection(
    result: CollectionResult,
    directory: str | Path,
    *,
    force: bool = False,
    scene: Scene | None = None,
    inputs: Sequence[str] = (),
    autofocus: dict[str, Any] | None = None,
    title: str | None = None,
) -> dict[str, Any]:
    """Write ``directory``/results.json, report.html, mosaic.png and figures of a collection.

    What ``sarmotion analyze --out DIRECTORY`` writes for an input cut into several
    patches; the document is the same schema as one patch's (``sarmotion.results/3``).
    Parameters as :func:`save`'s, ``force`` concerning :data:`COLLECTION_OUTPUTS`.

    Returns
    -------
    dict
        The document written to ``results.json``.
    """
    from ..documents.results import collection_document, collection_mover_images
    from .collection import write_collection_report

    doc = collection_document(result, scene=scene)
    doc["inputs"] = list(inputs)
    if autofocus is not None:
        doc["autofocus"] = autofocus
    images = "movers.png" if len(result.plan.patches) > 1 else None
    kept = [im is not None for im in collection_mover_images(result)]
    for m, im in zip(doc["movers"], kept, strict=True):
        m["image"] = images if im else m.get("image")
    out = Path(directory)
    with _claimed_stage(out, force=force, names=COLLECTION_OUTPUTS) as stage:
        write_json(stage / "results.json", doc)
        write_collection_report(
            result, stage, document=doc, title=_title(title, inputs), inputs=inputs
        )
    return doc


def save_report(
    result: AnalysisResult,
    directory: str | Path,
    *,
    force: bool = False,
    scene: Scene | None = None,
    inputs: Sequence[str] = (),
    title: str | None = None,
) -> Path:
    """Write ``directory``/report.html (self-contained) and its figures as PNG.

    Parameters are those of :func:`save`; ``force`` concerns :data:`REPORT_OUTPUTS`.

    Returns
    -------
    Path
        ``directory/report.html``.
    """
    out = Path(directory)
    with _claimed_stage(out, force=force, names=REPORT_OUTPUTS) as stage:
        doc = analysis_document(result, scene=scene, inputs=inputs)
        write_report(result, stage, document=doc, title=_title(title, inputs), inputs=inputs)
    return out / "report.html"


def _title(title: str | None, inputs: Sequence[str]) -> str:
    if title is not None:
        return title
    if not inputs:
        return "sarmotion analysis"
    return f"sarmotion analysis: {', '.join(Path(i).name for i in inputs)}"
