"""A command's inputs as traces: a scene (simulated here), native traces, GOTCHA or CPHD files.

One entry point, :func:`read_inputs` (:func:`sarmotion.sources.read_source`), dispatches
on what it is given: a built-in scene name or a scene ``.toml`` is simulated (its ground
truth kept), a ``.h5`` file is read as native traces, ``.mat`` files as GOTCHA phase
history (several files form one aperture), a ``.cphd`` file as CPHD phase history (one
channel). The help texts of the commands' inputs and frame are here.
"""

from __future__ import annotations

from ..simulation import builtin_scene_names
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

#: A command's inputs read as one acquisition: :func:`sarmotion.sources.read_source`.
read_inputs = read_source
