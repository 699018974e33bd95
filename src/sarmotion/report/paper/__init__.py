"""Every figure of the paper, regenerated from data, with the numbers behind it.

- :mod:`~sarmotion.report.paper.build` — :func:`build_figures` and the ``index.html`` page;
- :mod:`~sarmotion.report.paper.captions` — the paper's captions;
- ``fig_imaging``, ``fig_separation``, ``fig_rank``, ``fig_motion`` — the figure builders
  of each part of the paper; ``_context`` — the scenes and analyses they share.
"""

from .build import FIGURE_LABELS, FigureRecord, build_figures, figure_filename
from .captions import CAPTIONS

__all__ = ["CAPTIONS", "FIGURE_LABELS", "FigureRecord", "build_figures", "figure_filename"]
