"""The tracks of a long acquisition over its stationary image, and their speeds.

:func:`tracks_figure` draws, left, the incoherent mean of the sub-apertures' stationary
images (dB) with each track in its own colour (filtered positions, a dot per detection,
a ring where the state was coasted on the prediction, the roads dashed) and each state's
position uncertainty: its 1-sigma ellipse from the filter's covariance (without a road it
stretches along the cross-range family, which the data of a sub-aperture do not fix) and,
where a road fixed the position, the 1-sigma interval along the road. Right, each track's
ground speed and range speed over slow time. :func:`write_tracks_report`
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
from matplotlib.patches import Ellipse, Patch

from .._version import __version__
from ..tracking import TrackingResult
from .plotting import LEGEND_PT

__all__ = ["sigma_ellipse", "tracks_figure", "write_tracks_report"]

_COLOURS = ("tab:red", "tab:cyan", "tab:green", "tab:orange", "tab:purple", "tab:pink")


def sigma_ellipse(centre_m: Any, cov_m2: Any, **style: Any) -> Ellipse:
    """The 1-sigma ellipse of a 2-D Gaussian: axes ``2 sqrt(eigenvalues)`` along the eigenvectors.

    Parameters
    ----------
    centre_m : (2,) array_like
        Mean (m).
    cov_m2 : (2, 2) array_like
        Covariance (m^2).
    """
    vals, vecs = np.linalg.eigh(np.asarray(cov_m2, dtype=np.float64))
    vals = np.clip(vals, 0.0, None)
    angle = float(np.degrees(np.arctan2(vecs[1, 1], vecs[0, 1])))  # the major axis
    return Ellipse(
        (float(centre_m[0]), float(centre_m[1])),
        width=2.0 * float(np.sqrt(vals[1])),
        height=2.0 * float(np.sqrt(vals[0])),
        angle=angle,
        **style,
    )


def _road_interval(fix: Any) -> np.ndarray:
    """End points (2, 2) of the 1-sigma interval a road gives: along its covariance's major axis."""
    vals, vecs = np.linalg.eigh(np.asarray(fix.covariance_m2, dtype=np.float64))
    half = float(np.sqrt(max(vals[1], 0.0))) * vecs[:, 1]
    p = np.asarray(fix.position_m, dtype=np.float64)
    return np.array([p - half, p + half])


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
        for s in trk.states:
            ax_map.add_patch(
                sigma_ellipse(
                    s.position_m, s.position_cov_m2, fc=colour, ec=colour, alpha=0.18, lw=0.8
                )
            )
            if s.on_road:
                seg = _road_interval(s.road)
                ax_map.plot(seg[:, 0], seg[:, 1], "-", color="yellow", lw=3.0, alpha=0.9)
        t = np.array([s.time_s for s in trk.states])
        speed = np.hypot(*np.array([s.velocity_mps for s in trk.states]).T)
        u = np.array([s.range_speed_mps for s in trk.states])
        ax_speed.plot(t, speed, "-o", color=colour, ms=3, label=f"track {trk.id} speed")
        ax_speed.plot(t, u, ":", color=colour, label=f"track {trk.id} range speed")
    x0, x1, y0, y1 = result.grid.extent
    ax_map.set(xlim=(x0, x1), ylim=(y0, y1), xlabel="x (m)", ylabel="y (m)", title="tracks")
    if result.tracks:
        if any(s.on_road for trk in result.tracks for s in trk.states):
            ax_map.plot([], [], "-", color="yellow", lw=3.0, label="1-sigma interval on a road")
        handles, _ = ax_map.get_legend_handles_labels()
        handles.append(Patch(fc="0.5", alpha=0.3, label="1-sigma position (filter)"))
        ax_map.legend(handles=handles, loc="upper right", fontsize=LEGEND_PT)
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
it): see <code>cross_range_family</code> in tracks.json. The map draws each state's
1-sigma position ellipse from the filter's covariance (long along the family where no
road fixes the position) and, on a road, the 1-sigma interval the road gives.</p>
<img src="data:image/png;base64,{uri}" alt="tracks">
<table><tr>{head}</tr>{"".join(rows)}</table>
</body></html>
"""
    page = d / "report.html"
    page.write_text(text)
    return [png, page]
