"""The Python API after ``analyze``: a short repr, a summary, ``save`` and ``save_report``.

The analysis of a scene of one patch (``sarmotion.analyze(...).single_result``).

``sarmotion.save`` writes what ``sarmotion analyze --out`` writes (the command calls it);
``sarmotion.save_report`` the report alone. Printing a result is a line, not the arrays
behind it; the summary says what the data fix (range offset and speeds, with their
standard errors) and what they do not (the cross-range position).
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

import sarmotion
from sarmotion.cli.main import run
from sarmotion.core.geometry import range_speed
from sarmotion.io.staging import OutputError

#: A number printed as minus zero: "-0.00" not followed by another digit.
NEGATIVE_ZERO = re.compile(r"-0\.0+(?![0-9])")


@pytest.fixture(scope="module")
def scene1():
    sim = sarmotion.simulate(sarmotion.load_scene("scene1"))
    collection = sarmotion.analyze(sim.traces, sarmotion.AnalysisOptions(trajectory=False))
    assert len(collection.plan.patches) == 1  # Scene 1 is one patch: the analysis itself
    return sim, collection.single_result


def test_repr_is_a_line_with_the_counts_and_the_time(scene1):
    _, result = scene1
    text = repr(result)
    assert "\n" not in text and len(text) < 200, text
    tr = result.traces
    assert f"{tr.n_pulses} pulses x {tr.n_samples} samples" in text
    assert f"{len(result.movers)} mover(s)" in text
    assert f"{len(result.stationary)} stationary target(s)" in text
    assert f"{result.timings_s['total']:.2f} s" in text
    for m in result.movers:
        assert "\n" not in repr(m) and len(repr(m)) < 200
        assert f"range_speed_mps={m.range_speed_mps:.2f}" in repr(m)


def test_summary_gives_range_offsets_within_a_resolution_cell_and_says_cross_range_is_unknown(
    scene1,
):
    sim, result = scene1
    text = result.summary()
    lines = text.splitlines()
    assert 5 <= len(lines) <= 10 + 3 * len(result.movers), text
    assert not NEGATIVE_ZERO.search(text), text
    assert "cross range: not known" in text
    assert f"{len(result.stationary)} stationary target(s)" in text
    # Each mover's range offset is (truth - rho_o) . b to within a range resolution
    # cell c / (2 B): the data fix it, whatever the cross-range position.
    geometry = result.traces.geometry
    b = geometry.ground_m_o / np.linalg.norm(geometry.ground_m_o)
    rho_o = result.traces.reference_point_m[:2]
    resolution_m = 299_792_458.0 / (2.0 * result.traces.radar.bandwidth_hz)
    offsets = [float(v) for v in re.findall(r"range offset (-?\d+\.\d+)", text)]
    assert len(offsets) == len(result.movers) == 2
    movers = [t for t in sim.scene.targets if np.any(t.velocity_mps)]
    for k, m in enumerate(result.movers):
        assert f"range speed {m.range_speed_mps:.2f}" in text
        assert f"cross-range speed {m.cross_range_speed_mps:.2f}" in text
        assert f"statistic {m.evidence.statistic_db:.1f} dB" in text
        truth = min(
            movers, key=lambda t: abs(range_speed(t.velocity_mps, geometry) - m.range_speed_mps)
        )
        assert abs(offsets[k] - float((truth.position_m[:2] - rho_o) @ b)) < resolution_m


def test_a_positive_range_speed_closes_the_range(scene1):
    """The sign the help and the summary state: u . m_o > 0 moves towards the radar."""
    _, result = scene1
    tr = result.traces
    geometry = tr.geometry
    antenna = tr.trajectory.centre_m
    rho_o = np.asarray(tr.reference_point_m, dtype=float)
    for u in (np.array([3.0, 1.0]), np.array([-2.0, 4.0])):
        ds = 1e-3  # s: the range changes at the rate -u . m_o
        moved = rho_o + ds * np.array([u[0], u[1], 0.0])
        closing = np.linalg.norm(antenna - rho_o) - np.linalg.norm(antenna - moved)
        assert np.sign(closing) == np.sign(range_speed(u, geometry))
        assert closing / ds == pytest.approx(range_speed(u, geometry), rel=1e-3)


def test_save_writes_what_analyze_writes_and_refuses_to_overwrite(scene1, tmp_path):
    sim, result = scene1
    out = tmp_path / "api"
    doc = sarmotion.save(result, out, scene=sim.scene, inputs=["scene1"])
    names = {p.name for p in out.iterdir()}
    assert names == {
        "results.json",
        "report.html",
        "traces.png",
        "objectives.png",
        "images.png",
        "movers.png",
    }
    saved = json.loads((out / "results.json").read_text())
    assert saved == json.loads(json.dumps(doc))
    assert saved["inputs"] == ["scene1"] and "truth" in saved and saved["point_quality"]
    # The command writes the same files, with the same keys.
    cli = tmp_path / "cli"
    assert run(["-q", "analyze", "scene1", "--no-trajectory", "--out", str(cli)]) == 0
    assert {p.name for p in cli.iterdir()} == names
    cli_doc = json.loads((cli / "results.json").read_text())
    assert set(cli_doc) == set(saved)
    assert [set(m) for m in cli_doc["movers"]] == [set(m) for m in saved["movers"]]
    # An existing output is kept unless force.
    before = (out / "results.json").read_bytes()
    with pytest.raises(OutputError, match="--force|exists|already"):
        sarmotion.save(result, out)
    assert (out / "results.json").read_bytes() == before
    sarmotion.save(result, out, force=True)
    assert "truth" not in json.loads((out / "results.json").read_text())


def test_save_report_writes_the_report_alone(scene1, tmp_path):
    _, result = scene1
    path = sarmotion.save_report(result, tmp_path / "r", title="scene 1 by hand")
    assert path == tmp_path / "r" / "report.html"
    text = path.read_text()
    assert "<title>scene 1 by hand</title>" in text and "data:image/png;base64," in text
    assert not (tmp_path / "r" / "results.json").exists()


def test_report_legends_are_legible(scene1):
    """Every legend of the report's figures is set at 8 pt or more (LEGEND_PT)."""
    from sarmotion.report.html import (
        images_figure,
        movers_figure,
        objectives_figure,
        trajectories_figure,
    )

    _, result = scene1
    sizes = []
    for fig in (
        objectives_figure(result),
        images_figure(result),
        movers_figure(result),
        trajectories_figure(result),
    ):
        for ax in fig.axes:
            legend = ax.get_legend()
            if legend is not None:
                sizes += [t.get_fontsize() for t in legend.get_texts()]
    assert len(sizes) >= 5 and min(sizes) >= 8.0, sizes


