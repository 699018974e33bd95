"""What the data fix of a mover, said everywhere; nothing detected dropped; results.json documented.

Over a degree a mover's data fix its range history, not its cross-range position
(:mod:`sarmotion.motion.aperture`). The console, results.json and the report must say so
(range with its error, cross range unknown, the family across the scene); the candidates
beyond ``--max-movers`` must be counted and listed; results.json must validate against
the schema shipped in the package (``sarmotion/documents/schemas/results.json``), which
must describe every key.
"""

from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest

from sarmotion.documents import RESULTS_SCHEMA
from sarmotion.documents.schema import load_schema
from sarmotion.imaging import resolution
from sarmotion.motion.aperture import ranges_m
from sarmotion.simulation import load_scene, simulate

jsonschema = pytest.importorskip("jsonschema")

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = load_schema(RESULTS_SCHEMA)


@pytest.fixture(scope="module")
def scene1():
    return simulate(load_scene("scene1"))


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """``sarmotion demo``: Scene 1, two movers, trajectories; its console, results.json, report."""
    out = tmp_path_factory.mktemp("demo") / "run"
    from click.testing import CliRunner

    from sarmotion.cli.main import main

    res = CliRunner().invoke(main, ["demo", "--out", str(out)])
    assert res.exit_code == 0, res.output
    doc = json.loads((out / "results.json").read_text())
    return res.output, doc, (out / "report.html").read_text(), out


def _capped(tmp_path_factory, n: int):
    out = tmp_path_factory.mktemp(f"cap{n}") / "run"
    from click.testing import CliRunner

    from sarmotion.cli.main import main

    args = ["analyze", "scene1", "--out", str(out), "--no-trajectory", "--max-movers", str(n)]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    doc = json.loads((out / "results.json").read_text())
    return res.output, doc, (out / "report.html").read_text()


@pytest.fixture(scope="module")
def capped1(tmp_path_factory):
    return _capped(tmp_path_factory, 1)


@pytest.fixture(scope="module")
def capped0(tmp_path_factory):
    return _capped(tmp_path_factory, 0)


# ---------------------------------------------------------------- 1. what the data fix
def test_console_gives_the_range_with_its_error_and_the_cross_range_as_unknown(demo):
    text, doc, _, _ = demo
    assert "position (" not in text  # no bare (x, y) as if both were measured
    assert "-0.00" not in text
    for k, m in enumerate(doc["movers"]):
        line = next(s for s in text.splitlines() if s.strip().startswith(f"mover {k + 1}:"))
        assert f"range {m['range_m']:.2f} +- " in line.replace("range -0.00", "range 0.00")
    assert text.count("cross range not determined by the data") == len(doc["movers"]) == 2
    assert "across the scene" in text


def test_results_say_cross_range_unknown_and_give_the_range_the_data_fix(demo):
    _, doc, _, _ = demo
    ref = np.asarray(doc["reference_point_m"][:2])
    e_r = np.asarray(doc["frame"]["range_direction"])
    for m in doc["movers"]:
        assert m["cross_range_known"] is False
        assert m["range_m"] == pytest.approx(float((np.asarray(m["position_m"]) - ref) @ e_r))
        assert m["range_std_m"] == m["standard_errors"]["range_position_m"]
        assert m["amplitude_complex"] == {"re": m["amplitude"][0], "im": m["amplitude"][1]}


def test_speeds_are_the_velocity_against_the_recorded_look_direction(demo):
    _, doc, _, _ = demo
    f = doc["frame"]
    m_o = np.asarray(f["look_direction"])
    assert np.linalg.norm(m_o) == pytest.approx(1.0, abs=1e-12)
    # e_r is the ground projection of m_o, normalised: it points towards the antenna
    np.testing.assert_allclose(f["range_direction"], m_o[:2] / np.linalg.norm(m_o[:2]))
    for m in doc["movers"]:
        v = np.asarray(m["velocity_mps"])
        assert v @ f["range_speed_vector"] == pytest.approx(m["range_speed_mps"], abs=1e-9)
        assert v @ f["cross_range_speed_vector"] == pytest.approx(
            m["cross_range_speed_mps"], abs=1e-9
        )


