"""CPHD as an input of the pipeline and the command line: analyze, convert, image."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sarkit.verification as skver

from sarmotion.cli.inputs import read_inputs
from sarmotion.cli.main import EXIT_BAD_INPUT, run
from sarmotion.io import load_image, load_traces, read_cphd, save_traces, write_cphd
from sarmotion.pipeline import AnalysisOptions, analyze
from sarmotion.simulation import load_scene, simulate

DAYTON = (39.78, -84.05, 250.0)


def _consistent(path: Path) -> bool:
    with open(path, "rb") as fh:
        con = skver.CphdConsistency.from_file(fh, thorough=True)
        con.check()
    return not con.failures()


def _fails(args, capsys, pattern):
    code = run(args)
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT
    assert len(err.splitlines()) == 1, err
    assert err.startswith("sarmotion: error:") and pattern in err, err


@pytest.mark.slow
def test_scene1_from_cphd_gives_the_movers_of_native_traces(tmp_path):
    sim = simulate(load_scene("scene1"))
    native, _ = read_inputs([str(save_traces(tmp_path / "s1.h5", sim.traces))])
    cphd, _ = read_inputs([str(write_cphd(tmp_path / "s1.cphd", sim.traces, origin_llh=DAYTON))])
    assert cphd.metadata["source"] == "simulation"  # stored metadata: same default method
    options = AnalysisOptions(trajectory=False)
    a, b = analyze(native, options), analyze(cphd, options)
    assert b.method == a.method == "combined"
    assert len(a.movers) == len(b.movers) == 2
    # Measured: the same estimates to 1e-4 m and 1e-4 m/s (complex64 data in the file).
    for ma, mb in zip(a.movers, b.movers, strict=True):
        assert np.abs(mb.position_m - ma.position_m).max() < 1e-3
        assert np.abs(mb.velocity_mps - ma.velocity_mps).max() < 1e-3
    assert len(b.stationary) == len(a.stationary) == 20


def test_convert_to_cphd_and_image_it(tmp_path, capsys):
    out = tmp_path / "sub" / "h.cphd"
    assert run(["convert", "hyperbola", "--to", "cphd", "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    assert _consistent(out)
    img_dir = tmp_path / "img"
    code = run(["image", str(out), "--out", str(img_dir), "--size", "20", "--spacing", "0.1"])
    assert code == 0, capsys.readouterr().err
    img = load_image(img_dir / "image.h5")
    iy, ix = np.unravel_index(np.argmax(np.abs(img["values"])), img["values"].shape)
    # The hyperbola scene's target is at (0, 5) m: within one pixel, as from the scene.
    assert abs(img["x_m"][ix] - 0.0) <= 0.1 and abs(img["y_m"][iy] - 5.0) <= 0.1


def test_convert_back_from_cphd_with_a_vector_range(tmp_path, capsys):
    h5 = tmp_path / "r.h5"
    assert run(["simulate", "rotscatt", "--out", str(h5)]) == 0
    cphd = tmp_path / "r.cphd"
    args = ["convert", str(h5), "--to", "cphd", "--out", str(cphd), "--origin", *map(str, DAYTON)]
    assert run(args) == 0
    assert read_cphd(cphd).metadata["cphd"]["n_vectors_in_channel"] == 117
    part = tmp_path / "part.h5"
    args = ["convert", str(cphd), "--to", "h5", "--out", str(part), "--vectors", "20", "80"]
    assert run(args) == 0
    expected = load_traces(h5).select_pulses(20, 80)
    back = load_traces(part)
    assert np.abs(back.data - expected.data).max() < 1e-6 * np.abs(expected.data).max()
    assert np.abs(back.positions_m - expected.positions_m).max() < 1e-6
    gotcha = tmp_path / "g"
    assert run(["convert", str(cphd), "--to", "gotcha", "--out", str(gotcha)]) == 0
    assert len(list(gotcha.glob("*.mat"))) == 1


def test_convert_and_cphd_inputs_fail_in_one_line(tmp_path, capsys):
    out = tmp_path / "x.cphd"
    _fails(
        ["convert", "hyperbola", "--to", "cphd", "--out", str(out), "--channel", "1"],
        capsys,
        "--channel and --vectors apply to a CPHD",
    )
    _fails(
        [
            "convert",
            "hyperbola",
            "--to",
            "h5",
            "--out",
            str(tmp_path / "x.h5"),
            "--origin",
            "0",
            "0",
            "0",
        ],
        capsys,
        "--origin applies to --to cphd only",
    )
    assert not out.exists()
    bad = tmp_path / "bad.cphd"
    bad.write_bytes(b"CPHD/1.1.0\nXML_BLOCK_SIZE := 10\n")
    _fails(["image", str(bad), "--out", str(tmp_path / "img")], capsys, str(bad))
    assert not (tmp_path / "img").exists()
    good = write_cphd(tmp_path / "good.cphd", simulate(load_scene("hyperbola")).traces)
    _fails(
        ["convert", str(good), "--to", "h5", "--out", str(tmp_path / "y.h5"), "--channel", "VV"],
        capsys,
        "no channel 'VV' (channels: 1)",
    )
    _fails(["analyze", str(good), str(good), "--out", str(tmp_path / "a")], capsys, "one CPHD file")
