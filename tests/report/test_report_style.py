"""The reports' figures and pages: the look-direction arrow, one page style, the track map.

The arrow is checked against the geometry itself: the ground vector from the antenna at
the aperture centre (``s = 0``, interpolated between pulses) to the reference point, for
a GOTCHA circle and for a squinted straight flight seen from another side of the scene.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from matplotlib.patches import Ellipse
from matplotlib.text import Annotation

from sarmotion.collection import CollectionOptions, analyze_collection
from sarmotion.documents import results_document
from sarmotion.pipeline import AnalysisOptions, analyze
from sarmotion.report.analysis_figures import images_figure, movers_figure
from sarmotion.report.collection import mosaic_figure
from sarmotion.report.plotting import LOOK_ARROW_GID, LOOK_LABEL
from sarmotion.simulation import load_scene, simulate

#: Largest angle (deg) between the drawn arrow and the look direction.
TOL_DEG = 1.0

_AZIMUTH_DEG, _SQUINT_DEG = 215.0, 25.0


def _squinted_spec() -> dict:
    """A straight flight 7 km from the scene on the ground at azimuth 215 degrees,
    7 km up, 25 degrees off broadside: the look is neither along an axis nor normal to
    the flight."""
    a, sq = np.radians(_AZIMUTH_DEG), np.radians(_SQUINT_DEG)
    out = np.array([np.cos(a), np.sin(a)])  # from the scene towards the antenna
    broadside = np.array([-out[1], out[0]])
    d = np.cos(sq) * broadside + np.sin(sq) * out
    return {
        "kind": "linear",
        "centre_m": [7000.0 * out[0], 7000.0 * out[1], 7000.0],
        "direction": [d[0], d[1], 0.0],
        "aperture_m": 175.0,
        "pulse_spacing_m": 1.5,
        "speed_mps": 70.0,
    }


def _expected_look(traces) -> np.ndarray:
    """Unit ground vector from the antenna at s = 0 to the reference point."""
    s = traces.slow_times_s
    antenna = np.array([np.interp(0.0, s, traces.positions_m[:, k]) for k in range(3)])
    g = np.asarray(traces.reference_point_m, dtype=float)[:2] - antenna[:2]
    return g / np.hypot(*g)


@pytest.fixture(scope="module", params=["gotcha", "squinted"])
def geometry(request):
    """Scene 1 seen from the geometry: traces, collection, analysis and its document."""
    scene = load_scene("scene1")
    if request.param == "squinted":
        scene = dataclasses.replace(scene, trajectory_spec=_squinted_spec())
    traces = simulate(scene).traces
    options = AnalysisOptions(trajectory=False)
    collection = analyze_collection(
        traces,
        CollectionOptions(analysis=options),
        region_m=_REGION,
        n_workers=0,
        describe=lambda r: results_document(r)["movers"],  # as the command line does
    )
    result = collection.single_result or analyze(traces, options)
    return traces, collection, result, results_document(result)


#: Region of the collections: Scene 1's targets (every coordinate within 24.0 m), inside
#: the squinted flight's unambiguous scene (the box along x and y in it is +-28.3 m).
_REGION = (-26.0, -26.0, 26.0, 26.0)


def _angle_deg(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    c = np.dot(a, b) / (np.hypot(*a) * np.hypot(*b))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def _arrows(ax) -> list[Annotation]:
    return [a for a in ax.texts if isinstance(a, Annotation) and a.get_gid() == LOOK_ARROW_GID]


def _check_arrow(ax, look) -> None:
    """One arrow on ``ax`` along ``look`` (data coordinates), labelled, inside the axes."""
    arrows = _arrows(ax)
    assert len(arrows) == 1, [t.get_text() for t in ax.texts]
    arrow = arrows[0]
    drawn = np.subtract(arrow.xy, arrow.xyann)  # tail (xytext) to head (xy)
    assert _angle_deg(drawn, look) < TOL_DEG, (drawn, look)
    assert arrow.arrow_patch is not None
    assert any(t.get_text() == LOOK_LABEL for t in ax.texts)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    for x, y in (arrow.xy, arrow.xyann):
        assert min(x0, x1) < x < max(x0, x1) and min(y0, y1) < y < max(y0, y1)


def test_image_figures_of_the_analysis_report_show_the_look_direction(geometry):
    traces, _, result, doc = geometry
    look = _expected_look(traces)
    fig = images_figure(result, doc)
    panels = [ax for ax in fig.axes if ax.get_images() and ax.get_xlabel() == "x (m)"]
    assert len(panels) == 2
    for ax in panels:
        _check_arrow(ax, look)
    assert result.movers  # the mover images are drawn
    fig = movers_figure(result, document=doc)
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_images()]
    assert len(panels) == len(result.movers)
    for ax in panels:
        _check_arrow(ax, look)


def test_collection_mosaic_shows_the_look_direction(geometry):
    traces, collection, _, _ = geometry
    _check_arrow(mosaic_figure(collection).axes[0], _expected_look(traces))


def test_image_command_draws_the_look_direction(geometry, tmp_path, monkeypatch):
    """``sarmotion image``: image.png's figure carries the arrow."""
    import sarmotion.cli.image as image_cli
    from sarmotion.cli.main import run
    from sarmotion.io import save_traces

    traces, *_ = geometry
    made = []

    def keep(*args, **kwargs):
        made.append(image_cli_figure(*args, **kwargs))
        return made[-1]

    image_cli_figure = image_cli.full_resolution_image_figure
    monkeypatch.setattr(image_cli, "full_resolution_image_figure", keep)
    path = save_traces(tmp_path / "traces.h5", traces)
    code = run([image_cli.image.name, str(path), "--out", str(tmp_path / "out")] + _SMALL)
    assert code == 0
    assert (tmp_path / "out" / "image.png").is_file() and len(made) == 1
    _check_arrow(made[0].axes[0], _expected_look(traces))