def test_family_members_in_the_scene_have_the_data_range_history_and_hold_the_truth(demo, scene1):
    """Each listed member has the reported motion's range history (what the data fix); the
    true mover lies on the drawn family, within the distance of the truth to the exact family
    member (``errors.family_position_m``) plus the chord error between members, c**2/(8 R)."""
    _, doc, _, _ = demo
    acq = scene1.traces.acquisition
    x0, x1, y0, y1 = doc["scene_extent_m"]
    ground_cell = resolution(acq).ground_range_m
    truth = {t["label"]: t for t in doc["truth"]}
    for m in doc["movers"]:
        fam = m["cross_range_family"]["in_scene"]
        p, v = np.asarray(fam["positions_m"]), np.asarray(fam["velocities_mps"])
        ref_ranges = ranges_m(acq, np.r_[m["position_m"], 0.0], np.asarray(m["velocity_mps"]))
        for pk, vk in zip(p, v, strict=True):
            rms = np.sqrt(np.mean((ranges_m(acq, np.r_[pk, 0.0], vk) - ref_ranges) ** 2))
            assert rms < 1e-3 * ground_cell  # the same range history: the data cannot tell
        # the family crosses the whole scene in cross range (from one side to the other)
        assert fam["cross_offsets_m"][0] < 0.0 < fam["cross_offsets_m"][-1]
        assert min(p[0, 1], p[-1, 1]) == pytest.approx(y0, abs=1e-6)
        assert max(p[0, 1], p[-1, 1]) == pytest.approx(y1, abs=1e-6)
        assert np.all((p[:, 0] >= x0 - ground_cell) & (p[:, 0] <= x1 + ground_cell))
        # the truth lies on the polyline the report draws
        t = truth[m["errors"]["matched"]]
        chord = float(np.max(np.hypot(*np.diff(p, axis=0).T)))
        sagitta = chord**2 / (8.0 * (acq.geometry.range_m - np.hypot(x1 - x0, y1 - y0)))
        d = _distance_to_polyline(np.asarray(t["position_m"]), p)
        assert d <= m["errors"]["family_position_m"] + sagitta + 1e-9


def _distance_to_polyline(q: np.ndarray, p: np.ndarray) -> float:
    best = np.inf
    for a, b in zip(p[:-1], p[1:], strict=True):
        w = b - a
        s = np.clip((q - a) @ w / (w @ w), 0.0, 1.0)
        best = min(best, float(np.hypot(*(a + s * w - q))))
    return best


def test_trajectory_lists_positions_consistent_with_its_velocities(demo):
    """Knot positions: the piecewise-linear trajectory through position_m at s = 0."""
    _, doc, _, _ = demo
    for m in doc["movers"]:
        tj = m["trajectory"]
        t, p, v = (np.asarray(tj[k]) for k in ("slow_times_s", "positions_m", "velocities_mps"))
        assert p.shape == (t.size, 2) and v.shape == (t.size - 1, 2)
        np.testing.assert_allclose(np.diff(p, axis=0) / np.diff(t)[:, None], v, atol=1e-9)
        at_zero = [np.interp(0.0, t, p[:, 0]), np.interp(0.0, t, p[:, 1])]
        np.testing.assert_allclose(at_zero, m["position_m"], atol=1e-9)


def test_report_draws_each_mover_as_its_family_and_says_what_is_known(demo):
    _, doc, text, out = demo
    assert "not determined by the data" in text
    assert "range (m) &plusmn; standard error" in text
    assert "circles: movers" not in text.lower()


def test_images_figure_draws_the_family_not_a_circle(scene1):
    from sarmotion.documents import results_document
    from sarmotion.pipeline import AnalysisOptions, analyze
    from sarmotion.report.analysis_figures import images_figure

    result = analyze(scene1.traces, AnalysisOptions(trajectory=False))
    doc = results_document(result)
    ax = images_figure(result, doc).axes[0]
    lines = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2]
    assert len(lines) == len(doc["movers"]) == 2
    for m, ln in zip(doc["movers"], lines, strict=True):
        np.testing.assert_allclose(
            np.c_[ln.get_xdata(), ln.get_ydata()],
            m["cross_range_family"]["in_scene"]["positions_m"],
        )
        assert "cross range unknown" in ln.get_label() and "range \u00b1" in ln.get_label()
    assert not any(ln.get_marker() == "o" for ln in ax.get_lines())  # no circle on the movers


