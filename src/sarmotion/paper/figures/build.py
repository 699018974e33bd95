"""Every figure of the paper, regenerated from data, with the numbers behind it.

:func:`build_figures` writes into an output directory, for each figure ``fig:NAME`` of
Borcea, Callaghan & Papanicolaou, "Motion estimation and imaging of complex scenes with
synthetic aperture radar":

* ``fig_NAME.png`` -- the figure (the label with ``:`` replaced by ``_``);
* ``fig_NAME.npz`` -- the arrays plotted in it (axes included);
* ``index.html`` -- the figures in the paper's sections (:data:`SECTIONS`), with a table
  of contents; each full width (click: natural size) above the paper's caption and,
  beside it, the line of what it shows numerically; the conventions, and the one
  definition of signal-to-clutter used by every figure, at the top.

Every figure is legible as the index shows it: a figure whose PNG is wider than the
index's column (:data:`INDEX_COLUMN_PX`) is scaled down by the browser, its text with
it, so a wide figure is shrunk before it is saved until its smallest text (legends,
tick and axis labels) shows at 8 pt or more
(:func:`sarmotion.report.plotting.fit_to_column`); each figure's ``<img>`` records that
smallest size in points as ``data-text-pt``.

The headline numbers of each figure (:attr:`FigureRecord.headline`) are measured by the
package's building blocks on the built-in scenes; nothing is typed in. Conventions are
the paper's: traces ``|.|`` normalised by the maximum named on each colour bar
(``max|M|``, the unseparated data, unless a panel says otherwise), sparse parts and
filtered traces also in dB, slow time ``s`` (s) and fast time ``t`` (ns); images in dB
re their peak with ground axes in m.

``fig:setup`` draws the antenna positions of the GOTCHA files passed as ``gotcha_paths``
(read by :func:`sarmotion.io.read_gotcha`). ``quick=True`` runs the same code paths on
reduced sizes (coarser image grids and speed grids, fewer sweep values, shorter rank
apertures), for tests. A full build takes about 6 minutes on two cores, a quick one 2.

This is a report layer: it imports matplotlib (beside :mod:`sarmotion.report.plotting`, whose
panel functions it uses) and writes files. Progress goes through a callback
``progress(label, done, total)``.
"""

from __future__ import annotations

import html
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...core.progress import ProgressCallback
from ...report.plotting import fit_to_column, save_figure, smallest_text_pt
from ._context import _Context, _Result
from .captions import CAPTIONS
from .fig_imaging import _fig_hyperbola, _fig_image_comp, _fig_rot_scatt, _fig_straight_trace
from .fig_motion import (
    _fig_filter10,
    _fig_filter30,
    _fig_final_sep,
    _fig_mot_est,
    _fig_objfxns,
    _fig_sep_imgs,
)
from .fig_rank import _fig_converge_rank, _fig_eigenvals2, _fig_rank1
from .fig_separation import (
    _fig_annihil_scene1,
    _fig_data_decomp,
    _fig_filt_comp,
    _fig_rotate2stage,
    _fig_rotate_true_filt,
    _fig_rpca2mov,
    _fig_rpca_ex1,
    _fig_rpca_ex2a,
    _fig_rpca_ex2b,
)
from .fig_setup import _fig_setup

__all__ = [
    "FigureRecord",
    "FIGURE_DPI",
    "FIGURE_LABELS",
    "INDEX_COLUMN_PX",
    "SECTIONS",
    "build_figures",
    "figure_filename",
]


log = logging.getLogger(__name__)


#: Figure labels in the paper's order.
FIGURE_LABELS: tuple[str, ...] = tuple(CAPTIONS)


def figure_filename(label: str, suffix: str = ".png") -> str:
    """File name of a figure: ``fig:rpcaEx2b`` -> ``fig_rpcaEx2b.png``."""
    return label.replace(":", "_") + suffix


#: Resolution of the figures' PNGs (pixels per inch).
FIGURE_DPI = 150

#: Width (CSS px) of the index's column in a 1400-px-wide window: less the navigation
#: (17em at 0.85 x 16 px, its padding 2 x 1.2em and its border: 265 px) and main's
#: padding (2 x 2.5em at 16 px: 80 px). A wider PNG is shown scaled down to it.
INDEX_COLUMN_PX = 1400 - 265 - 80


