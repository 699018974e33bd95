"""Every JSON document the command line writes validates against the schema shipped with it.

The schemas are package data (``sarmotion/documents/schemas``); each written document
names its schema (``$schema``, the schema's ``$id``). One analysis and one of several
patches write the same ``sarmotion.results/3`` document, console and report sections (the
patches' adding the mosaic and the patch table). The tests that run the command line are
in the slow tier (``python -m pytest -m slow``).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from sarmotion.core import Radar, Traces, Trajectory, to_fast_time
from sarmotion.documents.schema import SCHEMA_FILES, load_schema, schema_uri, validate
from sarmotion.simulation import PointTarget, simulate_phase_history

jsonschema = pytest.importorskip("jsonschema")

#: The two-patch scene of tests/collection/test_collection_run.py: six stationary points, one mover.
REGION = ("-60", "-25", "60", "25")
STATIONARY = [(-40.0, -10.0), (-25.0, 12.0), (-8.0, -18.0), (20.0, 8.0), (35.0, -12.0)]
MOVER = PointTarget(position_m=(2.0, 4.0), velocity_mps=(-6.0, 7.0), reflectivity=0.8j)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """Run every command that writes a JSON document; their output directories."""
    from sarmotion.io import save_traces

    base = tmp_path_factory.mktemp("documents")
    traj, radar = Trajectory.circular(), Radar()
    targets = [PointTarget(position_m=p) for p in STATIONARY] + [MOVER]
    ph = simulate_phase_history(targets, traj, radar, (0.0, 0.0, 0.0))
    traces = Traces(
        data=to_fast_time(ph),
        trajectory=traj,
        radar=radar,
        reference_point_m=(0.0, 0.0, 0.0),
        metadata={"source": "simulation", "scene": "two patches"},
    )
    save_traces(base / "two.h5", traces)
    runs = {
        "single": ["analyze", "scene1", "--no-trajectory"],
        "patches": ["analyze", str(base / "two.h5"), "--region", *REGION, "--patch-size", "60"],
        "track": ["track", "scene1", "--sub-aperture", "0.6", "--overlap", "0"],
        "image": ["image", "rotscatt", "--size", "20"],
        "separate": ["separate", "rotscatt", "--method", "annihilation"],
    }
    runs["patches"] += ["--workers", "0", "--no-trajectory"]
    runs["track"] += ["--workers", "0"]
    out = {}
    consoles = {}
    for name, args in runs.items():
        out[name] = base / name
        code, text = _run([*args, "--out", str(out[name])])
        assert code == 0, (name, text)
        consoles[name] = text
    return out, consoles


def _run(args: list[str]) -> tuple[int, str]:
    from click.testing import CliRunner

    from sarmotion.cli import main

    res = CliRunner().invoke(main, args)
    return res.exit_code, res.output + (repr(res.exception) if res.exit_code else "")


def test_the_schemas_are_package_data_and_valid_draft_2020_12():
    for name in SCHEMA_FILES:
        schema = load_schema(name)
        jsonschema.Draft202012Validator.check_schema(schema)
        assert schema["$id"] == schema_uri(name)
        assert schema["properties"]["schema"]["const"] == name
        assert schema["properties"]["$schema"]["const"] == schema["$id"]
        assert set(schema["required"]) >= {"$schema", "schema"}


@pytest.mark.slow  # runs the command line (about two minutes on two cores)
def test_every_written_json_document_validates(written):
    out, _ = written
    found = sorted(p for d in out.values() for p in Path(d).glob("*.json"))
    names = {p.parent.name + "/" + p.name for p in found}
    assert names == {
        "single/results.json",
        "patches/results.json",
        "track/tracks.json",
        "image/peaks.json",
        "separate/separation.json",
    }
    for path in found:
        doc = json.loads(path.read_text())
        assert doc["$schema"] == schema_uri(doc["schema"]), path
        assert validate(doc) == [], path


@pytest.mark.slow  # runs the command line (about two minutes on two cores)
def test_a_document_off_its_schema_fails(written):
    out, _ = written
    doc = json.loads((out["patches"] / "results.json").read_text())
    assert validate(doc) == []
    wrong = json.loads(json.dumps(doc))
    wrong["movers"][0].pop("standard_errors")
    assert any("standard_errors" in e for e in validate(wrong))
    wrong = json.loads(json.dumps(doc))
    wrong["schema"] = "sarmotion.collection/1"
    assert validate(wrong) != []
    peaks = json.loads((out["image"] / "peaks.json").read_text())
    peaks["peaks"][0]["peak_db"] = "loud"
    assert validate(peaks) != []


def _sections(page: str) -> list[str]:
    return re.findall(r"<section><h2>([^<]+)</h2>", page)


@pytest.mark.slow  # runs the command line (about two minutes on two cores)
def test_one_patch_and_several_write_one_schema_one_report_one_console(written):
    out, consoles = written
    one = json.loads((out["single"] / "results.json").read_text())
    two = json.loads((out["patches"] / "results.json").read_text())
    assert one["schema"] == two["schema"] == "sarmotion.results/3"
    assert len(one["plan"]["patches"]) == 1 and len(two["plan"]["patches"]) == 2
    # the same keys at the top and per mover (truth only for the simulated scene TOML)
    truth = {"truth", "false_movers", "missed_movers", "point_quality"}
    assert set(one) - truth == set(two) - truth
    assert set(one["movers"][0]) - {"errors", "trajectory"} == set(two["movers"][0])
    for m in one["movers"] + two["movers"]:
        assert m["cross_range_known"] is False
        assert m["standard_errors"]["conditional_on"]
        assert m["image"] == "movers.png"
        lo, hi = m["cross_range_family"]["range_speed_span_mps"]
        assert lo <= m["range_speed_mps"] <= hi
        assert m["position_std_m"] > 0
    single = (out["single"] / "report.html").read_text()
    patches = (out["patches"] / "report.html").read_text()
    assert _sections(patches) == [
        s for s in _sections(patches) if s in _sections(single) or s in ("Mosaic", "Patches")
    ]
    assert set(_sections(patches)) - set(_sections(single)) == {"Mosaic", "Patches"}
    assert set(_sections(single)) <= set(_sections(patches))
    for page in (single, patches):
        assert '<span class="info">not determined by the data</span>' in page
        assert '<span class="bad">not determined' not in page
        assert "conditional on" in page and "across the scene" in page
    assert (out["patches"] / "movers.png").is_file() and (out["single"] / "movers.png").is_file()
    for name in ("single", "patches"):
        text = consoles[name]
        assert "at the listed cross range;" in text and "m/s across the scene" in text
        assert "cross range not determined by the data" in text


@pytest.mark.slow  # runs the command line (about two minutes on two cores)
def test_the_range_speed_span_is_the_familys_across_the_scene(written):
    """The span's ends are the range speeds ``u . m_o`` of the family's end members."""
    out, _ = written
    doc = json.loads((out["single"] / "results.json").read_text())
    w = np.asarray(doc["frame"]["range_speed_vector"])
    for m in doc["movers"]:
        v = np.asarray(m["cross_range_family"]["in_scene"]["velocities_mps"])
        lo, hi = m["cross_range_family"]["range_speed_span_mps"]
        assert lo == pytest.approx(float(np.min(v @ w)), abs=1e-9)
        assert hi == pytest.approx(float(np.max(v @ w)), abs=1e-9)
        # a uniform position along a straight segment of length L: L / sqrt(12)
        p = np.asarray(m["cross_range_family"]["in_scene"]["positions_m"])
        length = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
        assert m["position_std_m"] == pytest.approx(length / np.sqrt(12.0), rel=0.02)


@pytest.fixture(scope="module")
def injected():
    """Scene 1's stationary points and one mover at (10, 15) m moving at (4, -6) m/s."""
    import dataclasses

    from sarmotion.pipeline import AnalysisOptions, analyze
    from sarmotion.simulation import load_scene, simulate

    scene = load_scene("scene1")
    stationary = tuple(t for t in scene.targets if not t.is_moving)
    mover = PointTarget(position_m=(10.0, 15.0), velocity_mps=(4.0, -6.0), label="injected")
    sim = simulate(dataclasses.replace(scene, targets=(*stationary, mover)))
    return sim, stationary, analyze(sim.traces, AnalysisOptions(trajectory=False))


