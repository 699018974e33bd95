"""The exception of the I/O layer (staged, atomic writing is in :mod:`sarmotion.io.staging`)."""

from __future__ import annotations

from ..errors import InputError

__all__ = ["DataError"]


class DataError(InputError):
    """An input file or a data set is unusable (an :class:`~sarmotion.errors.InputError`).

    The message is one line that names the file (when there is one) and what is wrong
    with it: missing file, wrong format, missing field, wrong shape (expected and got),
    non-finite values, inconsistent or non-consecutive files.
    """
