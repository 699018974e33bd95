"""fig:setup: the acquisition geometry, drawn from the GOTCHA files' antenna positions."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._context import _Context, _Result

__all__ = []


def _fig_setup(ctx: _Context) -> _Result:
    """Platform path, look direction, scene and reference point of the GOTCHA pass.

    The antenna positions are those of the GOTCHA files (read by
    :func:`sarmotion.io.read_gotcha`) when :class:`_Context` has them; without the data,
    the nominal GOTCHA circle (:meth:`sarmotion.core.Trajectory.circular`, same aperture)
    is drawn and the title says so.
    """
    from ...core import Trajectory, look_geometry

    traces = ctx.gotcha_traces
    if traces is not None:
        pos = traces.positions_m
        rho_o = traces.reference_point_m
        files = list(traces.metadata.get("files", []))
        per_file = list(traces.metadata.get("pulses_per_file", [len(pos)]))
        source = f"GOTCHA pass 1 HH, {len(per_file)} files"
        traj = traces.trajectory
    else:
        traj = Trajectory.circular(aperture_deg=4.0)
        pos = traj.positions_m
        rho_o = np.zeros(3)
        files, per_file = [], [len(pos)]
        source = "nominal GOTCHA circle (data not found)"
    geo = look_geometry(traj, rho_o)
    centre = traj.centre_m
    ground = np.linalg.norm(centre[:2] - rho_o[:2])
    altitude = float(centre[2] - rho_o[2])
    ang = np.unwrap(np.arctan2(pos[:, 1] - rho_o[1], pos[:, 0] - rho_o[0]))
    aperture_deg = float(np.degrees(ang.max() - ang.min()))
    a_m = float(np.sum(np.linalg.norm(np.diff(pos, axis=0), axis=1)))
    elevation_deg = float(np.degrees(np.arctan2(altitude, ground)))

    fig = _blank_figure()
    ax3 = fig.add_subplot(1, 3, 1, projection="3d")
    ax1 = fig.add_subplot(1, 3, 2)
    ax2 = fig.add_subplot(1, 3, 3)
    edges = np.cumsum([0, *per_file])
    _draw_path(ax3, pos, rho_o, centre, edges, bool(files), source)
    _draw_aperture(ax1, pos, geo, edges, bool(files), a_m, ground)
    _draw_scene(ax2, pos, rho_o, geo, aperture_deg)
    fig.tight_layout()
    h = {
        "n_pulses": float(len(pos)),
        "range_to_reference_m": float(geo.range_m),
        "ground_range_m": float(ground),
        "altitude_m": altitude,
        "elevation_deg": elevation_deg,
        "aperture_deg": aperture_deg,
        "aperture_length_m": a_m,
        "from_data": float(traces is not None),
    }
    summary = (
        f"{source}: {len(pos)} pulses over {aperture_deg:.2f}° of azimuth "
        f"(a = {a_m:.0f} m of flight), range L = {geo.range_m / 1e3:.2f} km to ρ_o, "
        f"altitude {altitude / 1e3:.2f} km, ground range {ground / 1e3:.2f} km "
        f"(elevation {elevation_deg:.1f}°)"
    )
    arrays: dict[str, Any] = {"positions_m": pos, "reference_point_m": rho_o}
    return _Result(fig, arrays, h, summary)


def _draw_path(
    ax: Any,
    pos: NDArray,
    rho_o: NDArray,
    centre: NDArray,
    edges: NDArray,
    labelled: bool,
    source: str,
) -> None:
    """3-D panel: the platform path per file, the full circle, lines of sight to rho_o."""
    for k in range(len(edges) - 1):
        seg = pos[edges[k] : edges[k + 1]] / 1e3
        lab = f"file {k + 1}" if labelled else "platform path"
        ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], lw=3, label=lab)
    # the rest of the circle, for context
    r_g = float(np.mean(np.linalg.norm(pos[:, :2] - rho_o[:2], axis=1)))
    th = np.linspace(0, 2 * np.pi, 361)
    ax.plot(
        (rho_o[0] + r_g * np.cos(th)) / 1e3,
        (rho_o[1] + r_g * np.sin(th)) / 1e3,
        np.full_like(th, np.mean(pos[:, 2])) / 1e3,
        ":",
        color="0.6",
        lw=0.8,
        label="full circle",
    )
    for p, style in ((pos[0], "--"), (centre, "-"), (pos[-1], "--")):
        ax.plot(
            [p[0] / 1e3, rho_o[0] / 1e3],
            [p[1] / 1e3, rho_o[1] / 1e3],
            [p[2] / 1e3, rho_o[2] / 1e3],
            style,
            color="tab:red",
            lw=1.0,
        )
    ax.scatter([rho_o[0] / 1e3], [rho_o[1] / 1e3], [rho_o[2] / 1e3], color="k", s=20)
    ax.text(rho_o[0] / 1e3, rho_o[1] / 1e3, rho_o[2] / 1e3 - 0.6, "ρ_o", fontsize=10)
    ax.text(*(centre / 1e3 + [0.3, 0.0, 0.3]), "r(s)", fontsize=10)
    ax.set_xlabel("x (km)")
    ax.set_ylabel("y (km)")
    ax.set_zlabel("z (km)")
    ax.set_title(f"{source}:\nplatform path and lines of sight", fontsize=10)
    ax.legend(fontsize=8, loc="upper left")
    ax.view_init(elev=22, azim=-120)


def _draw_aperture(
    ax: Any, pos: NDArray, geo: Any, edges: NDArray, labelled: bool, a_m: float, ground: float
) -> None:
    """The synthetic aperture from above, along track against towards the scene (m)."""
    # the synthetic aperture from above, in along-track / towards-the-scene coordinates (m)
    mid = len(pos) // 2
    tang = geo.tangent[:2] / np.linalg.norm(geo.tangent[:2])
    inward = -geo.ground_m_o[:2] / np.linalg.norm(geo.ground_m_o[:2])
    along = (pos[:, :2] - pos[mid, :2]) @ tang
    towards = (pos[:, :2] - pos[mid, :2]) @ inward
    for k in range(len(edges) - 1):
        sl = slice(edges[k], edges[k + 1])
        ax.plot(along[sl], towards[sl], lw=3, label=f"file {k + 1}" if labelled else None)
    sagitta = float(towards.max() - towards.min())
    ax.set_xlabel("along track (m)")
    ax.set_ylabel("towards ρ_o (m)  [axis stretched]")
    ax.set_title(
        f"the aperture from above:\na = {a_m:.0f} m, {len(pos)} pulses, bowed {sagitta:.1f} m",
        fontsize=10,
    )
    ax.annotate(
        f"ρ_o: {ground / 1e3:.2f} km this way",
        xy=(0.5, 0.97),
        xytext=(0.5, 0.80),
        xycoords="axes fraction",
        ha="center",
        arrowprops={"arrowstyle": "-|>", "color": "tab:red"},
        color="tab:red",
        fontsize=9,
    )
    if labelled:
        ax.legend(fontsize=8, loc="lower center")
    ax.margins(0.1, 0.6)


def _draw_scene(ax: Any, pos: NDArray, rho_o: NDArray, geo: Any, aperture_deg: float) -> None:
    """The imaged scene on the ground with the look and flight directions."""
    # the scene on the ground, with the look direction and the cross-range direction
    half = 30.0
    sq = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]]) * half + rho_o[:2]
    ax.plot(sq[:, 0], sq[:, 1], "k-", lw=1, label="imaged scene (60 m x 60 m)")
    ax.plot(*rho_o[:2], "k+", ms=12, mew=2, label="ρ_o (reference point)")
    look = -geo.ground_m_o / np.linalg.norm(geo.ground_m_o)  # from the platform to the scene
    cross = geo.tangent[:2] / np.linalg.norm(geo.tangent[:2])
    ax.annotate(
        "",
        xy=rho_o[:2],
        xytext=rho_o[:2] - 22 * look,
        arrowprops={"arrowstyle": "-|>", "color": "tab:red", "lw": 2},
    )
    ax.text(*(rho_o[:2] - 22 * look + [0, -5]), "look (range)", color="tab:red", fontsize=9)
    ax.annotate(
        "",
        xy=rho_o[:2] + 15 * cross,
        xytext=rho_o[:2],
        arrowprops={"arrowstyle": "-|>", "color": "tab:blue", "lw": 2},
    )
    ax.text(*(rho_o[:2] + 16 * cross), "flight (cross range)", color="tab:blue", fontsize=9)
    # lines of sight at the ends of the aperture, on the ground
    for p in (pos[0], pos[-1]):
        d = (p[:2] - rho_o[:2]) / np.linalg.norm(p[:2] - rho_o[:2])
        ax.plot(*np.c_[rho_o[:2], rho_o[:2] + 40 * d], ":", color="tab:red", lw=1)
    ax.set_xlim(-45, 45)
    ax.set_ylim(-45, 45)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(
        f"the scene on the ground:\naperture {aperture_deg:.2f}° seen from ρ_o", fontsize=10
    )
    ax.legend(fontsize=8, loc="lower left")


def _blank_figure() -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=(17.0, 5.6))
