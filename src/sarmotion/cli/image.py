"""``sarmotion image``: a backprojection image."""

from __future__ import annotations

import time
from pathlib import Path

import click
import numpy as np

from ..core.text import fixed
from ..documents.peaks import peaks_document
from ..imaging import backproject, resolution
from ..imaging.quality import point_quality
from ..io import DataError, save_image, staged_directory, write_json
from ..io.sicd import check_sicd_grid, write_sicd
from ..report.autofocus import phase_error_figure
from ..report.plotting import full_resolution_image_figure, save_figure
from .autofocus import autofocus_options, read_focused
from .common import (
    MAX_GROUND_SPEED_MPS,
    ORIGIN_RULE,
    InputError,
    Progress,
    check_out,
    extent_grid,
    force_option,
    lenient_option,
    origin_callback,
    out_option,
    say,
    speed_option,
    square_grid,
)
from .inputs import FRAME_HELP, INPUTS_HELP, LABELS_HELP
from .main import elapsed_s

OUTPUTS = ("image.png", "image.h5", "peaks.json", "autofocus.png")

__all__ = ["image"]


@click.command(epilog=f"{INPUTS_HELP}\n\n{FRAME_HELP} {LABELS_HELP}")
@click.argument("inputs", nargs=-1, required=True)
@out_option("Output directory: image.png, image.h5, peaks.json.")
@force_option
@click.option(
    "--velocity",
    nargs=2,
    type=float,
    default=None,
    metavar="UX UY",
    help="Motion-compensate for this ground velocity (m/s): each pixel is imaged at the "
    "position it has moved to at every pulse [eq:imagecompu].",
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
    help="Rectangular image extent (m), instead of --size/--centre (not with them); "
    "pixels of --spacing.",
)
@speed_option
@lenient_option
@autofocus_options
@click.option(
    "--method",
    type=click.Choice(["exact", "ffbp"]),
    default="exact",
    show_default=True,
    help="'exact': every pulse summed at every pixel (about 88 dB from the exact sum on "
    "the CPU, 96 dB on the GPU). 'ffbp': fast factorised backprojection, several times "
    "faster on large images, at least 55 dB from the exact sum by its error budget; exact "
    "where it would not save work.",
)
@click.option(
    "--device",
    type=click.Choice(["cpu", "cuda"]),
    default="cpu",
    show_default=True,
    help="Where to backproject: 'cuda' runs it on an NVIDIA GPU (the sarmotion[gpu] extra).",
)
@click.option(
    "--sicd",
    "sicd_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Also write the complex image as a SICD 1.4.0 NITF file (passes sarkit's checker).",
)
@click.option(
    "--origin",
    "origin_llh",
    nargs=3,
    type=float,
    default=None,
    metavar="LAT LON HAE",
    callback=origin_callback,
    help="--sicd: geodetic position (deg, deg, m) of the origin of the scene frame; default "
    f"0 0 0; {ORIGIN_RULE}.",
)
@click.option(
    "--dynamic-range",
    "dynamic_range_db",
    type=float,
    default=40.0,
    show_default=True,
    help="Displayed dynamic range below the peak (dB, > 0).",
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
    lenient: bool,
    autofocus: str | None,
    pga_iterations: int,
    sicd_path: Path | None,
    origin_llh: tuple[float, float, float] | None,
    dynamic_range_db: float,
    method: str,
    device: str,
    force: bool,
) -> None:
    """Backprojection image of INPUTS: a scene, native traces, GOTCHA .mat or CPHD files.

    Each pixel sums the traces at its round-trip travel time over the aperture
    [eq:image].
    Writes OUT/image.png (dB, peak-normalised; an arrow shows the radar's look direction
    on the ground at the aperture centre), OUT/image.h5 (complex image with its axes)
    and OUT/peaks.json (the brightest points).
    """
    if device == "cuda":
        from ..imaging.cuda import NEEDS, available

        if not available():
            raise InputError(f"--device cuda: {NEEDS}")
    check_out(out, force=force, names=OUTPUTS)
    if sicd_path is not None:
        try:
            check_out(sicd_path, force=force)
        except InputError as exc:
            raise InputError(str(exc).replace("--out", "--sicd", 1)) from None
        if sicd_path.resolve().parent == out.resolve() and sicd_path.name in OUTPUTS:
            raise InputError(f"--sicd {sicd_path} would replace an output of --out")
    if origin_llh is not None:
        if sicd_path is None:
            raise InputError("--origin applies to --sicd only")
    given = {
        flag
        for name, flag in (("size_m", "--size"), ("centre", "--centre"))
        if ctx.get_parameter_source(name) is not click.core.ParameterSource.DEFAULT
    }
    if grid_extent is not None and given:
        raise InputError(
            f"--grid sets the image extent; do not combine it with {', '.join(sorted(given))}"
        )
    if not (np.isfinite(dynamic_range_db) and dynamic_range_db > 0):
        raise InputError(f"--dynamic-range must be > 0 (dB), got {dynamic_range_db}")
    if velocity is not None and not np.all(np.isfinite(velocity)):
        raise InputError(f"--velocity must be finite, got {velocity}")
    if velocity is not None and np.hypot(*velocity) > MAX_GROUND_SPEED_MPS:
        raise InputError(
            f"--velocity must be a ground speed of at most {MAX_GROUND_SPEED_MPS:g} m/s, got "
            f"{np.hypot(*velocity):.4g} m/s"
        )
    if not np.all(np.isfinite(centre)):
        raise InputError(f"--centre must be finite, got {centre}")
    if grid_extent is None:
        grid = square_grid(size_m, spacing_m, centre)
    else:
        grid = extent_grid(grid_extent, spacing_m)
    say(
        ctx,
        f"image: {_names(inputs)} -> {grid.shape[1]} x {grid.shape[0]} pixels at "
        f"{spacing_m:g} m, {method} backprojection on the {device.upper()}",
    )
    traces, _, focus = read_focused(
        inputs,
        autofocus=autofocus,
        pga_iterations=pga_iterations,
        speed_mps=speed_mps,
        lenient=lenient,
    )
    if sicd_path is not None:
        try:
            check_sicd_grid(grid.x_m, grid.y_m, traces)
        except DataError as exc:
            raise InputError(f"--sicd: {exc}; choose a finer --spacing") from None
    t0 = time.perf_counter()
    with Progress(enabled=ctx.obj["progress"]) as bar:
        if device == "cuda":
            from ..imaging.cuda import backproject_cuda

            img = backproject_cuda(traces, grid, velocity_mps=velocity, method=method,
                                   progress=bar)  # fmt: skip
        else:
            img = backproject(traces, grid, velocity_mps=velocity, method=method, progress=bar)
    elapsed = time.perf_counter() - t0
    peaks = img.peaks(5, min_separation_m=3.0)
    quality = [_quality(traces, (x, y), velocity) for x, y, v in peaks if abs(v) > 0]
    with staged_directory(out) as stage:
        fig = full_resolution_image_figure(
            img.values,
            x_m=grid.x_m,
            y_m=grid.y_m,
            title=_title(inputs, grid, velocity, dynamic_range_db),
            dynamic_range_db=dynamic_range_db,
            dpi=IMAGE_DPI,
            look_direction=-resolution(traces).range_direction,  # e_r points to the antenna
        )
        save_figure(fig, stage / "image.png", dpi=IMAGE_DPI, tight=False)
        if focus is not None:
            save_figure(
                phase_error_figure(
                    traces.slow_times_s,
                    focus.phase_error_rad,
                    focus.rms_history_rad,
                    tol_rad=focus.tol_rad,
                ),
                stage / "autofocus.png",
            )
        save_image(
            stage / "image.h5",
            img.values,
            x_m=grid.x_m,
            y_m=grid.y_m,
            velocity_mps=velocity,
            metadata={
                "inputs": list(inputs),
                **traces.metadata,
                "imaging": _imaging_record(img.metadata, device),
            },
        )
        pixel_pulses = grid.shape[0] * grid.shape[1] * traces.n_pulses
        write_json(
            stage / "peaks.json",
            peaks_document(
                peaks,
                quality=quality,
                autofocus=None if focus is None else focus.to_dict(),
                seconds=elapsed,
                pixel_pulses=pixel_pulses,
            ),
        )
        if sicd_path is not None:
            write_sicd(
                sicd_path,
                img.values,
                x_m=grid.x_m,
                y_m=grid.y_m,
                traces=traces,
                origin_llh=origin_llh or (0.0, 0.0, 0.0),
            )
    if peaks and abs(peaks[0][2]) > 0:
        x, y, _ = peaks[0]
        where = f"brightest point at ({fixed(x)}, {fixed(y)}) m"
    else:
        where = "the image is zero: no echo falls on this grid"
    extra = ", autofocus.png" if focus is not None else ""
    extra += f" and {sicd_path}" if sicd_path is not None else ""
    click.echo(
        f"wrote {out}/image.png, image.h5, peaks.json{extra}; {where}; backprojection "
        f"{elapsed:.2f} s, {elapsed_s():.1f} s in all (start-up, reading and figures included)"
    )


