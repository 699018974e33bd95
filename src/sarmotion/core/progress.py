"""The progress convention of every long computation.

A long computation takes ``progress: ProgressCallback | None`` and calls
``progress(stage, done, total)`` as it advances: ``stage`` names the step in words
("backprojection", "separation", ...), ``done`` of ``total`` units of it are finished.
Callers draw bars (the command line) or log; the science layer never prints.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["ProgressCallback", "report"]

#: ``progress(stage, done, total)``; see the module docstring.
ProgressCallback = Callable[[str, int, int], Any]


def report(progress: ProgressCallback | None, stage: str, done: int, total: int) -> None:
    """Call ``progress(stage, done, total)`` when a callback is given."""
    if progress is not None:
        progress(stage, done, total)