def test_mover_and_trajectory_figures_draw_the_family_across_the_scene(scene1):
    """Scene 1's movers (cross range not fixed by 1 degree): each mover's panel and the
    trajectory figure hold a line through the family's members in the scene, from one
    side of the scene to the other, and nothing that places the mover at one point."""
    from sarmotion.documents import results_document
    from sarmotion.pipeline import AnalysisOptions, analyze
    from sarmotion.report.analysis_figures import movers_figure, trajectories_figure

    result = analyze(scene1.traces, AnalysisOptions())
    doc = results_document(result)
    _, _, y0, y1 = doc["scene_extent_m"]
    assert len(doc["movers"]) == 2 and all(m["trajectory"] for m in doc["movers"])
    assert not any(m["cross_range_known"] for m in doc["movers"])
    families = [
        np.asarray(m["cross_range_family"]["in_scene"]["positions_m"]) for m in doc["movers"]
    ]

    def family_line(ax, k):
        lines = [ln for ln in ax.get_lines() if ln.get_label().startswith(f"mover {k + 1}: family")]
        assert len(lines) == 1, [ln.get_label() for ln in ax.get_lines()]
        xy = np.c_[lines[0].get_xdata(), lines[0].get_ydata()]
        np.testing.assert_allclose(xy, families[k])
        assert min(xy[0, 1], xy[-1, 1]) == pytest.approx(y0, abs=1e-6)  # across the scene
        assert max(xy[0, 1], xy[-1, 1]) == pytest.approx(y1, abs=1e-6)
        assert lines[0].get_linestyle() == "--"

    panels = movers_figure(result, document=doc).axes
    for k in range(len(families)):
        family_line(panels[k], k)
        assert not [ln for ln in panels[k].get_lines() if ln.get_marker() == "o"]
    ax = trajectories_figure(result, document=doc).axes[0]
    for k in range(len(families)):
        family_line(ax, k)
        (at_zero,) = [
            ln for ln in ax.get_lines() if ln.get_label().startswith(f"mover {k + 1}, s = 0")
        ]
        assert at_zero.get_label().endswith("(the member at the reference cross range)")
    ax.figure.canvas.draw()  # the view holds every family from end to end
    (xa, xb), (ya, yb) = ax.get_xlim(), ax.get_ylim()
    for p in families:
        assert xa <= p[:, 0].min() and p[:, 0].max() <= xb
        assert ya <= p[:, 1].min() and p[:, 1].max() <= yb


# ------------------------------------------------- the report reads the document alone
def test_report_html_imports_neither_the_pipeline_nor_the_analysis():
    tree = ast.parse((ROOT / "src" / "sarmotion" / "report" / "html.py").read_text())
    modules = [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)] + [
        a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names
    ]
    assert not any("pipeline" in m or "documents" in m or "analysis" in m for m in modules)


@pytest.mark.parametrize("version", [2, 1])
def test_report_from_a_loaded_results_json_of_either_version(demo, tmp_path, version):
    from sarmotion.report.html import write_html

    _, doc, _, out = demo
    loaded = json.loads((out / "results.json").read_text())
    if version == 1:  # what a sarmotion.results/1 file held
        loaded["schema"] = "sarmotion.results/1"
        for key in ("frame", "scene_extent_m", "movers_not_estimated"):
            loaded.pop(key)
        for m in loaded["movers"]:
            for key in ("cross_range_known", "range_m", "range_std_m", "amplitude_complex"):
                m.pop(key)
            m["cross_range_family"].pop("in_scene")
            m["trajectory"].pop("positions_m")
    page = write_html(loaded, tmp_path, title="from results.json").read_text()
    assert "not determined by the data" in page
    assert page.count("<tr>") > len(doc["movers"]) + len(doc["stationary"])
    if version == 2:
        assert "family across the scene from" in page


