"""The figures of an analysis's report, from the :class:`~sarmotion.pipeline.AnalysisResult`.

Plotting layer. The trace and image panels are drawn by :mod:`sarmotion.report.plotting`;
the objective-function and trajectory plots (not in the paper's figure set of that module)
are drawn here. A mover is drawn as what its data fix (:func:`draw_family`): its
cross-range family across the scene, not a point like a stationary target.

:func:`analysis_figures` makes the report's figures; :func:`write_report` saves them
and writes ``report.html`` with :func:`sarmotion.report.html.write_html`, which reads
the results document only.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patheffects import withStroke

from ..documents.results import results_document
from ..motion import trajectory_error
from ..pipeline import AnalysisResult
from .html import COLUMN_PX, REPORT_DPI, ReportFigure, write_html
from .plotting import (
    CSS_PX_PER_IN,
    LEGEND_PT,
    LEGIBLE_PT,
    image_figure,
    plot_image,
    subplots,
    traces_figure,
)

__all__ = [
    "analysis_figures",
    "draw_family",
    "look_direction",
    "traces_panels_figure",
    "objectives_figure",
    "images_figure",
    "movers_figure",
    "mover_panels_figure",
    "trajectories_figure",
    "write_report",
]

_COLOURS = ("tab:red", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink")

#: Side of one mover's panel in :func:`movers_figure` (in).
MOVER_PANEL_IN = 4.6


def _movers_per_row() -> int:
    """Most mover panels a row whose PNG shows its legends at :data:`LEGIBLE_PT` or more.

    At :data:`~sarmotion.report.html.REPORT_DPI` a ``LEGEND_PT`` legend is ``LEGEND_PT *
    dpi / 96`` CSS pt at natural size; the page scales a PNG wider than its column
    (:data:`~sarmotion.report.html.COLUMN_PX`) down to it, so a row may be
    ``COLUMN_PX * LEGEND_PT * dpi / (96 * LEGIBLE_PT)`` PNG pixels wide at most.
    """
    widest_px = COLUMN_PX * LEGEND_PT * REPORT_DPI / (CSS_PX_PER_IN * LEGIBLE_PT)
    return max(1, int(widest_px // (MOVER_PANEL_IN * REPORT_DPI)))


def traces_panels_figure(result: AnalysisResult) -> Figure:
    """``|M|``, ``|L|``, ``|S|`` (dB), each mover's separated traces and the residual."""
    tr = result.traces
    panels: list[tuple[str, Any, bool]] = [("data |M|", tr.data, False)]
    stat = result.separation.stationary
    if stat is not None:
        panels.append(("stationary |L|", stat, False))
        panels.append(("moving |S| (dB)", result.separation.moving, True))
    else:
        panels.append(("filtered |Q M| (dB)", result.separation.moving, True))
    for k, m in enumerate(result.movers):
        panels.append((f"mover {k + 1} |D_{k + 1}| (dB)", m.traces, True))
    panels.append(("residual (dB)", result.residual, True))
    fig = traces_figure(
        panels,
        slow_times_s=tr.slow_times_s,
        fast_times_s=tr.fast_times_s,
        normalise_by=float(np.abs(tr.data).max()),
        ncols=min(3, len(panels)),  # 12.6 in: shown unscaled in the 1294-px column
    )
    for ax in fig.axes:  # legible at the report's 110 dpi (default 8 px)
        ax.tick_params(labelsize=10)
        ax.xaxis.label.set_size(11)
        ax.yaxis.label.set_size(11)
    fig.tight_layout()
    return fig


