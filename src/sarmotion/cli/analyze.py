"""``sarmotion analyze`` and ``sarmotion demo``: the whole pipeline."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import click

from ..collection import CollectionOptions, drop_smear
from ..io import DataError
from ..io.sicd import write_sicd
from ..io.staging import claimed
from ..pipeline import AnalysisOptions
from ..pipeline import analyze as run_analysis
from ..report.analysis import ANALYSIS_OUTPUTS, save
from ..separation import SeparationOptions
from .autofocus import ReadOptions, autofocus_options
from .collection import COLLECTION_OUTPUTS, echo_document, run_collection
from .common import (
    MAX_GROUND_SPEED_MPS,
    SCHEDULER_LIMITS,
    InputError,
    Progress,
    as_flags,
    check_image_size,
    check_out,
    connect_scheduler_flag,
    false_alarm_rate_option,
    force_option,
    lenient_option,
    max_speed_callback,
    method_option,
    noise_options,
    out_option,
    say,
    scheduler_callback,
    speed_option,
    workers_callback,
)
from .inputs import FRAME_HELP, INPUTS_HELP

OUTPUTS = ANALYSIS_OUTPUTS

__all__ = ["analyze", "demo"]


def _options(
    method: str,
    max_movers: int,
    size_m: float | None,
    trajectory: bool,
    sub_aperture_deg: float,
    false_alarm_rate: float = 0.01,
    device: str = "cpu",
    defocus_search: bool = True,
    wide_defocus_search: bool = False,
) -> AnalysisOptions:
    """AnalysisOptions from the flags; a bad value is reported under its flag's name."""
    with as_flags(
        max_movers="--max-movers",
        image_size_m="--size",
        sub_aperture_deg="--sub-aperture",
        false_alarm_rate="--false-alarm-rate",
    ):
        return AnalysisOptions(
            separation=SeparationOptions(method=None if method == "auto" else method),
            max_movers=max_movers,
            image_size_m=size_m,
            trajectory=trajectory,
            sub_aperture_deg=sub_aperture_deg,
            false_alarm_rate=false_alarm_rate,
            device=device,
            defocus_search=defocus_search,
            wide_defocus_search=wide_defocus_search,
        )


def run_analyze(
    inputs: Sequence[str],
    out: Path,
    options: AnalysisOptions,
    *,
    reading: ReadOptions | None = None,
    progress: bool = False,
    force: bool = False,
    sicd: bool = False,
    read: tuple[Any, Any, Any] | None = None,
    plan: Any = None,
    collection_options: dict[str, Any] | None = None,
) -> None:
    """Analyse ``inputs`` and write ``out``/results.json, report.html and its figures.

    ``reading``: how the inputs are read (:class:`~.autofocus.ReadOptions`, its defaults
    when ``None``): ``autofocus="gotcha"`` applies GOTCHA's stored corrections, ``"pga"``
    phase-gradient autofocus (its phase error goes in the document and report). ``read``:
    the inputs' ``(traces, simulation, autofocus result)`` when already read. ``plan``
    and ``collection_options``: the patch plan that made the scene one patch and its
    options, for the document (a single analysis is a collection of one patch).

    With ``sicd``, also the stationary image as ``stationary.nitf`` and each mover's
    compensated image as ``mover-K.nitf`` (SICD, :func:`~sarmotion.io.sicd.write_sicd`).
    """
    reading = ReadOptions() if reading is None else reading
    if claimed(out) is None:  # the analyze command claimed it before reading
        check_out(out, force=force, names=OUTPUTS, patterns=("mover-*.nitf",) if sicd else ())
    traces, sim, focus = read if read is not None else reading.read(inputs)
    with Progress(enabled=progress) as bar:
        # one smear rule for every size: a mover's echo is not listed as stationary points
        result = drop_smear(run_analysis(traces, options, progress=bar))
    save_single(
        result,
        out,
        inputs,
        sim=sim,
        focus=focus,
        sicd=sicd,
        plan=plan,
        collection_options=collection_options,
    )


def save_single(
    result: Any,
    out: Path,
    inputs: Sequence[str],
    *,
    sim: Any = None,
    focus: Any = None,
    sicd: bool = False,
    plan: Any = None,
    collection_options: dict[str, Any] | None = None,
) -> None:
    """Write one analysis (``result``, an AnalysisResult) into ``out`` and say what it found.

    ``sim`` and ``focus``: the simulation of a scene and the autofocus result, for the
    document; ``plan`` and ``collection_options``: the plan of one patch and its options.
    """
    doc = save(
        result,
        out,
        scene=sim.scene if sim is not None else None,
        inputs=inputs,
        autofocus=focus.to_dict() if focus is not None else None,
        also=(lambda stage: _write_sicd_images(result, stage)) if sicd else None,
        plan=plan,
        collection_options=collection_options,
    )
    echo_document(out, doc, result.timings_s["total"])


