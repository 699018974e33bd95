"""Figures and a self-contained HTML report of an analysis (:mod:`sarmotion.pipeline`).

Plotting layer: with :mod:`sarmotion.report.plotting` the only module that imports matplotlib.
The trace and image panels are drawn by :mod:`sarmotion.report.plotting`; the objective-function
and trajectory plots (not in the paper's figure set of that module) are drawn here.

:func:`write_report` saves each figure as a PNG in ``directory`` and writes
``report.html`` with the same PNGs embedded as base64 data URIs, so the HTML file can be
mailed or archived alone.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from .._version import __version__
from ..documents.results import results_document
from ..motion import trajectory_error
from ..pipeline import AnalysisResult
from .plotting import LEGEND_PT, image_figure, plot_image, subplots, traces_figure

__all__ = [
    "traces_panels_figure",
    "objectives_figure",
    "images_figure",
    "movers_figure",
    "trajectories_figure",
    "write_report",
]

#: Stationary detections closer than this (m) to a brighter one are merged in the report.
_MERGE_M = 0.5

_COLOURS = ("tab:red", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink")


# ======================================================================== figures
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


def images_figure(result: AnalysisResult) -> Figure:
    """Preliminary image and stationary image, with movers and stationary targets marked.

    Circles: the movers' estimated positions at ``s = 0`` (preliminary image) and the
    listed stationary targets (stationary image).
    """
    g = result.preliminary_image.grid
    found = [s.position_m for s in result.stationary]
    movers = [tuple(m.position_m[:2]) for m in result.movers]
    return image_figure(
        [
            ("preliminary image |I| (eq:image)", result.preliminary_image.values),
            ("stationary image (from L)", result.stationary_image.values),
        ],
        x_m=g.x_m,
        y_m=g.y_m,
        markers=[movers, found],
    )


def movers_figure(result: AnalysisResult, *, truth: dict[str, Any] | None = None) -> Figure:
    """Each mover's image from its own traces, compensated at its estimated velocity."""
    n = max(1, len(result.movers))
    fig, axes = subplots(1, n, figsize=(4.6 * n, 4.0), squeeze=False)
    for k, m in enumerate(result.movers):
        ax = axes[0, k]
        g = m.image.grid
        u = m.velocity_mps
        plot_image(
            ax,
            m.image.values,
            x_m=g.x_m,
            y_m=g.y_m,
            title=f"mover {k + 1}, u = ({u[0]:.2f}, {u[1]:.2f}) m/s",
            markers=[tuple(m.position_m[:2])],
        )
        if truth and truth["errors"][k] is not None:
            name = truth["errors"][k]["matched"]
            t = next((t for t in truth["truth"] if t["label"] == name), None)
            if t is not None:
                ax.plot(*t["position_m"], "x", color="w", ms=9, mew=2, label="truth")
                ax.legend(fontsize=LEGEND_PT, loc="lower right")
    if not result.movers:
        axes[0, 0].text(0.5, 0.5, "no mover found", ha="center", va="center")
        axes[0, 0].set_axis_off()
    fig.tight_layout()
    return fig


def trajectories_figure(result: AnalysisResult, *, truth: dict[str, Any] | None = None) -> Figure:
    """Trajectory error ``|rho^e(s) - rho(s)|`` (simulations), else the trajectories."""
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
            ax.plot(tj.positions_m[:, 0], tj.positions_m[:, 1], color=colour)
            ax.plot(*tj.position_at_zero_m[:2], "o", color=colour, label=f"mover {k + 1}, s = 0")
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


# ========================================================================= report
def _png(fig: Figure, path: Path, dpi: int = 110) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    data = buf.getvalue()
    path.write_bytes(data)
    return data


def _fmt(v: Any, digits: int = 2) -> str:
    if v is None:
        return "&ndash;"
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(_fmt(x, digits) for x in v) + ")"
    if isinstance(v, float):
        text = f"{v:.{digits}f}"
        return text[1:] if text.startswith("-") and float(text) == 0.0 else text
    return html.escape(str(v))