# ------------------------------------------------------ 2. nothing dropped silently
def test_candidates_beyond_max_movers_are_counted_listed_and_said(capped1, scene1):
    text, doc, page = capped1
    assert len(doc["movers"]) == 1
    extra = doc["movers_not_estimated"]
    assert len(extra) == 1
    threshold = doc["detection"]["threshold_db"]
    res_u = doc["range_speed_resolution_mps"]
    cell = resolution(scene1.traces).ground_range_m
    ref = np.asarray(doc["reference_point_m"][:2])
    e_r = np.asarray(doc["frame"]["range_direction"])
    found = {doc["movers"][0]["errors"]["matched"]}
    (missed,) = [t for t in doc["truth"] if t["label"] not in found]
    c = extra[0]
    assert c["statistic_db"] >= threshold
    assert abs(c["range_speed_mps"] - missed["range_speed_mps"]) <= res_u
    assert abs(c["range_m"] - float((np.asarray(missed["position_m"]) - ref) @ e_r)) <= cell
    assert "1 more candidate(s) passed the detector" in text
    assert f"statistic {c['statistic_db']:.1f} dB" in text
    assert "Detected, not estimated: 1 candidate(s) beyond max_movers = 1" in page


def test_max_movers_0_lists_every_detection_and_never_says_none_passed(capped0, demo):
    text, doc, page = capped0
    assert doc["movers"] == []
    demo_speeds = sorted(m["range_speed_mps"] for m in demo[1]["movers"])
    listed = sorted(c["range_speed_mps"] for c in doc["movers_not_estimated"])
    res_u = doc["range_speed_resolution_mps"]
    assert len(listed) == len(demo_speeds) == 2
    assert np.all(np.abs(np.subtract(listed, demo_speeds)) <= res_u)
    assert "no candidate passed the detector" not in page
    assert "2 more candidate(s) passed the detector" in text
    assert "(and 2 detected, not estimated)" in page


def test_no_cap_reached_lists_nothing_beyond(demo):
    assert demo[1]["movers_not_estimated"] == []


# ---------------------------------------------------------------- 3. the schema
def test_schema_is_draft_2020_12_and_describes_every_key():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    assert SCHEMA["$schema"].endswith("2020-12/schema")
    assert SCHEMA["properties"]["schema"]["const"] == RESULTS_SCHEMA
    undocumented = []

    def walk(node, path):
        for key, sub in node.get("properties", {}).items():
            if not sub.get("description", "").strip():
                undocumented.append(f"{path}.{key}")
            walk(sub, f"{path}.{key}")
        for key in ("items", "additionalProperties"):
            if isinstance(node.get(key), dict):
                walk(node[key], path + "[]")
        for sub in node.get("anyOf", []):
            walk(sub, path)

    walk(SCHEMA, "")
    assert undocumented == []


def test_real_outputs_validate_against_the_schema(demo, capped1, capped0):
    validator = jsonschema.Draft202012Validator(SCHEMA)
    for doc in (demo[1], capped1[1], capped0[1]):
        errors = [f"{list(e.path)}: {e.message}" for e in validator.iter_errors(doc)]
        assert errors == []


def test_schema_rejects_an_undocumented_key(demo):
    validator = jsonschema.Draft202012Validator(SCHEMA)
    doc = json.loads(json.dumps(demo[1]))
    doc["movers"][0]["new_key"] = 1.0
    assert not validator.is_valid(doc)


