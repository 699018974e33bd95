"""The tracks of a long acquisition over its stationary image, and their speeds.

:func:`tracks_figure` draws, left, the incoherent mean of the sub-apertures' stationary
images (dB) with each track in its own colour (filtered positions, a dot per detection,
a ring where the state was coasted on the prediction, the roads dashed) and each state's
position uncertainty: its 1-sigma ellipse from the filter's covariance (without a road it
stretches along the cross-range family, which the data of a sub-aperture do not fix) and,
where a road fixed the position, the 1-sigma interval along the road. Right, each track's
ground speed and range speed over slow time; an arrow gives the radar's look direction.
:func:`write_tracks_report` saves it as ``tracks.png`` and writes a self-contained
``report.html`` (the PNG embedded; the analysis report's page,
:mod:`sarmotion.report.page`) with the table of the tracks' states.
"""

from __future__ import annotations

import base64
import html
import io
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.patches import Ellipse, Patch

from ..core.text import fixed
from ..tracking import TrackingResult
from .page import figure, header_line, page, section, table
from .plotting import LEGEND_PT, draw_look_arrow

__all__ = [
    "sigma_ellipse",
    "timing_rows",
    "tracks_figure",
    "turn_line",
    "write_tracks_report",
]

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


#: Opacity of a 1-sigma ellipse's fill: the image shows through where a few overlap.
ELLIPSE_FILL_ALPHA = 0.2

#: Width of a 1-sigma ellipse's edge (pt): the least that shows on screen at the report's
#: resolution beside the tracks' 1.8-pt lines.
ELLIPSE_EDGE_PT = 1.3

#: What the legend says of the ellipses.
ELLIPSE_LABEL = "1\u03c3 uncertainty (long along the cross-range family)"


def _ellipse_style(colour: Any) -> dict[str, Any]:
    """A 1-sigma ellipse in ``colour``: filled at :data:`ELLIPSE_FILL_ALPHA`, solid edge.

    The fill's opacity is the face colour's own (``alpha`` of the patch would fade the
    edge with it); drawn under the track's line and markers (``zorder`` 1.5 < 2).
    """
    return {
        "fc": to_rgba(colour, ELLIPSE_FILL_ALPHA),
        "ec": to_rgba(colour, 1.0),
        "lw": ELLIPSE_EDGE_PT,
        "zorder": 1.5,
    }


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
                sigma_ellipse(s.position_m, s.position_cov_m2, **_ellipse_style(colour))
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
            ax_map.plot([], [], "-", color="yellow", lw=3.0, label="1\u03c3 interval on a road")
        handles, _ = ax_map.get_legend_handles_labels()
        handles.append(Patch(**_ellipse_style("0.45"), label=ELLIPSE_LABEL))
        ax_map.legend(handles=handles, loc="upper right", fontsize=LEGEND_PT)
        ax_speed.legend(fontsize=LEGEND_PT)
    look = _look(result)
    if look is not None:
        draw_look_arrow(ax_map, look)
    ax_speed.set(xlabel="slow time s (s)", ylabel="m/s", title="speed and range speed")
    ax_speed.grid(alpha=0.3)
    return fig


def _look(result: TrackingResult) -> np.ndarray | None:
    """Ground look direction (radar towards the scene) of the middle sub-aperture, or None."""
    subs = result.sub_apertures
    if not subs:
        return None
    times = np.array([sub.time_s for sub in subs])
    mid = subs[int(np.argmin(np.abs(times - np.median(times))))]
    return -np.asarray(mid.range_direction, dtype=np.float64)  # e_r points to the antenna


_HEAD = (
    "track",
    "s (s)",
    "position (m)",
    "position std (m)",
    "velocity (m/s)",
    "range speed (m/s)",
    "detected",
    "position from",
)


def _state_row(track_id: Any, s: dict[str, Any]) -> list[str]:
    """One state of a track as the table's cells (from tracks.json)."""
    road = s.get("road")
    where = "on road" if road and road["fixed"] else "road parallel" if road else "family"
    return [
        html.escape(str(track_id)),
        f"{s['time_s']:.2f}",
        "({:.2f}, {:.2f})".format(*s["position_m"]),
        f"{s['position_std_m']:.2f}",
        "({:.2f}, {:.2f})".format(*s["velocity_mps"]),
        f"{s['range_speed_mps']:.3f}",
        "yes" if s["detected"] else "coasted",
        where,
    ]


