"""The whole scene of a collection: the stationary mosaic, the patches and the movers.

Plotting layer. :func:`write_collection_report` writes the analysis's report
(:func:`sarmotion.report.html.write_html`: the same sections for every size) with
``mosaic.png`` (the stationary mosaic in dB, every patch's core outlined, each mover at
its kept fit with its cross-range family drawn as a line clipped to the region, the
radar's look direction as an arrow) and the patch table added, each mover's image as
its kept patch made it and the trajectories.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ..collection import CollectionResult
from ..documents.results import collection_mover_images
from .plotting import draw_look_arrow

__all__ = ["mosaic_figure", "trajectories_from_document", "write_collection_report"]


def _clip_line(p: np.ndarray, d: np.ndarray, box: tuple[float, float, float, float]):
    """Ends of the line ``p + t d`` inside ``box = (x0, y0, x1, y1)``, or None."""
    lo, hi = -np.inf, np.inf
    x0, y0, x1, y1 = box
    for k, (a, b) in enumerate(((x0, x1), (y0, y1))):
        if abs(d[k]) < 1e-15:
            if not a <= p[k] <= b:
                return None
            continue
        t1, t2 = (a - p[k]) / d[k], (b - p[k]) / d[k]
        lo, hi = max(lo, min(t1, t2)), min(hi, max(t1, t2))
    if lo > hi:
        return None
    return p + lo * d, p + hi * d


def _holding(
    box: tuple[float, float, float, float], points: Sequence[np.ndarray]
) -> tuple[float, float, float, float]:
    """``box`` ``(x0, y0, x1, y1)`` widened to hold ``points`` with a 5 % margin (m)."""
    if not points:
        return box
    p = np.vstack(points)
    x0, y0 = min(box[0], float(p[:, 0].min())), min(box[1], float(p[:, 1].min()))
    x1, y1 = max(box[2], float(p[:, 0].max())), max(box[3], float(p[:, 1].max()))
    if (x0, y0, x1, y1) == tuple(box):
        return box
    pad = 0.05 * max(x1 - x0, y1 - y0)
    return (x0 - pad, y0 - pad, x1 + pad, y1 + pad)


def mosaic_figure(result: CollectionResult) -> Figure:
    """Mosaic (dB re its peak), patch cores, movers and their families clipped to the region.

    Drawn on the ground ``x``, ``y``: each core's true outline (a square turned to the
    look; dotted for a core beyond the region that searched for movers only) and the
    region's (dashed), over the bounding box of the region, its cores and the movers.

    An arrow shows the radar's look direction on the ground at the aperture centre
    (``-result.range_direction``, :func:`~sarmotion.report.plotting.draw_look_arrow`).
    """
    fig = Figure(figsize=(8, 8))
    ax = fig.add_subplot(1, 1, 1)
    img = np.asarray(result.mosaic, dtype=np.float64)  # a float32 zero over 1e-300 is 0/0
    peak = float(img.max()) if img.size else 0.0
    db = 20 * np.log10(np.maximum(img, 1e-12 * max(peak, 1e-300)) / max(peak, 1e-300))
    ax.imshow(db, origin="lower", extent=result.mosaic_extent_m, cmap="gray", vmin=-40, vmax=0)
    for p in result.plan.patches:  # each core's true outline, turned to the look
        q = np.vstack([p.corners_m, p.corners_m[:1]])
        ax.plot(q[:, 0], q[:, 1], color="tab:cyan", lw=0.6, ls=":" if p.movers_only else "-")
        c = p.corners_m.mean(axis=0)
        ax.text(c[0], c[1], str(p.index), color="tab:cyan", fontsize=7, ha="center", va="center")
    outline = result.plan.region_polygon
    q = np.vstack([outline, outline[:1]])
    ax.plot(q[:, 0], q[:, 1], color="tab:orange", lw=1.0, ls="--")
    # the region's cores, and the movers found beyond them (in a core that searched for
    # movers only: its mover's image landed there)
    found = [np.asarray(m.position_m[:2]) for m, _ in result.movers]
    region = _holding(result.plan.extent_m, found)
    for k, (m, _) in enumerate(result.movers):
        family = m.document.get("cross_range_family", {}).get("position_per_m", (0.0, 0.0))
        fam = np.asarray(family, float)
        pos = np.asarray(m.position_m[:2], float)
        ends = _clip_line(pos, fam, region) if np.linalg.norm(fam) > 0 else None
        if ends is not None:
            ax.plot([ends[0][0], ends[1][0]], [ends[0][1], ends[1][1]], color="tab:red", lw=0.8)
        ax.plot(*pos, "o", mfc="none", color="tab:red")
        ax.text(pos[0], pos[1], f" {k + 1}", color="tab:red", fontsize=9)
    ax.set_xlim(region[0], region[2])
    ax.set_ylim(region[1], region[3])
    if result.range_direction is not None:  # e_r points towards the antenna
        draw_look_arrow(ax, -np.asarray(result.range_direction, dtype=np.float64))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("stationary mosaic (dB), patch cores, movers and their cross-range families")
    fig.tight_layout()
    return fig


def trajectories_from_document(document: dict[str, Any]) -> Figure | None:
    """The movers' estimated trajectories over the aperture, from the document alone.

    Each mover's ``trajectory.positions_m`` (the knots of its piecewise-linear estimate,
    the member at its patch centre's cross range), with its cross-range family across the
    scene (:func:`~sarmotion.report.analysis_figures.draw_family`); ``None`` when no mover
    has a trajectory.
    """
    from .analysis_figures import _COLOURS, draw_family

    movers = [(k, m) for k, m in enumerate(document["movers"]) if m.get("trajectory")]
    if not movers:
        return None
    fig = Figure(figsize=(6.0, 4.2))
    ax = fig.add_subplot(1, 1, 1)
    for k, m in movers:
        colour = _COLOURS[k % 6]
        p = np.asarray(m["trajectory"]["positions_m"], float)
        ax.plot(p[:, 0], p[:, 1], "-", color=colour, lw=1.6)
        draw_family(ax, m, colour, f"mover {k + 1}", marker=False)
        ax.plot(*m["position_m"], ".", color=colour, label=f"mover {k + 1}, s = 0")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title("estimated trajectories over the aperture, and the families")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def write_collection_report(
    result: CollectionResult,
    directory: Path,
    *,
    document: dict[str, Any],
    title: str,
    inputs: Sequence[str] = (),
) -> Path:
    """Write ``report.html`` and its figures into ``directory``: the analysis's report.

    The same page and sections as one analysis's (:func:`sarmotion.report.html.write_html`,
    from the document), the mosaic (``mosaic.png``) and the patch table added when the
    region has several patches. Figures: each mover's image as its kept patch made it
    (``movers.png``), the movers' trajectories from the document (``trajectories.png``).
    A region of one patch is the analysis's own report
    (:func:`~sarmotion.report.analysis_figures.write_report`).
    """
    from .analysis_figures import mover_panels_figure, write_report
    from .html import ReportFigure, write_html

    directory = Path(directory)
    if result.single_result is not None:
        return write_report(
            result.single_result, directory, document=document, title=title, inputs=inputs
        )
    truth = None
    if "truth" in document:
        truth = {
            "truth": document["truth"],
            "errors": [m.get("errors") for m in document["movers"]],
        }
    families = (
        "Lines: each mover's cross-range family across its patch, the positions its data fit "
        "equally (the data fix its range, not where along the line it is); tick: the member "
        "at its patch centre's cross range, listed in the tables."
    )
    figures = [
        ReportFigure(
            "Mosaic",
            "The stationary mosaic (dB re its peak), every patch's core outlined and "
            "numbered, each mover (circle, numbered as in the table) with its cross-range "
            "family (line). Arrow: the radar's look direction on the ground at the aperture "
            "centre.",
            mosaic_figure(result),
            "mosaic.png",
        )
    ]
    if document["movers"]:
        panels = [
            None if im is None else (im["x_m"], im["y_m"], im["magnitude"])
            for im in collection_mover_images(result)
        ]
        figures.append(
            ReportFigure(
                "Images",
                "Each mover imaged from its kept patch's traces, compensated at its estimated "
                "velocity. " + families + (" Cross: truth." if truth else ""),
                mover_panels_figure(panels, document, truth=truth),
                "movers.png",
            )
        )
    traj = trajectories_from_document(document)
    if traj is not None:
        figures.append(
            ReportFigure(
                "Trajectories",
                "Phase-space trajectory estimates (the member at each mover's patch centre's "
                "cross range) and the families.",
                traj,
                "trajectories.png",
            )
        )
    return write_html(document, directory, figures=figures, title=title, inputs=inputs)