@pytest.mark.slow  # runs the command line (about two minutes on two cores)
def test_the_range_speed_span_holds_the_truth_the_standard_error_does_not(injected):
    """The mover sits 15 m off the reference cross range: its range speed there is many
    standard errors from the truth (the error is conditional on the reference cross
    range), and the span over its family across the scene holds the truth."""
    from sarmotion.core.geometry import range_speed
    from sarmotion.documents.results import results_document

    sim, _, result = injected
    (m,) = result.movers
    truth = float(range_speed(np.array([4.0, -6.0]), sim.traces.geometry))
    assert abs(m.range_speed_mps - truth) > 100 * m.bound.range_speed_mps
    entry = results_document(result)["movers"][0]
    lo, hi = entry["cross_range_family"]["range_speed_span_mps"]
    assert lo <= truth <= hi
    text = result.summary()
    assert f"{lo:.2f} to {hi:.2f} m/s across the scene" in text
    assert "conditional on that cross range" in text


@pytest.mark.slow  # runs the command line (about two minutes on two cores)
def test_one_smear_rule_drops_the_movers_echo_and_keeps_every_true_point(injected):
    """drop_smear on one analysis: what it drops lies off every true stationary point
    (farther than a few resolution cells), and every true point stays listed."""
    from sarmotion.collection import drop_smear
    from sarmotion.imaging import resolution

    sim, stationary, result = injected
    kept = drop_smear(result)
    dropped = [t for t in result.stationary if t not in kept.stationary]
    assert kept.stationary_mover_images == len(dropped) > 0
    true = np.array([t.position_m[:2] for t in stationary])
    cells = resolution(sim.traces)
    cell = max(cells.ground_range_m, cells.cross_range_m)
    for t in dropped:
        assert np.min(np.hypot(*(true - np.asarray(t.position_m)).T)) > 3 * cell
    listed = np.array([t.position_m for t in kept.stationary])
    for p in true:
        assert np.min(np.hypot(*(listed - p).T)) <= cell
