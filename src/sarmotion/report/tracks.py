"""The tracks of a long acquisition over its stationary image, and their speeds.

:func:`tracks_figure` draws, left, the incoherent mean of the sub-apertures' stationary
images (dB) with each track in its own colour (filtered positions, a dot per detection,
a ring where the state was coasted on the prediction, the roads dashed) and, right, each
track's ground speed and range speed over slow time. :func:`write_tracks_report`
saves it as ``tracks.png`` and writes a small self-contained ``report.html`` (the PNG
embedded) with a table per track.
"""

from __future__ import annotations

import base64
import html
import io
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from .._version import __version__
from ..tracking import TrackingResult
from .plotting import LEGEND_PT

__all__ = ["tracks_figure", "write_tracks_report"]

_COLOURS = ("tab:red", "tab:cyan", "tab:green", "tab:orange", "tab:purple", "tab:pink")


def tracks_figure(result: TrackingResult) -> Figure:
    """Tracks over the stationary image, and their speeds over time."""
    fig = Figure(figsize=(12.5, 5.4), layout="constrained")
    ax_map, ax_speed = fig.subplots(1, 2, width_ratios=[1.1, 1.0])
    db = np.clip(np.asarray(result.stationary_db, dtype=np.float64), -40.0, 0.0)
    im = ax_map.imshow(db, extent=result.grid.extent, origin="lower", cmap="gray", vmin=-40, vmax=0)
    fig.colorbar(im, ax=ax_map, label="stationary image (dB)", shrink=0.8)
    for road in result.roads:
        p = road.points_m
        ax_map.plot(p[:, 0], p[:, 1], "--", color="yellow", lw=1.0, alpha=0.8)
    for k, trk in enumerate(result.tracks):
        colour = _COLOURS[k % len(_COLOURS)]
        p = np.array([s.position_m for s in trk.states])
        hit = np.array([s.detection is not None for s in trk.states])
        ax_map.plot(p[:, 0], p[:, 1], "-", color=colour, lw=1.8, label=f"track {trk.id}")
        ax_map.plot(p[hit, 0], p[hit, 1], "o", color=colour, ms=4)
        ax_map.plot(p[~hit, 0], p[~hit, 1], "o", mfc="none", color=colour, ms=6)
        t = np.array([s.time_s for s in trk.states])
        speed = np.hypot(*np.array([s.velocity_mps for s in trk.states]).T)
        u = np.array([s.range_speed_mps for s in trk.states])
        ax_speed.plot(t, speed, "-o", color=colour, ms=3, label=f"track {trk.id} speed")
        ax_speed.plot(t, u, ":", color=colour, label=f"track {trk.id} range speed")
    x0, x1, y0, y1 = result.grid.extent
    ax_map.set(xlim=(x0, x1), ylim=(y0, y1), xlabel="x (m)", ylabel="y (m)", title="tracks")
    if result.tracks:
        ax_map.legend(loc="upper right", fontsize=LEGEND_PT)
        ax_speed.legend(fontsize=LEGEND_PT)
    ax_speed.set(xlabel="slow time s (s)", ylabel="m/s", title="speed and range speed")
    ax_speed.grid(alpha=0.3)
    return fig


def write_tracks_report(
    result: TrackingResult,
    directory: str | Path,
    *,
    document: dict[str, Any],
    title: str = "sarmotion tracks",
) -> list[Path]:
    """Write ``tracks.png`` and ``report.html`` into ``directory``; return their paths."""
    d = Path(directory)
    fig = tracks_figure(result)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    png = d / "tracks.png"
    png.write_bytes(buf.getvalue())
    uri = base64.b64encode(buf.getvalue()).decode("ascii")
    rows = []
    for trk in document["tracks"]:
        for s in trk["states"]:
            road = s.get("road")
            where = "on road" if road and road["fixed"] else "road parallel" if road else "family"
            rows.append(
                "<tr>"
                + "".join(
                    f"<td>{c}</td>"
                    for c in (
                        trk["id"],
                        f"{s['time_s']:.2f}",
                        "({:.2f}, {:.2f})".format(*s["position_m"]),
                        f"{s['position_std_m']:.2f}",
                        "({:.2f}, {:.2f})".format(*s["velocity_mps"]),
                        f"{s['range_speed_mps']:.3f}",
                        "yes" if s["detected"] else "coasted",
                        where,
                    )
                )
                + "</tr>"
            )
    head = "".join(
        f"<th>{h}</th>"
        for h in (
            "track",
            "s (s)",
            "position (m)",
            "position std (m)",
            "velocity (m/s)",
            "range speed (m/s)",
            "detected",
            "position from",
        )
    )
    n_sub = len(document["sub_apertures"])
    text = f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:Helvetica,Arial,sans-serif;margin:20px;color:#222}}
table{{border-collapse:collapse;font-size:13px}} th,td{{border:1px solid #ccc;padding:3px 7px}}
img{{max-width:100%}}</style></head><body>
<h1>{html.escape(title)}</h1>
<p>{len(document["tracks"])} track(s) over {n_sub} sub-aperture(s);
{result.timings_s["total"]:.1f} s. sarmotion {__version__}. Without a road, a state's
cross-range position is one point of its family (the data of a few degrees do not fix
it): see <code>cross_range_family</code> in tracks.json.</p>
<img src="data:image/png;base64,{uri}" alt="tracks">
<table><tr>{head}</tr>{"".join(rows)}</table>
</body></html>
"""
    page = d / "report.html"
    page.write_text(text)
    return [png, page]