_CSS = """
body{font-family:-apple-system,'Segoe UI',Helvetica,Arial,sans-serif;margin:0;color:#222;
background:#f5f6f8}
header{background:#1f3a5f;color:#fff;padding:18px 32px}
header h1{margin:0;font-size:22px} header p{margin:4px 0 0;opacity:.85;font-size:13px}
main{max-width:1400px;margin:0 auto;padding:16px 32px}
section{background:#fff;border:1px solid #dde1e6;border-radius:6px;margin:16px 0;
padding:12px 20px}
h2{font-size:17px;border-bottom:1px solid #e5e7eb;padding-bottom:6px;color:#1f3a5f}
table{border-collapse:collapse;font-size:13px;margin:8px 0}
th,td{border:1px solid #d0d5dc;padding:4px 8px;text-align:right}
th{background:#eef1f5} td.l,th.l{text-align:left}
.kv td:first-child{text-align:left;color:#555}
img{max-width:100%;height:auto;display:block;margin:6px 0}
.note{font-size:12px;color:#555}
.bad{color:#b42318;font-weight:600} .ok{color:#067647}
"""


def _detection_cell(m: dict[str, Any]) -> str:
    d = m.get("detection")
    if d is None:
        return _fmt(m["g_peak_db"], 1)
    return (
        f"{d['statistic_db']:.1f} / {d['threshold_db']:.1f}, p = {d['p_value']:.1e}, "
        f"{d['focus_gain_db']:.1f}"
    )


def _errors_cell(m: dict[str, Any]) -> str:
    e = m.get("standard_errors")
    if e is None:
        return "&ndash;"
    return (
        f"{e['range_position_m']:.2g}, {e['range_speed_mps']:.2g}, "
        f"{e['cross_range_speed_mps']:.2g}; {m['snr_db']:.1f}"
    )


