"""``sarmotion simulate``: the traces of a scene."""

from __future__ import annotations

from pathlib import Path

import click

from ..io import save_traces, staged_directory, write_gotcha
from ..simulation import load_scene
from ..simulation import simulate as run

__all__ = ["simulate"]


@click.command()
@click.argument("scene")
@click.option(
    "--out",
    "out",
    required=True,
    type=click.Path(path_type=Path),
    help="Output: a .h5 file (native traces) or a directory (GOTCHA .mat files).",
)
@click.option("--snr-db", type=float, default=None, help="Add white noise at this SNR (dB).")
@click.option("--seed", type=int, default=0, show_default=True, help="Noise seed.")
@click.option(
    "--spreading/--no-spreading",
    default=False,
    show_default=True,
    help="Include the 1/R^2 amplitude decay.",
)
def simulate(scene: str, out: Path, snr_db: float | None, seed: int, spreading: bool) -> None:
    """Simulate the traces of SCENE (a built-in name or a scene .toml file).

    Writes native traces (.h5, with the stationary-only and moving-only truth as extra
    datasets "stationary" and "moving") or, if OUT is not a .h5 path, GOTCHA-format .mat
    files into the directory OUT.
    """
    sim = run(load_scene(scene), snr_db=snr_db, rng=seed, spreading=spreading)
    if out.suffix.lower() in (".h5", ".hdf5"):
        out.parent.mkdir(parents=True, exist_ok=True)
        save_traces(out, sim.traces, extra={"stationary": sim.stationary, "moving": sim.moving})
        click.echo(f"wrote {out} ({sim.traces.n_pulses} pulses x {sim.traces.n_samples} samples)")
    else:
        with staged_directory(out) as stage:
            files = write_gotcha(sim.traces, stage)
        click.echo(f"wrote {len(files)} GOTCHA file(s) to {out}")
