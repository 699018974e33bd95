"""``sarmotion inject``: simulated targets added to traces."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
import numpy as np

from ..io import read_inputs, save_traces, staged_directory, write_gotcha
from ..simulation import PointTarget
from ..simulation import inject as run
from .common import InputError

__all__ = ["inject"]


def _parse_target(text: str) -> Any:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"--target {text!r}: expected numbers X,Y[,UX,UY[,AMP]]") from None
    if len(values) not in (2, 4, 5) or not np.all(np.isfinite(values)):
        raise InputError(f"--target {text!r}: expected X,Y or X,Y,UX,UY or X,Y,UX,UY,AMP")
    x, y = values[:2]
    u = values[2:4] if len(values) >= 4 else [0.0, 0.0]
    amp = values[4] if len(values) == 5 else None
    return PointTarget(position_m=[x, y], velocity_mps=u), amp


@click.command()
@click.argument("inputs", nargs=-1, required=True)
@click.option(
    "--target",
    "targets",
    multiple=True,
    required=True,
    metavar="X,Y[,UX,UY[,AMP]]",
    help="Point target to add: position at s = 0 (m), ground velocity (m/s), "
    "amplitude in data units (default: the median over pulses of max|D|). "
    "Repeat for several targets.",
)
@click.option(
    "--out",
    "out",
    required=True,
    type=click.Path(path_type=Path),
    help="Output: a .h5 file (native traces) or a directory (GOTCHA .mat files).",
)
@click.option(
    "--speed",
    "speed_mps",
    type=float,
    default=70.0,
    show_default=True,
    help="Platform speed for GOTCHA slow time (m/s).",
)
def inject(inputs: tuple[str, ...], targets: tuple[str, ...], out: Path, speed_mps: float) -> None:
    """Add simulated point targets (stationary or moving) to real or simulated traces."""
    traces, _ = read_inputs(inputs, speed_mps=speed_mps)
    default_amp = float(np.median(np.abs(traces.data).max(axis=1)))
    parsed = []
    for text in targets:
        t, amp = _parse_target(text)
        parsed.append(
            PointTarget(
                position_m=t.position_m,
                velocity_mps=t.velocity_mps,
                reflectivity=default_amp if amp is None else amp,
            )
        )
    result = run(traces, parsed)
    if out.suffix.lower() in (".h5", ".hdf5"):
        out.parent.mkdir(parents=True, exist_ok=True)
        save_traces(out, result)
        click.echo(f"wrote {out} with {len(parsed)} injected target(s)")
    else:
        with staged_directory(out) as stage:
            files = write_gotcha(result, stage)
        click.echo(f"wrote {len(files)} GOTCHA file(s) to {out} with {len(parsed)} target(s)")
