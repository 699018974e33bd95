"""sarmotion: single-antenna SAR imaging and motion estimation of complex scenes.

Implements Borcea, Callaghan & Papanicolaou, "Motion Estimation and Imaging of
Complex Scenes with Synthetic Aperture Radar": separation of the echoes of
stationary and moving targets (travel-time annihilation filters, windowed robust
PCA and their combination), range and cross-range speed estimation, separation of
movers, trajectory estimation and focused imaging.

The names a user starts with are here: :func:`analyze` with :class:`AnalysisOptions`,
:func:`read_gotcha`, :func:`load_scene` and :func:`simulate`, :func:`backproject`,
:class:`Traces` and :class:`Scene`; an analysis is printed with ``print(result)`` (one
line) or ``print(result.summary())`` and written with :func:`save` (what ``sarmotion
analyze --out`` writes) or :func:`save_report` (the HTML report alone). The
subpackages, in the order data flow through them: ``core`` (radar, geometry, traces),
``simulation``, ``io``, ``imaging``, ``separation``, ``motion``, ``pipeline``,
``tracking``, ``documents``, ``report``, ``paper``, ``cli``. A module imports only from
the layers below its own (``tests/test_layering.py`` states the layers);
:mod:`sarmotion.errors` holds the exceptions every layer raises.
"""

from importlib import import_module
from typing import TYPE_CHECKING

from ._version import __version__

if TYPE_CHECKING:
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
    "read_gotcha",
    "save",
    "save_report",
    "simulate",
]


def __getattr__(name: str) -> object:
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
