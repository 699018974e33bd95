"""``sarmotion simulate``: the traces of a scene."""

from __future__ import annotations

from pathlib import Path

import click

from ..core.traces import Traces
from ..io import save_traces, staged_directory, staged_file, write_gotcha
from ..io.gotcha import AZIMUTH_NAME_GLOB, AZIMUTH_NAME_PATTERN, written_by_sarmotion
from ..io.plausibility import (
    check_envelope,
    check_reference_point,
    check_signal,
    check_speed,
    check_times,
    check_track,
)
from ..simulation import load_scene
from ..simulation import simulate as run
from .common import as_flags, check_out, gotcha_force_option, noise_options, out_option

__all__ = ["simulate"]


def check_readable(traces: Traces, out: Path, *, lenient: bool) -> None:
    """The readers' plausibility rules on simulated traces, before they are written.

    What a native traces file must meet (:func:`~sarmotion.io.load_traces`): the antenna
    track and times, the platform speed, the reference point's grazing angle and the
    phase history's signal and dynamic range. A scene file's bounds
    (:mod:`~sarmotion.simulation.scene`) keep to the geometric rules already; the phase
    history's (a Gaussian pulse's spectrum sampled far into its tails exceeds the
    dynamic range) are known only once simulated. ``lenient``: a warning instead, as the
    reader's ``--lenient``.
    """
    pos, s, ref = traces.positions_m, traces.slow_times_s, traces.reference_point_m
    where = f"{out} (simulated)"
    check_envelope(where, "antenna positions", pos - ref, lenient=lenient)
    check_track(where, "antenna positions", pos, lenient=lenient)
    check_times(where, "slow times", s, lenient=lenient)
    check_speed(where, "antenna positions and slow times", pos, s, lenient=lenient)
    check_reference_point(where, "reference_point_m", pos, ref, lenient=lenient)
    check_signal(where, "phase history", traces.phase_history(), lenient=lenient)


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
@click.option(
    "--lenient",
    is_flag=True,
    help="Simulate targets beyond the scene's unambiguous scene (they alias: a warning says "
    "where to), and write traces that break a reader's plausibility rule, with a warning "
    "(then read them with --lenient).",
)
def simulate(
    scene: str,
    out: Path,
    snr_db: float | None,
    seed: int,
    spreading: bool,
    force: bool,
    lenient: bool,
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
        sim = run(load_scene(scene, lenient=lenient), snr_db=snr_db, rng=seed, spreading=spreading)
    check_readable(sim.traces, out, lenient=lenient)
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
