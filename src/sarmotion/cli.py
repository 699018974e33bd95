"""Command-line interface: ``sarmotion simulate | image | inject | separate | analyze | demo``.

The only module that parses arguments and configures logging. Bad input never shows
a traceback: one line on stderr (``sarmotion: error: ...``) and exit status 2; outputs
are staged in a hidden sibling directory and moved into place only on success, so a
failed run leaves nothing half-written.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import click
import numpy as np

from . import __version__

log = logging.getLogger("sarmotion")

EXIT_BAD_INPUT = 2


class InputError(Exception):
    """Bad user input: reported as one line, exit status 2."""


# --------------------------------------------------------------------------- helpers
@contextlib.contextmanager
def staged_directory(out: Path) -> Iterator[Path]:
    """Yield a hidden staging directory; move its files into ``out`` only on success."""
    out = Path(out)
    parent = out.resolve().parent
    parent.mkdir(parents=True, exist_ok=True)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} exists and is not a directory")
    stage = Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=parent))
    try:
        yield stage
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    out.mkdir(parents=True, exist_ok=True)
    for item in sorted(stage.iterdir()):
        target = out / item.name
        if target.is_dir() and item.is_dir():
            shutil.rmtree(target)
        os.replace(item, target)
    shutil.rmtree(stage, ignore_errors=True)


class Progress:
    """A tqdm progress bar driven by ``callback(done, total)`` calls from the library."""

    def __init__(self, description: str, *, enabled: bool = True) -> None:
        self.description = description
        self.enabled = enabled
        self._bar: Any = None

    def __call__(self, done: int, total: int) -> None:
        """Advance the bar to ``done`` of ``total``."""
        if not self.enabled:
            return
        if self._bar is None:
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc=self.description, unit="step", leave=False)
        self._bar.n = done
        self._bar.refresh()

    def stage(self, name: str, done: int, total: int) -> None:
        """Advance the bar of stage ``name``; a new bar starts when the stage changes."""
        if name != self.description:
            self.close()
            self.description = name
        self(done, total)

    def close(self) -> None:
        """Remove the bar."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _is_scene_reference(text: str) -> bool:
    from .scene import builtin_scene_names

    return text in builtin_scene_names() or text.lower().endswith(".toml")


def load_input(
    inputs: Sequence[str],
    *,
    speed_mps: float = 70.0,
    autofocus: bool = False,
    snr_db: float | None = None,
    seed: int = 0,
) -> tuple[Any, Any]:
    """Read ``inputs`` as traces.

    Returns ``(traces, simulation_or_None)``: a built-in scene name or scene ``.toml`` is
    simulated (with its ground truth), a ``.h5`` file is read as native traces, and
    ``.mat`` files are read as GOTCHA phase history (several files form one aperture).
    """
    from .io import load_traces, read_gotcha
    from .scene import load_scene
    from .simulate import simulate

    if not inputs:
        raise InputError("no INPUT given")
    first = inputs[0]
    if len(inputs) == 1 and _is_scene_reference(first):
        sim = simulate(load_scene(first), snr_db=snr_db, rng=seed)
        return sim.traces, sim
    for p in inputs:
        if not Path(p).exists():
            raise InputError(f"input not found: {p}")
    suffixes = {Path(p).suffix.lower() for p in inputs}
    if suffixes == {".h5"} or suffixes == {".hdf5"}:
        if len(inputs) != 1:
            raise InputError("give one native traces file (.h5) at a time")
        return load_traces(first), None
    if suffixes == {".mat"}:
        return read_gotcha(list(inputs), speed_mps=speed_mps, autofocus=autofocus), None
    raise InputError(
        f"cannot read {', '.join(inputs)}: expected a built-in scene name, a scene .toml, "
        "a native traces .h5 file, or GOTCHA .mat files"
    )


def _parse_target(text: str) -> Any:
    from .scene import PointTarget

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


def _write_json(path: Path, payload: dict[str, Any]) -> None:
    path.write_text(json.dumps(payload, indent=2, default=_json_default) + "\n")


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, complex):
        return [obj.real, obj.imag]
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON-serialisable: {type(obj).__name__}")


def _grid(size_m: float, spacing_m: float, centre: tuple[float, float]) -> Any:
    from .imaging import ImageGrid

    if not (size_m > 0 and spacing_m > 0):
        raise InputError(f"--size and --spacing must be positive, got {size_m}, {spacing_m}")
    if size_m / spacing_m > 4096:
        raise InputError(
            f"--size/--spacing gives {size_m / spacing_m:.0f} pixels a side (max 4096)"
        )
    return ImageGrid.square(centre_m=centre, size_m=size_m, spacing_m=spacing_m)


