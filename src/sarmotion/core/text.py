"""Numbers in text a person reads: console lines, summaries."""

from __future__ import annotations

__all__ = ["fixed"]


def fixed(value: float, digits: int = 2) -> str:
    """``value`` with ``digits`` decimals, never ``-0.00``: a value that rounds to zero is 0.

    A coordinate of ``-4e-25`` m is printed ``0.00``, not ``-0.00``.
    """
    text = f"{float(value):.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text