def turn_line(track: dict[str, Any]) -> str:
    """One line on a track's turn test (``tracks.json``'s ``turn``)."""
    turn = track.get("turn")
    head = f"track {track['id']}: "
    if turn is None:
        return head + "no turn test (a detection has no velocity covariance)"
    if turn["statistic"] is None:
        return head + "no turn test (no two detections from disjoint sub-apertures)"
    verdict = "turning" if turn["flagged"] else "no change of velocity"
    rate = (
        ""
        if turn["apparent_turn_rate_deg_s"] is None
        else f", apparent turn rate {turn['apparent_turn_rate_deg_s']:.2f} +- "
        f"{turn['apparent_turn_rate_std_deg_s']:.2f} deg/s (of the estimates' heading)"
    )
    return (
        head + f"{verdict}: chi-square {turn['statistic']:.3g} against {turn['threshold']:.3g} "
        f"(2 dof, false-alarm probability {turn['false_alarm']:g} per track over "
        f"{turn['n_pairs']} pair(s)){rate}{ground_rate_text(turn.get('turn_rate'))}"
    )


def ground_rate_text(rate: dict[str, Any] | None) -> str:
    """The turn rate in the ground frame in words (``turn``'s ``turn_rate``), or ''."""
    if not rate:
        return ""
    lo, hi = rate["interval_deg_s"]
    level = f"{100 * rate['confidence']:g} %"
    if rate["fixed"]:
        return (
            f"; turn rate in the ground frame {rate['rate_deg_s']:.3g} deg/s "
            f"({level} interval {lo:.3g} to {hi:.3g}, {rate['n_looks']} looks)"
        )
    return (
        f"; turn rate not fixed by the {rate['n_looks']} looks: rates from {lo:.3g} to "
        f"{hi:.3g} deg/s fit within {level} (best {rate['rate_deg_s']:.3g})"
    )


def coherent_line(fit: dict[str, Any]) -> str:
    """The track focused over all its pulses in words (``tracks.json``'s ``coherent``)."""
    (x, y), (ux, uy) = fit["position_m"], fit["velocity_mps"]
    head = (
        f"focused over {fit['n_pulses']} pulses: ({fixed(x, 3)}, {fixed(y, 3)}) m, velocity "
        f"({fixed(ux, 4)}, {fixed(uy, 4)}) m/s at s = {fixed(fit['time_s'])} s"
    )
    if fit["position_std_m"] is None:
        spread = (
            f", bound {fit['position_bound_m']:.2g} m (error not measured: "
            f"{fit['n_sub_apertures']} sub-apertures)"
        )
    else:
        spread = (
            f" +- {fit['position_std_m']:.2g} m (bound {fit['position_bound_m']:.2g} m times "
            f"{fit['error_factor']:.3g})"
        )
    verdict = "coherent" if fit["coherent"] else "not coherent: the looks' fit stands"
    return f"{head}{spread}; coherence {fit['coherence']:.3f}, {verdict}"


def fit_line(fit: dict[str, Any]) -> str:
    """The track's fit over its looks in words: a fixed position, or the family it leaves."""
    (x, y), (ux, uy) = fit["position_m"], fit["velocity_mps"]
    looks = f"{fit['n_looks']} looks over {fixed(fit['aspect_deg'], 2)} deg of aspect"
    margin = fit.get("acceleration_std_mps2") or 0.0
    uniform = f", allowing {margin:.2g} m/s^2 of acceleration" if margin > 0 else ", uniform motion"
    if fit["fixed"]:
        return (
            f"position fixed by {looks}: ({fixed(x, 2)}, {fixed(y, 2)}) m +- "
            f"{fit['position_std_m']:.2g} m at s = {fixed(fit['time_s'])} s{uniform}, "
            f"velocity ({fixed(ux, 2)}, {fixed(uy, 2)}) m/s"
        )
    dx, dy = fit["family"]["position_per_m"]
    return (
        f"position not fixed by {looks}: on the family through ({fixed(x, 2)}, {fixed(y, 2)}) m "
        f"along ({fixed(dx, 3)}, {fixed(dy, 3)}) (standard deviation {fit['position_std_m']:.2g} m "
        f"along it from the ranges and range rates, the scene's prior included{uniform})"
    )


