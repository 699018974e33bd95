"""``sarmotion image``: a backprojection image."""

from __future__ import annotations

import time
from pathlib import Path

import click
import numpy as np

from ..imaging import backproject
from ..io import read_inputs, save_image, staged_directory, write_json
from ..report.plotting import image_figure, save_figure
from .common import InputError, Progress, extent_grid, square_grid

__all__ = ["image"]


@click.command()
@click.argument("inputs", nargs=-1, required=True)
@click.option(
    "--out",
    "out",
    required=True,
    type=click.Path(path_type=Path),
    help="Output directory (image.png, image.h5).",
)
@click.option(
    "--velocity",
    nargs=2,
    type=float,
    default=None,
    metavar="UX UY",
    help="Motion-compensate for this ground velocity (m/s), eq:imagecompu.",
)
@click.option(
    "--size",
    "size_m",
    type=float,
    default=100.0,
    show_default=True,
    help="Side of the square image (m).",
)
@click.option(
    "--spacing", "spacing_m", type=float, default=0.25, show_default=True, help="Pixel spacing (m)."
)
@click.option(
    "--centre",
    nargs=2,
    type=float,
    default=(0.0, 0.0),
    show_default=True,
    metavar="X Y",
    help="Image centre (m).",
)
@click.option(
    "--grid",
    "grid_extent",
    nargs=4,
    type=float,
    default=None,
    metavar="XMIN XMAX YMIN YMAX",
    help="Rectangular image extent (m), instead of --size/--centre; pixels of --spacing.",
)
@click.option(
    "--speed",
    "speed_mps",
    type=float,
    default=70.0,
    show_default=True,
    help="Platform speed for GOTCHA slow time (m/s).",
)
@click.option("--autofocus", is_flag=True, help="Apply the GOTCHA files' autofocus corrections.")
@click.option(
    "--dynamic-range",
    "dynamic_range_db",
    type=float,
    default=40.0,
    show_default=True,
    help="Displayed dynamic range (dB).",
)
@click.pass_context
def image(
    ctx: click.Context,
    inputs: tuple[str, ...],
    out: Path,
    velocity: tuple[float, float] | None,
    size_m: float,
    spacing_m: float,
    centre: tuple[float, float],
    grid_extent: tuple[float, float, float, float] | None,
    speed_mps: float,
    autofocus: bool,
    dynamic_range_db: float,
) -> None:
    """Backprojection image (eq:image) of INPUTS: a scene, native traces or GOTCHA .mat files.

    Writes OUT/image.png (dB, peak-normalised), OUT/image.h5 (complex image with its axes)
    and OUT/peaks.json (the brightest points).
    """
    traces, _ = read_inputs(inputs, speed_mps=speed_mps, autofocus=autofocus)
    if grid_extent is None:
        grid = square_grid(size_m, spacing_m, centre)
    else:
        grid = extent_grid(grid_extent, spacing_m)
    if velocity is not None and not np.all(np.isfinite(velocity)):
        raise InputError(f"--velocity must be finite, got {velocity}")
    t0 = time.perf_counter()
    with Progress(enabled=ctx.obj["progress"]) as bar:
        img = backproject(traces, grid, velocity_mps=velocity, progress=bar)
    elapsed = time.perf_counter() - t0
    peaks = img.peaks(5, min_separation_m=3.0)
    with staged_directory(out) as stage:
        title = (
            "image" if velocity is None else f"image, u = ({velocity[0]:g}, {velocity[1]:g}) m/s"
        )
        fig = image_figure(
            [(title, img.values)], x_m=grid.x_m, y_m=grid.y_m, dynamic_range_db=dynamic_range_db
        )
        save_figure(fig, stage / "image.png")
        save_image(
            stage / "image.h5",
            img.values,
            x_m=grid.x_m,
            y_m=grid.y_m,
            velocity_mps=velocity,
            metadata={"inputs": list(inputs), **traces.metadata},
        )
        write_json(
            stage / "peaks.json",
            {
                "schema": "sarmotion.peaks/1",
                "peaks": [
                    {"position_m": [x, y], "peak_db": 20 * np.log10(abs(v) / abs(peaks[0][2]))}
                    for x, y, v in peaks
                ],
                "seconds": elapsed,
                "pixel_pulses_per_second": grid.shape[0]
                * grid.shape[1]
                * traces.n_pulses
                / elapsed,
            },
        )
    x, y, _ = peaks[0]
    click.echo(
        f"wrote {out}/image.png, image.h5, peaks.json; brightest point at "
        f"({x:.2f}, {y:.2f}) m; {elapsed:.2f} s"
    )
