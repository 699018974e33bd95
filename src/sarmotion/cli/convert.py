"""``sarmotion convert``: traces from one format to another (CPHD, native HDF5, GOTCHA)."""

from __future__ import annotations

from pathlib import Path

import click

from ..io import save_traces, staged_directory, staged_file, write_cphd, write_gotcha
from ..io.gotcha import AZIMUTH_NAME_GLOB, AZIMUTH_NAME_PATTERN, written_by_sarmotion
from .autofocus import autofocus_options, read_focused
from .common import (
    ORIGIN_RULE,
    InputError,
    check_out,
    gotcha_force_option,
    lenient_option,
    noise_options,
    origin_callback,
    out_option,
    speed_option,
)
from .inputs import INPUTS_HELP

__all__ = ["convert"]


@click.command(epilog=INPUTS_HELP)
@click.argument("inputs", nargs=-1, required=True)
@click.option(
    "--to",
    "to",
    type=click.Choice(["cphd", "h5", "gotcha"]),
    required=True,
    help="Output format: cphd (a CPHD 1.1.0 file), h5 (native traces) or gotcha (a directory "
    "of GOTCHA .mat files).",
)
@out_option("Output file (cphd, h5) or directory (gotcha).")
@gotcha_force_option
@click.option(
    "--channel",
    default=None,
    help="CPHD input: channel identifier; default the file's reference channel.",
)
@click.option(
    "--vectors",
    nargs=2,
    type=int,
    default=None,
    metavar="START STOP",
    help="CPHD input: vectors START to STOP-1 only (0-based); default all.",
)
@click.option(
    "--origin",
    "origin_llh",
    nargs=3,
    type=float,
    default=None,
    metavar="LAT LON HAE",
    callback=origin_callback,
    help="--to cphd: geodetic position (deg, deg, m) of the origin of the scene frame; "
    f"default 0 0 0; {ORIGIN_RULE}.",
)
@speed_option
@lenient_option
@autofocus_options
@noise_options
def convert(
    inputs: tuple[str, ...],
    to: str,
    out: Path,
    channel: str | None,
    vectors: tuple[int, int] | None,
    origin_llh: tuple[float, float, float] | None,
    speed_mps: float,
    lenient: bool,
    autofocus: str | None,
    pga_iterations: int,
    snr_db: float | None,
    seed: int,
    force: bool,
) -> None:
    """Convert INPUTS (a scene, a native .h5 file, GOTCHA .mat files or a .cphd file).

    The traces are written unchanged as CPHD (one FX-domain channel that passes sarkit's
    consistency checker, geometry on the WGS 84 ellipsoid around --origin), as native
    traces (.h5) or as GOTCHA .mat files (into the directory OUT). From a CPHD file,
    --channel and --vectors choose what is read.
    """
    cphd_input = all(Path(p).suffix.lower() == ".cphd" for p in inputs)
    if (channel is not None or vectors is not None) and not cphd_input:
        raise InputError("--channel and --vectors apply to a CPHD (.cphd) input only")
    if origin_llh is not None and to != "cphd":
        raise InputError("--origin applies to --to cphd only")
    check_out(
        out,
        force=force,
        patterns=(AZIMUTH_NAME_GLOB,) if to == "gotcha" else (),
        sweep=written_by_sarmotion,
    )
    traces, _, _ = read_focused(
        inputs,
        autofocus=autofocus,
        pga_iterations=pga_iterations,
        speed_mps=speed_mps,
        snr_db=snr_db,
        seed=seed,
        channel=channel,
        vectors=vectors,
        lenient=lenient,
    )
    if to == "gotcha":
        with staged_directory(out) as stage:
            files = write_gotcha(traces, stage, name_pattern=AZIMUTH_NAME_PATTERN)
        click.echo(f"wrote {len(files)} GOTCHA file(s) to {out}")
        return
    with staged_file(out) as path:
        if to == "cphd":
            write_cphd(path, traces, origin_llh=origin_llh or (0.0, 0.0, 0.0))
        else:
            save_traces(path, traces)
    click.echo(f"wrote {out} ({traces.n_pulses} pulses x {traces.n_samples} samples, {to})")