#: Width (CSS px) of the report's column: main's 1400 px less its padding (2 x 32) and a
#: section's padding and border (2 x 20 + 2); a wider PNG is shown scaled down to it.
REPORT_COLUMN_PX = 1400 - 64 - 42


def test_report_legends_read_at_8_pt_as_the_page_shows_them(scene1, tmp_path):
    """A legend's displayed size: LEGEND_PT x (PNG dpi / 96 CSS px per inch) x the scale
    the page applies to the PNG (its width against the column), in CSS points."""
    import base64
    import io

    from PIL import Image

    from sarmotion.report.plotting import LEGEND_PT

    sim, result = scene1
    text = sarmotion.save_report(result, tmp_path / "r", scene=sim.scene).read_text()
    shown = {}
    for alt, data in re.findall(r'<img alt="([^"]*)" src="data:image/png;base64,([^"]+)"', text):
        png = Image.open(io.BytesIO(base64.b64decode(data)))
        scale = min(1.0, REPORT_COLUMN_PX / png.width)
        shown[alt[:20]] = LEGEND_PT * png.info["dpi"][0] / 96.0 * scale
    with_legends = [k for k in shown if k.startswith(("g(u) with", "Each mover imaged"))]
    assert len(with_legends) == 2, shown
    assert min(shown[k] for k in with_legends) >= 8.0 - 0.05, shown


def test_the_alias_free_extent_options_are_checked_and_recorded_only_when_given():
    from sarmotion.pipeline import AnalysisOptions

    plain = AnalysisOptions().to_dict()
    assert "alias_free_extent_m" not in plain and "alias_free_centre_m" not in plain
    given = AnalysisOptions(alias_free_extent_m=500.0, alias_free_centre_m=np.array([1.0, -2.0]))
    assert given.alias_free_centre_m == (1.0, -2.0)
    d = given.to_dict()
    assert d["alias_free_extent_m"] == 500.0 and d["alias_free_centre_m"] == [1.0, -2.0]
    json.dumps(d)
    with pytest.raises(ValueError, match="alias_free_extent_m"):
        AnalysisOptions(alias_free_extent_m=0.0)
    with pytest.raises(ValueError, match="alias_free_centre_m"):
        AnalysisOptions(alias_free_centre_m=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="alias_free_centre_m"):
        AnalysisOptions(alias_free_centre_m=(np.nan, 2.0))


def test_the_wide_defocus_search_is_recorded_only_when_on():
    # Off (the default) it is left out, as documents were before the option; on, the
    # results schema's analysis options admit it as a boolean, not required.
    from sarmotion.documents.schema import load_schema
    from sarmotion.pipeline import AnalysisOptions

    assert "wide_defocus_search" not in AnalysisOptions().to_dict()
    assert AnalysisOptions(wide_defocus_search=True).to_dict()["wide_defocus_search"] is True

    def holders(node):
        if isinstance(node, dict):
            if "defocus_search" in node.get("properties", {}):
                yield node
            for v in node.values():
                yield from holders(v)
        elif isinstance(node, list):
            for v in node:
                yield from holders(v)

    found = list(holders(load_schema("sarmotion.results/3")))
    assert found
    for node in found:
        assert node["properties"]["wide_defocus_search"]["type"] == "boolean"
        assert "wide_defocus_search" not in node.get("required", [])
