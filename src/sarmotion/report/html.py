"""The self-contained HTML report of an analysis, from its results document alone.

:func:`write_html` reads the ``sarmotion.results`` document (the dict written as, or
loaded from, results.json; versions 1 and 2) and the report's figures, saves each figure
as a PNG in the output directory and writes ``report.html`` with the same PNGs embedded
as base64 data URIs, so the HTML file can be mailed or archived alone. The figures are
made from the analysis itself by :mod:`sarmotion.report.analysis_figures`, whose
:func:`~sarmotion.report.analysis_figures.write_report` is the one call from an
:class:`~sarmotion.pipeline.AnalysisResult` to a report (also importable from here).

Each mover is reported as what its data fix: its range with the standard error, and its
cross-range position as not determined, with the family of positions across the scene.
"""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from importlib import import_module
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from matplotlib.figure import Figure

from .page import figure as _figure_html
from .page import header_line, page, section
from .page import table as _html_table

__all__ = ["COLUMN_PX", "REPORT_DPI", "ReportFigure", "write_html"]

# Made from the AnalysisResult in sarmotion.report.analysis_figures; importable from here.
_FROM_ANALYSIS = (
    "write_report",
    "traces_panels_figure",
    "objectives_figure",
    "images_figure",
    "movers_figure",
    "trajectories_figure",
)


