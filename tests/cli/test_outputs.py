"""Outputs that cannot clobber or mix (sarmotion.io.staging and every command's --out).

One test per finding: concurrent runs into one --out, special files and links as --out,
--force leaving stale files, SIGKILL during the final move, staging folders of dead runs
never cleaned, a file created at the output path while a run works.
"""

from __future__ import annotations

import os
import signal
import socket
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from sarmotion.cli.main import EXIT_BAD_INPUT, run
from sarmotion.io import (
    OutputError,
    claim_output,
    read_gotcha,
    staged_directory,
    staged_file,
    staging,
)
from sarmotion.io.gotcha import written_by_sarmotion

ROOT = Path(__file__).resolve().parents[2]
STAGING = ROOT / "src" / "sarmotion" / "io" / "staging.py"


def _entries(path: Path) -> dict[str, bytes]:
    """Every file under ``path`` with its content (relative names)."""
    return {
        str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()
    }


def _one_line_refusal(args, capsys, pattern):
    code = run(args)
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT, err
    assert len(err.splitlines()) == 1 and err.startswith("sarmotion: error:"), err
    assert pattern in err, err
    return err


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


# ------------------------------------------------------------------ one writer
def _holder(out: Path, kind: str) -> subprocess.Popen:
    """Another process that claims ``out`` and holds it until its stdin closes."""
    code = textwrap.dedent(
        f"""
        import sys
        from sarmotion.io import claim_output
        claim = claim_output({str(out)!r}, kind={kind!r})
        print("ready", flush=True)
        sys.stdin.read()
        claim.release()
        """
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.Popen(
        [sys.executable, "-c", code],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        env=env,
        text=True,
    )
    assert proc.stdout.readline().strip() == "ready"
    return proc


@pytest.mark.parametrize(
    ("args", "kind", "work"),
    [
        (["image", "hyperbola", "--size", "10"], "directory", ("image", "backproject")),
        (["simulate", "hyperbola"], "file", ("simulate", "run")),
    ],
)
def test_a_concurrent_run_is_refused_at_once_naming_the_holder(
    tmp_path, capsys, monkeypatch, args, kind, work
):
    import importlib

    module = importlib.import_module(f"sarmotion.cli.{work[0]}")

    def no_work(*a, **k):
        raise AssertionError("the refused run started its work")

    out = tmp_path / ("o.h5" if kind == "file" else "o")
    holder = _holder(out, kind)
    try:
        with monkeypatch.context() as m:
            m.setattr(module, work[1], no_work)
            err = _one_line_refusal([*args, "--out", str(out)], capsys, f"pid {holder.pid}")
        assert "another sarmotion run" in err
        assert not out.exists()
    finally:
        holder.communicate("", timeout=30)
    assert holder.returncode == 0
    assert run([*args, "--out", str(out)]) == 0  # free again, and no lock file left behind
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]


