"""The HTML report: numbers as printed, captions without truth on measured data, layout."""

from __future__ import annotations

import io

import pytest

from sarmotion.pipeline import AnalysisOptions, analyze
from sarmotion.report.html import _fmt, _merged_stationary, _stationary_html, write_report
from sarmotion.simulation import load_scene, simulate


def test_no_negative_zero():
    assert _fmt(-0.0001) == "0.00"
    assert _fmt(-0.004, 2) == "0.00"
    assert _fmt(-0.006, 2) == "-0.01"
    assert _fmt([-0.0, 1.234]) == "(0.00, 1.23)"


def test_stationary_detections_within_half_a_metre_merge_into_the_brightest():
    found = [
        {"position_m": [-15.6, 21.6], "peak_db": 0.0},
        {"position_m": [-15.3, 21.9], "peak_db": -6.0},  # 0.42 m away: merged
        {"position_m": [-27.8, 38.8], "peak_db": -3.0},
        {"position_m": [-27.8, 39.4], "peak_db": -9.0},  # 0.6 m away: kept
    ]
    kept = _merged_stationary(found)
    assert [k["peak_db"] for k in kept] == [0.0, -3.0, -9.0]


def test_the_sidelobes_left_out_of_the_listing_are_counted():
    doc = {"stationary": [{"position_m": [-15.6, 21.6], "peak_db": 0.0}]}
    assert "not listed" not in _stationary_html(doc)
    doc["stationary_sidelobes_dropped"] = 3
    assert "3 local maxima of the stationary image that a brighter target's sidelobes " in (
        _stationary_html(doc)
    )


@pytest.fixture(scope="module")
def no_mover_report(tmp_path_factory):
    """A report without truth (as for measured data) and without movers."""
    sim = simulate(load_scene("hyperbola"))
    result = analyze(sim.traces, AnalysisOptions(max_movers=0, trajectory=False))
    out = tmp_path_factory.mktemp("report")
    write_report(result, out, inputs=["hyperbola"])
    return out, (out / "report.html").read_text()


def test_report_without_truth_has_no_truth_captions_and_no_empty_mover_panel(no_mover_report):
    out, text = no_mover_report
    assert "truth" not in text.lower()
    assert not (out / "movers.png").exists()
    assert "No mover found" in text


def test_report_gives_the_aperture_in_degrees(no_mover_report):
    _, text = no_mover_report
    assert "deg of azimuth" in text and "movers sought on" in text


@pytest.fixture(scope="module")
def scene1_report(tmp_path_factory):
    """Scene 1 with its truth: two movers."""
    from sarmotion.documents import results_document
    from sarmotion.pipeline import compare_with_truth

    sim = simulate(load_scene("scene1"))
    result = analyze(sim.traces, AnalysisOptions(trajectory=False))
    doc = results_document(result, truth=compare_with_truth(result, sim.scene))
    out = tmp_path_factory.mktemp("scene1")
    write_report(result, out, document=doc, inputs=["scene1"])
    return result, doc, (out / "report.html").read_text()


def test_estimates_and_true_targets_are_named_apart(scene1_report):
    _, doc, text = scene1_report
    assert "matched estimate" in text and "true target" in text
    assert "per m of cross-range offset: position (m/m) / velocity (m/s per m)" in text
    assert "triangles: truth" in text  # truth markers are explained when there is truth


def test_trajectory_error_axis_is_linear_and_trace_ticks_legible(scene1_report):
    from sarmotion.report.html import traces_panels_figure, trajectories_figure

    result, doc, _ = scene1_report
    truth = {"truth": doc["truth"], "errors": [m.get("errors") for m in doc["movers"]]}
    ax = trajectories_figure(result, truth=truth).axes[0]
    assert ax.get_yscale() == "linear"
    fig = traces_panels_figure(result)
    sizes = {t.get_fontsize() for a in fig.axes for t in a.get_xticklabels()}
    assert min(sizes) >= 10


def _legend_figure(width_in: float, legend_pt: float = 8.0):
    """Three panels side by side with a legend of ``legend_pt`` (tight layout)."""
    from sarmotion.report.plotting import subplots

    fig, axes = subplots(1, 3, figsize=(width_in, width_in / 3.5))
    for ax in axes:
        ax.plot([0, 1], [0, 1], label="a line")
        ax.set_xlabel("x (m)")
        ax.legend(fontsize=legend_pt)
    fig.tight_layout()
    return fig


def test_smallest_text_counts_tick_labels_legends_and_titles():
    from sarmotion.report.plotting import smallest_text_pt

    fig = _legend_figure(9.0, legend_pt=8.0)
    assert smallest_text_pt(fig) == 8.0
    fig.axes[1].tick_params(labelsize=6.5)  # tick labels exist only once drawn
    assert smallest_text_pt(fig) == 6.5
    fig.axes[2].set_title("t", fontsize=5.0)
    assert smallest_text_pt(fig) == 5.0
    fig.axes[2].set_visible(False)  # an unused panel's text is not shown
    assert smallest_text_pt(fig) == 6.5


