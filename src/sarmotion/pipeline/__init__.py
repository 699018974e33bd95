"""The whole analysis of one acquisition, as a list of stages.

- :mod:`~sarmotion.pipeline.options` — :class:`AnalysisOptions`, every choice in one
  frozen, validated object;
- :mod:`~sarmotion.pipeline.detection` — :func:`detect`: preliminary image, separation
  and the range-speed test;
- :mod:`~sarmotion.pipeline.movers` — :func:`estimate_movers`: the mover stage as named
  steps, movers one at a time;
- :mod:`~sarmotion.pipeline.refit` — the movers' final fit on the data minus a stationary
  estimate made without them;
- :mod:`~sarmotion.pipeline.stages` — the later stages: trajectories, images,
  stationary targets;
- :mod:`~sarmotion.pipeline.analyze` — :func:`analyze`, the stages in order;
- :mod:`~sarmotion.pipeline.results` — :class:`AnalysisResult`, the :class:`Mover`
  record and the other parts;
- :mod:`~sarmotion.pipeline.family` — what the data fix of a mover's position: its
  range coordinate and the part of its cross-range family in the scene;
- :mod:`~sarmotion.pipeline.truth` — comparison with the true scene of a simulation.
"""

from .analyze import analyze
from .detection import DetectionResult, detect
from .family import FamilySegment, family_segment, range_coordinate
from .movers import MoverStage, estimate_movers, extract_mover
from .options import AnalysisOptions
from .results import AnalysisResult, Mover, MoverEvidence, NotEstimated, StationaryTarget
from .truth import MoverErrors, TrueMover, TruthComparison, compare_with_truth, family_errors

__all__ = [
    "AnalysisOptions",
    "AnalysisResult",
    "DetectionResult",
    "FamilySegment",
    "Mover",
    "MoverErrors",
    "MoverEvidence",
    "MoverStage",
    "NotEstimated",
    "StationaryTarget",
    "TrueMover",
    "TruthComparison",
    "analyze",
    "compare_with_truth",
    "detect",
    "estimate_movers",
    "extract_mover",
    "family_errors",
    "family_segment",
    "range_coordinate",
]
