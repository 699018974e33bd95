"""``--autofocus gotcha|pga`` on the command line: outputs, refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sarmotion.cli.main import run
from sarmotion.io import save_traces
from sarmotion.simulation import load_scene, simulate


def one_line_error(capsys, *words):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    for w in words:
        assert w in err[0], err[0]


def test_image_with_pga_writes_the_phase_error(tmp_path):
    out = tmp_path / "img"
    assert run(["image", "example1", "--out", str(out), "--size", "30", "--autofocus", "pga"]) == 0
    doc = json.loads((out / "peaks.json").read_text())
    focus = doc["autofocus"]
    assert focus["method"] == "pga" and focus["n_iter"] >= 1
    assert len(focus["phase_error_rad"]) == len(focus["slow_times_s"])
    assert (out / "autofocus.png").stat().st_size > 1000
    # Each listed peak carries its quality figures (or why it has none).
    assert all("quality" in p for p in doc["peaks"])


def test_bare_autofocus_flag_means_gotcha(tmp_path):
    for i, args in enumerate((["--autofocus"], ["--autofocus", "gotcha"])):
        out = tmp_path / f"o{i}"
        assert run(["image", "example1", "--out", str(out), "--size", "10", *args]) == 0
        assert json.loads((out / "peaks.json").read_text())["autofocus"] is None
        assert not (out / "autofocus.png").exists()


def test_more_iterations_than_pulses(tmp_path, capsys):
    out = tmp_path / "o"
    args = ["image", "example1", "--out", str(out), "--autofocus", "pga"]
    assert run([*args, "--pga-iterations", "100000"]) == 2
    one_line_error(capsys, "--pga-iterations", "number of pulses")
    assert run([*args, "--pga-iterations", "0"]) == 2
    one_line_error(capsys, "--pga-iterations")
    assert not out.exists()


def test_pga_without_a_bright_scatterer(tmp_path, capsys):
    tr = simulate(load_scene("example1")).traces
    noise = np.random.default_rng(7).standard_normal((2, *tr.shape))
    path = save_traces(tmp_path / "noise.h5", tr.with_data(noise[0] + 1j * noise[1]))
    out = tmp_path / "o"
    assert run(["image", str(path), "--out", str(out), "--autofocus", "pga"]) == 2
    one_line_error(capsys, "--autofocus pga", "no bright scatterer")
    assert not out.exists()


@pytest.mark.slow
def test_analyze_with_pga_reports_the_phase_error(tmp_path):
    out = tmp_path / "a"
    assert (
        run(["analyze", "scene1", "--out", str(out), "--no-trajectory", "--autofocus", "pga"]) == 0
    )
    doc = json.loads((out / "results.json").read_text())
    assert doc["autofocus"]["method"] == "pga"
    assert (out / "autofocus.png").exists()
    assert "Phase-gradient autofocus" in (out / "report.html").read_text()


def test_convert_with_pga_writes_corrected_traces(tmp_path):
    from sarmotion.io import load_traces

    out = tmp_path / "t.h5"
    assert run(["convert", "example1", "--to", "h5", "--out", str(out), "--autofocus", "pga"]) == 0
    tr = load_traces(out)
    assert tr.metadata["autofocus"] == "pga" and tr.metadata["pga_iterations"] >= 1
