"""The whole analysis of one acquisition, as a list of stages.

- :mod:`~sarmotion.pipeline.options` — :class:`AnalysisOptions`, every choice in one
  frozen, validated object;
- :mod:`~sarmotion.pipeline.stages` — the stages: preliminary image, range speeds, movers
  one at a time, trajectories, images, stationary targets;
- :mod:`~sarmotion.pipeline.refit` — the movers' final fit on the data minus a stationary
  estimate made without them;
- :mod:`~sarmotion.pipeline.analyze` — :func:`analyze`, the stages in order;
- :mod:`~sarmotion.pipeline.results` — :class:`AnalysisResult` and its parts;
- :mod:`~sarmotion.pipeline.truth` — comparison with the true scene of a simulation.
"""

from .analyze import analyze
from .options import AnalysisOptions
from .results import AnalysisResult, MoverEvidence, MoverResult, StationaryTarget
from .stages import MoverFit, extract_mover
from .truth import MoverErrors, TrueMover, TruthComparison, compare_with_truth

__all__ = [
    "AnalysisOptions",
    "AnalysisResult",
    "MoverErrors",
    "MoverEvidence",
    "MoverFit",
    "MoverResult",
    "StationaryTarget",
    "TrueMover",
    "TruthComparison",
    "analyze",
    "compare_with_truth",
    "extract_mover",
]