def __getattr__(name: str) -> object:
    if name in _FROM_ANALYSIS:
        return getattr(import_module(".analysis_figures", __package__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class ReportFigure(NamedTuple):
    """A figure of the report: its section, caption, the figure and its PNG file name."""

    section: str
    caption: str
    figure: Figure
    name: str


#: Resolution of the report's PNGs (pixels per inch): saved at their figure size.
REPORT_DPI = 110

#: Width (CSS px) of the report's column in a 1400-px-wide window: main's 1400 px less
#: its padding (2 x 32 px) and a section's padding and border (2 x 20 + 2 px). A wider
#: PNG is shown scaled down to it (``img{max-width:100%}``).
COLUMN_PX = 1400 - 64 - 42

#: Stationary detections closer than this (m) to a brighter one are merged in the report.
_MERGE_M = 0.5


# ========================================================================= report
def _png(fig: Figure, path: Path, dpi: int = REPORT_DPI) -> bytes:
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


def write_html(
    document: dict[str, Any],
    directory: str | Path,
    *,
    figures: Sequence[ReportFigure] = (),
    title: str = "sarmotion analysis",
    inputs: Sequence[str] = (),
) -> Path:
    """Save ``figures`` as PNG in ``directory`` and write ``directory/report.html``.

    Parameters
    ----------
    document : dict
        The results document (``sarmotion.results/2`` or ``/1``, e.g. loaded from
        results.json), with ``truth`` for simulated inputs: every number and table of the
        page comes from it.
    directory : path
        Existing output directory.
    figures : sequence of ReportFigure
        The figures, in order within their sections
        (:func:`sarmotion.report.analysis_figures.analysis_figures`); the autofocus figure is
        drawn here from the document's ``autofocus`` entry.
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
    doc = document
    truth = "truth" in doc
    sections: dict[str, list[str]] = {}
    figures = [ReportFigure(*f) for f in figures]
    if doc.get("autofocus"):
        figures.append(ReportFigure(*_autofocus_figure(doc["autofocus"])))
    for where, caption, fig, name in figures:
        b64 = base64.b64encode(_png(fig, out / name)).decode("ascii")
        sections.setdefault(where, []).append(_figure_html(b64, caption))
    movers = _movers_html(doc) + _not_estimated_html(doc) + (_truth_html(doc) if truth else "")
    parts = [
        section("Acquisition", _acquisition_html(doc, inputs)),
        section("Moving targets", movers),
    ]
    for name in ("Autofocus", "Traces", "Motion estimation", "Images", "Trajectories"):
        if name in sections:
            parts.append(section(name, "".join(sections[name])))
    parts.append(section("Stationary targets", _stationary_html(doc)))
    timing_rows = [[html.escape(k), _fmt(v, 2)] for k, v in doc["timings_s"].items()]
    parts.append(section("Timings", _html_table(["stage", "wall-clock (s)"], timing_rows)))
    path = out / "report.html"
    found = (
        f"{len(doc['movers'])} mover(s){_beyond(doc)}, {len(doc['stationary'])} "
        "stationary target(s)"
    )
    path.write_text(page(title, header_line(found), parts), encoding="utf-8")
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


def _range_cell(m: dict[str, Any]) -> str:
    """Range coordinate and its standard error (``/2``); ``/1`` documents lack them."""
    if "range_m" not in m:
        return "&ndash;"
    return f"{_fmt(m['range_m'], 2)} &plusmn; {m['range_std_m']:.2g}"


def _family_cell(m: dict[str, Any]) -> str:
    """What the data say of the cross range: known, or the family across the scene."""
    if m.get("cross_range_known"):
        return "known: " + _fmt(m["position_m"])
    fam = m["cross_range_family"]
    seg = fam.get("in_scene")
    text = '<span class="bad">not determined by the data</span>'
    if seg:
        p, v = seg["positions_m"], seg["velocities_mps"]
        text += (
            f"; family across the scene from {_fmt(p[0])} m at {_fmt(v[0])} m/s "
            f"to {_fmt(p[-1])} m at {_fmt(v[-1])} m/s"
        )
    elif "in_scene" in fam:
        text += "; the family does not cross the imaged scene"
    return text


def _movers_html(doc: dict[str, Any]) -> str:
    """The table of estimated movers (estimates only; truth has its own tables)."""
    rows = []
    for k, m in enumerate(doc["movers"]):
        fam = m["cross_range_family"]
        rows.append(
            [
                str(k + 1),
                _range_cell(m),
                _fmt(m["range_speed_mps"], 3),
                _family_cell(m),
                _fmt(m["position_m"]),
                _fmt(m["velocity_mps"]),
                _fmt(m["cross_range_speed_mps"], 3),
                _detection_cell(m),
                _errors_cell(m),
                _fmt(m["peak_db"], 1),
                _fmt(fam["position_per_m"], 3) + " / " + _fmt(fam["velocity_mps_per_m"], 4),
            ]
        )
    if not rows:
        if doc.get("movers_not_estimated"):
            return "<p>No mover estimated: see the candidates not estimated below.</p>"
        return "<p>No mover found: no candidate passed the detector.</p>"
    head = [
        "estimate",
        "range (m) &plusmn; standard error",
        "range speed (m/s)",
        "cross range",
        "position at s=0, at the reference cross range (m)",
        "velocity there (m/s)",
        "cross-range speed there (m/s)",
        "detection: statistic / threshold (dB), p, focus gain (dB)",
        "standard errors: range position (m), range speed, cross-range speed (m/s); SNR (dB)",
        "image peak (dB re the stationary image's peak)",
        "family, per m of cross-range offset: position (m/m) / velocity (m/s per m)",
    ]
    return _html_table(head, rows, escape_head=False) + (
        '<p class="note">Range: the ground-range coordinate from the reference point '
        "(positive towards the radar), what the data fix. The data of a few degrees do not "
        "fix a mover's cross-range position: position + t a and velocity + t b fit them as "
        "well for any t metres of cross-range offset (a, b in the last column; "
        "sarmotion.motion.aperture), and the figures draw each mover as that family across "
        "the scene. Position, velocity and cross-range speed are those of the member at "
        "the reference cross range.</p>"
    )


def _not_estimated_html(doc: dict[str, Any]) -> str:
    """The candidates that passed the detector beyond ``max_movers``: listed, not dropped."""
    extra = doc.get("movers_not_estimated") or []
    if not extra:
        return ""
    rows = [
        [
            str(k + 1),
            _fmt(c["statistic_db"], 1),
            _fmt(c["range_m"], 1),
            _fmt(c["range_speed_mps"], 3),
            _fmt(c["width_resolutions"], 1),
        ]
        for k, c in enumerate(extra)
    ]
    cap = doc.get("options", {}).get("max_movers")
    threshold = (doc.get("detection") or {}).get("threshold_db")
    over = f" (threshold {threshold:.1f} dB)" if threshold is not None else ""
    head = ["candidate", "statistic (dB)", "range (m)", "range speed (m/s)"]
    head += ["width (resolutions)"]
    return (
        f"<h3>Detected, not estimated: {len(extra)} candidate(s) beyond max_movers = {cap}</h3>"
        + f"<p>These passed the detector{over} after {cap} mover(s) were estimated; they "
        "were neither fitted nor tested against a stationary explanation. Range: the "
        "aligned trace's peak at the range speed (not fitted). Raise --max-movers to "
        "estimate them.</p>" + _html_table(head, rows)
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
    truth_table = _html_table(head, trows) if trows else "<p>The scene has no movers.</p>"
    errors = (
        _errors_table(doc)
        if doc["movers"]
        else "<p>No mover was estimated, so there are no errors to show.</p>"
    )
    return (
        "<h3>Truth</h3>"
        + truth_table
        + "<h3>Errors (estimate &minus; truth)</h3>"
        + errors
        + f"<p>False movers: {doc['false_movers']}; missed movers: "
        f"{doc['missed_movers']}.</p>" + _family_note(doc)
    )


def _family_note(doc: dict[str, Any]) -> str:
    """How far an estimate may sit from the truth along its family (with estimates only)."""
    if not doc["movers"]:
        return ""
    return (
        '<p class="note">The cross-range position and the range speed of a mover are '
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
    sidelobes = doc.get("stationary_sidelobes_dropped", 0)
    if sidelobes:
        text += (
            f'<p class="note">{sidelobes} local maxima of the stationary image that a brighter '
            "target's sidelobes explain are not listed.</p>"
        )
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


def _beyond(doc: dict[str, Any]) -> str:
    n = len(doc.get("movers_not_estimated") or [])
    return f" (and {n} detected, not estimated)" if n else ""
