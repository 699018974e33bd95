"""The HTML report: numbers as printed, captions without truth on measured data, layout."""

from __future__ import annotations

import pytest

from sarmotion.pipeline import AnalysisOptions, analyze
from sarmotion.report.html import _fmt, _merged_stationary, write_report
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