def objectives_figure(result: AnalysisResult, *, truth: dict[str, Any] | None = None) -> Figure:
    """``g(u)`` on ``S`` with its detection threshold, and each mover's ``g_perp`` and ML profile.

    Left: ``g``, its local floor and the threshold (floor times the statistic's
    threshold), the detected range speeds. Right, per mover: ``g_perp`` (``eq:OBJ2``,
    minimum) and the matched filter's global profile over the cross-range speed
    (maximum: the maximum-likelihood estimate).
    """
    rs = result.range_speeds
    det = result.detection
    n = len(result.movers)
    # At most three panels a row: 12 in at the report's 110 dpi fit its 1294-px column
    # unscaled, so the legends read at their LEGEND_PT.
    ncols = min(3, 1 + n)
    nrows = -(-(1 + n) // ncols)
    fig, axes = subplots(nrows, ncols, figsize=(4.0 * ncols, 3.6 * nrows), squeeze=False)
    axes = axes.ravel()
    for extra in axes[1 + n :]:
        extra.set_visible(False)
    ax = axes[0]
    top = float(rs.objective.max())
    ax.plot(rs.grid_mps, rs.objective / top, color="k", lw=1.0, label="g(u)")
    if det is not None:
        ax.plot(rs.grid_mps, det.floor_curve / top, color="0.6", ls=":", lw=1, label="local floor")
        ax.plot(
            rs.grid_mps,
            det.floor_curve * 10.0 ** (det.threshold_db / 20.0) / top,
            color="tab:blue",
            ls="--",
            lw=1,
            label=f"threshold {det.threshold_db:.1f} dB "
            f"(false alarms {det.false_alarm_rate:g} per scene)",
        )
        ax.axvspan(-det.min_speed_mps, det.min_speed_mps, color="0.9", lw=0)
    for k, m in enumerate(result.movers):
        u = m.range_speed_mps
        ax.axvline(u, color=_COLOURS[k % 6], ls="--", lw=1, label=f"mover {k + 1}: {u:.2f} m/s")
    if truth:
        for t in truth["truth"]:
            ax.plot(t["range_speed_mps"], 1.02, "v", color="k", ms=6)
    ax.set_xlabel("range speed u (m/s)")
    ax.set_ylabel("g(u) / max")
    ax.set_title("g(u) on S (eq:OBJg) and the detector", fontsize=10)
    ax.legend(fontsize=LEGEND_PT, loc="upper left")
    for k, m in enumerate(result.movers):
        _cross_panel(axes[1 + k], k, m, truth)
    fig.tight_layout()
    return fig


def _cross_panel(ax: Any, k: int, m: Any, truth: dict[str, Any] | None) -> None:
    """One mover's ``g_perp`` and maximum-likelihood profile against the cross-range speed."""
    cc = m.g_perp
    ax.plot(cc.grid_mps, cc.objective / cc.objective.max(), color="k", lw=1.0, label="g_perp")
    ax.axvline(cc.speed_mps, color="k", ls=":", lw=1, label=f"g_perp min {cc.speed_mps:.2f} m/s")
    if m.fit is not None:
        f = m.fit
        ax.plot(
            f.grid_mps,
            f.profile / f.profile.max(),
            color=_COLOURS[k % 6],
            lw=1.0,
            label="ML profile",
        )
    up = m.cross_range_speed_mps
    sd = f" +- {m.bound.cross_range_speed_mps:.2g}" if m.bound is not None else ""
    ax.axvline(up, color=_COLOURS[k % 6], ls="--", lw=1, label=f"ML {up:.2f}{sd} m/s")
    if truth and truth["errors"][k] is not None:
        err = truth["errors"][k]["cross_range_speed_mps"]
        ax.axvline(up - err, color="0.4", ls="-.", lw=1, label="truth")
    ax.set_xlabel("cross-range speed u_perp (m/s)")
    ax.set_ylabel("/ max")
    ax.set_title(f"mover {k + 1}: g_perp (eq:OBJ2) and matched filter", fontsize=10)
    ax.legend(fontsize=LEGEND_PT)


def draw_family(
    ax: Any, entry: dict[str, Any], colour: str, label: str, *, marker: bool = True
) -> None:
    """A mover drawn as what the data fix: its cross-range family across the scene.

    The family's members in the scene (``cross_range_family.in_scene`` of the results
    document) as a line, with the range standard error in the legend; a small tick marks
    the member at the reference cross range (``position_m``), the one the tables list.
    A mover whose cross range is known (``cross_range_known``) is a point.
    """
    std = entry.get("range_std_m")
    err = f"; range \u00b1 {std:.1g} m" if std is not None else ""
    fam = (entry.get("cross_range_family") or {}).get("in_scene")
    x, y = entry["position_m"]
    if entry.get("cross_range_known") or not fam:
        ax.plot(x, y, "o", mfc="none", mec=colour, ms=9, mew=1.5, label=f"{label}{err}")
        return
    p = np.asarray(fam["positions_m"], dtype=float)
    ax.plot(
        p[:, 0],
        p[:, 1],
        "--",
        color=colour,
        lw=1.4,
        alpha=0.9,
        label=f"{label}: family (cross range unknown){err}",
    )
    if marker:
        ax.plot(x, y, "_", color=colour, ms=12, mew=2.0)


def look_direction(document: dict[str, Any]) -> np.ndarray | None:
    """Ground direction (2,) from the radar towards the scene: ``-frame.range_direction``.

    ``range_direction`` (``e_r``) of the results document points from the reference point
    towards the antenna at ``s = 0`` (docs/results.md); the radar looks the other way.
    ``None`` for a ``sarmotion.results/1`` document (no ``frame``).
    """
    frame = document.get("frame")
    if not frame:
        return None
    return -np.asarray(frame["range_direction"], dtype=np.float64)


def _legend_below(ax: Any) -> None:
    """The axes' legend under them, where it hides nothing of the image."""
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), fontsize=LEGEND_PT, frameon=False)


