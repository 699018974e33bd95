"""sarmotion: single-antenna SAR imaging and motion estimation of complex scenes.

Implements Borcea, Callaghan & Papanicolaou, "Motion Estimation and Imaging of
Complex Scenes with Synthetic Aperture Radar": separation of the echoes of
stationary and moving targets (travel-time annihilation filters, windowed robust
PCA and their combination), range and cross-range speed estimation, separation of
movers, trajectory estimation and focused imaging.

The names a user starts with are here: :func:`analyze` with :class:`AnalysisOptions`,
:func:`read` (any input as traces) and :func:`open` (as pulse blocks), :func:`read_gotcha`,
:func:`load_scene` and :func:`simulate`, :func:`backproject`,
:class:`Traces` and :class:`Scene`; an analysis is printed with ``print(result)`` (one
line) or ``print(result.summary())`` and written with :func:`save` (what ``sarmotion
analyze --out`` writes) or :func:`save_report` (the HTML report alone). The
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
    from .core import Traces
    from .imaging import backproject
    from .io import read_gotcha
    from .pipeline import AnalysisOptions, analyze
    from .report.analysis import save, save_report
    from .simulation import Scene, load_scene, simulate

# The names are imported on first use (PEP 562): ``import sarmotion`` and the command
# line's start-up do not pay for numba, scipy and matplotlib before they are needed.
_LAZY = {
    "AnalysisOptions": ".pipeline",
    "Scene": ".simulation",
    "Traces": ".core",
    "analyze": ".pipeline",
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

__getattr__, __dir__ = _attach(__name__, _LAZY, eager=("__version__", "open", "read"))


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