@dataclass(frozen=True, kw_only=True)
class FigureRecord:
    """One regenerated figure.

    Attributes
    ----------
    label : str
        The paper's label, e.g. ``"fig:rpcaEx2b"``.
    png, npz : Path
        The figure and its arrays.
    caption : str
        The paper's caption.
    summary : str
        One line of what the figure shows numerically.
    headline : dict of str to float
        The measured numbers behind :attr:`summary`.
    seconds : float
        Wall-clock time to build it (s).
    text_pt : float
        Font size (pt) of the figure's smallest text (legends, tick and axis labels,
        titles), as drawn: the PNG at :data:`FIGURE_DPI` shows it at ``text_pt *
        FIGURE_DPI / 96`` CSS pt, scaled by the index's column when wider.
    """

    label: str
    png: Path
    npz: Path
    caption: str
    summary: str
    headline: dict[str, float] = field(default_factory=dict)
    seconds: float = 0.0
    text_pt: float = float("nan")


_BUILDERS: dict[str, Callable[[_Context], _Result]] = {
    "fig:setup": _fig_setup,
    "fig:hyperbola": _fig_hyperbola,
    "fig:imageComp": _fig_image_comp,
    "fig:straightTrace": _fig_straight_trace,
    "fig:rotScatt": _fig_rot_scatt,
    "fig:dataDecomp": _fig_data_decomp,
    "fig:rpcaEx1": _fig_rpca_ex1,
    "fig:rpcaEx2a": _fig_rpca_ex2a,
    "fig:rpcaEx2b": _fig_rpca_ex2b,
    "fig:annihilScene1": _fig_annihil_scene1,
    "fig:rpca2mov": _fig_rpca2mov,
    "fig:rotateTrueFilt": _fig_rotate_true_filt,
    "fig:filtComp": _fig_filt_comp,
    "fig:rotate2stage": _fig_rotate2stage,
    "fig:objfxns": _fig_objfxns,
    "fig:rank1": _fig_rank1,
    "fig:convergeRank": _fig_converge_rank,
    "fig:eigenvals2": _fig_eigenvals2,
    "fig:filter10scatt1ord": _fig_filter10,
    "fig:filter30scatt1ord": _fig_filter30,
    "fig:motEstscatt": _fig_mot_est,
    "fig:rpca2movFinalSep": _fig_final_sep,
    "fig:sepImgs": _fig_sep_imgs,
}


# ============================================================================ driver
def _for_npz(value: Any) -> NDArray:
    """Arrays as stored: complex traces and images as complex64 (plotting precision)."""
    a = np.asarray(value)
    return a.astype(np.complex64) if a.dtype == np.complex128 else a


#: The paper's sections and subsections, and the figures each holds (in order).
SECTIONS: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("1", "Introduction", ("fig:setup",)),
    ("2.1", "Preliminaries: pulse and range compression", ("fig:hyperbola",)),
    (
        "3.1",
        "Data separation: travel time transformations and data separation",
        ("fig:imageComp", "fig:straightTrace", "fig:rotScatt"),
    ),
    (
        "3.2",
        "Data separation with robust PCA",
        ("fig:dataDecomp", "fig:rpcaEx1", "fig:rpcaEx2a", "fig:rpcaEx2b"),
    ),
    ("3.3", "Discussion", ("fig:annihilScene1", "fig:rpca2mov")),
    (
        "3.4",
        "Velocity estimation and separation of traces from moving targets",
        ("fig:rotateTrueFilt", "fig:filtComp", "fig:rotate2stage", "fig:objfxns"),
    ),
    (
        "4.4",
        "Analysis of data separation with robust PCA (rank of Y)",
        ("fig:rank1", "fig:convergeRank", "fig:eigenvals2"),
    ),
    (
        "5.2",
        "Numerical simulations: annihilation filters",
        ("fig:filter10scatt1ord", "fig:filter30scatt1ord", "fig:motEstscatt"),
    ),
    (
        "5.3",
        "Numerical simulations: data separation for Scene 1",
        ("fig:rpca2movFinalSep", "fig:sepImgs"),
    ),
)

