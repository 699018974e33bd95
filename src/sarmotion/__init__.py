"""sarmotion: single-antenna SAR imaging and motion estimation of complex scenes.

Implements Borcea, Callaghan & Papanicolaou, "Motion Estimation and Imaging of
Complex Scenes with Synthetic Aperture Radar": separation of the echoes of
stationary and moving targets (travel-time annihilation filters, windowed robust
PCA and their combination), range and cross-range speed estimation, separation of
movers, trajectory estimation and focused imaging.

The names a user starts with are here: :func:`analyze` with :class:`AnalysisOptions`,
:func:`read_gotcha`, :func:`load_scene` and :func:`simulate`, :func:`backproject`,
:class:`Traces` and :class:`Scene`. The subpackages, in the order data flow through them:
``core`` (radar, geometry, traces), ``simulation``, ``io``, ``imaging``, ``separation``,
``motion``, ``pipeline``, ``report``, ``cli``.
"""

__version__ = "0.1.0"

from .core import Traces  # noqa: E402
from .imaging import backproject  # noqa: E402
from .io import read_gotcha  # noqa: E402
from .pipeline import AnalysisOptions, analyze  # noqa: E402
from .simulation import Scene, load_scene, simulate  # noqa: E402

__all__ = [
    "AnalysisOptions",
    "Scene",
    "Traces",
    "__version__",
    "analyze",
    "backproject",
    "load_scene",
    "read_gotcha",
    "simulate",
]