def _html_table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    h = "".join(f"<th>{html.escape(c)}</th>" for c in head)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{h}</tr>{body}</table>"


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
        The analysis.
    directory : path
        Existing output directory.
    document : dict, optional
        ``results_document(result, ...)`` (with ``truth`` for simulated inputs); computed
        without truth if not given.
    title : str
        Report title.
    inputs : sequence of str
        The input names, for the header.

    Returns
    -------
    Path
        The HTML file.
    """
    out = Path(directory)
    doc = document if document is not None else results_document(result)
    truth = None
    if "truth" in doc:
        truth = {"truth": doc["truth"], "errors": [m.get("errors") for m in doc["movers"]]}
    sections: dict[str, list[str]] = {}
    figures = _figures(result, truth)
    if doc.get("autofocus"):
        figures.append(_autofocus_figure(doc["autofocus"]))
    for section, caption, fig, name in figures:
        b64 = base64.b64encode(_png(fig, out / name)).decode("ascii")
        sections.setdefault(section, []).append(
            f'<img alt="{html.escape(caption)}" src="data:image/png;base64,{b64}">'
            f'<p class="note">{html.escape(caption)}</p>'
        )
    movers = _movers_html(doc) + (_truth_html(doc) if truth is not None else "")
    parts = [
        f"<section><h2>Acquisition</h2>{_acquisition_html(doc, inputs)}</section>",
        f"<section><h2>Moving targets</h2>{movers}</section>",
    ]
    for name in ("Autofocus", "Traces", "Motion estimation", "Images", "Trajectories"):
        if name in sections:
            parts.append(f"<section><h2>{name}</h2>{''.join(sections[name])}</section>")
    parts.append(f"<section><h2>Stationary targets</h2>{_stationary_html(doc)}</section>")
    timing_rows = [[html.escape(k), _fmt(v, 2)] for k, v in doc["timings_s"].items()]
    parts.append(
        "<section><h2>Timings</h2>"
        + _html_table(["stage", "wall-clock (s)"], timing_rows)
        + "</section>"
    )
    path = out / "report.html"
    path.write_text(_page(title, doc, parts), encoding="utf-8")
    return path


def _autofocus_figure(focus: dict[str, Any]) -> tuple[str, str, Figure, str]:
    """The phase-gradient autofocus section: estimated phase error and convergence."""
    from .autofocus import phase_error_figure

    fig = phase_error_figure(
        focus["slow_times_s"],
        focus["phase_error_rad"],
        focus["rms_history_rad"],
        tol_rad=focus["tol_rad"],
    )
    state = "converged" if focus["converged"] else "stopped at the iteration cap"
    caption = (
        f"Phase-gradient autofocus of the phase history: the estimated phase error per "
        f"pulse (mean and linear term removed; RMS {focus['phase_error_rms_rad']:.3g} rad), "
        f"removed from the traces before the analysis; {focus['n_iter']} iteration(s), "
        f"{state} (tolerance {focus['tol_rad']:g} rad)."
    )
    return ("Autofocus", caption, fig, "autofocus.png")


def _figures(
    result: AnalysisResult, truth: dict[str, Any] | None
) -> list[tuple[str, str, Figure, str]]:
    """The report's figures: (section, caption, figure, file name)."""
    marks = truth is not None
    figures = [
        (
            "Traces",
            "Range-compressed traces: slow time s (vertical) against fast time t. Data M, "
            f"its separation ({result.method}) into L and S, each mover's own traces "
            "(its s-independent part in its frame T_+^{u,rho}, mapped back) and what is left.",
            traces_panels_figure(result),
            "traces.png",
        ),
        (
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
        (
            "Images",
            "Preliminary image of M (circles: movers' estimated positions at s = 0) and the "
            "stationary image (circles: listed stationary targets). dB re each image's peak.",
            images_figure(result),
            "images.png",
        ),
    ]
    if result.movers:
        figures.append(
            (
                "Images",
                "Each mover imaged from its own traces, compensated at its estimated velocity. "
                "Circle: estimated position at s = 0" + ("; cross: truth." if marks else "."),
                movers_figure(result, truth=truth),
                "movers.png",
            )
        )
    if any(m.trajectory is not None for m in result.movers):
        figures.append(
            (
                "Trajectories",
                "Phase-space trajectory estimate (sub-apertures, Wigner ridge), anchored at "
                "the estimated position at s = 0"
                + (": distance to the true trajectory (m)." if marks else "."),
                trajectories_figure(result, truth=truth),
                "trajectories.png",
            )
        )
    return figures


def _movers_html(doc: dict[str, Any]) -> str:
    """The table of estimated movers (estimates only; truth has its own tables)."""
    rows = []
    for k, m in enumerate(doc["movers"]):
        fam = m["cross_range_family"]
        rows.append(
            [
                str(k + 1),
                _fmt(m["position_m"]),
                _fmt(m["velocity_mps"]),
                _fmt(m["range_speed_mps"], 3),
                _fmt(m["cross_range_speed_mps"], 3),
                _detection_cell(m),
                _errors_cell(m),
                _fmt(m["peak_db"], 1),
                _fmt(fam["position_per_m"], 3) + " / " + _fmt(fam["velocity_mps_per_m"], 4),
            ]
        )
    if not rows:
        return "<p>No mover found: no candidate passed the detector.</p>"
    head = [
        "estimate",
        "position at s=0 (m)",
        "velocity (m/s)",
        "range speed (m/s)",
        "cross-range speed (m/s)",
        "detection: statistic / threshold (dB), p, focus gain (dB)",
        "standard errors: range position (m), range speed, cross-range speed (m/s); SNR (dB)",
        "image peak (dB re stationary)",
        "family, per m of cross-range offset: position (m/m) / velocity (m/s per m)",
    ]
    return _html_table(head, rows) + (
        '<p class="note">The data of a few degrees do not fix a mover\'s cross-range '
        "position: position + t a and velocity + t b fit them as well for any t metres "
        "of cross-range offset (a, b in the last column; sarmotion.motion.aperture). The "
        "estimate is the member near the reference cross range.</p>"
    )


def _truth_html(doc: dict[str, Any]) -> str:
    """Truth table (each row beside the estimate it was matched to) and the errors."""
    matched = {
        m["errors"]["matched"]: k + 1 for k, m in enumerate(doc["movers"]) if m.get("errors")
    }
    truth_rows = sorted(doc["truth"], key=lambda t: matched.get(t["label"], len(matched) + 1))
    trows = [
        [
            html.escape(t["label"] or "-"),
            str(matched.get(t["label"], "missed")),
            _fmt(t["position_m"]),
            _fmt(t["velocity_mps"]),
            _fmt(t["range_speed_mps"], 3),
            _fmt(t["cross_range_speed_mps"], 3),
        ]
        for t in truth_rows
    ]
    head = ["true target", "matched estimate", "position at s=0 (m)", "velocity (m/s)"]
    head += ["range speed (m/s)", "cross-range speed (m/s)"]
    return (
        "<h3>Truth</h3>"
        + _html_table(head, trows)
        + "<h3>Errors (estimate &minus; truth)</h3>"
        + _errors_table(doc)
        + f"<p>False movers: {doc['false_movers']}; missed movers: "
        f"{doc['missed_movers']}.</p>"
        + '<p class="note">The cross-range position and the range speed of a mover are '
        "tied over a few degrees (sarmotion.motion.aperture, module notes): a mover away from "
        "the reference cross range is placed on the data-consistent family near it, "
        "shifted in cross range by about L &delta;u / (V &minus; u_t). &ldquo;Truth to "
        "family&rdquo; is the error of the family member at the truth's cross-range "
        "offset: what the data can resolve.</p>"
    )


def _errors_table(doc: dict[str, Any]) -> str:
    erows = []
    for k, m in enumerate(doc["movers"]):
        e = m.get("errors")
        if e is None:
            erows.append([str(k + 1), '<span class="bad">false mover</span>'] + [""] * 7)
            continue
        erows.append(
            [
                str(k + 1),
                html.escape(e["matched"]),
                _fmt(e["range_speed_mps"], 3),
                _fmt(e["cross_range_speed_mps"], 3),
                _fmt(e["position_range_m"], 2),
                _fmt(e["position_cross_range_m"], 2),
                _fmt(e["family_position_m"], 3) + " / " + _fmt(e["family_velocity_mps"], 3),
                _fmt(e.get("trajectory_max_m"), 2),
                _fmt(e["image_peak_m"], 2),
            ]
        )
    head = ["estimate", "true target", "range speed (m/s)", "cross-range speed (m/s)"]
    head += ["position, range (m)", "position, cross range (m)"]
    head += ["truth to family: position (m) / velocity (m/s)", "max trajectory error (m)"]
    return _html_table(head + ["image peak to truth (m)"], erows)


def _merged_stationary(stationary: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Detections brightest first, each dropped within 0.5 m of a brighter one kept."""
    kept: list[dict[str, Any]] = []
    for s in sorted(stationary, key=lambda s: -s["peak_db"]):
        p = np.asarray(s["position_m"][:2], dtype=float)
        if all(np.hypot(*(p - np.asarray(k["position_m"][:2]))) > _MERGE_M for k in kept):
            kept.append(s)
    return kept


def _stationary_html(doc: dict[str, Any]) -> str:
    listed = _merged_stationary(doc["stationary"])
    rows = [
        [str(i + 1), _fmt(list(s["position_m"])), _fmt(s["peak_db"], 1)]
        for i, s in enumerate(listed[:40])
    ]
    text = _html_table(["#", "position (m)", "level (dB re peak)"], rows)
    merged = len(doc["stationary"]) - len(listed)
    if merged:
        text += (
            f'<p class="note">{merged} detection(s) within {_MERGE_M} m of a brighter one '
            "are merged into it here (all are in results.json).</p>"
        )
    if len(listed) > len(rows):
        text += f'<p class="note">... and {len(listed) - len(rows)} more in results.json.</p>'
    if doc.get("point_quality"):
        text += _quality_html(doc["point_quality"])
    return text


def _quality_html(entries: list[dict[str, Any]]) -> str:
    """Point-target quality of the brightest stationary targets, measured and theory."""
    rows = []
    for q in entries:
        if "error" in q:
            rows.append([_fmt(list(q["position_m"])), html.escape(q["error"])] + [""] * 5)
            continue
        r, c = q["range"], q["cross_range"]
        rows.append(
            [
                _fmt(list(q["position_m"])),
                f"{_fmt(r['irw_m'], 3)} / {_fmt(r['irw_theory_m'], 3)}",
                f"{_fmt(c['irw_m'], 3)} / {_fmt(c['irw_theory_m'], 3)}",
                f"{_fmt(r['pslr_db'], 1)} / {_fmt(r['pslr_theory_db'], 1)}",
                f"{_fmt(c['pslr_db'], 1)} / {_fmt(c['pslr_theory_db'], 1)}",
                f"{_fmt(r['islr_db'], 1)} / {_fmt(r['islr_theory_db'], 1)}",
                f"{_fmt(c['islr_db'], 1)} / {_fmt(c['islr_theory_db'], 1)}",
            ]
        )
    head = [
        "position (m)",
        "IRW range (m)",
        "IRW cross range (m)",
        "PSLR range (dB)",
        "PSLR cross range (dB)",
        "ISLR range (dB)",
        "ISLR cross range (dB)",
    ]
    return (
        "<h3>Point-target quality</h3>"
        + _html_table(head, rows)
        + '<p class="note">Measured / theory (flat spectrum of the data\'s bandwidth and '
        "aperture) on cuts along range and cross range through the brightest stationary "
        "targets of the stationary traces; ISLR over +-10 resolution cells.</p>"
    )


def _acquisition_html(doc: dict[str, Any], inputs: Sequence[str]) -> str:
    sub = float(doc["options"].get("sub_aperture_deg", doc["aperture_deg"]))
    searched = (
        f"movers sought on the central {sub:g} deg, then focused on all pulses"
        if doc["aperture_deg"] > 1.5 * sub
        else "movers sought on the whole aperture"
    )
    acq = [
        ["inputs", html.escape(", ".join(inputs) or "-")],
        ["source", html.escape(str(doc["source"].get("source", "-")))],
        ["pulses &times; samples", f"{doc['n_pulses']} &times; {doc['n_samples']}"],
        [
            "aperture",
            f"{_fmt(doc['aperture_s'], 3)} s, {_fmt(doc['aperture_deg'], 2)} deg of azimuth; "
            + searched,
        ],
        ["platform speed (m/s)", _fmt(doc["platform_speed_mps"], 1)],
        ["reference point (m)", _fmt(doc["reference_point_m"])],
        ["separation method", html.escape(doc["method"])],
        ["range-speed resolution (m/s)", _fmt(doc["range_speed_resolution_mps"], 3)],
    ]
    if doc.get("detection"):
        det = doc["detection"]
        acq.append(
            [
                "mover detector",
                f"g(u) over its local floor &ge; {det['threshold_db']:.2f} dB "
                f"(false-alarm rate {det['false_alarm_rate']:g} per scene, "
                f"{det['n_candidates']} candidates), |u| &ge; {det['min_speed_mps']:.2f} m/s, "
                f"width &le; {det['max_width_resolutions']:.1f} resolutions, "
                f"focus gain &ge; {det['min_focus_gain_db']:.1f} dB",
            ]
        )
    return (
        '<table class="kv">'
        + "".join(f"<tr><td>{a}</td><td>{b}</td></tr>" for a, b in acq)
        + "</table>"
    )


def _page(title: str, doc: dict[str, Any], parts: list[str]) -> str:
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    head = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<header><h1>{html.escape(title)}</h1><p>sarmotion {__version__} &middot; {now} "
        f"&middot; {len(doc['movers'])} mover(s), {len(doc['stationary'])} stationary "
        "target(s)</p></header><main>",
    ]
    return "\n".join([*head, *parts, "</main></body></html>"])
