"""What the reader fuzz tests share: a time limit, a one-line-error check and counts."""

from __future__ import annotations

import signal
from collections.abc import Callable
from pathlib import Path
from typing import Any

from sarmotion.io import DataError

#: Longest a reader may take on one mutant (s).
TIME_LIMIT_S = 10.0


class Hang(Exception):
    """A reader took more than :data:`TIME_LIMIT_S` on a mutant."""


def _alarm(signum, frame):
    raise Hang(f"the reader took more than {TIME_LIMIT_S:g} s")


def read_or_refuse(read: Callable[[Path], Any], target: Path, stats: dict[str, int]) -> Any:
    """``read(target)`` within the time limit; None when it raised a one-line DataError.

    Counts the mutant in ``stats`` (``mutants``, ``refused``, ``accepted``); any other
    exception, or a DataError whose message is not one line starting with the path,
    fails the test.
    """
    stats["mutants"] = stats.get("mutants", 0) + 1
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT_S)
    try:
        out = read(target)
    except DataError as exc:
        stats["refused"] = stats.get("refused", 0) + 1
        assert "\n" not in str(exc) and str(exc).startswith(str(target)), str(exc)
        return None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)
    stats["accepted"] = stats.get("accepted", 0) + 1
    return out


def assert_every_mutant_ran(all_stats: dict[str, dict[str, int]], n_mutants: int) -> None:
    """Every file saw ``n_mutants`` mutants, some refused and some accepted."""
    print(all_stats)  # shown with -s: mutants, refused and accepted per file
    for name, stats in all_stats.items():
        assert stats.get("mutants", 0) >= n_mutants, (name, stats)
        assert stats.get("refused", 0) > 0 and stats.get("accepted", 0) > 0, (name, stats)