_STYLE = """
body{font-family:Georgia,'Times New Roman',serif;color:#222;margin:0;line-height:1.45}
header{background:#f4f1ea;border-bottom:1px solid #ddd;padding:1.2em 2em}
header h1{margin:0 0 .3em 0;font-size:1.6em}
.layout{display:flex;align-items:flex-start}
nav{position:sticky;top:0;flex:0 0 17em;max-height:100vh;overflow-y:auto;padding:1em 1.2em;
 border-right:1px solid #ddd;font-family:sans-serif;font-size:.85em;background:#fafafa}
nav a{color:#05a;text-decoration:none} nav a:hover{text-decoration:underline}
nav ol{padding-left:1.2em;margin:.2em 0 .8em 0} nav li{margin:.15em 0}
main{flex:1;padding:1em 2.5em;max-width:1500px}
h2{border-bottom:2px solid #ccc;padding-bottom:.2em;margin-top:2em}
figure{margin:1.5em 0 2.5em 0;padding:0}
figure img{width:100%;height:auto;border:1px solid #eee;cursor:zoom-in;display:block}
figure.small img{max-width:900px}
figcaption{display:grid;grid-template-columns:1fr 1fr;gap:1.5em;margin-top:.6em;font-size:.95em}
.caption b,.measured b{font-family:sans-serif;font-size:.85em;text-transform:uppercase;
 letter-spacing:.04em}
.measured{color:#04507a;background:#eef6fb;padding:.5em .8em;border-left:3px solid #05a}
.files{font-family:sans-serif;font-size:.8em;color:#777;grid-column:1 / span 2}
.label{font-family:monospace;color:#888;font-size:.8em}
.conventions{background:#fffbe8;border:1px solid #eadfa8;padding:.6em 1em;font-size:.92em}
#zoom{display:none;position:fixed;inset:0;background:rgba(0,0,0,.85);z-index:10;
 overflow:auto;cursor:zoom-out}
#zoom img{display:block;margin:1em auto;max-width:none}
"""

_SCRIPT = """
document.querySelectorAll('figure img').forEach(function(im){
  im.addEventListener('click',function(e){e.preventDefault();
    var z=document.getElementById('zoom');z.firstChild.src=im.src;z.style.display='block';});
});
document.getElementById('zoom').addEventListener('click',function(){this.style.display='none';});
"""


def _write_index(out: Path, records: Sequence[FigureRecord], quick: bool) -> Path:
    from ._context import SCR_DEFINITION

    by_label = {r.label: r for r in records}
    number = {lab: i for i, lab in enumerate(FIGURE_LABELS, start=1)}
    toc, body = [], []
    for sec, title, labels in SECTIONS:
        present = [by_label[lab] for lab in labels if lab in by_label]
        if not present:
            continue
        anchor = "sec-" + sec.replace(".", "-")
        items = "".join(
            f'<li><a href="#{html.escape(r.label)}">Figure {number[r.label]} '
            f'<span class="label">{html.escape(r.label)}</span></a></li>'
            for r in present
        )
        toc.append(
            f'<li><a href="#{anchor}">{html.escape(sec)} {html.escape(title)}</a>'
            f"<ol>{items}</ol></li>"
        )
        body.append(f'<section id="{anchor}"><h2>{html.escape(sec)} {html.escape(title)}</h2>')
        for r in present:
            ncol_small = r.label in ("fig:rpcaEx2a", "fig:convergeRank")
            body.append(
                f'<figure id="{html.escape(r.label)}"'
                f"{' class=small' if ncol_small else ''}>"
                f'<a href="{r.png.name}"><img src="{r.png.name}" loading="lazy" '
                f'alt="{html.escape(r.label)}" data-text-pt="{r.text_pt:g}"></a>\n<figcaption>'
                f'<div class="caption"><b>Figure {number[r.label]}</b> '
                f'<span class="label">{html.escape(r.label)}</span> &mdash; '
                f"{html.escape(r.caption)}</div>\n"
                f'<div class="measured"><b>Measured</b> {html.escape(r.summary)}</div>\n'
                f'<div class="files"><a href="{r.npz.name}">{r.npz.name}</a> (the arrays '
                f"plotted) &middot; built in {r.seconds:.1f} s</div></figcaption></figure>"
            )
        body.append("</section>")
    total = sum(r.seconds for r in records)
    page = (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        "<title>Motion estimation and imaging of complex scenes with SAR: the figures"
        f"</title>\n<style>{_STYLE}</style></head><body>\n"
        "<header><h1>Motion estimation and imaging of complex scenes with synthetic "
        "aperture radar &mdash; the figures, regenerated</h1>"
        f"<div>{len(records)} figures{' (quick: reduced sizes)' if quick else ''}, built in "
        f"{total:.0f} s by <code>sarmotion.paper.figures.build_figures</code>, each beside the "
        "paper's caption and what it measures. Click a figure to see it at full size.</div>"
        "</header>\n"
        f'<div class="layout"><nav><b>Contents</b><ol>{"".join(toc)}</ol></nav><main>\n'
        '<div class="conventions"><b>Conventions.</b> Traces are shown as |.| normalised by '
        "the maximum named on each colour bar (max|M|: the unseparated data), in dB where "
        "marked; slow time s in s, fast time t in ns; images in dB re their peak, ground "
        f"axes in m. <b>Signal-to-clutter</b>, in every figure: {html.escape(SCR_DEFINITION)}"
        "</div>\n"
        + "\n".join(body)
        + '\n</main></div><div id="zoom"><img alt="zoomed figure"></div>'
        f"<script>{_SCRIPT}</script></body></html>\n"
    )
    path = out / "index.html"
    path.write_text(page, encoding="utf-8")
    return path


