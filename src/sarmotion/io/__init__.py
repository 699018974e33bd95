"""Acquisition formats: GOTCHA and CPHD phase history, native HDF5 files, staged writing.

This layer reads and writes the data of an acquisition and imports only
:mod:`sarmotion.core` and the package's base modules (the documents an analysis produces
are built in :mod:`sarmotion.documents`; the command line turns its inputs into traces in
:mod:`sarmotion.cli.inputs`). Every bad input raises :class:`DataError` (an
:class:`~sarmotion.errors.InputError`, hence a ``ValueError``) with one line naming the
file and the problem; implausible geometry or samples break the rules of
:mod:`sarmotion.io.plausibility` (``lenient=True`` logs them instead). Every reader
computes from the headers of its input what it will allocate and refuses an input beyond
:func:`memory_limit` (:func:`set_memory_limit`; ``--max-memory`` on the command line)
before allocating it. :func:`read_files` and :func:`open_blocks` read any supported
file by its kind (the one dispatch by suffix, :mod:`sarmotion.io.files`). Large files
are read block by block with :func:`open_cphd_blocks`
and :func:`open_native_blocks`, and a CPHD file is written block by block with
:func:`write_cphd_blocks` (:class:`CphdWriter`).
"""

from .._limits import memory_limit, set_memory_limit
from .cphd import (
    CphdBlocks,
    CphdWriter,
    is_cphd_file,
    open_cphd_blocks,
    read_cphd,
    write_cphd,
    write_cphd_blocks,
)
from .errors import DataError
from .files import file_kind, open_blocks, read_files
from .gotcha import is_gotcha_file, read_gotcha, write_gotcha
from .jsonfile import write_json
from .native import (
    IMAGE_SCHEMA,
    TRACES_SCHEMA,
    NativeBlocks,
    load_extra,
    load_image,
    load_traces,
    native_schema,
    open_native_blocks,
    save_image,
    save_traces,
)
from .staging import (
    OutputError,
    claim_output,
    staged_directory,
    staged_file,
    staged_paths,
)

#: The native traces reader under the name of the other readers (``read_gotcha``,
#: ``read_cphd``).
read_native = load_traces

__all__ = [
    "DataError",
    "file_kind",
    "open_blocks",
    "read_files",
    "read_native",
    "read_gotcha",
    "write_gotcha",
    "is_gotcha_file",
    "read_cphd",
    "write_cphd",
    "write_cphd_blocks",
    "CphdWriter",
    "is_cphd_file",
    "save_traces",
    "load_traces",
    "load_extra",
    "save_image",
    "load_image",
    "native_schema",
    "TRACES_SCHEMA",
    "IMAGE_SCHEMA",
    "CphdBlocks",
    "NativeBlocks",
    "memory_limit",
    "open_cphd_blocks",
    "open_native_blocks",
    "set_memory_limit",
    "OutputError",
    "claim_output",
    "staged_directory",
    "staged_file",
    "staged_paths",
    "write_json",
]
