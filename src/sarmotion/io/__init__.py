"""Input and output: GOTCHA and CPHD phase history, native HDF5 files, the results document.

This is the only layer of sarmotion that opens files. Every bad input raises
:class:`DataError` (a ``ValueError``) with one line naming the file and the problem;
implausible geometry or samples break the rules of :mod:`sarmotion.io.plausibility`
(``lenient=True`` logs them instead). Every reader computes from the headers of its input
what it will allocate and refuses an input beyond :func:`memory_limit`
(:func:`set_memory_limit`; ``--max-memory`` on the command line) before allocating it.
Large files are read block by block with :func:`open_cphd_blocks` and
:func:`open_native_blocks`.
"""

from .._limits import memory_limit, set_memory_limit
from .cphd import CphdBlocks, is_cphd_file, open_cphd_blocks, read_cphd, write_cphd
from .errors import DataError
from .gotcha import is_gotcha_file, read_gotcha, write_gotcha
from .inputs import is_scene_reference, read_inputs
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
    "CphdBlocks",
    "NativeBlocks",
    "memory_limit",
    "open_cphd_blocks",
    "open_native_blocks",
    "set_memory_limit",
]

from .results import RESULTS_SCHEMA, results_document, write_json  # noqa: E402

__all__ += [
    "RESULTS_SCHEMA",
    "is_scene_reference",
    "read_inputs",
    "results_document",
    "OutputError",
    "claim_output",
    "staged_directory",
    "staged_file",
    "staged_paths",
    "write_json",
]

from .roads import read_roads  # noqa: E402
from .tracks import TRACKS_SCHEMA, tracks_document  # noqa: E402

__all__ += ["TRACKS_SCHEMA", "read_roads", "tracks_document"]
