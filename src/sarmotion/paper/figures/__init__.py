"""Every figure of the paper, regenerated from data, with the numbers behind it.

The plotting half of the paper wing (:mod:`sarmotion.paper`): it sits in the report layer
and draws with :mod:`sarmotion.report.plotting`.

- :mod:`~sarmotion.paper.figures.build` — :func:`build_figures` and the ``index.html`` page;
- :mod:`~sarmotion.paper.figures.captions` — the paper's captions;
- ``fig_imaging``, ``fig_separation``, ``fig_rank``, ``fig_motion`` — the figure builders
  of each part of the paper; ``_context`` — the scenes and analyses they share.
"""

from .build import FIGURE_LABELS, FigureRecord, build_figures, figure_filename
from .captions import CAPTIONS

__all__ = ["CAPTIONS", "FIGURE_LABELS", "FigureRecord", "build_figures", "figure_filename"]
