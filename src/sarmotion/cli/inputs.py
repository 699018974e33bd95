"""A command's inputs as traces: a scene (simulated here), native traces, GOTCHA or CPHD files.

One entry point, :func:`read_inputs` (:func:`sarmotion.sources.read_source`), dispatches
on what it is given: a built-in scene name or a scene ``.toml`` is simulated (its ground
truth kept), a ``.h5`` file is read as native traces, ``.mat`` files as GOTCHA phase
history (several files form one aperture), a ``.cphd`` file as CPHD phase history (one
channel). The help texts of the commands' inputs and frame are here.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..core.traces import Traces
from ..simulation import Simulation, builtin_scene_names
from ..sources import is_scene_reference, read_source

__all__ = ["FRAME_HELP", "INPUTS_HELP", "LABELS_HELP", "is_scene_reference", "read_inputs"]

#: What a command's INPUTS may be, for its help (the epilog of image, analyze, track, ...).
INPUTS_HELP = (
    "INPUTS: a built-in scene ("
    + ", ".join(builtin_scene_names())
    + ") or a scene .toml file, simulated with its ground truth; a native traces .h5 file; "
    "GOTCHA .mat files (consecutive files form one acquisition) or a directory of them; or "
    "a CPHD .cphd file."
)

#: The frame and the sign conventions, in words, for the help of the commands that
#: report positions and speeds (the geometry: :class:`sarmotion.core.geometry.LookGeometry`).
FRAME_HELP = (
    "Frame: ground coordinates x, y (m) of the data, around the reference point. Range is "
    "measured along the line of sight projected on the ground, cross range across it, "
    "along the flight path; for the built-in scenes and GOTCHA's first degrees the radar lies "
    "towards +x (x is range) and flies along +y (y is cross range). A range speed is "
    "positive towards the radar (the range closes) and negative away from it."
)

#: What the bracketed labels of the help are.
LABELS_HELP = (
    "Labels in brackets, such as [eq:image] or [sect:RPCA], name equations and sections of "
    "the paper (Borcea, Callaghan & Papanicolaou) by their LaTeX labels."
)


def read_inputs(
    inputs: Sequence[str],
    *,
    speed_mps: float = 70.0,
    autofocus: bool = False,
    snr_db: float | None = None,
    seed: int = 0,
    lenient: bool = False,
    channel: str | None = None,
    vectors: tuple[int, int] | None = None,
) -> tuple[Traces, Simulation | None]:
    """Read ``inputs`` as one acquisition.

    Parameters
    ----------
    inputs : sequence of str
        One scene name or ``.toml``; or one native ``.h5``; or one or more GOTCHA ``.mat``
        or directories of them; or one CPHD ``.cphd`` (files are read by
        :func:`sarmotion.io.read_files`).
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
    return read_source(
        inputs,
        speed_mps=speed_mps,
        autofocus=autofocus,
        snr_db=snr_db,
        seed=seed,
        lenient=lenient,
        channel=channel,
        vectors=vectors,
    )
