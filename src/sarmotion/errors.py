"""The exceptions of sarmotion: who is at fault decides the class.

* :class:`SarmotionError` -- the base; ``except SarmotionError`` catches every failure
  that sarmotion diagnosed itself (and nothing it did not).
* :class:`InputError` -- the input is unusable: a file, a scene description, a command-line
  value. The message is one line naming the file, key or flag and what is wrong. The
  command line reports it on stderr and exits with status 2. The I/O layer's
  :class:`~sarmotion.io.DataError`, the MATLAB structure check's
  :class:`~sarmotion.io.matv5.MatStructureError` and
  :class:`~sarmotion.simulation.SceneError` are subclasses.
* :class:`EstimationError` -- valid input on which an estimator finds nothing to estimate:
  ``g(u)`` has no peak in the searched band, the fast-time search of a trajectory runs
  past the end of the traces' window. Callers that can go on without the estimate catch
  this class, and only this class, so that a defect (any other exception) is not
  silenced.

Both subclass :class:`ValueError`, so code that caught ``ValueError`` around these calls
still catches them. Any other exception that reaches the command line is a defect of
sarmotion: exit status 1 with one line, and ``-vv`` shows the traceback.
"""

from __future__ import annotations

__all__ = ["EstimationError", "InputError", "SarmotionError"]


class SarmotionError(Exception):
    """Base class of the exceptions sarmotion raises on purpose."""


class InputError(SarmotionError, ValueError):
    """The input (a file, a scene, an option) is unusable; one line says where and why."""


class EstimationError(SarmotionError, ValueError):
    """Valid input on which an estimator finds no answer (no peak, window edge reached)."""
