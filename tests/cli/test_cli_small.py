"""Small things a first hour trips on: inputs, file names, the data's place, the console.

Each test is one finding: an unknown input name lists the built-in scenes; a directory
is read as its GOTCHA files by every command (as ``paper --gotcha`` reads it); written
GOTCHA files are named by their azimuth; ``paper`` finds the data beside a clone as the
tests do; a concurrent ``analyze`` into the same new ``--out`` is refused before it reads
anything; ``image.png`` shows every image pixel; the console prints no ``-0.00`` and its
time covers the whole run.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest
from test_outputs import _holder, _one_line_refusal

from gotcha_files import save_struct, small_struct
from sarmotion.cli.main import run
from sarmotion.io import load_image, read_gotcha
from sarmotion.simulation import builtin_scene_names, load_scene, simulate

ROOT = Path(__file__).resolve().parents[2]

#: A number printed as minus zero: "-0.00" not followed by another digit.
NEGATIVE_ZERO = re.compile(r"-0\.0+(?![0-9])")


def _gotcha_dir(path: Path, n_files: int = 2, az0_deg: float = 0.0) -> list[Path]:
    """``n_files`` consecutive small GOTCHA files (5 pulses each) in ``path``."""
    path.mkdir(parents=True, exist_ok=True)
    step = 5 * 0.00853  # small_struct's azimuth step per file (degrees)
    return [
        save_struct(
            path / f"data_3dsar_pass1_az{k + 1:03d}_HH.mat",
            small_struct(az0_deg=az0_deg + k * step, seed=k),
        )
        for k in range(n_files)
    ]


def test_an_unknown_input_name_lists_the_built_in_scenes(tmp_path, capsys):
    err = _one_line_refusal(["image", "scene2", "--out", str(tmp_path / "o")], capsys, "scene2")
    assert "input not found" in err
    for name in builtin_scene_names():
        assert name in err


def test_a_directory_input_is_its_gotcha_files(tmp_path, capsys):
    files = _gotcha_dir(tmp_path / "g")
    args = ["--size", "10", "--spacing", "1"]
    assert run(["image", str(tmp_path / "g"), "--out", str(tmp_path / "d"), *args]) == 0
    assert run(["image", *map(str, files), "--out", str(tmp_path / "f"), *args]) == 0
    from_dir = load_image(tmp_path / "d" / "image.h5")
    from_files = load_image(tmp_path / "f" / "image.h5")
    np.testing.assert_array_equal(from_dir["values"], from_files["values"])
    (tmp_path / "empty").mkdir()
    err = _one_line_refusal(
        ["image", str(tmp_path / "empty"), "--out", str(tmp_path / "e")], capsys, "empty"
    )
    assert ".mat" in err


def test_written_gotcha_files_are_named_by_their_azimuth(tmp_path):
    """File azNNN holds the azimuths [NNN - 1, NNN) degrees, as in the AFRL release."""
    (src,) = _gotcha_dir(tmp_path / "g", n_files=1, az0_deg=2.3)
    assert run(["convert", str(src), "--to", "gotcha", "--out", str(tmp_path / "c")]) == 0
    assert [p.name for p in (tmp_path / "c").iterdir()] == ["data_3dsar_pass1_az003_HH.mat"]
    assert run(["simulate", "scene1", "--out", str(tmp_path / "s")]) == 0
    traces = simulate(load_scene("scene1")).traces
    pos = traces.positions_m[0] - traces.reference_point_m
    expected = 1 + int(np.floor(np.degrees(np.arctan2(pos[1], pos[0])) % 360.0))
    (written,) = (tmp_path / "s").iterdir()
    assert written.name == f"data_3dsar_pass1_az{expected:03d}_HH.mat"
    back = read_gotcha([written])
    th0 = np.degrees(np.arctan2(*(back.positions_m[0, 1::-1] - back.reference_point_m[1::-1])))
    assert expected - 1 <= th0 % 360.0 < expected


def test_paper_finds_the_gotcha_data_beside_the_clone(tmp_path, monkeypatch):
    clone = tmp_path / "sarmotion"
    clone.mkdir()
    _gotcha_dir(tmp_path / "shared" / "data" / "gotcha")
    monkeypatch.chdir(clone)
    monkeypatch.delenv("SARMOTION_GOTCHA_DIR", raising=False)
    assert run(["-q", "paper", "--only", "fig:setup", "--quick", "--out", "p"]) == 0
    index = (clone / "p" / "index.html").read_text()
    assert "data not found" not in index
    assert "GOTCHA pass 1 HH, 2 files" in index


def test_a_concurrent_analysis_into_one_new_out_is_refused_before_reading(
    tmp_path, capsys, monkeypatch
):
    import sarmotion.cli.autofocus as reading

    def no_work(*a, **k):
        raise AssertionError("the refused run read its inputs")

    out = tmp_path / "o"
    holder = _holder(out, "directory")
    try:
        monkeypatch.setattr(reading, "read_focused", no_work)
        start = time.perf_counter()
        _one_line_refusal(["analyze", "scene1", "--out", str(out)], capsys, f"pid {holder.pid}")
        assert time.perf_counter() - start < 5.0  # refused at once: nothing was read
        assert not out.exists()
    finally:
        holder.communicate("", timeout=30)


def test_image_png_shows_every_pixel_with_a_title_that_says_what_it_is():
    """A checkerboard of 80 x 80 pixels comes out as whole 5 x 5 blocks of the PNG."""
    import io

    from sarmotion.report.plotting import full_resolution_image_figure

    n = 80
    board = 1.0 + 99.0 * ((np.add.outer(np.arange(n), np.arange(n)) % 2) == 0)
    x = np.arange(n) * 0.25
    fig = full_resolution_image_figure(board, x_m=x, y_m=x, title="t\nwo", dpi=100)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    png = matplotlib.image.imread(io.BytesIO(buf.getvalue()))
    box = fig.axes[0].get_window_extent()
    assert round(box.width) == round(box.height) == 5 * n  # k = ceil(400 / 80) = 5
    top = png.shape[0] - round(box.y1)
    grey = png[top : top + 5 * n, round(box.x0) : round(box.x0) + 5 * n, 0]
    levels = grey[2::5, 2::5][::-1]  # the centre of each 5 x 5 block; y runs upwards
    assert np.array_equal(levels > 0.5, board > 50)
    spread = np.ptp(grey.reshape(n, 5, n, 5), axis=(1, 3))
    assert spread[1:-1, 1:-1].max() < 1e-6  # uniform blocks (the frame covers the outer ring)


def test_image_command_title_and_size(tmp_path):
    assert run(["-q", "image", "scene1", "--out", str(tmp_path / "o")]) == 0
    png = matplotlib.image.imread(tmp_path / "o" / "image.png")
    assert png.shape[0] > 400 and png.shape[1] > 400  # 400 x 400 pixels, margins around
    from sarmotion.cli.common import square_grid
    from sarmotion.cli.image import _title

    title = _title(["scene1"], square_grid(100.0, 0.25, (0.0, 0.0)), None, 40.0)
    assert "scene1" in title and "400 x 400 pixels of 0.25 m" in title
    assert "100 x 100 m" in title and "dB re its peak" in title


@pytest.mark.slow
def test_console_has_no_negative_zero_and_its_time_covers_the_run(tmp_path):
    """Scene 1's mover at (0, 0) printed as (0.00, 0.00); the time includes start-up.

    The time printed "in all" runs from the process's start: it is at most the wall
    time measured outside and at least 0.75 of it (what is left out is the interpreter's
    exit and the fork, well under a quarter of a run of several seconds).
    """
    # The test run's environment, so that bytecode and numba's cache stay out of src/.
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "MPLBACKEND": "Agg"}
    args = ["analyze", "scene1", "--no-trajectory", "--out", str(tmp_path / "o")]
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "sarmotion", "-q", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    wall = time.perf_counter() - start
    assert proc.returncode == 0, proc.stderr
    assert not NEGATIVE_ZERO.search(proc.stdout), proc.stdout
    assert "cross range of the reference point: (0.00, 0.00) m" in proc.stdout
    analysis = float(re.search(r"analysis (\d+\.\d) s", proc.stdout)[1])
    in_all = float(re.search(r"(\d+\.\d) s in all", proc.stdout)[1])
    assert analysis < in_all <= wall + 0.05
    assert in_all >= 0.75 * wall
