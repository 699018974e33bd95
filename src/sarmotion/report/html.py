"""The self-contained HTML report of an analysis, from its results document alone.

:func:`write_html` reads the ``sarmotion.results`` document (the dict written as, or
loaded from, results.json; versions 1 to 3, of one patch or several) and the report's
figures, saves each figure as a PNG in the output directory and writes ``report.html``
with the same PNGs embedded as base64 data URIs, so the HTML file can be mailed or
archived alone. The figures are made from the analysis itself by
:mod:`sarmotion.report.analysis_figures`, whose
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
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from matplotlib.figure import Figure

from .._lazy import attach
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


__getattr__ = attach(__name__, dict.fromkeys(_FROM_ANALYSIS, ".analysis_figures"))[0]


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
        The results document (``sarmotion.results/3``, ``/2`` or ``/1``, e.g. loaded from
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
    several = len(_patches(doc)) > 1
    parts = [section("Acquisition", _acquisition_html(doc, inputs))]
    if several:  # the mosaic and the patch table: only a region of several patches
        parts.append(section("Mosaic", "".join(sections.get("Mosaic", []))))
        parts.append(section("Patches", _patches_html(doc)))
    parts.append(section("Moving targets", movers))
    if "Autofocus" in sections:
        parts.append(section("Autofocus", "".join(sections["Autofocus"])))
    # the same sections for every size: what a size has no figure for is said
    for name in ("Traces", "Motion estimation", "Images", "Trajectories"):
        body = "".join(sections.get(name, [])) or f'<p class="note">{_absent(name, doc)}</p>'
        parts.append(section(name, body))
    parts.append(section("Stationary targets", _stationary_html(doc)))
    timing_rows = [[html.escape(k), _fmt(v, 2)] for k, v in _stage_order(doc["timings_s"])]
    parts.append(
        section(
            "Timings",
            _html_table(["stage", "wall-clock (s)"], timing_rows)
            + (
                '<p class="note">Indented: the parts of the stage above them, not added to '
                "the total.</p>"
                if any("." in k for k in doc["timings_s"])
                else ""
            ),
        )
    )
    path = out / "report.html"
    found = (
        f"{len(doc['movers'])} mover(s){_beyond(doc)}, {len(doc['stationary'])} "
        "stationary target(s)"
    )
    path.write_text(page(title, header_line(found), parts), encoding="utf-8")
    return path


def _stage_order(timings: dict[str, float]) -> list[tuple[str, float]]:
    """The stages in their order, each one's parts (``stage.part``) under it, ``total`` last.

    A part is shown indented (an em space before its name): it is inside its stage's time.
    """
    stages = [k for k in timings if "." not in k and k != "total"]
    rows: list[tuple[str, float]] = []
    for k in stages:
        rows.append((k, timings[k]))
        rows += [
            ("\u2003" + p.split(".", 1)[1], timings[p]) for p in timings if p.startswith(k + ".")
        ]
    placed = {k for k in stages} | {p for p in timings if p.split(".", 1)[0] in stages}
    rows += [(k, v) for k, v in timings.items() if k not in placed and k != "total"]
    if "total" in timings:
        rows.append(("total", timings["total"]))
    return rows


def _patches(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """The plan's patches (a ``/1`` or ``/2`` document: none listed)."""
    return (doc.get("plan") or {}).get("patches") or []


def _absent(name: str, doc: dict[str, Any]) -> str:
    """Why a section has no figure, in words."""
    n = len(_patches(doc))
    if name in ("Traces", "Motion estimation") and n > 1:
        return (
            f"The {n} patches' traces and g(u) are not kept by a collection (each patch's "
            "analysis is let go once its movers and stationary targets are merged); "
            "results.json lists each patch's analysis in patch_summaries."
        )
    if name == "Trajectories":
        return "No trajectory estimated (no mover, or --no-trajectory)."
    if name == "Images":
        return "No image drawn."
    return "Not drawn."