#: Resolution of image.png (PNG pixels per inch of its layout).
IMAGE_DPI = 100


def _names(inputs) -> str:
    """The inputs' file names, or their count when the names are long."""
    names = ", ".join(Path(i).name for i in inputs)
    return names if len(names) <= 50 else f"{len(inputs)} inputs"


def _title(inputs, grid, velocity, dynamic_range_db: float) -> str:
    """image.png's title: what was imaged, the extent, the pixels, the scale."""
    names = _names(inputs)
    ny, nx = grid.shape
    x, y = grid.x_m, grid.y_m
    spacing = float(x[1] - x[0]) if nx > 1 else float(y[1] - y[0]) if ny > 1 else 0.0
    cx = 0.5 * (float(x[0]) + float(x[-1]))
    cy = 0.5 * (float(y[0]) + float(y[-1]))
    lines = [
        f"backprojection image of {names}",
        f"{nx * spacing:g} x {ny * spacing:g} m around ({fixed(cx, 1)}, {fixed(cy, 1)}) m: "
        f"{nx} x {ny} pixels of {spacing:g} m",
        f"|I| in dB re its peak, {dynamic_range_db:g} dB shown",
    ]
    if velocity is not None:
        lines.append(f"compensated for a ground velocity of ({velocity[0]:g}, {velocity[1]:g}) m/s")
    return "\n".join(lines)


def _quality(traces, point, velocity) -> dict:
    """Point-target quality of a peak (:func:`point_quality`), or why it has none."""
    try:
        return point_quality(traces, point, velocity_mps=velocity).to_dict()
    except ValueError as exc:
        return {"error": str(exc)}


def _imaging_record(meta: dict, device: str) -> dict:
    """How the image was formed: method, kernel, device, and FFBP's path and error budget."""
    record = {"method": meta.get("method"), "kernel_variant": meta.get("kernel_variant"),
              "device": device}  # fmt: skip
    ffbp = meta.get("ffbp")
    if ffbp:
        record["ffbp_path"] = str(ffbp.get("path"))
        if ffbp.get("budget_db") is not None:
            record["ffbp_budget_db"] = float(ffbp["budget_db"])
    return record