def images_figure(result: AnalysisResult, document: dict[str, Any] | None = None) -> Figure:
    """Preliminary image with the movers' families, stationary image with its targets.

    Each mover is drawn as its cross-range family across the scene (:func:`draw_family`:
    the data fix its range, not where along the line it is); circles mark the listed
    stationary targets on the stationary image; an arrow on each shows the radar's look
    direction (:func:`look_direction`).
    """
    doc = document if document is not None else results_document(result)
    g = result.preliminary_image.grid
    found = [s.position_m for s in result.stationary]
    fig = image_figure(
        [
            ("preliminary image |I| (eq:image)", result.preliminary_image.values),
            ("stationary image (from L)", result.stationary_image.values),
        ],
        x_m=g.x_m,
        y_m=g.y_m,
        markers=[[], found],
        look_direction=look_direction(doc),
    )
    ax_pre, ax_stat = fig.axes[0], fig.axes[1]  # the panels first, then their colour bars
    for k, entry in enumerate(doc["movers"]):
        draw_family(ax_pre, entry, _COLOURS[k % 6], f"mover {k + 1}")
    ax_pre.set(xlim=(g.x_m[0], g.x_m[-1]), ylim=(g.y_m[0], g.y_m[-1]))
    if doc["movers"]:
        _legend_below(ax_pre)
    if found:
        ax_stat.plot([], [], "o", mfc="none", mec="tab:red", label="stationary target")
        _legend_below(ax_stat)
    fig.set_size_inches(fig.get_size_inches()[0], 4.6)  # room for the legends below
    fig.tight_layout()
    return fig


def movers_figure(
    result: AnalysisResult,
    *,
    truth: dict[str, Any] | None = None,
    document: dict[str, Any] | None = None,
) -> Figure:
    """Each mover's image from its own traces, compensated at its estimated velocity.

    Over it, the mover's cross-range family (:func:`draw_family`) and the radar's look
    direction (an arrow, :func:`look_direction`). The panels fill rows
    of :func:`_movers_per_row` (rows are added for more movers), so that the legends
    read at :data:`~sarmotion.report.plotting.LEGIBLE_PT` or more in the report's
    column whatever the number of movers (:func:`mover_panels_figure`).
    """
    doc = document if document is not None else results_document(result)
    panels = [(m.image.grid.x_m, m.image.grid.y_m, m.image.values) for m in result.movers]
    return mover_panels_figure(panels, doc, truth=truth)