def _extent_grid(extent: tuple[float, float, float, float], spacing_m: float) -> Any:
    from .imaging import ImageGrid

    x0, x1, y0, y1 = extent
    if not (np.all(np.isfinite(extent)) and x1 > x0 and y1 > y0 and spacing_m > 0):
        raise InputError(
            f"--grid must be XMIN < XMAX, YMIN < YMAX (m) and --spacing > 0, got {extent}, "
            f"{spacing_m}"
        )
    if max(x1 - x0, y1 - y0) / spacing_m > 4096:
        raise InputError("--grid/--spacing gives more than 4096 pixels a side")
    return ImageGrid.from_extent(x_range_m=(x0, x1), y_range_m=(y0, y1), spacing_m=spacing_m)


# --------------------------------------------------------------------------- commands
@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="sarmotion")
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bars.")
@click.pass_context
def main(ctx: click.Context, verbose: int, quiet: bool) -> None:
    """Single-antenna SAR imaging and motion estimation of complex scenes.

    Separates the echoes of stationary and moving targets (travel-time annihilation
    filters, windowed robust PCA), estimates the movers' velocities and positions, and
    images everything in focus (Borcea, Callaghan & Papanicolaou). Inputs are built-in
    scenes (example1, example2, scene1, filter10, filter30, hyperbola, rotscatt), scene
    .toml files, native .h5 traces, or GOTCHA .mat phase-history files.
    """
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    ctx.ensure_object(dict)
    ctx.obj["progress"] = not quiet and sys.stderr.isatty()


@main.command()
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
    from .io import save_traces, write_gotcha
    from .scene import load_scene
    from .simulate import simulate as run

    sim = run(load_scene(scene), snr_db=snr_db, rng=seed, spreading=spreading)
    if out.suffix.lower() in (".h5", ".hdf5"):
        out.parent.mkdir(parents=True, exist_ok=True)
        save_traces(out, sim.traces, extra={"stationary": sim.stationary, "moving": sim.moving})
        click.echo(f"wrote {out} ({sim.traces.n_pulses} pulses x {sim.traces.n_samples} samples)")
    else:
        with staged_directory(out) as stage:
            files = write_gotcha(sim.traces, stage)
        click.echo(f"wrote {len(files)} GOTCHA file(s) to {out}")