def build_figures(
    out_dir: str | Path,
    *,
    only: str | Sequence[str] | None = None,
    quick: bool = False,
    gotcha_paths: Sequence[str | Path] | None = None,
    progress: ProgressCallback | None = None,
) -> list[FigureRecord]:
    """Regenerate the paper's figures with data.

    Parameters
    ----------
    out_dir : str or Path
        Output directory (created). Receives ``fig_NAME.png`` and ``fig_NAME.npz`` per
        figure ``fig:NAME`` and ``index.html``.
    only : str or sequence of str, optional
        Build only these labels (``"fig:rpcaEx2b"``; the ``fig:`` prefix may be left out).
    quick : bool
        Reduced sizes (coarser grids, fewer sweep values), same code paths; for tests.
    gotcha_paths : sequence of path, optional
        GOTCHA ``.mat`` files of one pass (read by :func:`sarmotion.io.read_gotcha`):
        ``fig:setup`` draws their antenna positions; without them, the nominal GOTCHA
        circle.
    progress : callable, optional
        ``progress(label, done, total)`` after each figure.

    Returns
    -------
    list of FigureRecord
        In the paper's order.
    """
    if only is None:
        labels = list(FIGURE_LABELS)
    else:
        wanted = [only] if isinstance(only, str) else list(only)
        labels = []
        for w in wanted:
            lab = w if w.startswith("fig:") else f"fig:{w}"
            if lab not in _BUILDERS:
                raise ValueError(
                    f"only must name figures among {', '.join(FIGURE_LABELS)}; got {w!r}"
                )
            labels.append(lab)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ctx = _Context(quick, gotcha_paths)
    records = []
    for i, lab in enumerate(labels, start=1):
        t0 = time.perf_counter()
        res = _BUILDERS[lab](ctx)
        fit_to_column(res.fig, dpi=FIGURE_DPI, column_px=INDEX_COLUMN_PX)
        png = save_figure(res.fig, out / figure_filename(lab), dpi=FIGURE_DPI)
        npz = out / figure_filename(lab, ".npz")
        np.savez_compressed(npz, **{k: _for_npz(v) for k, v in res.arrays.items()})
        dt = time.perf_counter() - t0
        rec = FigureRecord(
            label=lab,
            png=png,
            npz=npz,
            caption=CAPTIONS[lab],
            summary=res.summary,
            headline={k: float(v) for k, v in res.headline.items()},
            seconds=dt,
            text_pt=smallest_text_pt(res.fig),
        )
        records.append(rec)
        log.info("%s (%.1f s): %s", lab, dt, res.summary)
        if progress is not None:
            progress(lab, i, len(labels))
    _write_index(out, records, quick)
    return records