def test_two_runs_into_one_new_out_at_once(tmp_path):
    """Two real commands started together: one writes, the other is refused at once."""
    out = tmp_path / "o"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    cmd = [sys.executable, "-m", "sarmotion", "image", "hyperbola", "--size", "10", "--out"]
    procs = [
        subprocess.Popen([*cmd, str(out)], env=env, stderr=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    results = [(p.wait(timeout=120), p.stderr.read()) for p in procs]
    codes = sorted(code for code, _ in results)
    assert codes in ([0, EXIT_BAD_INPUT], [0, 0]), results
    if codes == [0, EXIT_BAD_INPUT]:
        err = next(e for c, e in results if c == EXIT_BAD_INPUT).strip()
        assert "being written by another sarmotion run (pid" in err and "\n" not in err
    else:  # the second started after the first had finished: it found outputs to refuse
        pytest.fail("both runs succeeded: the second must need --force")
    assert sorted(p.name for p in out.iterdir()) == ["image.h5", "image.png", "peaks.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]


# ---------------------------------------------------------------- special files
def _fifo(p):
    os.mkfifo(p)


def _socket(p):
    s = socket.socket(socket.AF_UNIX)
    s.bind(str(p))
    s.close()


def _dangling(p):
    p.symlink_to(p.parent / "nowhere")


def _self(p):
    p.symlink_to(p.name)


def _loop(p):
    (p.parent / "loop-b").symlink_to(p.name)
    p.symlink_to("loop-b")


def _to_fifo(p):
    os.mkfifo(p.parent / "fifo")
    p.symlink_to(p.parent / "fifo")


def _to_file(p):
    (p.parent / "real.h5").write_bytes(b"precious")
    p.symlink_to(p.parent / "real.h5")


def _to_dir(p):
    (p.parent / "real").mkdir()
    (p.parent / "real" / "keep.txt").write_text("precious")
    p.symlink_to(p.parent / "real")


def _chardev(p):
    if os.geteuid() != 0:
        pytest.skip("making a device node needs root")
    os.mknod(p, 0o600 | stat.S_IFCHR, os.makedev(1, 3))  # a second /dev/null


SPECIAL = {
    "fifo": (_fifo, "FIFO"),
    "socket": (_socket, "socket"),
    "chardev": (_chardev, "character device"),
    "dangling link": (_dangling, "symbolic link"),
    "link to itself": (_self, "symbolic link"),
    "link loop": (_loop, "symbolic link"),
    "link to a fifo": (_to_fifo, "symbolic link"),
    "link to a file": (_to_file, "symbolic link"),
    "link to a directory": (_to_dir, "symbolic link"),
}


def _lstat_all(d: Path):
    return {p.name: (stat.S_IFMT(os.lstat(p).st_mode), os.lstat(p).st_ino) for p in d.iterdir()}


@pytest.mark.parametrize("force", [False, True])
@pytest.mark.parametrize("name", sorted(SPECIAL))
@pytest.mark.parametrize("kind", ["file", "directory"])
def test_special_files_and_links_are_refused(tmp_path, capsys, name, kind, force):
    make, what = SPECIAL[name]
    target = tmp_path / ("target.h5" if kind == "file" else "target")
    make(target)
    before = _lstat_all(tmp_path)
    args = ["simulate", "hyperbola"] if kind == "file" else ["image", "hyperbola", "--size", "10"]
    err = _one_line_refusal(
        [*args, "--out", str(target), *(["--force"] if force else [])], capsys, what
    )
    assert str(target) in err
    assert _lstat_all(tmp_path) == before  # not replaced, nothing added
    if name == "link to a file":
        assert (tmp_path / "real.h5").read_bytes() == b"precious"
    if name == "link to a directory":
        assert _entries(tmp_path / "real") == {"keep.txt": b"precious"}


# -------------------------------------------------------------- the whole set
def test_force_replaces_a_previous_gotcha_output_and_keeps_look_alike_files(tmp_path, capsys):
    """A previous run's files go (their header marks them); the user's files stay."""
    out = tmp_path / "g"
    assert run(["convert", "hyperbola", "--to", "gotcha", "--out", str(out)]) == 0
    assert set(_entries(out)) == {"data_3dsar_pass1_az359_HH.mat"}
    (out / "notes.txt").write_text("mine")
    (out / "data_3dsar_pass1_az007_HH.mat").write_bytes(b"MATLAB 5.0 the user's own degree")
    args = ["convert", "scene1", "--to", "gotcha", "--out", str(out)]
    _one_line_refusal(args, capsys, "--force")
    assert run([*args, "--force"]) == 0
    after = _entries(out)
    assert after.pop("notes.txt") == b"mine"
    assert after.pop("data_3dsar_pass1_az007_HH.mat") == b"MATLAB 5.0 the user's own degree"
    assert set(after) == {"data_3dsar_pass1_az360_HH.mat"}  # the previous run's az359 went


@pytest.mark.parametrize(
    "command",
    [
        ["convert", "AZ", "--to", "gotcha"],
        ["simulate", "hyperbola"],
        ["inject", "AZ", "--target", "1,2,3,4"],
    ],
    ids=["convert", "simulate", "inject"],
)
def test_force_never_deletes_the_users_own_mat_files(tmp_path, command):
    """A folder holds a GOTCHA file and the user's my_calibration.mat: --force keeps the latter."""
    d = tmp_path / "d"
    assert run(["convert", "hyperbola", "--to", "gotcha", "--out", str(d)]) == 0
    (azfile,) = d.glob("*.mat")
    (d / "my_calibration.mat").write_bytes(b"calibration")
    args = [a if a != "AZ" else str(azfile) for a in command]
    assert run([*args, "--out", str(d), "--force"]) == 0
    assert (d / "my_calibration.mat").read_bytes() == b"calibration"
    assert azfile.exists() and written_by_sarmotion(azfile)


def test_written_gotcha_files_carry_the_writers_mark_and_read_back(tmp_path):
    out = tmp_path / "g"
    assert run(["convert", "hyperbola", "--to", "gotcha", "--out", str(out)]) == 0
    (path,) = out.glob("*.mat")
    assert written_by_sarmotion(path)
    assert read_gotcha(path).n_pulses > 0  # the header is free text to every reader
    import scipy.io

    assert "data" in scipy.io.loadmat(path)
    assert not written_by_sarmotion(out / "missing.mat")


def test_force_leaves_no_stale_output_of_the_same_command(tmp_path, capsys):
    """A previous analysis's movers.png and trajectories.png go when the new one has none."""
    out = tmp_path / "a"
    out.mkdir()
    for name in ("results.json", "report.html", "movers.png", "trajectories.png"):
        (out / name).write_bytes(b"from a previous run")
    (out / "keep.txt").write_text("mine")
    args = ["analyze", "hyperbola", "--out", str(out), "--no-trajectory", "--max-movers", "0"]
    _one_line_refusal(args, capsys, "--force")
    assert run([*args, "--force"]) == 0
    names = {p.name for p in out.iterdir()}
    assert "movers.png" not in names and "trajectories.png" not in names
    assert (out / "keep.txt").read_text() == "mine"
    assert all(b"from a previous run" != p.read_bytes() for p in out.iterdir() if p.is_file())


def test_a_file_created_at_the_target_mid_run_is_not_replaced(tmp_path):
    for kind in ("file", "directory"):
        out = tmp_path / f"new-{kind}"
        claim = claim_output(out, kind=kind)
        try:
            with pytest.raises(OutputError, match="created while sarmotion ran; --force"):
                with claim.stage() as stage:
                    (stage if kind == "file" else stage / "a.txt").write_text("new")
                    if kind == "file":
                        out.write_text("the user's")
                    else:
                        out.mkdir()
                        (out / "x").write_text("the user's")
        finally:
            claim.release()
        if kind == "file":
            assert out.read_text() == "the user's"
        else:
            assert _entries(out) == {"x": b"the user's"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new-directory", "new-file"]


def test_a_file_created_mid_run_is_replaced_with_force(tmp_path):
    out = tmp_path / "f.txt"
    claim = claim_output(out, kind="file", force=True)
    try:
        with claim.stage() as path:
            path.write_text("new")
            out.write_text("the user's")
    finally:
        claim.release()
    assert out.read_text() == "new"


# ------------------------------------------------------- SIGKILL at every step
KILLER = textwrap.dedent(
    """
    import importlib.util, os, shutil, signal, sys
    spec = importlib.util.spec_from_file_location("staging", sys.argv[1])
    staging = importlib.util.module_from_spec(spec)
    sys.modules["staging"] = staging
    spec.loader.exec_module(staging)
    out, kind, kill_at, exchange = sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5]
    calls = [0]

    def killing(fn):
        def wrapped(*a, **k):
            calls[0] += 1
            if calls[0] == kill_at:
                os.kill(os.getpid(), signal.SIGKILL)
            return fn(*a, **k)
        return wrapped

    if exchange == "no":
        staging._renameat2_fn = None
    for name in ("rename", "link", "mkdir", "unlink", "chmod"):
        setattr(staging.os, name, killing(getattr(os, name)))
    staging._renameat2 = killing(staging._renameat2)
    staging._rmtree = killing(staging._rmtree)
    claim = staging.claim_output(out, kind=kind, force=True, names=("a.txt", "b.txt"))
    with claim.stage() as stage:
        if kind == "file":
            open(stage, "w").write("new")
        else:
            open(os.path.join(stage, "a.txt"), "w").write("new a")
            open(os.path.join(stage, "c.txt"), "w").write("new c")
    claim.release()
    print("finished", calls[0])
    """
)

OLD_DIR = {"a.txt": b"old a", "b.txt": b"old b", "keep.txt": b"mine"}
NEW_DIR = {"a.txt": b"new a", "c.txt": b"new c", "keep.txt": b"mine"}


def _kill_run(out: Path, kind: str, kill_at: int, exchange: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", KILLER, str(STAGING), str(out), kind, str(kill_at), exchange],
        capture_output=True,
        text=True,
        timeout=60,
    )


def _prepare(out: Path, kind: str) -> None:
    if kind == "file":
        out.write_text("old")
    else:
        out.mkdir()
        for n, b in OLD_DIR.items():
            (out / n).write_bytes(b)


def _content(out: Path, kind: str):
    if not os.path.lexists(out):
        return None
    return out.read_bytes() if kind == "file" else _entries(out)


@pytest.mark.parametrize("exchange", ["yes", "no"])
@pytest.mark.parametrize("kind", ["file", "directory"])
def test_sigkill_at_any_step_leaves_the_old_output_or_the_new(tmp_path, kind, exchange):
    old, new = (b"old", b"new") if kind == "file" else (OLD_DIR, NEW_DIR)
    seen = set()
    for kill_at in range(1, 40):
        work = tmp_path / f"k{kill_at}"
        work.mkdir()
        out = work / ("out.txt" if kind == "file" else "out")
        _prepare(out, kind)
        proc = _kill_run(out, kind, kill_at, exchange)
        finished = proc.returncode == 0
        assert finished or proc.returncode == -signal.SIGKILL, proc.stderr
        now = _content(out, kind)
        if now is None:  # cut between the two renames of the fallback: recovered next time
            assert exchange == "no" and not finished
        else:
            assert now in (old, new), (kill_at, now)
        seen.add("new" if now == new else "old" if now == old else "absent")
        # the next claim recovers: the old output back if absent, dead runs' leftovers gone
        staging.claim_output(out, kind=kind, force=True).release()
        assert _content(out, kind) in (old, new)
        assert sorted(p.name for p in work.iterdir()) == [out.name], kill_at
        if finished:
            assert now == new
            break
    else:
        pytest.fail("the run never finished")
    assert {"old", "new"} <= seen


def test_staging_folders_of_dead_runs_are_removed(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "image.png").write_bytes(b"old")
    dead, alive = _dead_pid(), os.getppid()
    stale = [
        tmp_path / f".out.partial-{dead}-0123456789ab",
        tmp_path / ".out.partial-k2j4h6g8",  # named by an earlier version, without a PID
        tmp_path / f".out.old-{dead}-0123456789ab",
    ]
    live = tmp_path / f".out.partial-{alive}-0123456789ab"
    other = tmp_path / f".outer.partial-{dead}-0123456789ab"  # another output's
    for d in [*stale, live, other]:
        d.mkdir()
        (d / "x.mat").write_bytes(b"\0" * 1000)
    assert run(["image", "hyperbola", "--size", "10", "--out", str(out), "--force"]) == 0
    assert not any(d.exists() for d in stale)
    assert live.exists() and other.exists()
    assert (out / "image.png").read_bytes() != b"old"


def test_a_run_killed_mid_swap_is_recovered_by_the_next(tmp_path):
    """The previous output set aside by a dead run comes back when the target is absent."""
    out = tmp_path / "out"
    aside = tmp_path / f".out.old-{_dead_pid()}-0123456789ab"
    aside.mkdir()
    (aside / "peaks.json").write_text("[]")
    partial = tmp_path / f".out.partial-{_dead_pid()}-0123456789ab"
    partial.mkdir()
    claim = claim_output(out, kind="directory", names=("peaks.json",), force=True)
    claim.release()
    assert _entries(out) == {"peaks.json": b"[]"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_staged_file_and_directory_without_a_claim(tmp_path):
    with staged_file(tmp_path / "a" / "f.txt") as path:
        path.write_text("x")
    assert (tmp_path / "a" / "f.txt").read_text() == "x"
    with staged_directory(tmp_path / "d") as stage:
        (stage / "y.txt").write_text("y")
    with staged_directory(tmp_path / "d") as stage:
        (stage / "z.txt").write_text("z")
    assert _entries(tmp_path / "d") == {"y.txt": b"y", "z.txt": b"z"}  # others kept
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "d"]


def test_a_directory_that_is_not_an_output_directory_is_refused(tmp_path, capsys, monkeypatch):
    """Folders of the user's, or the current directory, are never swapped away."""
    out = tmp_path / "project"
    (out / "src").mkdir(parents=True)
    (out / "src" / "main.py").write_text("mine")
    args = ["image", "hyperbola", "--size", "10", "--force", "--out"]
    _one_line_refusal([*args, str(out)], capsys, "holds folders sarmotion does not write (src)")
    monkeypatch.chdir(out / "src")
    _one_line_refusal([*args, str(out)], capsys, "is the current directory or holds it")
    _one_line_refusal([*args, "."], capsys, "is the current directory or holds it")
    assert _entries(out) == {"src/main.py": b"mine"}
