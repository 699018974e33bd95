"""The paper wing: what serves the paper's figures and not the analysis of data.

- :mod:`~sarmotion.paper.rank` -- the rank theory of the trace matrix (``sect:rank``):
  its model, symbols, predictions and the numerical rank. Pure science (arrays in, arrays
  out) on :mod:`sarmotion.core` and :mod:`sarmotion.simulation`.
- :mod:`~sarmotion.paper.figures` -- every figure of the paper with the numbers behind
  it (``sarmotion paper``). Report layer: the only part of the wing that plots.

:func:`sarmotion.pipeline.analyze` uses neither. This package imports neither part
itself, so ``import sarmotion.paper.rank`` does not load matplotlib.
"""
