"""Command line: outputs of each command and one clear line for every kind of bad input."""

from pathlib import Path

import numpy as np
import pytest
import scipy.io

from sarmotion.cli.main import EXIT_BAD_INPUT, run
from sarmotion.io import load_image, load_traces, read_gotcha


def _fails(args, capsys, pattern, out=None):
    code = run(args)
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT
    assert len(err.splitlines()) == 1, err
    assert err.startswith("sarmotion: error:")
    assert pattern in err, err
    assert "Traceback" not in err
    if out is not None:
        assert not Path(out).exists(), "a failed command must not leave its output"
        assert not list(Path(out).parent.glob(f".{Path(out).name}.partial-*"))


def test_help_explains_every_command(capsys):
    for cmd in ([], ["simulate"], ["image"], ["inject"], ["separate"], ["demo"]):
        assert run([*cmd, "--help"]) == 0
        text = capsys.readouterr().out
        assert "Usage:" in text and len(text) > 200


def test_command_list_is_the_commands_own_help(capsys):
    """``sarmotion --help`` lists every command with the first sentence of its own help.

    The list is written without importing the commands (start-up); each entry must be
    what the command itself says, and every command of the group must be listed.
    """
    import click

    from sarmotion.cli.main import COMMANDS, main

    ctx = click.Context(main)
    for name, (_, sentence) in COMMANDS.items():
        command = main.get_command(ctx, name)
        assert command is not None and command.name == name
        assert command.get_short_help_str(limit=10_000) == sentence
    assert run(["--help"]) == 0
    listed = capsys.readouterr().out.split("Commands:")[1]
    assert [line.split()[0] for line in listed.strip().splitlines()] == sorted(COMMANDS)