def _patches_html(doc: dict[str, Any]) -> str:
    """The patch table: core, centre, traces, slow-time decimation, what each found."""
    summary = {p["index"]: p for p in doc.get("patch_summaries") or []}
    rows = []
    for p in _patches(doc):
        s = summary.get(p["index"], {})
        rows.append(
            [
                str(p["index"]),
                ", ".join(f"{v:.1f}" for v in p["core_m"]),
                _fmt(p["centre_m"], 1),
                f"{p['n_pulses']} &times; {p['n_samples']}",
                str(p["decimation"]),
                str(s.get("movers", "&ndash;")),
                (
                    "none: beyond the region, movers only"
                    if p.get("movers_only")
                    else str(s.get("stationary_listed", "&ndash;"))
                ),
            ]
        )
    head = ["patch", "core x0, y0, x1, y1 (m)", "centre (m)", "pulses &times; samples"]
    head += ["decimation", "movers", "stationary listed"]
    plan = doc.get("plan") or {}
    beyond = sum(bool(p.get("movers_only")) for p in _patches(doc))
    widened = (
        f" {beyond} of them lie beyond it and search for movers only: a mover's range speed "
        "shifts its image in cross range, here by up to "
        f"{plan.get('image_shift_m', float('nan')):.0f} m at the largest speed (dotted in "
        "the mosaic)."
        if beyond
        else ""
    )
    text = (
        f"<p>{len(rows)} patches of {plan.get('patch_size_m', float('nan')):.1f} m over the "
        f"region {_fmt(doc.get('region_m'), 1)} (x0, y0, x1, y1, m).{widened} A mover's "
        "range, family and speeds are measured from its kept patch's centre.</p>"
    )
    return text + _html_table(head, rows, escape_head=False)


def _region_rows(doc: dict[str, Any]) -> list[list[str]]:
    """The analysed region, its patches and what of a declared area lies outside the data."""
    plan = doc.get("plan")
    if not plan:
        return []
    n = len(plan.get("patches") or [])
    region = plan.get("region") or {}
    source = f" ({html.escape(str(region['source']))})" if region.get("source") else ""
    rows = [
        [
            "analysed region (m)",
            f"{_fmt(doc.get('region_m'), 1)} (x0, y0, x1, y1){source}; "
            + ("one patch" if n == 1 else f"{n} patches"),
        ]
    ]
    extent = doc.get("scene_extent_m")
    if n == 1 and extent:  # one analysis images its own square (options image_size_m)
        x0, x1, y0, y1 = extent
        rows.append(["imaged (m)", f"{_fmt([x0, y0, x1, y1], 1)} (x0, y0, x1, y1)"])
    scene = plan.get("unambiguous_scene")
    if isinstance(scene, dict) and scene.get("area_m2") is not None:
        corners = scene.get("corners_m") or []
        rows.append(
            [
                "data's unambiguous scene",
                f"{scene['area_m2']:.4g} m&sup2;, corners "
                + ", ".join(_fmt(list(c), 1) for c in corners)
                + " (m)",
            ]
        )
    outside = plan.get("outside")
    if isinstance(outside, dict) and "area_m2" in outside:
        rows.append(
            [
                "declared area outside the unambiguous scene",
                f"{outside['area_m2']:.4g} m&sup2; ({100.0 * outside.get('share', 0.0):.1f} %), "
                "not analysed",
            ]
        )
    return rows


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
    text = '<span class="info">not determined by the data</span>'
    if seg:
        p, v = seg["positions_m"], seg["velocities_mps"]
        text += (
            f"; family across the scene from {_fmt(p[0])} m at {_fmt(v[0])} m/s "
            f"to {_fmt(p[-1])} m at {_fmt(v[-1])} m/s"
        )
    elif "in_scene" in fam:
        text += "; the family does not cross the imaged scene"
    return text


def range_speed_text(m: dict[str, Any], *, html_out: bool = True) -> str:
    """A mover's range speed, its standard error and its span across the scene.

    The standard error is conditional on the listed member's cross range; the family's
    members across the scene (``cross_range_family.range_speed_span_mps``) fit the data as
    well, so the span is what the data leave of the range speed (absent in ``/1`` and
    ``/2`` documents).
    """
    pm = "&plusmn;" if html_out else "+-"
    e = m.get("standard_errors") or {}
    text = f"{m['range_speed_mps']:.3f}"
    if "range_speed_mps" in e:
        text += f" {pm} {e['range_speed_mps']:.2g} m/s at the listed cross range"
    span = (m.get("cross_range_family") or {}).get("range_speed_span_mps")
    if span and not m.get("cross_range_known"):
        text += f"; {span[0]:.2f} to {span[1]:.2f} m/s across the scene"
    return text