_SMALL = ["--size", "20", "--spacing", "0.5"]


# ------------------------------------------------------------------ one page style
def _style(text: str) -> str:
    return re.search(r"<style>(.*?)</style>", text, re.S)[1]


def _skeleton(text: str) -> list[str]:
    """The page's structure: its tags in order, down to the sections' headings."""
    body = text.split("<main>", 1)[0] + "<main>"
    return re.findall(r"<(/?(?:html|head|title|style|body|header|h1|p|main))\b", body)


def test_analysis_track_and_collection_reports_share_one_page_style(geometry, tmp_path):
    """One stylesheet, one header (title, then version, time, what was found), the body
    in sections; figures captioned alike."""
    from sarmotion.core.blocks import TracesBlocks
    from sarmotion.documents.results import collection_document
    from sarmotion.report.analysis_figures import write_report
    from sarmotion.report.collection import write_collection_report
    from sarmotion.report.page import CSS
    from sarmotion.report.tracks import write_tracks_report

    traces, collection, result, doc = geometry
    for name in ("analysis", "tracks", "collection"):
        (tmp_path / name).mkdir()
    analysis = write_report(result, tmp_path / "analysis", document=doc).read_text()
    tracking = _tracking_result(on_road=False)
    track_doc = {"tracks": [], "sub_apertures": []}
    tracks = write_tracks_report(tracking, tmp_path / "tracks", document=track_doc)[1]
    write_collection_report(
        collection,
        tmp_path / "collection",
        document=collection_document(collection, TracesBlocks(traces)),
        title="collection",
    )
    pages = [analysis, tracks.read_text(), (tmp_path / "collection/report.html").read_text()]
    assert [_style(p) for p in pages] == [CSS] * 3
    assert [_skeleton(p) for p in pages] == [_skeleton(analysis)] * 3
    for text in pages:
        assert re.search(r"<header><h1>[^<]+</h1><p>sarmotion [^<]+ &middot; \d{4}-", text)
        assert "<section><h2>" in text and text.rstrip().endswith("</main></body></html>")
        figures = re.findall(
            r'<img alt="[^"]+" src="data:image/png;base64,[^"]+"><p class="note">', text
        )
        assert figures  # every figure with its caption under it
    assert pages[0].count("<section><h2>Timings</h2><table>") == 1
    assert pages[1].count("<section><h2>Timings</h2><table>") == 1


# ------------------------------------------------------------------ the track map
def _tracking_result(*, on_road: bool):
    """One track of two states (test_results_known's): long ellipses, or on a road."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "documents"))
    from test_results_known import _tracking_result as made

    return made(on_road)


def test_track_report_timings_give_the_total_first_and_the_summed_analysis_as_worker_time(
    tmp_path,
):
    """Analyses summed over parallel workers (111.54 s) exceed the wall-clock total (62.80 s):
    the total comes first, the sum is labelled worker time and not a part of the total,
    and the wall-clock rows after the total add up to no more than it."""
    from sarmotion.report.tracks import timing_rows, write_tracks_report

    tracking = dataclasses.replace(
        _tracking_result(on_road=False), timings_s={"analysis": 111.54, "total": 62.80}
    )
    document = {"tracks": [], "sub_apertures": [{}] * 12}
    text = write_tracks_report(tracking, tmp_path, document=document)[1].read_text()
    timings = re.search(r"<h2>Timings</h2>(.*?)</section>", text, re.S)[1]
    assert "<th>time</th><th>s</th><th>what it counts</th>" in timings
    rows = re.findall(r"<tr><td>(.*?)</td><td>(.*?)</td><td>(.*?)</td></tr>", timings)
    assert [r[:2] for r in rows] == [("total", "62.80"), ("analysis (worker time)", "111.54")]
    assert "wall-clock" in rows[0][2]
    assert "12 sub-apertures" in rows[1][2] and "summed" in rows[1][2]
    assert "not a part of the total" in rows[1][2] and "1.8 x the total" in rows[1][2]
    # any further stage is wall-clock time within the total
    rows = timing_rows({"total": 10.0, "analysis": 8.0, "association": 1.5, "mean": 0.5}, 3)
    assert rows[0][0] == "total" and "0.8 x the total" in rows[1][2]
    parts = [float(r[1]) for r in rows[1:] if "worker time" not in r[0]]
    assert parts == [1.5, 0.5] and sum(parts) <= float(rows[0][1])


@pytest.mark.parametrize("on_road", [False, True])
def test_track_map_ellipses_are_filled_with_a_solid_edge_and_named(on_road):
    """Each 1-sigma ellipse: a translucent fill, an opaque edge of 1.2 pt or more in the
    track's colour, under the markers; the legend says what they are."""
    from matplotlib.colors import to_rgba

    from sarmotion.report.tracks import tracks_figure

    result = _tracking_result(on_road=on_road)
    ax = tracks_figure(result).axes[0]
    ellipses = [p for p in ax.patches if isinstance(p, Ellipse)]
    assert ellipses
    track_line = next(ln for ln in ax.get_lines() if ln.get_label() == "track 1")
    colour = to_rgba(track_line.get_color())
    markers = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
    for e in ellipses:
        face, edge = e.get_facecolor(), e.get_edgecolor()
        assert 0.0 < face[3] < 0.5  # the image and the other ellipses show through
        assert edge[3] == 1.0 and e.get_linewidth() >= 1.2
        np.testing.assert_allclose(edge[:3], colour[:3])
        assert all(e.get_zorder() < m.get_zorder() for m in markers)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "1\u03c3 uncertainty (long along the cross-range family)" in labels
