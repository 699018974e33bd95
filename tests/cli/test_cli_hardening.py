"""Bad input on the command line: one line, exit status 2, and the output target untouched.

One test per finding of a round of hostile use (corrupt files, meaningless options, --out
traps, interrupted runs, error texts).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import scipy.io

from gotcha_files import small_struct
from sarmotion.cli.main import EXIT_BAD_INPUT, EXIT_TERMINATED, run

ROOT = Path(__file__).resolve().parents[2]


def _snapshot(path: Path) -> dict[str, bytes | None]:
    """Every entry under ``path`` (and its siblings' names) with file contents."""
    parent = path.parent
    out: dict[str, bytes | None] = {}
    for p in sorted(parent.rglob("*")):
        out[str(p.relative_to(parent))] = p.read_bytes() if p.is_file() else None
    return out


def _refused(args, capsys, pattern, target):
    """Run ``args``; assert one error line holding ``pattern``, exit 2, target untouched."""
    before = _snapshot(Path(target))
    code = run(args)
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT, err
    assert len(err.splitlines()) == 1 and err.startswith("sarmotion: error:"), err
    assert pattern in err, err
    assert _snapshot(Path(target)) == before, "a refused command changed its output target"
    return err


@pytest.fixture
def work(tmp_path):
    """A directory with a good small GOTCHA file and an existing output directory."""
    scipy.io.savemat(tmp_path / "good.mat", {"data": small_struct(24, 32, az0_deg=0.3, seed=3)})
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("previous result")
    return tmp_path


def _corrupt(work, name, edit):
    s = small_struct(24, 32, az0_deg=0.3, seed=3)
    edit(s)
    path = work / name
    scipy.io.savemat(path, {"data": s})
    return str(path)


# ------------------------------------------------------------------ corrupt files
@pytest.mark.parametrize(
    ("edit", "pattern"),
    [
        (lambda s: s["z"].__setitem__((0, 5), 1e-3), "data.x/y/z, pulse 5"),
        (lambda s: s["r0"].__setitem__((0, 5), 23645.0), "data.r0, pulse 5: 23645 m"),
        (lambda s: s["fp"].__setitem__((4, 5), 4e35), "data.fp, pulse 5, frequency index 4"),
    ],
)
def test_corrupt_gotcha_files_are_refused(work, capsys, edit, pattern):
    bad = _corrupt(work, "bad.mat", edit)
    out = work / "out"
    err = _refused(["image", bad, "--out", str(out), "--size", "20"], capsys, pattern, out)
    assert "rule:" in err and "--lenient" in err


def test_lenient_accepts_with_a_warning(work, capsys, caplog):
    bad = _corrupt(work, "odd.mat", lambda s: s["th"].__setitem__((0, 3), 40.0))
    out = work / "new"
    with caplog.at_level("WARNING"):
        assert run(["image", bad, "--out", str(out), "--size", "20", "--lenient"]) == 0
    assert any("data.th, pulse 3" in r.getMessage() for r in caplog.records)
    assert (out / "image.h5").is_file()


def test_unreadable_mat_gets_a_short_reason(work, capsys):
    raw = bytearray((work / "good.mat").read_bytes())
    raw[0x110:0x114] = b"\xff\xff\xff\x7f"  # the first dimension of data.fp
    (work / "broken.mat").write_bytes(bytes(raw))
    out = work / "out"
    err = _refused(
        ["image", str(work / "broken.mat"), "--out", str(out)], capsys, "not a readable", out
    )
    for internal in ("referenced before assignment", "reshape", "codec"):
        assert internal not in err


def test_same_file_twice_is_called_a_duplicate(work, capsys):
    (work / "copy.mat").write_bytes((work / "good.mat").read_bytes())
    out = work / "out"
    args = ["image", str(work / "good.mat"), str(work / "copy.mat"), "--out", str(out)]
    _refused(args, capsys, "duplicate of good.mat", out)


# -------------------------------------------------------------- meaningless input
def test_negative_scene_amplitude(work, capsys):
    scene = work / "neg.toml"
    scene.write_text(
        'schema = "sarmotion.scene/1"\n[[targets]]\nposition_m = [0.0, 0.0]\namplitude = -1.0\n'
    )
    out = work / "out"
    for cmd in (["image", str(scene)], ["analyze", str(scene)], ["separate", str(scene)]):
        _refused([*cmd, "--out", str(out)], capsys, "targets[0].amplitude must be > 0", out)
    sim_out = work / "s.h5"
    _refused(
        ["simulate", str(scene), "--out", str(sim_out)], capsys, "amplitude must be > 0", sim_out
    )


@pytest.mark.parametrize(
    ("args", "pattern"),
    [
        (["image", "hyperbola", "--dynamic-range", "-10"], "--dynamic-range must be > 0"),
        (["separate", "hyperbola", "--threshold-db", "nan"], "--threshold-db must be finite"),
        (["separate", "hyperbola", "--eta-scale", "-1"], "--eta-scale must be > 0"),
        (["separate", "hyperbola", "--window", "1"], "--window must be >= 2"),
        (["image", "hyperbola", "--speed", "0"], "--speed must be within [0.001, 10000] m/s"),
        (["image", "hyperbola", "--speed", "1e-300"], "--speed must be within"),
        (["image", "hyperbola", "--velocity", "1e10", "0"], "--velocity must be a ground speed"),
        (["inject", "hyperbola", "--target", "1e300,0"], "X, Y must be within 10000 m"),
        (["image", "hyperbola", "--size", "-5"], "--size must be > 0"),
        (["analyze", "hyperbola", "--sub-aperture", "0"], "--sub-aperture must be > 0"),
        (["analyze", "hyperbola", "--max-movers", "-1"], "--max-movers must be >= 0"),
        (["image", "hyperbola", "--grid", "-5", "5", "-5", "5", "--size", "10"], "--grid sets"),
        (["inject", "hyperbola", "--target", "1,2,0,0,-3"], "AMP must be > 0"),
        (["separate", "hyperbola", "--seed", "-1"], "--seed must be >= 0"),
        (["separate", "hyperbola", "--snr-db", "nan"], "--snr-db must be finite"),
        (["image", "hyperbola", "--spacing", "inf"], "--spacing must be finite"),
        (["image", "hyperbola", "--velocity", "nan", "1"], "--velocity must be finite"),
    ],
)
def test_options_are_checked_and_named_by_flag(work, capsys, args, pattern):
    out = work / "out"
    err = _refused([*args, "--out", str(out)], capsys, pattern, out)
    for name in ("speed_mps", "eta_scale", "rpca_window", "candidate_threshold_db", "size_m"):
        assert name not in err


def test_paper_only_is_named_by_flag(work, capsys):
    out = work / "out"
    err = _refused(["paper", "--only", "nosuch", "--out", str(out)], capsys, "--only must", out)
    assert "only must" not in err.replace("--only must", "")


# ------------------------------------------------------------------- --out traps
def test_out_that_is_a_file_is_refused_before_work(work, capsys):
    target = work / "afile"
    target.write_text("not a directory")
    t0 = time.perf_counter()
    _refused(["analyze", "scene1", "--out", str(target)], capsys, "not a directory", target)
    assert time.perf_counter() - t0 < 5.0  # analyze scene1 itself takes ~10 s


def test_existing_outputs_need_force(work, capsys):
    out = work / "img"
    assert run(["image", "hyperbola", "--out", str(out), "--size", "10"]) == 0
    capsys.readouterr()
    _refused(["image", "hyperbola", "--out", str(out), "--size", "10"], capsys, "--force", out)
    assert run(["image", "hyperbola", "--out", str(out), "--size", "10", "--force"]) == 0


def test_simulate_does_not_overwrite_a_file(work, capsys):
    target = work / "existing.h5"
    target.write_bytes(b"precious")
    _refused(["simulate", "hyperbola", "--out", str(target)], capsys, "already exists", target)
    assert run(["simulate", "hyperbola", "--out", str(target), "--force"]) == 0
    assert target.read_bytes()[:4] == b"\x89HDF"


def test_read_only_out_directory_is_refused_before_work(work, capsys, monkeypatch):
    """As a read-only directory appears to a user (root may write anywhere)."""
    from sarmotion.cli import common

    out = work / "out"
    real_access = os.access

    def access(path, mode):
        if Path(path) == out and mode & os.W_OK:
            return False
        return real_access(path, mode)

    monkeypatch.setattr(common.os, "access", access)
    _refused(["image", "hyperbola", "--out", str(out)], capsys, "permission denied", out)


@pytest.mark.skipif(os.geteuid() == 0, reason="root ignores directory permissions")
def test_read_only_out_directory(work, capsys):
    out = work / "out"
    out.chmod(0o555)
    try:
        _refused(["image", "hyperbola", "--out", str(out)], capsys, "permission denied", out)
    finally:
        out.chmod(0o755)


@pytest.mark.parametrize("exchange", [True, False])
def test_failed_move_into_out_is_undone(work, capsys, monkeypatch, exchange):
    """A swap that fails (as on a read-only parent) leaves the previous output as it was."""
    from sarmotion.io import staging

    out = work / "img"
    assert run(["image", "hyperbola", "--out", str(out), "--size", "10"]) == 0
    capsys.readouterr()

    def refuse(src, dst):
        raise PermissionError(13, "Permission denied", str(dst))

    if exchange:
        monkeypatch.setattr(staging, "_exchange", refuse)
    else:  # no renameat2: rename the old output aside, then the new one in; the second fails
        real_rename = os.rename
        calls = []

        def flaky(src, dst):
            calls.append(dst)
            if len(calls) == 2:
                refuse(src, dst)
            return real_rename(src, dst)

        monkeypatch.setattr(staging, "_exchange", lambda a, b: False)
        monkeypatch.setattr(staging.os, "rename", flaky)
    args = ["image", "hyperbola", "--out", str(out), "--size", "12", "--force"]
    _refused(args, capsys, "Permission denied", out)


def test_directory_where_an_output_file_goes(work, capsys):
    out = work / "img"
    (out / "peaks.json").mkdir(parents=True)
    _refused(["image", "hyperbola", "--out", str(out)], capsys, "peaks.json", out)
    assert run(["image", "hyperbola", "--out", str(out), "--size", "10", "--force"]) == 0
    assert (out / "peaks.json").is_file()
    assert not list(work.rglob("*.partial-*"))


def test_sigterm_leaves_nothing_behind(tmp_path):
    out = tmp_path / "demo"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.Popen(
        [sys.executable, "-m", "sarmotion", "-v", "analyze", "scene1", "--out", str(out)],
        env=env,
        stderr=subprocess.PIPE,
        text=True,
    )
    # the first log line comes after the separation stage: the analysis is under way
    first = proc.stderr.readline()
    assert "separation" in first, first
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == EXIT_TERMINATED, err
    assert "terminated" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------- first hour
def test_help_texts_have_no_markup_and_no_bare_labels(capsys):
    commands = ([], ["image"], ["separate"], ["analyze"], ["simulate"], ["inject"], ["paper"])
    for cmd in (*commands, ["convert"], ["demo"]):
        assert run([*cmd, "--help"]) == 0
        text = capsys.readouterr().out
        assert "`" not in text
        for word in text.replace("\n", " ").split():
            if word.startswith(("eq:", "sect:", "(eq:", "(sect:")):
                pytest.fail(f"bare label {word} in {cmd} --help")


def test_analyze_has_autofocus_and_lenient(capsys):
    assert run(["analyze", "--help"]) == 0
    text = capsys.readouterr().out
    assert "--autofocus" in text and "--lenient" in text and "--force" in text


def test_quiet_after_the_command(work, capsys):
    out = work / "img"
    assert run(["image", "-q", "hyperbola", "--out", str(out), "--size", "10"]) == 0
    assert run(["analyze", "-q", "-v", "--help"]) == 0  # known to every command


def test_gitignore_covers_the_default_outputs():
    lines = (ROOT / ".gitignore").read_text().split()
    assert "sarmotion-demo/" in lines and "sarmotion-paper/" in lines


# ------------------------------------------------------------- further error texts
def test_scene_file_that_is_not_utf8(work, capsys):
    scene = work / "bad.toml"
    scene.write_bytes(b'schema = "sarmotion.scene/1"\n\xab\xcd = 1\n')
    out = work / "out"
    err = _refused(
        ["image", str(scene), "--out", str(out)], capsys, "not UTF-8 text (byte 29)", out
    )
    assert "codec" not in err


def test_truncated_native_file(work, capsys):
    full = work / "t.h5"
    assert run(["simulate", "rotscatt", "--out", str(full)]) == 0
    raw = full.read_bytes()
    (work / "cut.h5").write_bytes(raw[: len(raw) // 2])
    out = work / "out"
    err = _refused(
        ["image", str(work / "cut.h5"), "--out", str(out)], capsys, "not a readable HDF5", out
    )
    assert "synchronously" not in err and "sblock" not in err


def test_hdf5_reading_that_does_not_finish_is_refused(work, monkeypatch):
    """The child-process guard against HDF5 library loops (its timeout path)."""
    from sarmotion.io import DataError, native

    assert run(["simulate", "rotscatt", "--out", str(work / "t.h5")]) == 0
    native.check_hdf5_terminates(work / "t.h5")  # a good file passes
    monkeypatch.setattr(native, "_WALK", "import time; time.sleep(30)")
    with pytest.raises(DataError, match=r"t\.h5: not a readable HDF5 file: reading it did not"):
        native.check_hdf5_terminates(work / "t.h5", timeout_s=1.0)


def test_image_of_an_empty_region_says_so(work, capsys):
    out = work / "far"
    assert (
        run(["image", "hyperbola", "--centre", "1e6", "0", "--size", "10", "--out", str(out)]) == 0
    )
    assert "the image is zero" in capsys.readouterr().out


def test_separate_a_scene_without_movers(work, capsys):
    out = work / "sep"
    assert run(["separate", "hyperbola", "--out", str(out)]) == 0
    assert (out / "separation.json").is_file()


def test_a_defect_is_one_line_and_exit_1(work, capsys, monkeypatch):
    from sarmotion.cli import image as image_module
    from sarmotion.cli.main import EXIT_INTERNAL

    def broken(*args, **kwargs):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(image_module, "backproject", broken)
    out = work / "img"
    assert run(["image", "hyperbola", "--out", str(out)]) == EXIT_INTERNAL
    err = capsys.readouterr().err.strip()
    assert err.startswith("sarmotion: internal error: ZeroDivisionError") and "\n" not in err
    assert not out.exists()  # the failure came before the outputs were staged


def test_failure_leaves_no_directory_it_created(work):
    from sarmotion.io import staged_directory

    out = work / "new" / "deeper" / "img"
    with pytest.raises(RuntimeError), staged_directory(out) as stage:
        (stage / "x.txt").write_text("partial")
        raise RuntimeError("fails half-way")
    assert not (work / "new").exists()
