"""``sarmotion track``: movers followed across the sub-apertures of a long acquisition."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import click

from ..core.text import fixed
from ..documents.roads import read_roads
from ..documents.tracks import tracks_document
from ..io import staged_directory, write_json
from ..pipeline import AnalysisOptions
from ..report.tracks import coherent_line, fit_line, turn_line, write_tracks_report
from ..separation import SeparationOptions
from ..tracking import TrackingOptions, sub_aperture_slices
from ..tracking import track as run_tracking
from ..tracking.sub_apertures import check_sub_apertures
from .common import (
    SCHEDULER_LIMITS,
    InputError,
    Progress,
    as_flags,
    check_image_size,
    check_out,
    connect_scheduler_flag,
    dask_logging,
    false_alarm_rate_option,
    force_option,
    lenient_option,
    method_option,
    out_option,
    scheduler_callback,
    speed_option,
    workers_callback,
)
from .inputs import FRAME_HELP, INPUTS_HELP, read_inputs
from .main import elapsed_s

__all__ = ["track"]

#: What the command writes into --out.
OUTPUTS = ("tracks.json", "tracks.png", "report.html")


@click.command(epilog=f"{INPUTS_HELP}\n\n{FRAME_HELP}")
@click.argument("inputs", nargs=-1, required=True)
@out_option("Output directory: tracks.json, tracks.png and report.html.")
@force_option
@click.option(
    "--sub-aperture",
    "sub_aperture_deg",
    type=float,
    default=1.0,
    show_default=True,
    help="Azimuth span of each sub-aperture (degrees); at least enough for two "
    "cross-range resolution cells across the image (the minimum is said if not).",
)
@click.option(
    "--overlap",
    type=float,
    default=0.5,
    show_default=True,
    help="Fraction of a sub-aperture shared with the next, in [0, 0.9].",
)
@click.option(
    "--roads",
    "roads_file",
    type=click.Path(path_type=Path),
    default=None,
    help="GeoJSON LineStrings in the scene's ground coordinates (m): each detection is "
    "placed on the member of its cross-range family on the nearest road.",
)
@click.option(
    "--scheduler",
    default=None,
    callback=scheduler_callback,
    help="Address of a Dask scheduler (tcp://host:8786, or tls://host:8786 with the "
    "certificates of Dask's configuration); default a local cluster that only this "
    f"process can use. {SCHEDULER_LIMITS}",
)
@click.option(
    "--dashboard",
    "dashboard_address",
    default=None,
    metavar="HOST:PORT",
    help="Serve the local cluster's Dask dashboard there (needs bokeh); default none.",
)
@click.option(
    "--workers",
    "n_workers",
    type=int,
    default=None,
    callback=workers_callback,
    help="Local Dask workers (default one per core; at most 4 per core; 0: no Dask).",
)
@click.option(
    "--threads/--processes",
    "threads",
    default=True,
    show_default=True,
    help="Local Dask workers as threads of this process or as separate processes.",
)
@click.option(
    "--max-movers",
    type=int,
    default=5,
    show_default=True,
    help="Most movers sought per sub-aperture.",
)
@method_option
@false_alarm_rate_option
@click.option(
    "--size",
    "size_m",
    type=float,
    default=None,
    help="Side of each sub-aperture's square image around the reference point (m); "
    "default from the data's range window, at most 100 m.",
)
@speed_option
@lenient_option
@click.pass_context
def track(
    ctx: click.Context,
    inputs: tuple[str, ...],
    out: Path,
    sub_aperture_deg: float,
    overlap: float,
    roads_file: Path | None,
    scheduler: str | None,
    dashboard_address: str | None,
    n_workers: int | None,
    threads: bool,
    max_movers: int,
    method: str,
    false_alarm_rate: float,
    size_m: float | None,
    speed_mps: float,
    force: bool,
    lenient: bool,
) -> None:
    """Follow the movers of INPUTS across overlapping sub-apertures.

    Each sub-aperture is analysed as by `sarmotion
    analyze` (on Dask: a local cluster, or --scheduler); the detections are associated
    into tracks (Stone Soup), each track's prediction being the known position of its
    next detection. Writes OUT/tracks.json (schema sarmotion.tracks/1), tracks.png and
    report.html.
    """
    try:
        options = TrackingOptions(
            analysis=AnalysisOptions(
                separation=SeparationOptions(method=None if method == "auto" else method),
                max_movers=max_movers,
                image_size_m=size_m,
                trajectory=False,
                false_alarm_rate=false_alarm_rate,
            ),
            sub_aperture_deg=sub_aperture_deg,
            overlap=overlap,
        )
    except (TypeError, ValueError) as exc:
        text = str(exc)
        for name, flag in (
            ("sub_aperture_deg", "--sub-aperture"),
            ("overlap", "--overlap"),
            ("max_movers", "--max-movers"),
            ("image_size_m", "--size"),
            ("false_alarm_rate", "--false-alarm-rate"),
        ):
            if text.startswith(name + " "):
                raise InputError(flag + text[len(name) :]) from None
        raise InputError(text) from None
    check_image_size(size_m, options.analysis.spacing_m)
    if dashboard_address is not None and (scheduler is not None or n_workers == 0):
        raise InputError("--dashboard applies to the local cluster (no --scheduler, --workers > 0)")
    client = connect_scheduler_flag(scheduler)
    check_out(out, force=force, names=OUTPUTS)
    roads = read_roads(roads_file) if roads_file is not None else ()
    with as_flags(speed_mps="--speed"):
        traces, _ = read_inputs(inputs, speed_mps=speed_mps, lenient=lenient)
    with as_flags(sub_aperture_deg="--sub-aperture", image_size_m="--size"):
        slices = sub_aperture_slices(traces, sub_aperture_deg, overlap)
        size = float(options.analysis.resolved(traces).image_size_m)
        check_sub_apertures(traces, slices, sub_aperture_deg, size)
    pulses = slices[0].stop - slices[0].start
    where = (
        f"on {scheduler}"
        if scheduler is not None
        else "in this process"
        if n_workers == 0
        else f"on {n_workers or os.cpu_count() or 1} local {'thread' if threads else 'process'} "
        "worker(s)"
    )
    click.echo(
        f"{len(slices)} sub-aperture(s) of {pulses} pulses ({sub_aperture_deg:g} degrees, "
        f"overlap {overlap:g}), {size:.4g} m images, {where}"
    )
    uses_dask = scheduler is not None or n_workers != 0
    try:
        with (
            Progress(enabled=ctx.obj["progress"]) as bar,
            dask_logging() if uses_dask else contextlib.nullcontext(),
        ):
            result = run_tracking(
                traces,
                options,
                roads=roads,
                scheduler=client,
                n_workers=n_workers,
                processes=not threads,
                dashboard_address=dashboard_address,
                progress=bar,
            )
    except KeyboardInterrupt:
        # Ctrl-C once the cluster has closed: "sarmotion: aborted" alone (click would
        # print an empty line before it for a KeyboardInterrupt)
        raise click.Abort() from None
    doc = tracks_document(result)
    doc["inputs"] = list(inputs)
    with staged_directory(out) as stage:
        write_json(stage / "tracks.json", doc)
        write_tracks_report(
            result,
            stage,
            document=doc,
            title=f"sarmotion tracks: {', '.join(Path(i).name for i in inputs)}",
        )
    click.echo(
        f"wrote {out}/tracks.json, tracks.png and report.html: {len(result.tracks)} track(s) "
        f"over {len(result.sub_apertures)} sub-aperture(s); tracking "
        f"{result.timings_s['total']:.1f} s, {elapsed_s():.1f} s in all (start-up, reading "
        "and figures included)"
    )
    n_detections = sum(s["n_detections"] for s in doc["sub_apertures"])
    least = options.min_detections
    if len(result.tracks) == 0 and n_detections:
        fewer = (
            f"; this input gives {len(slices)} sub-aperture(s): a longer acquisition or a "
            "shorter --sub-aperture gives more"
            if len(slices) < least
            else ""
        )
        click.echo(
            f"  {n_detections} detection(s) in {len(slices)} sub-aperture(s), none followed: a "
            f"track needs at least {least} detections of one mover in different "
            f"sub-apertures{fewer}"
        )
    for t in doc["tracks"]:
        first, last = t["states"][0], t["states"][-1]
        on_road = sum(1 for s in t["states"] if s.get("road", {}).get("fixed"))
        parallel = sum(1 for s in t["states"] if s.get("road", {}).get("fixed") is False)
        click.echo(
            f"  track {t['id']}: {t['n_detections']} detection(s), s = {fixed(first['time_s'])} "
            f"to {fixed(last['time_s'])} s, range speed {fixed(first['range_speed_mps'])} to "
            f"{fixed(last['range_speed_mps'])} m/s, {on_road} state(s) on a road"
            + (
                f", {parallel} with the road parallel to the cross-range family (no point fixed)"
                if parallel
                else ""
            )
        )
        click.echo("    " + turn_line(t))
        if t.get("end"):
            click.echo("    " + t["end"]["text"])
        if t.get("fit"):
            click.echo("    " + fit_line(t["fit"]))
        if t.get("coherent"):
            click.echo("    " + coherent_line(t["coherent"]))
        missed = [s["road_missed"] for s in t["states"] if s.get("road_missed")]
        if missed:
            click.echo(f"    {len(missed)} detection(s) on no road; the first: {missed[0]}")