def test_a_wide_figure_is_shrunk_until_its_legends_read_at_8_pt_in_the_column():
    """17 in at 150 dpi shown in a 1055-px column: an 8-pt legend shows at about 5 pt.
    Shrunk, the PNG is at most 1055 x 150 / 96 px wide, so that the legend (still set at
    8 pt, 8 x 150 / 96 CSS pt at natural size) shows at 8 pt or more."""
    from sarmotion.report.plotting import displayed_pt, fit_to_column, saved_width_px

    dpi, column = 150, 1055
    fig = _legend_figure(17.0)
    before = displayed_pt(8.0, dpi=dpi, width_px=saved_width_px(fig, dpi=dpi), column_px=column)
    assert before < 6.0
    shown = fit_to_column(fig, dpi=dpi, column_px=column)
    width = saved_width_px(fig, dpi=dpi)
    assert shown == displayed_pt(8.0, dpi=dpi, width_px=width, column_px=column)
    # legible, and not shrunk further than needed (the last step is 1 % under the ratio,
    # the text's share of the width makes the PNG shrink by less than the figure)
    assert 8.0 <= shown < 8.0 * 1.05
    assert width <= column * 150 / 96
    assert {t.get_fontsize() for ax in fig.axes for t in ax.get_legend().get_texts()} == {8.0}
    # a figure already legible is left as it is
    narrow = _legend_figure(9.0)
    size = tuple(narrow.get_size_inches())
    assert fit_to_column(narrow, dpi=dpi, column_px=column) >= 8.0
    assert tuple(narrow.get_size_inches()) == size


#: A table with its header row and nothing under it.
_EMPTY_TABLE = r"<table><tr>(?:<th>.*?</th>)+</tr></table>"


def test_a_simulated_scene_without_movers_says_so_instead_of_empty_tables(tmp_path):
    """The hyperbola scene (one stationary target) with its truth: nothing to tabulate."""
    import re

    from sarmotion.documents import results_document
    from sarmotion.pipeline import compare_with_truth
    from sarmotion.report.html import write_html

    sim = simulate(load_scene("hyperbola"))
    result = analyze(sim.traces, AnalysisOptions(trajectory=False))
    assert not result.movers and not sim.scene.moving
    doc = results_document(result, truth=compare_with_truth(result, sim.scene))
    text = write_html(doc, tmp_path).read_text()
    assert "<h3>Truth</h3><p>The scene has no movers.</p>" in text
    assert "No mover was estimated, so there are no errors to show." in text
    assert not re.search(_EMPTY_TABLE, text), re.search(_EMPTY_TABLE, text)[0]


def test_movers_missed_are_listed_and_the_errors_table_gives_way_to_a_sentence(
    scene1_report, tmp_path
):
    """Scene 1's truth with no mover estimated: both true movers listed as missed."""
    import re

    from sarmotion.report.html import write_html

    _, doc, _ = scene1_report
    none = {**doc, "movers": [], "false_movers": 0, "missed_movers": len(doc["truth"])}
    text = write_html(none, tmp_path).read_text()
    assert text.count("<td>missed</td>") == len(doc["truth"]) == 2
    assert "No mover was estimated, so there are no errors to show." in text
    assert "The scene has no movers." not in text
    assert not re.search(_EMPTY_TABLE, text)


@pytest.mark.parametrize("n", [1, 3, 6])
def test_mover_images_keep_legible_legends_for_any_number_of_movers(scene1_report, n, tmp_path):
    """Scene 1's two movers repeated to ``n``: every mover drawn, in rows whose PNG shows
    its smallest text (legends, tick labels) at 8 pt or more in the report's column."""
    import dataclasses

    from PIL import Image

    from sarmotion.report.html import COLUMN_PX, _png, movers_figure
    from sarmotion.report.plotting import displayed_pt, smallest_text_pt

    result, doc, _ = scene1_report
    movers = tuple(result.movers[k % 2] for k in range(n))
    many = dataclasses.replace(result, movers=movers)
    many_doc = {**doc, "movers": [doc["movers"][k % 2] for k in range(n)]}
    fig = movers_figure(many, document=many_doc)
    images = [ax for ax in fig.axes if ax.get_visible() and ax.get_images()]
    assert len(images) == n  # each mover's image
    assert sum(ax.get_legend() is not None for ax in fig.axes) == n
    png = Image.open(io.BytesIO(_png(fig, tmp_path / "movers.png")))
    shown = displayed_pt(
        smallest_text_pt(fig), dpi=png.info["dpi"][0], width_px=png.width, column_px=COLUMN_PX
    )
    assert shown >= 8.0 - 0.01, (n, png.size, shown)


def test_timings_list_each_stages_parts_under_it_and_the_total_last():
    from sarmotion.report.html import _stage_order

    timings = {"a": 1.0, "movers": 3.0, "total": 4.0, "movers.fit": 2.0, "movers.x": 0.5}
    rows = _stage_order(timings)
    names = [k.strip("\u2003") for k, _ in rows]
    assert names == ["a", "movers", "fit", "x", "total"]
    assert [v for _, v in rows] == [1.0, 3.0, 2.0, 0.5, 4.0]
    # the stages (not their parts) add up to the total
    assert sum(v for k, v in rows if not k.startswith("\u2003") and k != "total") == 4.0