def test_help_starts_without_the_numerical_libraries():
    """``sarmotion --help`` imports neither numba, scipy nor matplotlib (start-up time)."""
    import subprocess
    import sys

    code = (
        "import sys; from sarmotion.cli import run; run(['--help']); "
        "print(sorted(m for m in ('numba', 'scipy', 'matplotlib') if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip().splitlines()[-1] == "[]"


def test_simulate_native_and_gotcha(tmp_path, capsys):
    out = tmp_path / "s.h5"
    assert run(["simulate", "rotscatt", "--out", str(out)]) == 0
    tr = load_traces(out)
    assert tr.shape == (117, 424)
    gdir = tmp_path / "g"
    assert run(["simulate", "rotscatt", "--out", str(gdir)]) == 0
    back = read_gotcha(sorted(gdir.glob("*.mat")))
    # complex64 storage in the GOTCHA format: ~1e-7 relative.
    np.testing.assert_allclose(back.data, tr.data, atol=1e-6 * np.abs(tr.data).max())


def test_image_of_a_scene_focuses_the_target(tmp_path, capsys):
    out = tmp_path / "img"
    code = run(["image", "hyperbola", "--out", str(out), "--size", "20", "--spacing", "0.1"])
    assert code == 0, capsys.readouterr().err
    img = load_image(out / "image.h5")
    iy, ix = np.unravel_index(np.argmax(np.abs(img["values"])), img["values"].shape)
    # The hyperbola scene's target is at (0, 5) m: within one pixel.
    assert abs(img["x_m"][ix] - 0.0) <= 0.1 and abs(img["y_m"][iy] - 5.0) <= 0.1
    assert (out / "image.png").stat().st_size > 1000


def test_image_method_ffbp_against_exact(tmp_path, capsys):
    # --method ffbp: the factorised image, recorded as such, within FFBP's 55 dB target of
    # the exact sum (no interpolation) on 2000 seeded pixels.
    from sarmotion.cli.inputs import read_inputs
    from sarmotion.imaging.exact_sum import exact_sum
    from sarmotion.imaging.ffbp import TARGET_DB

    out = tmp_path / "ffbp"
    code = run(["image", "rotscatt", "--out", str(out), "--size", "64", "--spacing", "0.25",
                "--method", "ffbp"])  # fmt: skip
    assert code == 0, capsys.readouterr().err
    img = load_image(out / "image.h5")
    record = img["metadata"]["imaging"]
    assert record["method"] == "ffbp" and record["ffbp_path"] != "exact"
    assert record["ffbp_budget_db"] >= TARGET_DB
    rng = np.random.default_rng(2027)
    iy = rng.integers(0, img["y_m"].size, 2000)
    ix = rng.integers(0, img["x_m"].size, 2000)
    traces, _ = read_inputs(["rotscatt"])
    ref = exact_sum(traces, np.stack([img["x_m"][ix], img["y_m"][iy]], axis=-1))
    fast = img["values"][iy, ix]
    ser = 20 * np.log10(np.linalg.norm(ref) / np.linalg.norm(fast - ref))
    assert ser >= TARGET_DB


def test_inject_and_image_compensated(tmp_path, capsys):
    base = tmp_path / "base.h5"
    assert run(["simulate", "hyperbola", "--out", str(base)]) == 0
    out = tmp_path / "inj.h5"
    assert run(["inject", str(base), "--target", "3,-4,5,2,1", "--out", str(out)]) == 0
    img = tmp_path / "img"
    args = [
        "image",
        str(out),
        "--out",
        str(img),
        "--size",
        "20",
        "--spacing",
        "0.1",
        "--velocity",
        "5",
        "2",
    ]
    assert run(args) == 0
    v = load_image(img / "image.h5")
    iy, ix = np.unravel_index(np.argmax(np.abs(v["values"])), v["values"].shape)
    assert abs(v["x_m"][ix] - 3.0) <= 0.1 and abs(v["y_m"][iy] + 4.0) <= 0.1


def test_missing_file(tmp_path, capsys):
    out = tmp_path / "o"
    _fails(["image", str(tmp_path / "nope.mat"), "--out", str(out)], capsys, "not found", out)


def test_not_a_gotcha_file(tmp_path, capsys):
    bad = tmp_path / "x.mat"
    bad.write_text("hello")
    out = tmp_path / "o"
    _fails(["image", str(bad), "--out", str(out)], capsys, str(bad), out)


def _gotcha_like(path, **fields):
    n = 5
    data = {
        "fp": np.ones((8, n), np.complex64),
        "freq": np.linspace(9.6e9, 9.61e9, 8)[:, None],
        "x": np.full((1, n), 7000.0),
        "y": np.linspace(0, 4, n)[None],
        "z": np.full((1, n), 7000.0),
        "r0": np.full((1, n), 9899.5),
        "th": np.zeros((1, n)),
        "phi": np.full((1, n), 45.0),
    }
    data.update(fields)
    data = {k: v for k, v in data.items() if v is not None}
    scipy.io.savemat(path, {"data": data})
    return path


def test_missing_field(tmp_path, capsys):
    bad = _gotcha_like(tmp_path / "a.mat", fp=None)
    _fails(["image", str(bad), "--out", str(tmp_path / "o")], capsys, "fp", tmp_path / "o")


def test_wrong_shape(tmp_path, capsys):
    bad = _gotcha_like(tmp_path / "a.mat", fp=np.ones((7, 5), np.complex64))
    _fails(["image", str(bad), "--out", str(tmp_path / "o")], capsys, "shape", tmp_path / "o")


def test_nan_data(tmp_path, capsys):
    fp = np.ones((8, 5), np.complex64)
    fp[3, 2] = np.nan
    bad = _gotcha_like(tmp_path / "a.mat", fp=fp)
    _fails(["image", str(bad), "--out", str(tmp_path / "o")], capsys, "NaN", tmp_path / "o")


def test_unknown_scene_key(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text("[[targets]]\nposition_m = [0, 0]\nspeed = 3\n")
    out = tmp_path / "o.h5"
    _fails(
        ["simulate", str(scene), "--out", str(out)], capsys, "unknown key 'targets[0].speed'", out
    )


def test_unknown_scene_name_and_bad_target(tmp_path, capsys):
    _fails(["simulate", "scene42", "--out", str(tmp_path / "o.h5")], capsys, "unknown scene")
    base = tmp_path / "b.h5"
    assert run(["simulate", "rotscatt", "--out", str(base)]) == 0
    capsys.readouterr()
    _fails(
        ["inject", str(base), "--target", "1,x", "--out", str(tmp_path / "i.h5")],
        capsys,
        "--target",
        tmp_path / "i.h5",
    )


@pytest.mark.gotcha
def test_image_real_gotcha(gotcha_files, tmp_path, capsys):
    out = tmp_path / "g"
    assert run(["image", *map(str, gotcha_files), "--out", str(out)]) == 0
    import json

    peaks = json.loads((out / "peaks.json").read_text())["peaks"]
    got = np.array([p["position_m"] for p in peaks[:2]])
    # The two calibration reflectors, within a pixel (0.25 m) and the README's rounding.
    want = np.array([[-15.5, 21.5], [-27.7, 38.7]])
    assert np.max(np.abs(got - want)) <= 0.4


@pytest.mark.parametrize("method", ["combined", "rpca", "annihilation"])
def test_separate_writes_traces_figures_and_quality(tmp_path, capsys, method):
    import json

    out = tmp_path / method
    args = ["separate", "rotscatt", "--method", method, "--out", str(out)]
    if method == "rpca":
        args += ["--window", "64", "--eta-scale", "1.5"]
    assert run(args) == 0, capsys.readouterr().err
    summary = json.loads((out / "separation.json").read_text())
    assert summary["schema"] == "sarmotion.separation/1" and summary["method"] == method
    assert 0.0 <= summary["quality"]["mover_trace_coverage"] <= 1.0
    assert (out / "separation.png").stat().st_size > 1000
    assert load_traces(out / "separated.h5").shape == (117, 424)


def test_paper_builds_a_figure_and_rejects_unknown_labels(tmp_path, capsys):
    out = tmp_path / "paper"
    assert run(["paper", "--only", "fig:rpcaEx1", "--quick", "--out", str(out)]) == 0
    assert (out / "fig_rpcaEx1.png").stat().st_size > 1000
    assert "fig_rpcaEx1.png" in (out / "index.html").read_text()
    capsys.readouterr()
    _fails(
        ["paper", "--only", "fig:nope", "--out", str(tmp_path / "p2")],
        capsys,
        "fig:nope",
        tmp_path / "p2",
    )


def test_paper_setup_reads_the_gotcha_directory(tmp_path, gotcha_dir):
    out = tmp_path / "setup"
    assert run(["paper", "--only", "setup", "--gotcha", str(gotcha_dir), "--out", str(out)]) == 0
    with np.load(out / "fig_setup.npz") as z:
        positions = z["positions_m"]
    # the antenna positions of the files, not the nominal circle
    assert positions.shape == read_gotcha(sorted(gotcha_dir.glob("*.mat"))).positions_m.shape
    assert "GOTCHA pass 1 HH" in (out / "index.html").read_text(encoding="utf-8")


def test_image_on_an_explicit_grid(tmp_path, capsys):
    out = tmp_path / "img"
    args = [
        "image",
        "hyperbola",
        "--out",
        str(out),
        "--grid",
        "-3",
        "2",
        "3",
        "9",
        "--spacing",
        "0.1",
    ]
    assert run(args) == 0, capsys.readouterr().err
    img = load_image(out / "image.h5")
    assert img["x_m"][0] == pytest.approx(-3.0, abs=0.1) and img["y_m"][-1] == pytest.approx(
        9.0, abs=0.1
    )
    iy, ix = np.unravel_index(np.argmax(np.abs(img["values"])), img["values"].shape)
    assert abs(img["x_m"][ix]) <= 0.1 and abs(img["y_m"][iy] - 5.0) <= 0.1
    _fails(
        ["image", "hyperbola", "--out", str(tmp_path / "b"), "--grid", "2", "1", "0", "1"],
        capsys,
        "--grid",
        tmp_path / "b",
    )
