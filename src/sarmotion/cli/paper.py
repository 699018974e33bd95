"""``sarmotion paper``: every figure of the paper."""

from __future__ import annotations

from pathlib import Path

import click

from ..io import staged_directory
from ..paper.figures import FIGURE_LABELS, build_figures
from .common import Progress, as_flags, check_out, force_option, out_option

__all__ = ["paper"]

#: Where the GOTCHA files are looked for without --gotcha or $SARMOTION_GOTCHA_DIR,
#: relative to the current directory: the data beside a clone (as the tests look).
GOTCHA_LOCATIONS = (Path("shared/data/gotcha"), Path("../shared/data/gotcha"))


def default_gotcha() -> list[Path]:
    """The GOTCHA .mat files of the first of :data:`GOTCHA_LOCATIONS` that holds some."""
    for d in GOTCHA_LOCATIONS:
        if d.is_dir():
            files = sorted(d.glob("*.mat"))
            if files:
                return files
    return []


@click.command()
@out_option(
    "Output directory: fig_NAME.png and fig_NAME.npz per figure, and index.html.",
    required=False,
    default=Path("sarmotion-paper"),
    show_default=True,
)
@force_option
@click.option(
    "--only",
    "only",
    multiple=True,
    metavar="LABEL",
    help="Build only this figure, named by its LaTeX label in the paper (e.g. fig:rpcaEx2b "
    "or rpcaEx2b); repeatable.",
)
@click.option(
    "--gotcha",
    "gotcha",
    type=click.Path(exists=True, path_type=Path),
    multiple=True,
    envvar="SARMOTION_GOTCHA_DIR",
    help="GOTCHA .mat files, or a directory of them, for the paper's fig:setup (the "
    "acquisition geometry); default $SARMOTION_GOTCHA_DIR, else shared/data/gotcha or "
    "../shared/data/gotcha from the current directory. Without them the paper's fig:setup "
    "draws the nominal GOTCHA circle.",
)
@click.option("--quick", is_flag=True, help="Reduced sizes (coarser grids, fewer sweep values).")
@click.option("--list", "list_only", is_flag=True, help="List the figure labels and exit.")
@click.pass_context
def paper(
    ctx: click.Context,
    out: Path,
    force: bool,
    only: tuple[str, ...],
    gotcha: tuple[Path, ...],
    quick: bool,
    list_only: bool,
) -> None:
    """Regenerate every figure of the paper, with the numbers behind it.

    Each figure is named after its LaTeX label in the paper (fig:rpcaEx2b ->
    fig_rpcaEx2b.png) and
    index.html shows it beside the paper's caption and a line of what it shows
    numerically (e.g. windowed vs whole-matrix RPCA error).
    """
    if list_only:
        click.echo("\n".join(FIGURE_LABELS))
        return
    gotcha_paths: list[Path] = []
    for g in gotcha:
        gotcha_paths += sorted(g.glob("*.mat")) if g.is_dir() else [g]
    if not gotcha:
        gotcha_paths = default_gotcha()
    selected = list(only) if only else None
    check_out(out, force=force, names=("index.html",), patterns=("fig_*",))
    total = len(selected) if selected else len(FIGURE_LABELS)
    with Progress(enabled=ctx.obj["progress"]) as bar:
        with staged_directory(out) as stage, as_flags(only="--only"):
            records = build_figures(
                stage,
                only=selected,
                quick=quick,
                gotcha_paths=gotcha_paths or None,
                progress=lambda label, done, n: bar("figures", done, n),
            )
    seconds = sum(r.seconds for r in records)
    click.echo(
        f"wrote {len(records)} of {total} figure(s) and index.html to {out} ({seconds:.0f} s)"
    )
