"""Figures and reports: the layer that imports matplotlib (with the paper's figures).

- :mod:`~sarmotion.report.plotting` — trace and image panels in the paper's style, and
  the radar's look direction as an arrow on an image;
- :mod:`~sarmotion.report.analysis_figures` — the figures of an analysis (movers drawn
  as their cross-range family) and its ``write_report``;
- :mod:`~sarmotion.report.html` — the self-contained HTML report, from the results
  document alone;
- :mod:`~sarmotion.report.tracks` — tracks over the stationary image and their speeds;
- :mod:`~sarmotion.report.page` — the page the HTML reports share (stylesheet, header,
  sections, tables).

The paper's figures are built in :mod:`sarmotion.paper.figures` with these panels.

Figures are built as :class:`matplotlib.figure.Figure` objects, never through pyplot's
global state, so importing this package switches no backend.
"""
