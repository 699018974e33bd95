"""``sarmotion separate``: stationary and moving traces."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import click
import numpy as np

from ..core.traces import Traces
from ..documents.separation import separation_document
from ..imaging import Image, backproject, scene_grid
from ..io import save_traces, staged_directory, write_json
from ..report.plotting import image_figure, save_figure, traces_figure
from ..separation import Separation, SeparationOptions
from ..separation import separate as run
from .common import (
    Progress,
    as_flags,
    check_out,
    force_option,
    lenient_option,
    noise_options,
    out_option,
    speed_option,
)
from .inputs import INPUTS_HELP, LABELS_HELP, read_inputs

OUTPUTS = ("separated.h5", "separation.png", "image.png", "separation.json")

__all__ = ["separate"]


@click.command(epilog=f"{INPUTS_HELP}\n\n{LABELS_HELP}")
@click.argument("inputs", nargs=-1, required=True)
@click.option(
    "--method",
    type=click.Choice(["auto", "combined", "rpca", "annihilation"]),
    default="auto",
    show_default=True,
    help="combined: each stationary point of the preliminary image is aligned in its own "
    "frame and its slow-time-constant part removed [sect:sepdisc]; rpca: "
    "windowed robust PCA, traces split into a low-rank and a sparse part "
    "[sect:RPCA]; annihilation: composed travel-time filters that cancel the echoes of the "
    "stationary points of the image [eq:OP2]. auto: combined for simulated "
    "scenes, rpca for measured data.",
)
@out_option("Output directory: separated.h5, separation.png, image.png, separation.json.")
@force_option
@click.option(
    "--window",
    type=int,
    default=None,
    help="rpca: fast-time window (samples); default chosen from the data.",
)
@click.option(
    "--eta-scale",
    type=float,
    default=None,
    help="rpca: factor on the default sparsity weight 1/sqrt(max(n, window)); default 1 "
    "for simulated scenes, 2 for measured (distributed) clutter.",
)
@click.option(
    "--threshold-db",
    type=float,
    default=-20.0,
    show_default=True,
    help="combined, annihilation: stationary points are the bright points of the "
    "preliminary image within this level of its peak (dB).",
)
@click.option(
    "--size",
    "size_m",
    type=float,
    default=None,
    help="Side of the preliminary image (m); default from the data's range window, at most 100 m.",
)
@click.option(
    "--spacing",
    "spacing_m",
    type=float,
    default=0.25,
    show_default=True,
    help="Pixel spacing of the preliminary image (m).",
)
@speed_option
@lenient_option
@noise_options
@click.pass_context
def separate(
    ctx: click.Context,
    inputs: tuple[str, ...],
    method: str,
    out: Path,
    window: int | None,
    eta_scale: float | None,
    threshold_db: float,
    size_m: float | None,
    spacing_m: float,
    speed_mps: float,
    lenient: bool,
    snr_db: float | None,
    seed: int,
    force: bool,
) -> None:
    """Separate the traces of stationary and moving targets in INPUTS.

    Writes OUT/separated.h5 (the traces M with extra datasets "stationary" (L, absent for
    the annihilation filter) and "moving" (S or Q M)), OUT/separation.png (|M|, |L|, |S|
    normalised by max|M|, S also in dB: the paper's style), OUT/image.png (the preliminary
    image with the stationary points used) and OUT/separation.json (method details and, for
    simulated scenes, quality against the truth).
    """
    check_out(out, force=force, names=OUTPUTS)
    options = _options(method, window, eta_scale, threshold_db)
    with as_flags(speed_mps="--speed", snr_db="--snr-db", size_m="--size", spacing_m="--spacing"):
        traces, sim = read_inputs(
            inputs, speed_mps=speed_mps, snr_db=snr_db, seed=seed, lenient=lenient
        )
        grid = scene_grid(traces, size_m=size_m, spacing_m=spacing_m)
    t0 = time.perf_counter()
    with Progress(enabled=ctx.obj["progress"]) as bar:
        prelim = backproject(traces, grid, progress=bar)
        sep = run(traces, prelim, options, progress=bar)
    elapsed = time.perf_counter() - t0
    summary = separation_document(sep, traces, inputs=inputs, seconds=elapsed, simulation=sim)
    with staged_directory(out) as stage:
        _write(stage, traces, sep, prelim, summary)
    line = f"wrote {out}/separated.h5, separation.png, image.png, separation.json ({elapsed:.1f} s)"
    if "quality" in summary and "relative_error_moving" in summary["quality"]:
        q = summary["quality"]
        line += (
            f"; ||S-S_true||/||S_true|| = {q['relative_error_moving']:.3f}, "
            f"mover retained {q['mover_retained']:.3f}"
        )
    click.echo(line)


def _options(
    method: str, window: int | None, eta_scale: float | None, threshold_db: float
) -> SeparationOptions:
    """SeparationOptions from the flags; a bad value is reported under its flag's name."""
    with as_flags(
        rpca_window="--window", eta_scale="--eta-scale", candidate_threshold_db="--threshold-db"
    ):
        return SeparationOptions(
            method=None if method == "auto" else method,
            rpca_window=window,
            eta_scale=eta_scale,
            candidate_threshold_db=threshold_db,
        )


def _write(
    stage: Path, traces: Traces, sep: Separation, prelim: Image, summary: dict[str, Any]
) -> None:
    """Write the separated traces, the figures and the summary into ``stage``."""
    panels = [("|M|", traces.data, False)]
    if sep.stationary is not None:
        panels.append(("|L|", sep.stationary, False))
        panels += [("|S|", sep.moving, False), ("|S| (dB)", sep.moving, True)]
        norm = float(np.abs(traces.data).max())
    else:
        panels += [("|Q M| (dB re max)", sep.moving, True)]
        norm = None
    extra = {"moving": sep.moving}
    if sep.stationary is not None:
        extra["stationary"] = sep.stationary
    save_traces(stage / "separated.h5", traces, extra=extra)
    fig = traces_figure(
        panels,
        slow_times_s=traces.slow_times_s,
        fast_times_s=traces.fast_times_s,
        normalise_by=norm,
        ncols=len(panels),
    )
    save_figure(fig, stage / "separation.png")
    points = [tuple(p[:2]) for p in sep.stationary_points_m]
    fig = image_figure(
        [("preliminary image, stationary points used", prelim.values)],
        x_m=prelim.grid.x_m,
        y_m=prelim.grid.y_m,
        markers=[points],
    )
    save_figure(fig, stage / "image.png")
    write_json(stage / "separation.json", summary)