def timing_rows(timings_s: dict[str, float], n_sub_apertures: int) -> list[list[str]]:
    """The rows of the tracks report's timings (HTML cells): the wall-clock total first.

    ``timings_s`` is :attr:`~sarmotion.tracking.TrackingResult.timings_s`: ``"total"``,
    the wall-clock time of the tracking call, and ``"analysis"``, the sub-apertures'
    analysis times added up. The sub-apertures are analysed in parallel on the workers,
    so that sum is worker time, not a part of the total: it exceeds the total whenever
    the workers overlap. Its row says so, with the sum over the total (the mean number
    of sub-apertures analysed at once, when above 1). Any other stage follows as
    wall-clock time.

    Parameters
    ----------
    timings_s : dict of str to float
        Seconds by stage.
    n_sub_apertures : int
        Sub-apertures analysed.

    Returns
    -------
    list of [str, str, str]
        Name, seconds and what it counts, per row.
    """
    rows = []
    total = timings_s.get("total")
    if total is not None:
        rows.append(
            [
                "total",
                f"{total:.2f}",
                "wall-clock time of the tracking: the sub-apertures analysed on the workers, "
                "their detections associated into tracks, the stationary images averaged",
            ]
        )
    for key, value in timings_s.items():
        if key == "total":
            continue
        if key == "analysis":
            ratio = f"; {value / total:.2g} x the total" if total else ""
            rows.append(
                [
                    "analysis (worker time)",
                    f"{value:.2f}",
                    f"each of the {n_sub_apertures} sub-apertures' analysis time on its "
                    "worker, summed: analyses on several workers run at once, so the sum "
                    "is not a part of the total and exceeds it when they overlap"
                    f"{ratio} (the mean number analysed at once, when above 1)",
                ]
            )
        else:
            rows.append([html.escape(key), f"{value:.2f}", "wall-clock time"])
    return rows


def write_tracks_report(
    result: TrackingResult,
    directory: str | Path,
    *,
    document: dict[str, Any],
    title: str = "sarmotion tracks",
) -> list[Path]:
    """Write ``tracks.png`` and ``report.html`` into ``directory``; return their paths.

    The page is the analysis report's (:func:`sarmotion.report.page.page`: its stylesheet,
    header and sections): the map and speeds, the table of every track's states, the
    timings.
    """
    d = Path(directory)
    fig = tracks_figure(result)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    png = d / "tracks.png"
    png.write_bytes(buf.getvalue())
    uri = base64.b64encode(buf.getvalue()).decode("ascii")
    rows = [_state_row(trk["id"], s) for trk in document["tracks"] for s in trk["states"]]
    n_sub = len(document["sub_apertures"])
    found = f"{len(document['tracks'])} track(s) over {n_sub} sub-aperture(s)"
    caption = (
        "Left: the tracks over the mean of the sub-apertures' stationary images (dB): "
        "filtered positions, a dot per detection, a ring where the state was coasted on "
        "the prediction, roads dashed. Shaded ellipses: each state's 1\u03c3 position "
        "uncertainty from the filter's covariance (long along the cross-range family where "
        "no road fixes the position); on a road, the 1\u03c3 interval the road gives. "
        "Arrow: the radar's look direction on the ground at the middle sub-aperture. "
        "Right: each track's ground speed and range speed over slow time."
    )
    note = (
        '<p class="note">Without a road, a state\'s cross-range position is one point of '
        "its family (the data of a few degrees do not fix it): see "
        "<code>cross_range_family</code> in tracks.json.</p>"
    )
    timings = timing_rows(result.timings_s, n_sub)
    parts = [
        section("Tracks", figure(uri, caption) + note),
        section(
            "Positions",
            "<ul>"
            + "".join(
                f"<li>track {t['id']}: {html.escape(fit_line(t['fit']))}"
                + (f"; {html.escape(coherent_line(t['coherent']))}" if t.get("coherent") else "")
                + "</li>"
                for t in document["tracks"]
                if t.get("fit")
            )
            + "</ul>"
            if any(t.get("fit") for t in document["tracks"])
            else "<p>No track has the bounds its fit over the looks needs.</p>",
        ),
        section(
            "Turns",
            "<ul>"
            + "".join(f"<li>{html.escape(turn_line(t))}</li>" for t in document["tracks"])
            + "</ul>"
            + "<p>Where each track ends, and why:</p><ul>"
            + "".join(
                f"<li>track {t['id']}: {html.escape(t['end']['text'])}</li>"
                for t in document["tracks"]
                if t.get("end")
            )
            + "</ul>"
            if document["tracks"]
            else "<p>No track.</p>",
        ),
        section(
            "States",
            table(_HEAD, rows) if rows else "<p>No track: no mover was followed.</p>",
        ),
        section("Timings", table(["time", "s", "what it counts"], timings)),
    ]
    page_path = d / "report.html"
    page_path.write_text(page(title, header_line(found), parts), encoding="utf-8")
    return [png, page_path]
