"""Any supported acquisition file, opened by its kind: the one dispatch by suffix.

Three kinds of file hold phase history: a native traces file (``.h5`` / ``.hdf5``,
:mod:`sarmotion.io.native`), GOTCHA ``.mat`` files (one or more, or a directory of them,
forming one aperture; :mod:`sarmotion.io.gotcha`) and a CPHD file (``.cphd``,
:mod:`sarmotion.io.cphd`). :func:`file_kind` names the kind of a list of paths,
:func:`read_files` reads them whole as :class:`~sarmotion.core.Traces`, and
:func:`open_blocks` opens them as a :class:`~sarmotion.core.blocks.PulseBlocks` source
(native and CPHD files block by block from disk; GOTCHA files, read whole, in memory).
Every entry point that reads files (the command line, :func:`sarmotion.read`,
:func:`sarmotion.open`) goes through these, so a file is read the same way everywhere.
Scenes (built-in names, ``.toml``) are simulated, not read: :func:`sarmotion.read`
handles them above this layer.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Literal

from ..core.blocks import PulseBlocks, TracesBlocks
from ..core.traces import Traces
from .cphd import open_cphd_blocks, read_cphd
from .errors import DataError
from .gotcha import read_gotcha
from .native import load_traces, open_native_blocks

__all__ = [
    "FileKind",
    "as_path_list",
    "expand_directories",
    "file_kind",
    "open_blocks",
    "read_files",
]

FileKind = Literal["native", "gotcha", "cphd"]

PathLike = str | os.PathLike[str]

#: Suffixes of each kind (lower case).
SUFFIXES: dict[str, FileKind] = {
    ".h5": "native",
    ".hdf5": "native",
    ".mat": "gotcha",
    ".cphd": "cphd",
}


def as_path_list(paths: PathLike | Sequence[PathLike]) -> list[str]:
    """One path or a sequence of paths as a list of strings."""
    if isinstance(paths, (str, os.PathLike)):
        return [os.fspath(paths)]
    return [os.fspath(p) for p in paths]


def expand_directories(paths: PathLike | Sequence[PathLike]) -> list[str]:
    """``paths`` with each directory replaced by its GOTCHA ``.mat`` files, sorted by name.

    GOTCHA's files are named by azimuth (``..._az001_HH.mat``), so name order is
    acquisition order.

    Raises
    ------
    DataError
        A directory that holds no ``.mat`` file.
    """
    out: list[str] = []
    for p in as_path_list(paths):
        path = Path(p)
        if path.is_dir():
            files = sorted(str(f) for f in path.glob("*.mat") if f.is_file())
            if not files:
                raise DataError(
                    f"{p}: a directory of inputs must hold GOTCHA .mat files; none found"
                )
            out += files
        else:
            out.append(p)
    return out


def file_kind(paths: PathLike | Sequence[PathLike]) -> tuple[FileKind, list[str]]:
    """The kind of the acquisition files ``paths``, and the files (directories expanded).

    Parameters
    ----------
    paths : path or sequence of paths
        One native file; or GOTCHA ``.mat`` files and directories of them; or one CPHD
        file.

    Returns
    -------
    (kind, files)
        ``"native"``, ``"gotcha"`` or ``"cphd"``, and the files in reading order.

    Raises
    ------
    DataError
        No path, a missing path, a mix of kinds, several native or CPHD files, or an
        unknown suffix.
    """
    given = as_path_list(paths)
    if not given:
        raise DataError("no input file given")
    for p in given:
        if not os.path.lexists(p):
            raise DataError(f"input not found: {p} (no such file)")
    files = expand_directories(given)
    kinds = {SUFFIXES.get(Path(p).suffix.lower()) for p in files}
    if len(kinds) != 1 or None in kinds:
        raise DataError(
            f"cannot read {', '.join(files)}: expected a native traces .h5 file, GOTCHA "
            ".mat files, or a CPHD .cphd file"
        )
    (kind,) = kinds
    assert kind is not None
    if kind != "gotcha" and len(files) != 1:
        what = "native traces file (.h5)" if kind == "native" else "CPHD file (.cphd)"
        raise DataError(f"give one {what} at a time")
    return kind, files


def _cphd_only(channel: str | None, vectors: tuple[int, int] | None) -> None:
    if channel is not None or vectors is not None:
        raise DataError("channel and vectors apply to a CPHD (.cphd) file only")


def read_files(
    paths: PathLike | Sequence[PathLike],
    *,
    lenient: bool = False,
    speed_mps: float = 70.0,
    autofocus: bool = False,
    channel: str | None = None,
    vectors: tuple[int, int] | None = None,
) -> Traces:
    """Read acquisition files whole, whatever their kind (:func:`file_kind`).

    Parameters
    ----------
    paths : path or sequence of paths
        One native ``.h5``; GOTCHA ``.mat`` files or directories of them (one aperture);
        or one CPHD ``.cphd``.
    lenient : bool
        Log a broken plausibility rule as a warning instead of refusing the file.
    speed_mps : float
        GOTCHA: platform speed that sets slow time (m/s).
    autofocus : bool
        GOTCHA: apply the files' autofocus corrections.
    channel : str, optional
        CPHD: channel identifier; default the file's reference channel.
    vectors : (int, int), optional
        CPHD: vectors ``start:stop`` to read (0-based, ``stop`` excluded); default all.

    Returns
    -------
    Traces

    Raises
    ------
    DataError
        As :func:`file_kind`, and every reader's refusals; ``channel``/``vectors`` for a
        file that is not CPHD.
    """
    kind, files = file_kind(paths)
    if kind != "cphd":
        _cphd_only(channel, vectors)
    if kind == "native":
        return load_traces(files[0], lenient=lenient)
    if kind == "gotcha":
        return read_gotcha(files, speed_mps=speed_mps, autofocus=autofocus, lenient=lenient)
    return read_cphd(files[0], channel=channel, vectors=vectors, lenient=lenient)


def open_blocks(
    paths: PathLike | Sequence[PathLike],
    *,
    lenient: bool = False,
    speed_mps: float = 70.0,
    autofocus: bool = False,
    channel: str | None = None,
    vectors: tuple[int, int] | None = None,
) -> PulseBlocks:
    """Open acquisition files as a block source of pulses, whatever their kind.

    A native or CPHD file is read block by block from disk (its headers and per-pulse
    parameters checked now, the signal as the blocks are read); GOTCHA files hold one
    degree each and are read whole (:func:`read_files`), then served from memory.
    Parameters are those of :func:`read_files`.

    Returns
    -------
    PulseBlocks
        ``radar``, ``reference_point_m``, ``trajectory``, ``n_pulses``, ``metadata`` and
        ``blocks(block_pulses)``.
    """
    kind, files = file_kind(paths)
    if kind == "cphd":
        return open_cphd_blocks(files[0], channel=channel, vectors=vectors, lenient=lenient)
    if kind == "native":
        _cphd_only(channel, vectors)
        return open_native_blocks(files[0], lenient=lenient)
    return TracesBlocks(
        read_files(
            files,
            lenient=lenient,
            speed_mps=speed_mps,
            autofocus=autofocus,
            channel=channel,
            vectors=vectors,
        )
    )
