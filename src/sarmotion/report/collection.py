"""The whole scene of a collection: the stationary mosaic, the patches and the movers.

Plotting layer. :func:`write_collection_report` saves ``mosaic.png`` (the stationary
mosaic in dB, every patch's core outlined, each mover at its kept fit with its
cross-range family drawn as a line clipped to the region, the radar's look direction
as an arrow) and a self-contained ``report.html`` embedding it, with the movers' and
patches' tables (the analysis report's page, :mod:`sarmotion.report.page`).
"""

from __future__ import annotations

import base64
import io
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ..collection import CollectionResult
from .page import figure, header_line, page, section, table
from .plotting import draw_look_arrow

__all__ = ["mosaic_figure", "write_collection_report"]


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


def mosaic_figure(result: CollectionResult) -> Figure:
    """Mosaic (dB re its peak), patch cores, movers and their families clipped to the region.

    An arrow shows the radar's look direction on the ground at the aperture centre
    (``-result.range_direction``, :func:`~sarmotion.report.plotting.draw_look_arrow`).
    """
    fig = Figure(figsize=(8, 8))
    ax = fig.add_subplot(1, 1, 1)
    img = result.mosaic
    peak = float(img.max()) if img.size else 0.0
    db = 20 * np.log10(np.maximum(img, 1e-12 * max(peak, 1e-300)) / max(peak, 1e-300))
    ax.imshow(db, origin="lower", extent=result.mosaic_extent_m, cmap="gray", vmin=-40, vmax=0)
    for p in result.plan.patches:
        x0, y0, x1, y1 = p.core_m
        ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], color="tab:cyan", lw=0.6)
        ax.text(
            0.5 * (x0 + x1),
            0.5 * (y0 + y1),
            str(p.index),
            color="tab:cyan",
            fontsize=7,
            ha="center",
            va="center",
        )
    region = result.plan.region_m
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


def _not_estimated_html(document: dict[str, Any]) -> str:
    """The candidates each patch detected beyond ``max_movers``: listed, not dropped."""
    extra = document.get("movers_not_estimated") or []
    if not extra:
        return ""
    cap = document["options"]["analysis"].get("max_movers")
    rows = "".join(
        f"<tr><td>{c['patch']}</td><td>{c['statistic_db']:.1f}</td><td>{c['range_m']:.1f}</td>"
        f"<td>{c['range_speed_mps']:.2f}</td></tr>"
        for c in extra
    )
    return (
        f"<h3>Detected, not estimated: {len(extra)} candidate(s) beyond max_movers = {cap} "
        "per patch</h3><p>They passed their patch's detector after its movers were "
        "estimated; neither fitted nor tested against a stationary explanation (range: the "
        "aligned trace's peak, from the patch's centre). Raise --max-movers to estimate "
        "them.</p><table><tr><th>patch</th><th>statistic (dB)</th><th>range (m)</th>"
        f"<th>range speed (m/s)</th></tr>{rows}</table>"
    )


def write_collection_report(
    result: CollectionResult, directory: Path, *, document: dict[str, Any], title: str
) -> None:
    """Write ``mosaic.png`` and ``report.html`` into ``directory``.

    The page is the analysis report's (:func:`sarmotion.report.page.page`: its stylesheet,
    header and sections).
    """
    directory = Path(directory)
    buf = io.BytesIO()
    mosaic_figure(result).savefig(buf, format="png", dpi=110)
    png = buf.getvalue()
    (directory / "mosaic.png").write_bytes(png)
    rows = [
        [
            str(k + 1),
            "({:.2f}, {:.2f})".format(*m["position_m"]),
            "({:.2f}, {:.2f})".format(*m["velocity_mps"]),
            f"{m['range_speed_mps']:.2f}",
            str(m["patch"]),
            ", ".join(str(p) for p in m["patches"]),
        ]
        for k, m in enumerate(document["movers"])
    ]
    patches = [
        [
            str(p["index"]),
            ", ".join(f"{v:.1f}" for v in p["core_m"]),
            f"{p['n_pulses']} x {p['n_samples']}",
            str(p["decimation"]),
        ]
        for p in document["plan"]["patches"]
    ]
    plan = document["plan"]
    summary = (
        f"<p>{len(plan['patches'])} patch(es) of {plan['patch_size_m']:.1f} m; "
        f"{len(document['movers'])} mover(s); {len(document['stationary'])} stationary "
        f"target(s) listed, {document['stationary_dropped']} beyond the cap not listed, "
        f"{document.get('stationary_sidelobes_dropped', 0)} dropped as a brighter target's "
        f"sidelobes, {document.get('stationary_mover_images_dropped', 0)} dropped as lying "
        "on a mover's echo.</p>"
    )
    caption = (
        "The stationary mosaic (dB re its peak), every patch's core outlined and numbered, "
        "each mover (circle, numbered as in the table) with its cross-range family (line). "
        "Arrow: the radar's look direction on the ground at the aperture centre."
    )
    movers_head = ["#", "position (m)", "velocity (m/s)", "range speed (m/s)", "patch kept"]
    movers = (
        table([*movers_head, "found in patches"], rows)
        if rows
        else "<p>No mover found: no candidate passed a patch's detector.</p>"
    )
    head = ["patch", "core x0, y0, x1, y1 (m)", "pulses x samples", "decimation"]
    parts = [
        section("Mosaic", summary + figure(base64.b64encode(png).decode(), caption)),
        section("Movers", movers + _not_estimated_html(document)),
        section("Patches", table(head, patches)),
    ]
    found = (
        f"{len(plan['patches'])} patch(es), {len(document['movers'])} mover(s), "
        f"{len(document['stationary'])} stationary target(s)"
    )
    (directory / "report.html").write_text(page(title, header_line(found), parts), encoding="utf-8")