@main.command()
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
    from .imaging import backproject
    from .io import save_image
    from .plotting import image_figure, save_figure

    traces, _ = load_input(inputs, speed_mps=speed_mps, autofocus=autofocus)
    if grid_extent is None:
        grid = _grid(size_m, spacing_m, centre)
    else:
        grid = _extent_grid(grid_extent, spacing_m)
    if velocity is not None and not np.all(np.isfinite(velocity)):
        raise InputError(f"--velocity must be finite, got {velocity}")
    t0 = time.perf_counter()
    with Progress("backprojection", enabled=ctx.obj["progress"]) as bar:
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
        _write_json(
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


@main.command()
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
    from .io import save_traces, write_gotcha
    from .scene import PointTarget
    from .simulate import inject as run

    traces, _ = load_input(inputs, speed_mps=speed_mps)
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


@main.command()
@click.argument("inputs", nargs=-1, required=True)
@click.option(
    "--method",
    type=click.Choice(["combined", "rpca", "annihilation"]),
    default="combined",
    show_default=True,
    help="combined: image-guided extraction in travel-time-aligned frames "
    "(sect:sepdisc); rpca: windowed robust PCA (sect:RPCA); annihilation: "
    "composed filters Q (eq:OP2) at stationary points of the image.",
)
@click.option(
    "--out", "out", required=True, type=click.Path(path_type=Path), help="Output directory."
)
@click.option(
    "--window",
    type=int,
    default=None,
    help="RPCA fast-time window (samples); default chosen from the data.",
)
@click.option(
    "--eta-scale",
    type=float,
    default=1.0,
    show_default=True,
    help="RPCA: factor on the default sparsity weight 1/sqrt(max(n, window)); about 2 "
    "suits real, distributed clutter.",
)
@click.option(
    "--threshold-db",
    type=float,
    default=-25.0,
    show_default=True,
    help="Stationary detection threshold in the preliminary image (dB re peak).",
)
@click.option(
    "--size",
    "size_m",
    type=float,
    default=None,
    help="Side of the preliminary image (m); default 60 m for scenes, 100 m for data.",
)
@click.option(
    "--spacing",
    "spacing_m",
    type=float,
    default=0.25,
    show_default=True,
    help="Pixel spacing of the preliminary image (m).",
)
@click.option(
    "--speed",
    "speed_mps",
    type=float,
    default=70.0,
    show_default=True,
    help="Platform speed for GOTCHA slow time (m/s).",
)
@click.option(
    "--snr-db", type=float, default=None, help="For scene inputs: add white noise at this SNR (dB)."
)
@click.option("--seed", type=int, default=0, show_default=True, help="Noise seed.")
@click.pass_context
def separate(
    ctx: click.Context,
    inputs: tuple[str, ...],
    method: str,
    out: Path,
    window: int | None,
    eta_scale: float,
    threshold_db: float,
    size_m: float | None,
    spacing_m: float,
    speed_mps: float,
    snr_db: float | None,
    seed: int,
) -> None:
    """Separate the traces of stationary and moving targets in INPUTS.

    Writes OUT/separated.h5 (the traces M with extra datasets "stationary" (L, absent for
    the annihilation filter) and "moving" (S or Q M)), OUT/separation.png (|M|, |L|, |S|
    normalised by max|M|, S also in dB: the paper's style), OUT/image.png (the preliminary
    image with the stationary points used) and OUT/separation.json (method details and, for
    simulated scenes, quality against the truth).
    """
    from .imaging import backproject
    from .io import save_traces
    from .plotting import image_figure, save_figure, traces_figure
    from .separation import (
        mover_trace_coverage,
        separate_annihilation,
        separate_combined,
        separate_rpca,
        separation_quality,
        stationary_candidates,
    )

    traces, sim = load_input(inputs, speed_mps=speed_mps, snr_db=snr_db, seed=seed)
    size = size_m if size_m is not None else (60.0 if sim is not None else 100.0)
    centre = tuple(traces.reference_point_m[:2])
    grid = _grid(size, spacing_m, centre)
    progress = ctx.obj["progress"]
    t0 = time.perf_counter()
    with Progress("preliminary image", enabled=progress) as bar:
        prelim = backproject(traces, grid, progress=bar)
    if method == "combined":
        with Progress("combined separation", enabled=progress) as bar:
            sep = separate_combined(
                traces,
                image_values=prelim.values,
                x_m=grid.x_m,
                y_m=grid.y_m,
                threshold_db=threshold_db,
                callback=bar,
            )
    elif method == "rpca":
        with Progress("windowed RPCA", enabled=progress) as bar:
            sep = separate_rpca(traces, window=window, eta_scale=eta_scale, callback=bar)
    else:
        pts = stationary_candidates(
            prelim.values, x_m=grid.x_m, y_m=grid.y_m, traces=traces, threshold_db=threshold_db
        )
        sep = separate_annihilation(traces, pts)
    elapsed = time.perf_counter() - t0
    summary: dict[str, Any] = {
        "schema": "sarmotion.separation/1",
        "method": method,
        "inputs": list(inputs),
        "n_pulses": traces.n_pulses,
        "n_samples": traces.n_samples,
        "seconds": elapsed,
        "stationary_points_m": sep.stationary_points_m,
        "info": {k: v for k, v in sep.info.items() if k != "candidates"},
    }
    if sim is not None:
        if sep.stationary is None:
            from .transforms import annihilate

            pts = sep.stationary_points_m

            def op(d: np.ndarray) -> np.ndarray:
                return annihilate(traces.with_data(d), pts).data

            quality = separation_quality(
                sep, true_stationary=sim.stationary, true_moving=sim.moving, operator=op
            )
        else:
            quality = separation_quality(
                sep, true_stationary=sim.stationary, true_moving=sim.moving
            )
        quality["mover_trace_coverage"] = mover_trace_coverage(sep.moving, traces, sim.scene.moving)
        summary["quality"] = quality
    m_max = float(np.abs(traces.data).max())
    panels = [("|M|", traces.data, False)]
    if sep.stationary is not None:
        panels.append(("|L|", sep.stationary, False))
        panels += [("|S|", sep.moving, False), ("|S| (dB)", sep.moving, True)]
        norm = m_max
    else:
        panels += [("|Q M| (dB re max)", sep.moving, True)]
        norm = None
    with staged_directory(out) as stage:
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
        pts2 = [tuple(p[:2]) for p in sep.stationary_points_m]
        fig = image_figure(
            [("preliminary image, stationary points used", prelim.values)],
            x_m=grid.x_m,
            y_m=grid.y_m,
            markers=[pts2],
        )
        save_figure(fig, stage / "image.png")
        _write_json(stage / "separation.json", summary)
    line = f"wrote {out}/separated.h5, separation.png, image.png, separation.json ({elapsed:.1f} s)"
    if "quality" in summary and "relative_error_moving" in summary["quality"]:
        q = summary["quality"]
        line += (
            f"; ||S-S_true||/||S_true|| = {q['relative_error_moving']:.3f}, "
            f"mover retained {q['mover_retained']:.3f}"
        )
    click.echo(line)


def _analyze(
    inputs: Sequence[str],
    out: Path,
    *,
    method: str | None,
    max_movers: int,
    speed_mps: float,
    size_m: float | None,
    trajectory: bool,
    snr_db: float | None,
    seed: int,
    progress: bool,
    sub_aperture_deg: float = 1.0,
) -> None:
    """Run :func:`sarmotion.analysis.analyze` on ``inputs`` and write ``out``."""
    from .analysis import analyze as run_analysis
    from .report import write_report

    if max_movers < 0:
        raise InputError(f"--max-movers must be >= 0, got {max_movers}")
    if size_m is not None and not size_m > 0:
        raise InputError(f"--size must be positive (m), got {size_m}")
    if not (np.isfinite(sub_aperture_deg) and sub_aperture_deg > 0):
        raise InputError(f"--sub-aperture must be positive (degrees), got {sub_aperture_deg}")
    traces, sim = load_input(inputs, speed_mps=speed_mps, snr_db=snr_db, seed=seed)
    with Progress("", enabled=progress) as bar:
        result = run_analysis(
            traces,
            method=method,
            max_movers=max_movers,
            image_size_m=size_m,
            trajectory=trajectory,
            sub_aperture_deg=sub_aperture_deg,
            progress=bar.stage,
        )
    doc = result.to_json_dict(truth=sim.scene if sim is not None else None)
    doc["inputs"] = list(inputs)
    with staged_directory(out) as stage:
        _write_json(stage / "results.json", doc)
        write_report(
            result,
            stage,
            document=doc,
            title=f"sarmotion analysis: {', '.join(Path(i).name for i in inputs)}",
            inputs=inputs,
        )
    click.echo(
        f"wrote {out}/results.json, report.html and figures: {len(result.movers)} mover(s), "
        f"{len(result.stationary)} stationary target(s), {result.timings_s['total']:.1f} s"
    )
    for k, m in enumerate(doc["movers"]):
        x, y = m["position_m"]
        ux, uy = m["velocity_mps"]
        click.echo(
            f"  mover {k + 1}: position ({x:.2f}, {y:.2f}) m, velocity ({ux:.2f}, {uy:.2f}) "
            f"m/s, range speed {m['range_speed_mps']:.2f} m/s"
        )


@main.command()
@click.argument("inputs", nargs=-1, required=True)
@click.option(
    "--out", "out", required=True, type=click.Path(path_type=Path), help="Output directory."
)
@click.option(
    "--method",
    type=click.Choice(["auto", "combined", "rpca", "annihilation"]),
    default="auto",
    show_default=True,
    help="Stationary/moving separation. auto: combined for simulated scenes, rpca "
    "(eta x 2) for measured data.",
)
@click.option("--max-movers", type=int, default=5, show_default=True, help="Most movers sought.")
@click.option(
    "--speed",
    "speed_mps",
    type=float,
    default=70.0,
    show_default=True,
    help="Platform speed for GOTCHA slow time (m/s).",
)
@click.option(
    "--size",
    "size_m",
    type=float,
    default=None,
    help="Side of the square image around the reference point (m); default from the "
    "data's range window, at most 100 m.",
)
@click.option(
    "--trajectory/--no-trajectory",
    default=True,
    show_default=True,
    help="Estimate each mover's trajectory (phase-space algorithm).",
)
@click.option(
    "--sub-aperture",
    "sub_aperture_deg",
    type=float,
    default=1.0,
    show_default=True,
    help="Azimuth span (degrees) the movers are estimated on; a wider aperture is "
    "analysed on its central sub-aperture and each mover then focused on all pulses.",
)
@click.option("--snr-db", type=float, default=None, help="Simulated inputs: add noise (dB).")
@click.option("--seed", type=int, default=0, show_default=True, help="Noise seed.")
@click.pass_context
def analyze(
    ctx: click.Context,
    inputs: tuple[str, ...],
    out: Path,
    method: str,
    max_movers: int,
    speed_mps: float,
    size_m: float | None,
    trajectory: bool,
    sub_aperture_deg: float,
    snr_db: float | None,
    seed: int,
) -> None:
    """Separate, estimate and image the stationary and moving targets of INPUTS.

    INPUTS: a built-in scene name or scene .toml (simulated), a native traces .h5 file,
    or GOTCHA .mat files. Writes OUT/results.json (schema sarmotion.results/1),
    OUT/report.html (self-contained) and the report's figures as PNG.
    """
    _analyze(
        inputs,
        out,
        method=None if method == "auto" else method,
        max_movers=max_movers,
        speed_mps=speed_mps,
        size_m=size_m,
        trajectory=trajectory,
        snr_db=snr_db,
        seed=seed,
        progress=ctx.obj["progress"],
        sub_aperture_deg=sub_aperture_deg,
    )


@main.command()
@click.option(
    "--out",
    "out",
    type=click.Path(path_type=Path),
    default=Path("sarmotion-demo"),
    show_default=True,
    help="Output directory.",
)
@click.pass_context
def demo(ctx: click.Context, out: Path) -> None:
    """Analyse Scene 1 (20 stationary targets, 2 movers): ``analyze scene1 --out OUT``."""
    ctx.invoke(analyze, inputs=("scene1",), out=out)


@main.command()
@click.option(
    "--out",
    "out",
    type=click.Path(path_type=Path),
    default=Path("sarmotion-paper"),
    show_default=True,
    help="Output directory: fig_NAME.png and fig_NAME.npz per figure, and index.html.",
)
@click.option(
    "--only",
    "only",
    multiple=True,
    metavar="LABEL",
    help="Build only this figure (e.g. fig:rpcaEx2b or rpcaEx2b); repeatable.",
)
@click.option("--quick", is_flag=True, help="Reduced sizes (coarser grids, fewer sweep values).")
@click.option("--list", "list_only", is_flag=True, help="List the figure labels and exit.")
@click.pass_context
def paper(
    ctx: click.Context, out: Path, only: tuple[str, ...], quick: bool, list_only: bool
) -> None:
    """Regenerate every figure of the paper, with the numbers behind it.

    Each figure is named after its LaTeX label (fig:rpcaEx2b -> fig_rpcaEx2b.png) and
    index.html shows it beside the paper's caption and a line of what it shows
    numerically (e.g. windowed vs whole-matrix RPCA error).
    """
    from .paper import FIGURE_LABELS, build_figures

    if list_only:
        click.echo("\n".join(FIGURE_LABELS))
        return
    selected = list(only) if only else None
    total = len(selected) if selected else len(FIGURE_LABELS)
    with Progress("figures", enabled=ctx.obj["progress"]) as bar:
        with staged_directory(out) as stage:
            records = build_figures(
                stage,
                only=selected,
                quick=quick,
                progress=lambda label, done, n: bar(done, n),
            )
    seconds = sum(r.seconds for r in records)
    click.echo(
        f"wrote {len(records)} of {total} figure(s) and index.html to {out} ({seconds:.0f} s)"
    )


# --------------------------------------------------------------------------- entry
def _known_errors() -> tuple[type[BaseException], ...]:
    from .io import DataError
    from .scene import SceneError

    return (InputError, DataError, SceneError, ValueError, FileNotFoundError, OSError)


def run(args: Sequence[str] | None = None) -> int:
    """Run the CLI with ``args``; return the exit status (never raises for bad input)."""
    try:
        main.main(
            args=list(args) if args is not None else None,
            prog_name="sarmotion",
            standalone_mode=False,
        )
    except click.exceptions.Abort:
        click.echo("sarmotion: aborted", err=True)
        return 130
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code
    except _known_errors() as exc:
        log.debug("bad input", exc_info=True)
        click.echo(f"sarmotion: error: {exc}", err=True)
        return EXIT_BAD_INPUT
    return 0


def entry_point() -> None:
    """Console-script entry point."""
    sys.exit(run())
