"""Wall-clock timing of the analysis's steps and the progress callback of one step."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

from ..core.progress import ProgressCallback

__all__ = ["timed", "staged"]


@contextmanager
def timed(timings: dict[str, float], step: str) -> Iterator[None]:
    """Add the wall-clock time of the ``with`` block to ``timings[step]`` (s)."""
    start = time.perf_counter()
    try:
        yield
    finally:
        timings[step] = timings.get(step, 0.0) + time.perf_counter() - start


def staged(progress: ProgressCallback | None, step: str) -> ProgressCallback | None:
    """``progress`` with its stage name replaced by ``step``."""
    if progress is None:
        return None
    return lambda _, done, total: progress(step, done, total)
