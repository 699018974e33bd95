"""Every figure of the paper, regenerated from data, with the numbers behind it.

:func:`build_figures` writes into an output directory, for each figure ``fig:NAME`` of
Borcea, Callaghan & Papanicolaou, "Motion estimation and imaging of complex scenes with
synthetic aperture radar":

* ``fig_NAME.png`` -- the figure (the label with ``:`` replaced by ``_``);
* ``fig_NAME.npz`` -- the arrays plotted in it (axes included);
* ``index.html`` -- every figure beside the paper's caption and one line of what it
  shows numerically.

The headline numbers of each figure (:attr:`FigureRecord.headline`) are measured by the
package's building blocks on the built-in scenes; nothing is typed in. Conventions are
the paper's: traces ``|M|`` normalised by ``max |M|`` of the data they come from, sparse
parts and filtered traces also in dB, slow time ``s`` (s) and fast time ``t`` (ns);
images in dB re their peak with ground axes in m.

``quick=True`` runs the same code paths on reduced sizes (coarser image grids and speed
grids, fewer sweep values, shorter rank apertures), for tests.

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
from ..plotting import save_figure
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

__all__ = ["FigureRecord", "FIGURE_LABELS", "build_figures", "figure_filename"]


log = logging.getLogger(__name__)


#: Figure labels in the paper's order.
FIGURE_LABELS: tuple[str, ...] = tuple(CAPTIONS)


def figure_filename(label: str, suffix: str = ".png") -> str:
    """File name of a figure: ``fig:rpcaEx2b`` -> ``fig_rpcaEx2b.png``."""
    return label.replace(":", "_") + suffix


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
    """

    label: str
    png: Path
    npz: Path
    caption: str
    summary: str
    headline: dict[str, float] = field(default_factory=dict)
    seconds: float = 0.0


_BUILDERS: dict[str, Callable[[_Context], _Result]] = {
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


def _write_index(out: Path, records: Sequence[FigureRecord], quick: bool) -> Path:
    rows = []
    for r in records:
        rows.append(
            f'<section id="{html.escape(r.label)}"><h2>{html.escape(r.label)}</h2>\n'
            f'<div class="row"><a href="{r.png.name}"><img src="{r.png.name}" '
            f'alt="{html.escape(r.label)}"></a>\n<div class="text"><p class="caption">'
            f'<b>Paper:</b> {html.escape(r.caption)}</p>\n<p class="measured"><b>Measured:</b> '
            f'{html.escape(r.summary)}</p>\n<p class="files"><a href="{r.npz.name}">'
            f"{r.npz.name}</a> &middot; built in {r.seconds:.1f} s</p></div></div></section>"
        )
    page = (
        '<!DOCTYPE html>\n<html><head><meta charset="utf-8"><title>The paper, reproduced'
        "</title>\n<style>body{font-family:sans-serif;max-width:1400px;margin:auto}"
        ".row{display:flex;gap:1.5em;align-items:flex-start}.row img{max-width:820px}"
        ".text{max-width:520px}.measured{color:#05a}</style></head><body>\n"
        "<h1>Motion estimation and imaging of complex scenes with SAR: figures reproduced"
        "</h1>\n"
        f"<p>{len(records)} figures{' (quick, reduced sizes)' if quick else ''}, generated by "
        "<code>sarmotion.report.paper.build_figures</code>.</p>\n"
        + "\n".join(rows)
        + "\n</body></html>\n"
    )
    path = out / "index.html"
    path.write_text(page, encoding="utf-8")
    return path


def build_figures(
    out_dir: str | Path,
    *,
    only: str | Sequence[str] | None = None,
    quick: bool = False,
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
    ctx = _Context(quick)
    records = []
    for i, lab in enumerate(labels, start=1):
        t0 = time.perf_counter()
        res = _BUILDERS[lab](ctx)
        png = save_figure(res.fig, out / figure_filename(lab))
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
        )
        records.append(rec)
        log.info("%s (%.1f s): %s", lab, dt, res.summary)
        if progress is not None:
            progress(lab, i, len(labels))
    _write_index(out, records, quick)
    return records
