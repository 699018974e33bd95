"""Any input as traces or pulse blocks: a scene is simulated, a file is read.

The one place that tells the kinds of input apart: a built-in scene name or a scene
``.toml`` file is simulated (:mod:`sarmotion.simulation`, its ground truth kept); native
``.h5``, GOTCHA ``.mat`` (files or a directory of them) and CPHD ``.cphd`` files are read
by their kind (:mod:`sarmotion.io.files`). The command line and the top-level
:func:`sarmotion.read` and :func:`sarmotion.open` go through :func:`read_source` and
:func:`open_source`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from .core.blocks import PulseBlocks, TracesBlocks
from .core.traces import Traces
from .io import DataError, open_blocks, read_files
from .io.files import SUFFIXES, as_path_list
from .simulation import Simulation, builtin_scene_names, load_scene, simulate

__all__ = ["is_scene_reference", "open_source", "read_source"]

PathLike = str | os.PathLike[str]


def is_scene_reference(text: PathLike) -> bool:
    """True for a built-in scene name or a path ending in ``.toml``."""
    text = os.fspath(text)
    return text in builtin_scene_names() or text.lower().endswith(".toml")


def _check_files(inputs: list[str]) -> None:
    for p in inputs:
        if not Path(p).exists():
            raise DataError(
                f"input not found: {p} (no such file; the built-in scenes are "
                f"{', '.join(builtin_scene_names())})"
            )
    if any(Path(p).suffix.lower() not in SUFFIXES for p in inputs if not Path(p).is_dir()):
        raise DataError(
            f"cannot read {', '.join(inputs)}: expected a built-in scene name, a scene .toml, "
            "a native traces .h5 file, GOTCHA .mat files, or a CPHD .cphd file"
        )


def read_source(
    inputs: PathLike | Sequence[PathLike],
    *,
    speed_mps: float = 70.0,
    autofocus: bool = False,
    snr_db: float | None = None,
    seed: int = 0,
    lenient: bool = False,
    channel: str | None = None,
    vectors: tuple[int, int] | None = None,
) -> tuple[Traces, Simulation | None]:
    """Read ``inputs`` as one acquisition, with the truth of a simulated scene.

    Parameters
    ----------
    inputs : path, str or sequence of them
        One scene name or ``.toml``; or one native ``.h5``; or one or more GOTCHA ``.mat``
        or directories of them; or one CPHD ``.cphd``.
    speed_mps : float
        GOTCHA: platform speed that sets slow time (m/s).
    autofocus : bool
        GOTCHA: apply the files' autofocus corrections.
    snr_db : float, optional
        Scenes: add white noise at this SNR (dB).
    seed : int
        Scenes: noise seed.
    lenient : bool
        Files: log a broken plausibility rule as a warning instead of refusing the file.
        Scenes: simulate targets beyond the unambiguous scene, with a warning, instead
        of refusing the scene (:func:`~sarmotion.simulation.check_aliasing`).
    channel : str, optional
        CPHD: channel identifier; default the file's reference channel.
    vectors : (int, int), optional
        CPHD: vectors ``start:stop`` to read (0-based, ``stop`` excluded); default all.

    Returns
    -------
    (Traces, Simulation or None)
        The traces, and the simulation (with its truth) for a scene.

    Raises
    ------
    DataError
        Missing or unreadable inputs, or a mix of kinds.
    """
    paths = as_path_list(inputs)
    if not paths:
        raise DataError("no INPUT given")
    if len(paths) == 1 and is_scene_reference(paths[0]):
        sim = simulate(load_scene(paths[0], lenient=lenient), snr_db=snr_db, rng=seed)
        return sim.traces, sim
    _check_files(paths)
    traces = read_files(
        paths,
        lenient=lenient,
        speed_mps=speed_mps,
        autofocus=autofocus,
        channel=channel,
        vectors=vectors,
    )
    return traces, None


def open_source(
    inputs: PathLike | Sequence[PathLike],
    *,
    speed_mps: float = 70.0,
    autofocus: bool = False,
    snr_db: float | None = None,
    seed: int = 0,
    lenient: bool = False,
    channel: str | None = None,
    vectors: tuple[int, int] | None = None,
) -> PulseBlocks:
    """Open ``inputs`` as a source of pulse blocks, whatever their kind.

    A native or CPHD file is read block by block from disk (:func:`sarmotion.io.open_blocks`);
    GOTCHA files and simulated scenes are held in memory. Parameters are those of
    :func:`read_source`.

    Returns
    -------
    PulseBlocks
        ``radar``, ``reference_point_m``, ``trajectory``, ``n_pulses``, ``metadata`` and
        ``blocks(block_pulses)``.
    """
    paths = as_path_list(inputs)
    if len(paths) == 1 and is_scene_reference(paths[0]):
        traces, _ = read_source(paths, snr_db=snr_db, seed=seed)
        return TracesBlocks(traces)
    if not paths:
        raise DataError("no INPUT given")
    _check_files(paths)
    return open_blocks(
        paths,
        lenient=lenient,
        speed_mps=speed_mps,
        autofocus=autofocus,
        channel=channel,
        vectors=vectors,
    )