#: Why --sicd is refused for a scene cut into patches (``{n}``: the patches).
SICD_PATCHES = (
    "--sicd: this analysis is cut into {n} patch(es) (or given a --region); SICD images are "
    "written for a scene of one patch analysed whole, without --region: leave --sicd out"
)


def _write_sicd_images(result, stage: Path) -> None:
    """The stationary image and each mover's compensated image as SICD files."""
    images = [("stationary.nitf", result.stationary_image, None)]
    images += [
        (f"mover-{k + 1}.nitf", m.image, m.velocity_mps) for k, m in enumerate(result.movers)
    ]
    for name, img, velocity in images:
        try:
            write_sicd(
                stage / name,
                img.values,
                x_m=img.grid.x_m,
                y_m=img.grid.y_m,
                traces=result.traces,
                velocity_mps=velocity,
            )
        except DataError as exc:
            raise InputError(f"--sicd {name}: {exc}") from None


@click.command(epilog=f"{INPUTS_HELP}\n\n{FRAME_HELP}")
@click.argument("inputs", nargs=-1, required=True)
@out_option("Output directory: results.json, report.html and its figures.")
@force_option
@method_option
@click.option("--max-movers", type=int, default=5, show_default=True, help="Most movers sought.")
@false_alarm_rate_option
@speed_option
@lenient_option
@autofocus_options
@click.option(
    "--size",
    "size_m",
    type=float,
    default=None,
    help="Side of the square image around the reference point (m); default from the "
    "data's range window, at most 100 m.",
)
@click.option(
    "--defocus-search/--no-defocus-search",
    default=True,
    show_default=True,
    help="Also seek movers whose range rate is that of a stationary point of the scene "
    "(their image lands inside it, where the separation takes them for stationary), by "
    "their focus over a bank of cross-range speeds. On data without movers its tests "
    "explain every candidate of the null benchmark; on the movers' benchmark, Scene 1 "
    "and GOTCHA it finds the same movers as without it (on GOTCHA's four degrees in "
    "about 0.4 s more).",
)
@click.option(
    "--wide-defocus-search/--no-wide-defocus-search",
    default=False,
    show_default=True,
    help="Let the defocus search also look over twice the degree the movers are "
    "estimated on, at the cross-range speeds under its first step, where a degree cannot "
    "tell a mover from a stationary point (data longer than a degree). It finds such "
    "movers among point targets; off by default because the bright targets of real "
    "scenes are not points over two degrees: on the four GOTCHA degrees in 30 m patches "
    "it declared slow movers where none is known.",
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
    help="Azimuth span (degrees, > 0) the movers are estimated on; a wider aperture is "
    "analysed on its central sub-aperture and each mover then focused on all pulses.",
)
@click.option(
    "--sicd",
    is_flag=True,
    help="Also write the stationary image and each mover's image as SICD files "
    "(OUT/stationary.nitf, OUT/mover-K.nitf). For a scene of one patch (no --region): a "
    "scene cut into patches is refused before any analysis.",
)
@click.option(
    "--region",
    type=float,
    nargs=4,
    default=None,
    metavar="X0 Y0 X1 Y1",
    help="Analyse this part of the scene (m), a box in the frame of --region-frame; "
    "default the image area the input declares (a CPHD's SceneCoordinates/ImageArea) "
    "within the data's unambiguous scene (echoes in the fast-time window and within the "
    "pulse rate at every pulse), or that whole scene where none is declared. "
    "A scene larger than one patch is cut into overlapping patches, squares along the "
    "look's range and cross range. A mover is found "
    "where its Doppler places its image: its range speed shifts it in cross range "
    "(about R/V metres per m/s), so patches beyond the region search for movers only "
    "(--search-beyond); a mover outside the region may be found too.",
)
@click.option(
    "--region-frame",
    type=click.Choice(["ground", "look"]),
    default="ground",
    show_default=True,
    help="Frame of --region: 'ground', X0 Y0 X1 Y1 along the scene's x and y; 'look', "
    "A0 B0 A1 B1 in ground range (towards the antenna) and cross range (range turned a "
    "quarter counter-clockwise) from the reference point, at the aperture centre.",
)
@click.option(
    "--patch-size",
    "patch_size_m",
    type=float,
    default=None,
    help="Side of each patch's core (m); default from the data's resolution and aperture. "
    "At least 8 resolution cells (the fast-time guard either side of a core), and at most "
    "1024 patches in a plan.",
)
@click.option(
    "--max-speed",
    "max_speed_mps",
    type=float,
    default=15.0,
    show_default=True,
    callback=max_speed_callback,
    help=f"Patches: largest ground speed of a mover (m/s, at most {MAX_GROUND_SPEED_MPS:g}: the "
    "speed of sound) their margins are sized for.",
)
@click.option(
    "--search-beyond/--no-search-beyond",
    "search_beyond",
    default=True,
    show_default=True,
    help="Patches: search for movers beyond the region too, out to the cross-range shift "
    "of a mover's image at --max-speed (its range speed moves its image about R/V metres "
    "per m/s), within the unambiguous scene. Those patches list no stationary target and "
    "add nothing to the mosaic; --no-search-beyond tiles the region alone, faster, and "
    "misses the movers whose images land outside it.",
)
@click.option(
    "--scheduler",
    default=None,
    callback=scheduler_callback,
    help="Patches: address of a Dask scheduler (tcp://host:8786, or tls://host:8786 with the "
    f"certificates of Dask's configuration); default a local cluster. {SCHEDULER_LIMITS}",
)
@click.option(
    "--workers",
    "n_workers",
    type=int,
    default=None,
    callback=workers_callback,
    help="Patches: local Dask workers (default one per core; at most 4 per core; 0: no Dask).",
)
@click.option(
    "--device",
    type=click.Choice(["cpu", "cuda"]),
    default="cpu",
    show_default=True,
    help="Where to backproject the images: 'cuda' on an NVIDIA GPU (the sarmotion[gpu] extra).",
)
@noise_options
@click.pass_context
def analyze(
    ctx: click.Context,
    inputs: tuple[str, ...],
    out: Path,
    method: str,
    max_movers: int,
    false_alarm_rate: float,
    speed_mps: float,
    size_m: float | None,
    trajectory: bool,
    defocus_search: bool,
    wide_defocus_search: bool,
    sub_aperture_deg: float,
    snr_db: float | None,
    seed: int,
    force: bool,
    lenient: bool,
    autofocus: str | None,
    pga_iterations: int,
    sicd: bool,
    region: tuple[float, float, float, float] | None,
    region_frame: str,
    patch_size_m: float | None,
    max_speed_mps: float,
    search_beyond: bool,
    scheduler: str | None,
    n_workers: int | None,
    device: str,
) -> None:
    """Separate, estimate and image the stationary and moving targets of INPUTS.

    Writes OUT/results.json (schema sarmotion.results/3), OUT/report.html
    (self-contained) and the report's figures as PNG, whatever the scene's size. A scene
    larger than one patch (or any --region) is cut into patches, analysed on Dask and
    merged: the same document and report, with mosaic.png and the patch table added.
    """
    if device == "cuda":
        from ..imaging.cuda import NEEDS, available

        if not available():
            raise InputError(f"--device cuda: {NEEDS}")
    options = _options(
        method,
        max_movers,
        size_m,
        trajectory,
        sub_aperture_deg,
        false_alarm_rate,
        device,
        defocus_search,
        wide_defocus_search,
    )
    check_image_size(size_m, options.spacing_m)
    client = connect_scheduler_flag(scheduler)
    # --out is claimed before the inputs are read, whether one analysis or patches will
    # write it: a concurrent run into the same directory is refused at once.
    check_out(
        out,
        force=force,
        names=tuple(dict.fromkeys(OUTPUTS + COLLECTION_OUTPUTS)),
        patterns=("mover-*.nitf",) if sicd else (),
    )

    with as_flags(patch_size_m="--patch-size", max_speed_mps="--max-speed"):
        copts = CollectionOptions(
            analysis=options,
            patch_size_m=patch_size_m,
            max_speed_mps=max_speed_mps,
            search_beyond=search_beyond,
        )

    def single(result: Any, sim: Any, focus: Any) -> None:
        save_single(
            result.single_result,
            out,
            inputs,
            sim=sim,
            focus=focus,
            sicd=sicd,
            plan=result.plan,
            collection_options=copts.to_dict(),
        )

    say(ctx, f"analyze: reading {', '.join(Path(i).name for i in inputs)}")
    run_collection(
        inputs,
        out,
        copts,
        region=region,
        region_frame=region_frame,
        scheduler=client,
        n_workers=n_workers,
        single=single,
        refuse_patches=SICD_PATCHES if sicd else None,
        reading=ReadOptions(
            speed_mps=speed_mps,
            snr_db=snr_db,
            seed=seed,
            lenient=lenient,
            autofocus=autofocus,
            pga_iterations=pga_iterations,
        ),
        progress=ctx.obj["progress"],
        force=force,
    )


#: The demo's own output directory: an earlier demo's output there is replaced.
DEMO_OUT = Path("sarmotion-demo")


@click.command(epilog=FRAME_HELP)
@out_option(
    "Output directory. At the default, an earlier demo's output (its results.json) is "
    "replaced, so the demo can be run again; elsewhere an existing output needs --force.",
    required=False,
    default=DEMO_OUT,
    show_default=True,
)
@force_option
@click.pass_context
def demo(ctx: click.Context, out: Path, force: bool) -> None:
    """Analyse the built-in Scene 1 (20 stationary targets, 2 movers) into OUT."""
    rerun = out == DEMO_OUT and (out / "results.json").is_file() and not out.is_symlink()
    run_analyze(
        ("scene1",), out, AnalysisOptions(), progress=ctx.obj["progress"], force=force or rerun
    )
