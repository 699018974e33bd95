"""One library call for any input and any size: ``sarmotion.analyze`` plans, runs, merges.

The call on a path, on a source from ``sarmotion.open`` and on traces in memory finds the
movers the command line finds, for a scene of one patch and for a CPHD file cut into
patches; its result is the one ``sarmotion.results/3`` document the command writes. The
smear rule holds on a direct analysis of one patch: a mover's echo smeared over the
stationary image is not listed as stationary points, and every true point stays.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import sarmotion
from sarmotion.cli.main import run
from sarmotion.collection import CollectionOptions, analyze_source, collection_options
from sarmotion.core import Radar
from sarmotion.documents.results import RESULTS_SCHEMA, collection_document
from sarmotion.documents.schema import validate
from sarmotion.imaging import resolution
from sarmotion.io import write_cphd_blocks
from sarmotion.pipeline import AnalysisOptions
from sarmotion.pipeline import analyze as analyze_traces
from sarmotion.simulation import PointTarget, collection_acquisition, random_collection

#: Side of the CPHD scene (m): four patches at the default patch size.
SIDE_M = 150.0


def _movers(doc: dict) -> list[tuple[float, ...]]:
    """Each mover's position and velocity (m, m/s), sorted."""
    return sorted(tuple(m["position_m"][:2]) + tuple(m["velocity_mps"][:2]) for m in doc["movers"])


def _same_movers(doc: dict, cli: dict) -> None:
    a, b = _movers(doc), _movers(cli)
    assert len(a) == len(b) > 0
    # one computation on the same samples: equal to round-off
    np.testing.assert_allclose(np.array(a), np.array(b), rtol=0, atol=1e-6)


def _saved_as_the_command_writes(result, out, cli_out) -> None:
    """``sarmotion.save(result)`` writes the command's files and movers, a valid document."""
    sarmotion.save(result, out)
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in cli_out.iterdir())
    doc = json.loads((out / "results.json").read_text())
    assert doc["schema"] == RESULTS_SCHEMA and validate(doc) == []
    _same_movers(doc, json.loads((cli_out / "results.json").read_text()))


def _cli(inputs: list[str], out, *flags: str) -> dict:
    assert run(["analyze", *inputs, "--out", str(out), *flags]) == 0
    return json.loads((out / "results.json").read_text())


@pytest.mark.slow  # whole analyses
def test_a_scene_of_one_patch_gives_the_commands_movers_from_a_path_a_source_and_traces(tmp_path):
    cli = _cli(["example1"], tmp_path / "cli")
    assert len(cli["plan"]["patches"]) == 1
    results = {
        "path": sarmotion.analyze("example1"),
        "source": sarmotion.analyze(sarmotion.open("example1")),
        "traces": sarmotion.analyze(sarmotion.read("example1")),
    }
    for name, result in results.items():
        assert result.single_result is not None, name
        doc = collection_document(result)
        assert doc["schema"] == RESULTS_SCHEMA and len(doc["plan"]["patches"]) == 1
        _same_movers(doc, cli)
        assert len(doc["stationary"]) == len(cli["stationary"]), name
    _saved_as_the_command_writes(results["path"], tmp_path / "saved", tmp_path / "cli")


@pytest.fixture(scope="module")
def cphd(tmp_path_factory):
    acq = collection_acquisition(SIDE_M)
    scene = random_collection(acq, SIDE_M, seed=31, n_movers=2, snr_db=-20.0)
    path = tmp_path_factory.mktemp("analysis") / "scene.cphd"
    write_cphd_blocks(path, scene, block_pulses=50)
    return path


@pytest.mark.slow  # whole analyses
def test_a_cphd_of_several_patches_gives_the_commands_movers_from_a_path_a_source_and_traces(
    cphd, tmp_path
):
    cli = _cli([str(cphd)], tmp_path / "cli", "--workers", "0")
    n = len(cli["plan"]["patches"])
    assert n > 1
    results = {
        "path": sarmotion.analyze(cphd, n_workers=0),
        "source": sarmotion.analyze(sarmotion.open(cphd), n_workers=0),
        "traces": sarmotion.analyze(sarmotion.read(cphd), n_workers=0),
    }
    for name, result in results.items():
        assert result.single_result is None and len(result.plan.patches) == n, name
        doc = collection_document(result)
        assert doc["schema"] == RESULTS_SCHEMA
        _same_movers(doc, cli)
        assert len(doc["stationary"]) == len(cli["stationary"]), name
    _saved_as_the_command_writes(results["path"], tmp_path / "saved", tmp_path / "cli")


@pytest.fixture(scope="module")
def smeared():
    """Scene 1's stationary points and one mover at (10, 15) m moving at (4, -6) m/s."""
    scene = sarmotion.load_scene("scene1")
    stationary = tuple(t for t in scene.targets if not t.is_moving)
    mover = PointTarget(position_m=(10.0, 15.0), velocity_mps=(4.0, -6.0), label="injected")
    sim = sarmotion.simulate(dataclasses.replace(scene, targets=(*stationary, mover)))
    options = AnalysisOptions(trajectory=False)
    return (
        sim,
        stationary,
        analyze_traces(sim.traces, options),
        sarmotion.analyze(sim.traces, options),
    )


@pytest.mark.slow  # whole analyses
def test_a_direct_analysis_of_one_patch_lists_no_movers_smear_as_stationary_points(smeared):
    """The stage below lists points on the mover's echo; the library call drops them all.

    What it drops lies farther than three resolution cells from every true stationary
    point; every true point stays listed within a cell; the count is the document's.
    """
    sim, stationary, bare, result = smeared
    one = result.single_result
    assert one is not None and len(one.movers) == len(bare.movers) == 1
    assert bare.stationary_mover_images == 0  # the stage below does not apply the rule
    dropped = [t for t in bare.stationary if t not in one.stationary]
    assert len(dropped) > 0 and one.stationary_mover_images == len(dropped)
    assert len(one.stationary) == len(bare.stationary) - len(dropped)
    true = np.array([t.position_m[:2] for t in stationary])
    cells = resolution(sim.traces)
    cell = max(cells.ground_range_m, cells.cross_range_m)
    for t in dropped:
        assert np.min(np.hypot(*(true - np.asarray(t.position_m)).T)) > 3 * cell
    listed = np.array([t.position_m for t in one.stationary])
    for p in true:
        assert np.min(np.hypot(*(listed - p).T)) <= cell
    doc = collection_document(result)
    assert doc["stationary_mover_images_dropped"] == len(dropped)
    assert len(doc["stationary"]) == len(one.stationary)


def test_options_of_either_kind_and_nothing_else():
    scene = sarmotion.Scene(
        name="tiny",
        targets=(PointTarget(position_m=(3.0, -4.0)),),
        trajectory_spec={"kind": "circular", "n_pulses": 24, "aperture_deg": 0.2},
        radar=Radar(n_samples=32, frequency_step_hz=4e6, bandwidth_hz=100e6, pulse="rect"),
    )
    traces = sarmotion.simulate(scene).traces
    a = AnalysisOptions(max_movers=2)
    assert collection_options(a) == CollectionOptions(analysis=a)
    c = CollectionOptions(max_speed_mps=10.0)
    assert collection_options(c) is c
    assert collection_options(None) == CollectionOptions()
    with pytest.raises(TypeError, match="options must be an AnalysisOptions or a Collection"):
        analyze_source(traces, {"max_movers": 2})
    with pytest.raises(TypeError, match="snr_db: options for reading a path"):
        sarmotion.analyze(traces, snr_db=10.0)
