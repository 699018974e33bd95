"""``sarmotion inject``: simulated targets added to traces."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
import numpy as np

from ..io import save_traces, staged_directory, staged_file, write_gotcha
from ..io.gotcha import AZIMUTH_NAME_GLOB, AZIMUTH_NAME_PATTERN, written_by_sarmotion
from ..simulation import PointTarget
from ..simulation import inject as run
from .common import (
    MAX_GROUND_SPEED_MPS,
    InputError,
    as_flags,
    check_out,
    gotcha_force_option,
    lenient_option,
    out_option,
    speed_option,
)
from .inputs import FRAME_HELP, INPUTS_HELP, read_inputs

__all__ = ["inject"]

#: Largest target offset from the reference point (m) --target accepts: the fast-time
#: window of GOTCHA spans +-51 m of differential range; 10 km is far beyond any scene.
MAX_OFFSET_M = 1e4


def _parse_target(text: str) -> Any:
    """``(PointTarget, amplitude, in_db)`` from ``X,Y[,UX,UY[,AMP]]``.

    ``AMP`` is in data units, or in dB relative to the default amplitude when it ends
    in ``dB`` (``-6dB``); ``None`` when absent.
    """
    fields = text.split(",")
    in_db = len(fields) == 5 and fields[4].strip().lower().endswith("db")
    if in_db:
        fields[4] = fields[4].strip()[:-2]
    try:
        values = [float(v) for v in fields]
    except ValueError:
        raise InputError(f"--target {text!r}: expected numbers X,Y[,UX,UY[,AMP]]") from None
    if len(values) not in (2, 4, 5) or not np.all(np.isfinite(values)):
        raise InputError(f"--target {text!r}: expected X,Y or X,Y,UX,UY or X,Y,UX,UY,AMP")
    x, y = values[:2]
    u = values[2:4] if len(values) >= 4 else [0.0, 0.0]
    amp = values[4] if len(values) == 5 else None
    if amp is not None and not in_db and amp <= 0:
        raise InputError(
            f"--target {text!r}: AMP must be > 0 (data units), or in dB with a dB suffix, "
            f"got {amp:g}"
        )
    if max(abs(x), abs(y)) > MAX_OFFSET_M or np.hypot(*u) > MAX_GROUND_SPEED_MPS:
        raise InputError(
            f"--target {text!r}: X, Y must be within {MAX_OFFSET_M:g} m of the reference point "
            f"and the speed at most {MAX_GROUND_SPEED_MPS:g} m/s"
        )
    return PointTarget(position_m=[x, y], velocity_mps=u), amp, in_db


@click.command(epilog=f"{INPUTS_HELP}\n\n{FRAME_HELP}")
@click.argument("inputs", nargs=-1, required=True)
@click.option(
    "--target",
    "targets",
    multiple=True,
    required=True,
    metavar="X,Y[,UX,UY[,AMP]]",
    help="Point target to add: position at s = 0 (m), ground velocity (m/s) and "
    "amplitude. AMP with a dB suffix (e.g. -6dB) is relative to the default amplitude: "
    "the median over the pulses of the brightest sample's modulus, max|D| (0dB: as bright "
    "as a typical pulse's strongest echo). A bare AMP is in data units: the modulus of "
    "the input's complex samples as stored (GOTCHA's fp, the CPHD signal, a native "
    "file's traces). Repeat for several targets.",
)
@out_option("Output: a .h5 file (native traces) or a directory (GOTCHA .mat files).")
@gotcha_force_option
@speed_option
@lenient_option
def inject(
    inputs: tuple[str, ...],
    targets: tuple[str, ...],
    out: Path,
    force: bool,
    speed_mps: float,
    lenient: bool,
) -> None:
    """Add simulated point targets (stationary or moving) to real or simulated traces."""
    native = out.suffix.lower() in (".h5", ".hdf5")
    check_out(
        out,
        force=force,
        patterns=() if native else (AZIMUTH_NAME_GLOB,),
        sweep=written_by_sarmotion,
    )
    for text in targets:
        _parse_target(text)
    with as_flags(speed_mps="--speed"):
        traces, _ = read_inputs(inputs, speed_mps=speed_mps, lenient=lenient)
    default_amp = float(np.median(np.abs(traces.data).max(axis=1)))
    parsed = []
    for text in targets:
        t, amp, in_db = _parse_target(text)
        if amp is None:
            amp = default_amp
        elif in_db:
            amp = default_amp * 10.0 ** (amp / 20.0)
        parsed.append(
            PointTarget(position_m=t.position_m, velocity_mps=t.velocity_mps, reflectivity=amp)
        )
    result = run(traces, parsed)
    if native:
        with staged_file(out) as path:
            save_traces(path, result)
        click.echo(f"wrote {out} with {len(parsed)} injected target(s)")
    else:
        with staged_directory(out) as stage:
            files = write_gotcha(result, stage, name_pattern=AZIMUTH_NAME_PATTERN)
        click.echo(f"wrote {len(files)} GOTCHA file(s) to {out} with {len(parsed)} target(s)")
