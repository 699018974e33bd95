"""sarmotion: single-antenna SAR imaging and motion estimation of complex scenes.

Implements Borcea, Callaghan & Papanicolaou, "Motion Estimation and Imaging of
Complex Scenes with Synthetic Aperture Radar": separation of the echoes of
stationary and moving targets (travel-time annihilation filters, windowed robust
PCA and their combination), range and cross-range speed estimation, separation of
movers, trajectory estimation and focused imaging.

The names a user starts with are here: :func:`analyze` with :class:`AnalysisOptions`
(any input: a path, a source from :func:`open` or traces; one patch or many, as the
scene needs), :func:`read` (any input as traces) and :func:`open` (as pulse blocks),
:func:`read_gotcha`, :func:`load_scene` and :func:`simulate`, :func:`backproject`,
:class:`Traces` and :class:`Scene`; an analysis of one patch (``result.single_result``)
is printed with ``print(...)`` (one line) or ``print(....summary())`` and written with
:func:`save` (what ``sarmotion analyze --out`` writes) or :func:`save_report` (the HTML
report alone). The
subpackages, in the order data flow through them: ``core`` (radar, geometry, traces),
``simulation``, ``io``, ``imaging``, ``separation``, ``motion``, ``pipeline``,
``tracking``, ``documents``, ``report``, ``paper``, ``cli``. A module imports only from
the layers below its own (``tests/test_layering.py`` states the layers);
:mod:`sarmotion.errors` holds the exceptions every layer raises.
"""

from typing import TYPE_CHECKING as _TYPE_CHECKING

from ._lazy import attach as _attach
from ._version import __version__

if _TYPE_CHECKING:
    from .collection import CollectionResult
    from .core import Traces
    from .imaging import backproject
    from .io import read_gotcha
    from .pipeline import AnalysisOptions
    from .report.analysis import save, save_report
    from .simulation import Scene, load_scene, simulate

# The names are imported on first use (PEP 562): ``import sarmotion`` and the command
# line's start-up do not pay for numba, scipy and matplotlib before they are needed.
_LAZY = {
    "AnalysisOptions": ".pipeline",
    "Scene": ".simulation",
    "Traces": ".core",
    "backproject": ".imaging",
    "load_scene": ".simulation",
    "read_gotcha": ".io",
    "save": ".report.analysis",
    "save_report": ".report.analysis",
    "simulate": ".simulation",
}

__all__ = [
    "AnalysisOptions",
    "Scene",
    "Traces",
    "__version__",
    "analyze",
    "backproject",
    "load_scene",
    "open",
    "read",
    "read_gotcha",
    "save",
    "save_report",
    "simulate",
]

__getattr__, __dir__ = _attach(__name__, _LAZY, eager=("__version__", "analyze", "open", "read"))


def read(inputs, **options):  # type: ignore[no-untyped-def]
    """Read any input as :class:`Traces`: a scene is simulated, a file is read by its kind.

    Parameters
    ----------
    inputs : path, str or sequence of them
        A built-in scene name or a scene ``.toml`` file; a native traces ``.h5`` file;
        GOTCHA ``.mat`` files or a directory of them (one aperture); or a CPHD ``.cphd``
        file.
    **options
        Those of :func:`sarmotion.sources.read_source`: ``lenient``, ``speed_mps`` and
        ``autofocus`` (GOTCHA), ``channel`` and ``vectors`` (CPHD), ``snr_db`` and ``seed``
        (scenes).

    Returns
    -------
    Traces
        The acquisition (a scene's truth: :func:`sarmotion.sources.read_source`).
    """
    from .sources import read_source

    return read_source(inputs, **options)[0]


def open(inputs, **options):  # type: ignore[no-untyped-def]  # noqa: A001
    """Open any input as a source of pulse blocks (large files are read block by block).

    Parameters are those of :func:`read`; the source has ``radar``,
    ``reference_point_m``, ``trajectory``, ``n_pulses``, ``metadata`` and
    ``blocks(block_pulses)`` (:func:`sarmotion.sources.open_source`).
    """
    from .sources import open_source

    return open_source(inputs, **options)


def analyze(  # type: ignore[no-untyped-def]
    source,
    options=None,
    *,
    region_m=None,
    region_frame: str = "ground",
    scheduler=None,
    n_workers: int | None = None,
    progress=None,
    **read_options,
) -> "CollectionResult":
    """Analyse any input, of any size: plan the patches, analyse them, merge the answers.

    The data's region (its declared image area within its unambiguous scene, or that
    scene) is planned as patches; a region of one patch is analysed whole, a larger one
    patch by patch and merged (:func:`sarmotion.collection.analyze_source`, what
    ``sarmotion analyze`` runs). On either path a mover's smeared echo is not listed as
    stationary points (the smear rule stated there).

    Parameters
    ----------
    source : Traces, a block source, path, str or sequence of them
        Traces in memory; a source from :func:`open`; or inputs as for :func:`read`
        (opened with :func:`open`: a CPHD or native file is read block by block).
    options : AnalysisOptions or CollectionOptions, optional
        The analysis options (then the patches' defaults), or the collection's.
    region_m, region_frame
        The region to analyse and its frame (:func:`sarmotion.collection.plan_patches`).
    scheduler, n_workers
        Where several patches run (:func:`sarmotion.collection.analyze_collection`):
        default a local Dask cluster of one worker per core; ``n_workers=0`` in this
        process.
    progress : callable, optional
        ``progress(stage, done, total)``.
    **read_options
        For a path: the options of :func:`open`.

    Returns
    -------
    CollectionResult
        The merged analysis, with the source it was made from;
        :func:`sarmotion.documents.results.collection_document` turns it into the
        ``sarmotion.results/3`` document. ``single_result`` is the whole
        :class:`~sarmotion.pipeline.AnalysisResult` when the region is one patch.
    """
    from .collection import analyze_source
    from .core.blocks import PulseBlocks
    from .core.traces import Traces
    from .documents.results import describe_patch

    if not isinstance(source, (Traces, PulseBlocks)):
        source = open(source, **read_options)
    elif read_options:
        raise TypeError(
            f"{', '.join(sorted(read_options))}: options for reading a path, "
            "not for data already read or open"
        )
    return analyze_source(
        source,
        options,
        region_m=region_m,
        region_frame=region_frame,
        scheduler=scheduler,
        n_workers=n_workers,
        describe=describe_patch,
        progress=progress,
    )
