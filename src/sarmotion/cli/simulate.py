"""``sarmotion simulate``: the traces of a scene."""

from __future__ import annotations

from pathlib import Path

import click

from ..io import save_traces, staged_directory, staged_file, write_gotcha
from ..io.gotcha import AZIMUTH_NAME_GLOB, AZIMUTH_NAME_PATTERN, written_by_sarmotion
from ..simulation import load_scene
from ..simulation import simulate as run
from .common import as_flags, check_out, gotcha_force_option, noise_options, out_option

__all__ = ["simulate"]


@click.command()
@click.argument("scene")
@out_option("Output: a .h5 file (native traces) or a directory (GOTCHA .mat files).")
@gotcha_force_option
@noise_options
@click.option(
    "--spreading/--no-spreading",
    default=False,
    show_default=True,
    help="Include the 1/R^2 amplitude decay.",
)
def simulate(
    scene: str, out: Path, snr_db: float | None, seed: int, spreading: bool, force: bool
) -> None:
    """Simulate the traces of SCENE (a built-in name or a scene .toml file).

    Writes native traces (.h5, with the stationary-only and moving-only truth as extra
    datasets "stationary" and "moving") or, if OUT is not a .h5 path, GOTCHA-format .mat
    files into the directory OUT.
    """
    native = out.suffix.lower() in (".h5", ".hdf5")
    check_out(
        out,
        force=force,
        patterns=() if native else (AZIMUTH_NAME_GLOB,),
        sweep=written_by_sarmotion,
    )
    with as_flags(snr_db="--snr-db", rng="--seed"):
        sim = run(load_scene(scene), snr_db=snr_db, rng=seed, spreading=spreading)
    if native:
        with staged_file(out) as path:
            save_traces(
                path,
                sim.traces,
                extra={"stationary": sim.stationary, "moving": sim.moving},
            )
        click.echo(f"wrote {out} ({sim.traces.n_pulses} pulses x {sim.traces.n_samples} samples)")
    else:
        with staged_directory(out) as stage:
            files = write_gotcha(sim.traces, stage, name_pattern=AZIMUTH_NAME_PATTERN)
        click.echo(f"wrote {len(files)} GOTCHA file(s) to {out}")
