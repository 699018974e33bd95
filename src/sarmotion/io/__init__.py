"""Input and output: GOTCHA and CPHD phase-history files and sarmotion's native HDF5 files.

This is the only layer of sarmotion that opens files. Every bad input raises
:class:`DataError` (a ``ValueError``) with one line naming the file and the problem.
"""

from .cphd import is_cphd_file, read_cphd, write_cphd
from .errors import DataError
from .gotcha import is_gotcha_file, read_gotcha, write_gotcha
from .native import (
    IMAGE_SCHEMA,
    TRACES_SCHEMA,
    load_extra,
    load_image,
    load_traces,
    native_schema,
    save_image,
    save_traces,
)

__all__ = [
    "DataError",
    "read_gotcha",
    "write_gotcha",
    "is_gotcha_file",
    "read_cphd",
    "write_cphd",
    "is_cphd_file",
    "save_traces",
    "load_traces",
    "load_extra",
    "save_image",
    "load_image",
    "native_schema",
    "TRACES_SCHEMA",
    "IMAGE_SCHEMA",
]
