"""Figures and reports: the only layer that imports matplotlib.

- :mod:`~sarmotion.report.plotting` — trace and image panels in the paper's style;
- :mod:`~sarmotion.report.html` — the self-contained HTML report of an analysis;
- :mod:`~sarmotion.report.tracks` — tracks over the stationary image and their speeds;
- :mod:`~sarmotion.report.paper` — every figure of the paper with its numbers.

Figures are built as :class:`matplotlib.figure.Figure` objects, never through pyplot's
global state, so importing this package switches no backend.
"""