def mover_panels_figure(
    panels: Sequence[tuple[Any, Any, Any] | None],
    document: dict[str, Any],
    *,
    truth: dict[str, Any] | None = None,
) -> Figure:
    """One panel per mover of ``document``: its image, its family, the truth if known.

    Parameters
    ----------
    panels : sequence of (x_m, y_m, values) or None
        Each mover's compensated image: its axes (m) and its values (complex or
        magnitude, shape ``(y, x)``); ``None`` where none was kept.
    document : dict
        The results document (its ``movers``, in the same order, and ``frame``).
    truth : dict, optional
        ``{"truth": [...], "errors": [...]}``: the true mover each estimate was matched to
        is marked with a cross.
    """
    doc = document
    n = max(1, len(panels))
    ncols = min(n, _movers_per_row())
    nrows = -(-n // ncols)
    side = MOVER_PANEL_IN
    fig, grid = subplots(nrows, ncols, figsize=(side * ncols, side * nrows), squeeze=False)
    axes = grid.ravel()
    for extra in axes[n:]:
        extra.set_visible(False)
    several = len((doc.get("plan") or {}).get("patches") or []) > 1
    where = "its patch centre's" if several else "the reference"
    for k, panel in enumerate(panels):
        ax = axes[k]
        entry = doc["movers"][k]
        if panel is None:
            ax.text(0.5, 0.5, f"mover {k + 1}: no image kept", ha="center", va="center")
            ax.set_axis_off()
            continue
        x_m, y_m, values = panel
        u = entry["velocity_mps"]
        plot_image(
            ax,
            values,
            x_m=x_m,
            y_m=y_m,
            title=f"mover {k + 1}, u = ({u[0]:.2f}, {u[1]:.2f}) m/s\n(the member at "
            f"{where} cross range)",
            look_direction=look_direction(doc),
        )
        draw_family(ax, entry, _COLOURS[k % 6], f"mover {k + 1}")
        if truth and truth["errors"][k] is not None:
            name = truth["errors"][k]["matched"]
            t = next((t for t in truth["truth"] if t["label"] == name), None)
            if t is not None:
                # white on the dark image, outlined in black to show in the white legend
                ax.plot(
                    *t["position_m"],
                    "x",
                    color="w",
                    ms=9,
                    mew=2,
                    label="truth",
                    path_effects=[withStroke(linewidth=3.5, foreground="k")],
                )
        ax.set(xlim=(x_m[0], x_m[-1]), ylim=(y_m[0], y_m[-1]))
        _legend_below(ax)
    if not panels:
        axes[0].text(0.5, 0.5, "no mover found", ha="center", va="center")
        axes[0].set_axis_off()
    fig.tight_layout()
    return fig


def trajectories_figure(
    result: AnalysisResult,
    *,
    truth: dict[str, Any] | None = None,
    document: dict[str, Any] | None = None,
) -> Figure:
    """Trajectory error ``|rho^e(s) - rho(s)|`` (simulations), else the trajectories.

    Each trajectory is that of the member at the reference cross range. Without the
    truth, a mover whose cross range the data do not fix (``cross_range_known`` false in
    ``document``, the results document of ``result``) is drawn with its cross-range
    family across the scene (:func:`draw_family`), where its trajectory may equally lie;
    its trajectory's point at ``s = 0`` is labelled as that one member, not as a
    position the data fix.
    """
    if truth is None and document is None:
        document = results_document(result)
    entries = (document or {}).get("movers") or []
    fig, ax = subplots(figsize=(6.0, 3.8))
    drawn = False
    for k, m in enumerate(result.movers):
        tj = m.trajectory
        if tj is None:
            continue
        colour = _COLOURS[k % 6]
        t = None
        if truth and truth["errors"][k] is not None:
            name = truth["errors"][k]["matched"]
            t = next((x for x in truth["truth"] if x["label"] == name), None)
        if t is not None:
            err = trajectory_error(tj, t["position_m"], t["velocity_mps"])
            ax.plot(tj.slow_times_s, err, color=colour, label=f"estimate {k + 1} vs truth '{name}'")
            ax.set_ylabel("|rho_e(s) - rho(s)| (m)")
        else:
            entry = entries[k] if k < len(entries) else None
            family = entry is not None and not entry.get("cross_range_known")
            ax.plot(tj.positions_m[:, 0], tj.positions_m[:, 1], color=colour)
            ax.plot(
                *tj.position_at_zero_m[:2],
                "o",
                color=colour,
                ms=4 if family else 6,
                label=f"mover {k + 1}, s = 0"
                + (" (the member at the reference cross range)" if family else ""),
            )
            if family:
                draw_family(ax, entry, colour, f"mover {k + 1}", marker=False)
            ax.set_xlabel("x (m)")
            ax.set_ylabel("y (m)")
        drawn = True
    if truth:
        ax.set_xlabel("slow time s (s)")
        ax.set_title("trajectory error (phase-space estimate)")
        ax.set_ylim(bottom=0.0)
    else:
        ax.set_title("estimated trajectories over the aperture")
        ax.set_aspect("equal", adjustable="datalim")
    if drawn:
        ax.legend(fontsize=LEGEND_PT)
    else:
        ax.text(0.5, 0.5, "no trajectory estimated", ha="center", va="center")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def analysis_figures(result: AnalysisResult, document: dict[str, Any]) -> list[ReportFigure]:
    """The report's figures: (section, caption, figure, file name).

    ``document`` is the results document of ``result`` (with ``truth`` for simulated
    inputs: the figures then mark the truth).
    """
    truth = None
    if "truth" in document:
        truth = {
            "truth": document["truth"],
            "errors": [m.get("errors") for m in document["movers"]],
        }
    marks = truth is not None
    families = (
        "Lines: each mover's cross-range family across the scene, the positions its data "
        "fit equally (the data of a few degrees fix its range, with the standard error in "
        "the legend, not where along the line it is); tick: the member at the reference "
        "cross range, listed in the tables. Arrow: the radar's look direction on the "
        "ground at the aperture centre, from the radar towards the scene."
    )
    figures = [
        ReportFigure(
            "Traces",
            "Range-compressed traces: slow time s (vertical) against fast time t. Data M, "
            f"its separation ({result.method}) into L and S, each mover's own traces "
            "(its s-independent part in its frame T_+^{u,rho}, mapped back) and what is left.",
            traces_panels_figure(result),
            "traces.png",
        ),
        ReportFigure(
            "Motion estimation",
            "g(u) with its local floor and the detection threshold (a stated false-alarm "
            "rate; grey band: the stationary band, not tested); dashed: the movers' range "
            "speeds" + (" (triangles: truth)" if marks else "") + ". Per mover: g_perp (its "
            "minimum) and the matched filter's global profile over the cross-range speed (its "
            "maximum is the maximum-likelihood estimate, with its Cramér–Rao standard error)"
            + (" (dotted: truth)." if marks else "."),
            objectives_figure(result, truth=truth),
            "objectives.png",
        ),
        ReportFigure(
            "Images",
            "Preliminary image of M and the stationary image (circles: listed stationary "
            "targets). dB re each image's peak. " + families,
            images_figure(result, document),
            "images.png",
        ),
    ]
    if result.movers:
        figures.append(
            ReportFigure(
                "Images",
                "Each mover imaged from its own traces, compensated at its estimated velocity "
                "(the velocity of the member at the reference cross range). "
                + families
                + (" Cross: truth." if marks else ""),
                movers_figure(result, truth=truth, document=document),
                "movers.png",
            )
        )
    if any(m.trajectory is not None for m in result.movers):
        figures.append(
            ReportFigure(
                "Trajectories",
                "Phase-space trajectory estimate (sub-apertures, Wigner ridge), anchored at "
                "the estimated position at s = 0 (the member at the reference cross range)"
                + (
                    ": distance to the true trajectory (m)."
                    if marks
                    else "; dashed: each mover's cross-range family across the scene, "
                    "where the data place its trajectory equally."
                ),
                trajectories_figure(result, truth=truth, document=document),
                "trajectories.png",
            )
        )
    return figures


def write_report(
    result: AnalysisResult,
    directory: str | Path,
    *,
    document: dict[str, Any] | None = None,
    title: str = "sarmotion analysis",
    inputs: Sequence[str] = (),
) -> Path:
    """Save the figures as PNG in ``directory`` and write ``directory/report.html``.

    Parameters
    ----------
    result : AnalysisResult
        The analysis: the figures' arrays.
    directory : path
        Existing output directory.
    document : dict, optional
        ``results_document(result, ...)`` (with ``truth`` for simulated inputs); computed
        without truth if not given. The page's text and tables come from it alone
        (:func:`sarmotion.report.html.write_html`).
    title : str
        Report title.
    inputs : sequence of str
        The input names, for the header.

    Returns
    -------
    Path
        The HTML file.
    """
    doc = document if document is not None else results_document(result)
    return write_html(
        doc, directory, figures=analysis_figures(result, doc), title=title, inputs=inputs
    )