# ---------------------------------------------------------- track: the uncertainty drawn
def _tracking_result(on_road: bool):
    """Two states of one track: without a road, covariance long along the family (y)."""
    from sarmotion.imaging import ImageGrid
    from sarmotion.tracking import Road, RoadFix, Track, TrackingOptions, TrackingResult, TrackState

    x = np.linspace(-30.0, 30.0, 61)
    cov_family = np.array([[0.04, 0.0], [0.0, 30.0**2]])  # 0.2 m in range, 30 m in cross range
    fix = RoadFix(
        road=0,
        offset_m=2.0,
        position_m=np.array([1.0, 2.0]),
        covariance_m2=np.array([[0.5, 0.4], [0.4, 0.5]]),  # 0.95 m along the road at 45 deg
        angle_deg=45.0,
        fixed=True,
    )
    states = tuple(
        TrackState(
            time_s=t,
            sub_aperture=k,
            position_m=np.array([1.0 + t, 2.0 + t]),
            velocity_mps=np.array([1.0, 1.0]),
            position_cov_m2=np.array([[0.3, 0.2], [0.2, 0.3]]) if on_road else cov_family,
            velocity_cov_m2ps2=np.eye(2),
            look_direction=np.array([0.7, 0.0, 0.7]),
            road=fix if on_road else None,
        )
        for k, t in enumerate((0.0, 1.0))
    )
    roads = (Road(points_m=np.array([[-20.0, -20.0], [20.0, 20.0]]), name="r"),) if on_road else ()
    return TrackingResult(
        tracks=(Track(id=1, states=states),),
        sub_apertures=(),
        stationary_db=np.zeros((61, 61)),
        grid=ImageGrid(x_m=x, y_m=x),
        options=TrackingOptions(),
        roads=roads,
        timings_s={"total": 0.0},
    )


@pytest.mark.parametrize("on_road", [False, True])
def test_track_map_draws_each_states_one_sigma_uncertainty(on_road):
    from matplotlib.patches import Ellipse

    from sarmotion.report.tracks import tracks_figure

    result = _tracking_result(on_road)
    ax = tracks_figure(result).axes[0]
    ellipses = [p for p in ax.patches if isinstance(p, Ellipse)]
    states = result.tracks[0].states
    assert len(ellipses) == len(states)
    for e, s in zip(ellipses, states, strict=True):
        vals = np.linalg.eigvalsh(s.position_cov_m2)
        np.testing.assert_allclose(e.center, s.position_m)
        np.testing.assert_allclose(sorted([e.width, e.height]), 2.0 * np.sqrt(vals), rtol=1e-12)
    if not on_road:  # the major axis lies along the family (y here): 60 m long
        assert max(ellipses[0].width, ellipses[0].height) == pytest.approx(60.0)
        assert ellipses[0].angle % 180.0 == pytest.approx(90.0)
    else:  # the road's interval: +-sqrt(0.9) m along the road through the fix
        seg = [ln for ln in ax.get_lines() if ln.get_linewidth() == 3.0 and len(ln.get_xdata())]
        assert len(seg) == len(states)
        xy = np.c_[seg[0].get_xdata(), seg[0].get_ydata()]
        assert np.hypot(*(xy[1] - xy[0])) == pytest.approx(2.0 * np.sqrt(0.9))
        np.testing.assert_allclose(xy.mean(axis=0), [1.0, 2.0])


def test_clip_family_keeps_the_part_of_the_tangent_line_inside_the_scene():
    from sarmotion.pipeline.family import clip_family

    extent = (-10.0, 10.0, -20.0, 20.0)
    # along y with a slant of 0.25 m/m: x leaves the scene first, at t = +-(10 - 2) / 0.25
    t0, t1 = clip_family([2.0, 0.0], [0.25, 1.0], extent)
    assert (t0, t1) == pytest.approx((-20.0, 20.0))
    t0, t1 = clip_family([-8.0, 0.0], [0.25, 1.0], extent)
    assert (t0, t1) == pytest.approx((-8.0, 20.0))  # x = -10 at t = -8, y = 20 at t = 20
    for t in (t0, t1):  # the ends lie on the boundary
        x, y = -8.0 + 0.25 * t, t
        assert min(abs(x - 10), abs(x + 10), abs(y - 20), abs(y + 20)) == pytest.approx(0.0)
    assert clip_family([30.0, 0.0], [0.0, 1.0], extent) is None  # parallel, outside
    assert clip_family([30.0, 0.0], [0.1, 1.0], extent) is None  # crosses x = 10 beyond y = 20