def _movers_html(doc: dict[str, Any]) -> str:
    """The table of estimated movers (estimates only; truth has its own tables)."""
    several = len(_patches(doc)) > 1
    rows = []
    for k, m in enumerate(doc["movers"]):
        fam = m["cross_range_family"]
        image = m.get("image")
        row = [
            str(k + 1),
            _range_cell(m),
            range_speed_text(m),
            "yes" if m.get("cross_range_known") else "no",
            _family_cell(m),
            _fmt(m.get("position_std_m"), 1),
            _fmt(m["position_m"]),
            _fmt(m["velocity_mps"]),
            _fmt(m["cross_range_speed_mps"], 3),
            _detection_cell(m),
            _errors_cell(m),
            _fmt(m["peak_db"], 1),
            _fmt(fam["position_per_m"], 3) + " / " + _fmt(fam["velocity_mps_per_m"], 4),
            f"{html.escape(image)} (mover {k + 1})" if image else "&ndash;",
        ]
        if several:
            row += [str(m.get("patch", "&ndash;")), _fmt(m.get("patches"), 0)]
        rows.append(row)
    if not rows:
        if doc.get("movers_not_estimated"):
            return "<p>No mover estimated: see the candidates not estimated below.</p>"
        return "<p>No mover found: no candidate passed the detector.</p>"
    reference = "its patch's centre" if several else "the reference point"
    head = [
        "estimate",
        "range (m) &plusmn; standard error",
        "range speed (m/s) &plusmn; standard error; span across the scene",
        "cross range known",
        "cross range",
        "position spread along the family in the scene (m, standard deviation)",
        f"position at s=0, at the cross range of {reference} (m)",
        "velocity there (m/s)",
        "cross-range speed there (m/s)",
        "detection: statistic / threshold (dB), p, focus gain (dB)",
        "standard errors: range position (m), range speed, cross-range speed (m/s); SNR (dB)",
        "image peak (dB re the stationary image's peak)",
        "family, per m of cross-range offset: position (m/m) / velocity (m/s per m)",
        "image",
    ]
    if several:
        head += ["patch kept", "found in patches"]
    conditional = next(
        (
            m["standard_errors"].get("conditional_on")
            for m in doc["movers"]
            if m.get("standard_errors")
        ),
        None,
    )
    cond = (
        f" The standard errors (Cramér–Rao bound at the measured SNR) are conditional on "
        f"{html.escape(conditional)}."
        if conditional
        else ""
    )
    return _html_table(head, rows, escape_head=False) + (
        f'<p class="note">Range: the ground-range coordinate from {reference} '
        "(positive towards the radar), what the data fix. The data of a few degrees do not "
        "fix a mover's cross-range position: position + t a and velocity + t b fit them as "
        "well for any t metres of cross-range offset (a, b in the family column; "
        "sarmotion.motion.aperture), and the figures draw each mover as that family across "
        "the scene. Position, velocity and cross-range speed are those of the member at "
        f"the cross range of {reference}; the span is the range speed of the family's "
        f"members across the scene.{cond}</p>"
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
    opts = doc.get("options", {})
    cap = opts.get("analysis", opts).get("max_movers")
    per_patch = " per patch" if len(_patches(doc)) > 1 else ""
    threshold = (doc.get("detection") or {}).get("threshold_db")
    over = f" (threshold {threshold:.1f} dB)" if threshold is not None else ""
    head = ["candidate", "statistic (dB)", "range (m)", "range speed (m/s)"]
    head += ["width (resolutions)"]
    return (
        f"<h3>Detected, not estimated: {len(extra)} candidate(s) beyond max_movers = {cap}"
        f"{per_patch}</h3>"
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
        "offset: what the data can resolve. The standard errors in the table above are "
        "conditional on the listed member's cross range, so an error along the family "
        "may be many of them; the range-speed span across the scene bounds it.</p>"
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
    counts = [
        (doc.get("stationary_dropped", 0), "beyond the cap"),
        (sidelobes, "dropped as a brighter target's sidelobes"),
        (
            doc.get("stationary_mover_images_dropped", 0),
            "dropped as lying on a mover's echo (its smear over the stationary image)",
        ),
    ]
    said = [f"{n} {why}" for n, why in counts if n]
    if said:  # the same account for every size, as on the console
        text += f'<p class="note">Not listed: {", ".join(said)}.</p>'

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
    opts = doc["options"].get("analysis", doc["options"])
    sub = float(opts.get("sub_aperture_deg", doc["aperture_deg"]))
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
    acq += _region_rows(doc)
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
