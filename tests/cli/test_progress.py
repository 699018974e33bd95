"""Progress a person sees: a plan line and bars on a terminal, lines when piped, -q quiet.

The commands run in a child process on a pseudo-terminal of 24 x 100 characters (a
terminal of size 0 gets bars 80 columns wide), as a person at a terminal runs them.
"""

from __future__ import annotations

import fcntl
import os
import pty
import re
import select
import signal
import struct
import subprocess
import sys
import termios
import time
from pathlib import Path

import pytest

from sarmotion.cli.common import Progress

ROOT = Path(__file__).resolve().parents[2]
#: The commands' environment. Without the tests' bytecode prefix (conftest.py): where
#: PYTHONDONTWRITEBYTECODE is set, a prefix that holds no bytecode has every module
#: compiled from source at each start (3 CPU-s more here), which no user's run does.
ENV = {
    **{k: v for k, v in os.environ.items() if k != "PYTHONPYCACHEPREFIX"},
    "PYTHONPATH": str(ROOT / "src"),
    "MPLBACKEND": "Agg",
}


def _on_terminal(args: list[str], timeout_s: float = 300.0) -> tuple[int, list[tuple[float, str]]]:
    """Run ``python -m sarmotion ARGS`` on a pseudo-terminal: exit status, (time, text) chunks."""
    pid, fd = pty.fork()
    if pid == 0:  # the child: a terminal of 24 rows, 100 columns
        fcntl.ioctl(0, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
        os.execve(sys.executable, [sys.executable, "-m", "sarmotion", *args], ENV)
    t0 = time.monotonic()
    chunks: list[tuple[float, str]] = []
    try:
        while time.monotonic() - t0 < timeout_s:
            ready, _, _ = select.select([fd], [], [], 0.5)
            if not ready:
                continue
            try:
                data = os.read(fd, 65536)
            except OSError:  # the child closed the terminal
                break
            if not data:
                break
            chunks.append((time.monotonic() - t0, data.decode("utf-8", "replace")))
    finally:
        _, status = os.waitpid(pid, 0)
        os.close(fd)
    return os.waitstatus_to_exitcode(status), chunks


def _first(chunks: list[tuple[float, str]], pattern: str) -> float | None:
    text, at = "", None
    for t, chunk in chunks:
        text += chunk
        if re.search(pattern, text):
            at = t
            break
    return at


def test_image_on_a_terminal_says_its_plan_then_shows_a_bar(tmp_path):
    args = ["image", "hyperbola", "--size", "60", "--spacing", "0.1", "--out", str(tmp_path / "i")]
    code, chunks = _on_terminal(args)
    text = "".join(c for _, c in chunks)
    assert code == 0, text
    plan = _first(chunks, r"image: hyperbola -> 600 x 600 pixels at 0\.1 m, exact backprojection")
    bar = _first(chunks, r"\rbackprojection:\s+\d+%\|")
    summary = _first(chunks, r"wrote .*image\.png")
    assert plan is not None and bar is not None and summary is not None, text
    assert plan <= bar <= summary


def test_quiet_leaves_only_the_summary(tmp_path):
    args = ["-q", "image", "hyperbola", "--size", "20", "--out", str(tmp_path / "i")]
    code, chunks = _on_terminal(args)
    lines = [ln for ln in "".join(c for _, c in chunks).splitlines() if ln.strip("\r\x1b[0m")]
    assert code == 0
    assert len(lines) == 1 and lines[0].startswith("wrote "), lines


def test_piped_the_plan_comes_first_and_progress_is_lines(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "sarmotion", "analyze", "scene1", "--no-trajectory",
         "--out", str(tmp_path / "a")],
        env=ENV, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout.splitlines()
    assert out[0] == "analyze: reading scene1"
    assert re.fullmatch(r"analyze: 117 pulses x \d+ samples: one analysis of .*", out[1]), out
    summary = next(k for k, ln in enumerate(out) if ln.startswith("wrote "))
    lines = out[2:summary]  # the progress, with the output it leads to
    assert lines and all(re.fullmatch(r"[^:]+: \d+/\d+ \(\d+ %\), \d+\.\d s", ln) for ln in lines)
    assert "\r" not in proc.stdout  # no bar drawn into a file
    assert proc.stderr == ""  # standard error is left to errors and logs


#: Most CPU time (user and system, s) a long command may spend before its plan line and
#: its first bar are on the terminal: the issue's "within 5 s of starting", counted in the
#: command's own CPU time so that it holds on a machine shared under load (on a quiet one,
#: wall time to the bar is about this: the start-up, reading and planning run on one
#: thread).
PLAN_AND_BAR_CPU_S = 5.0


def _until_seen(
    args: list[str], patterns: dict[str, str], timeout_s: float = 300.0
) -> tuple[dict[str, tuple[float, float]], str, int]:
    """Run ``python -m sarmotion ARGS`` on a pseudo-terminal until every pattern is seen.

    Returns, for each pattern seen, (wall time, the command's CPU time) when it was first
    on the terminal; the text; the exit status. Once all are seen (or after
    ``timeout_s``) the command gets the terminal's Ctrl-C (SIGINT to its process group),
    so that a long run stops there and cleans up as a person's would.
    """
    import psutil

    pid, fd = pty.fork()
    if pid == 0:  # the child: a terminal of 24 rows, 100 columns
        fcntl.ioctl(0, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
        os.execve(sys.executable, [sys.executable, "-m", "sarmotion", *args], ENV)
    child = psutil.Process(pid)
    t0 = time.monotonic()
    seen: dict[str, tuple[float, float]] = {}
    text = ""
    interrupted = False
    try:
        while True:
            done = len(seen) == len(patterns) or time.monotonic() - t0 > timeout_s
            if not interrupted and done:
                os.killpg(pid, signal.SIGINT)
                interrupted = True
                stop = time.monotonic() + 120.0
            if interrupted and time.monotonic() > stop:
                os.killpg(pid, signal.SIGKILL)
                break
            ready, _, _ = select.select([fd], [], [], 0.2)
            if not ready:
                continue
            try:
                data = os.read(fd, 65536)
            except OSError:  # the child closed the terminal
                break
            if not data:
                break
            try:
                cpu = sum(child.cpu_times()[:4])  # user, system, and those of its children
            except psutil.Error:
                cpu = float("nan")
            text += data.decode("utf-8", "replace")
            for name, pattern in patterns.items():
                if name not in seen and re.search(pattern, text):
                    seen[name] = (time.monotonic() - t0, cpu)
    finally:
        _, status = os.waitpid(pid, 0)
        os.close(fd)
    return seen, text, os.waitstatus_to_exitcode(status)


@pytest.fixture(scope="module")
def collections(tmp_path_factory) -> dict[str, Path]:
    """CPHD files of simulated collections of side 400 m (36 patches) and 150 m (4)."""
    from sarmotion.io import write_cphd_blocks
    from sarmotion.simulation import collection_acquisition, random_collection

    root = tmp_path_factory.mktemp("collections")
    paths = {}
    for side in (400.0, 150.0):
        scene = random_collection(collection_acquisition(side), side, seed=1, n_movers=2)
        path = root / f"scene{side:g}.cphd"
        paths[f"{side:g}"] = write_cphd_blocks(path, scene, block_pulses=200)
    return paths


#: The long commands: their arguments (``{cphd}``: the 400 m collection), then the plan
#: line and the bar they must show.
LONG = {
    "analyze-400m": (
        ["analyze", "{cphd}"],
        r"analyze: \d+ pulses x \d+ samples: 36 patches of \d+ m over \d+ x \d+ m",
        r"\rpatches:\s+\d+%\|",
    ),
    "image-1024": (
        ["image", "hyperbola", "--size", "102.4", "--spacing", "0.1"],
        r"image: hyperbola -> 1024 x 1024 pixels at 0\.1 m",
        r"\rbackprojection:\s+\d+%\|",
    ),
}


@pytest.mark.parametrize("case", list(LONG))
def test_a_long_command_says_its_plan_and_shows_a_bar_within_5_s(case, collections, tmp_path):
    """The plan line, then a bar with its ETA, within 5 s of the command's CPU time.

    ``analyze`` of the 400 m collection (36 patches on the local workers; minutes in all)
    and ``image`` of a 1024 x 1024 grid; each is interrupted once its bar shows.
    """
    args, plan, bar = LONG[case]
    args = [a.format(cphd=collections["400"]) for a in args] + ["--out", str(tmp_path / "o")]
    seen, text, code = _until_seen(args, {"plan": plan, "bar": bar})
    assert "plan" in seen and "bar" in seen, text
    assert seen["plan"][0] <= seen["bar"][0], text
    (wall_plan, cpu_plan), (wall_bar, cpu_bar) = seen["plan"], seen["bar"]
    assert cpu_bar <= PLAN_AND_BAR_CPU_S, (
        f"plan at {wall_plan:.1f} s ({cpu_plan:.1f} CPU-s), bar at {wall_bar:.1f} s "
        f"({cpu_bar:.1f} CPU-s)"
    )
    assert code in (0, 130), text  # done before the Ctrl-C, or stopped by it
    if code == 130:
        assert not (tmp_path / "o").exists()


#: The -q cases, which run to the end: ``image`` of the same 1024 x 1024 grid (seconds),
#: and ``analyze`` of the 150 m collection. That one stands for the 400 m: the same path
#: (a CPHD file larger than one patch, its plan, patches on the local workers, the one
#: progress object that -q turns off as a whole), 4 patches instead of 36, so a run of
#: tens of seconds rather than minutes; its summary names its patches.
QUIET = {
    "analyze-150m": (["analyze", "{cphd}"], r"wrote .*: 4 patches, "),
    "image-1024": (
        ["image", "hyperbola", "--size", "102.4", "--spacing", "0.1"],
        r"wrote .*image\.png",
    ),
}


@pytest.mark.parametrize("case", list(QUIET))
def test_quiet_long_commands_print_only_their_summary(case, collections, tmp_path):
    args, summary = QUIET[case]
    args = [a.format(cphd=collections["150"]) for a in args] + ["--out", str(tmp_path / "o")]
    code, chunks = _on_terminal(["-q", *args], timeout_s=600.0)
    text = "".join(c for _, c in chunks)
    assert code == 0, text
    lines = [ln for ln in text.splitlines() if ln.strip("\r\x1b[0m")]
    assert re.match(summary, lines[0]), lines
    assert "%|" not in text and "\r" not in text.replace("\r\n", ""), text  # no bar
    assert not [ln for ln in lines if re.match(r"(analyze|image): ", ln)], lines  # no plan
    assert all(ln.startswith("  ") for ln in lines[1:]), lines  # the summary's own lines


class _Tty:
    def __init__(self) -> None:
        self.text = ""

    def isatty(self) -> bool:
        return False

    def write(self, s: str) -> None:
        self.text += s

    def flush(self) -> None:
        pass


@pytest.mark.parametrize("total", [10, 1000, 7])
def test_lines_come_at_tenths_at_most_once_a_second_and_always_at_the_end(total, monkeypatch):
    clock = iter(range(0, 10_000))  # one second per call
    monkeypatch.setattr("sarmotion.cli.common.time.perf_counter", lambda: float(next(clock)))
    out = _Tty()
    bar = Progress(stream=out)
    for k in range(total + 1):
        bar("stage", k, total)
    lines = out.text.splitlines()
    shares = [int(re.search(r"\((\d+) %\)", ln).group(1)) for ln in lines]
    assert shares == sorted(set(shares)) and shares[-1] == 100
    assert len(lines) <= 11
    fast = _Tty()
    monkeypatch.setattr("sarmotion.cli.common.time.perf_counter", lambda: 0.0)
    quick = Progress(stream=fast)
    for k in range(total + 1):
        quick("stage", k, total)
    assert fast.text.splitlines() == [f"stage: {total}/{total} (100 %), 0.0 s"]
    silent = _Tty()
    off = Progress(enabled=False, stream=silent)
    off("stage", total, total)
    assert silent.text == ""


def test_pga_says_what_it_found(tmp_path, capsys):
    from sarmotion.cli.main import run

    assert (
        run(["image", "scene1", "--autofocus", "pga", "--size", "20", "--out", str(tmp_path)]) == 0
    )
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("autofocus: phase error"))
    assert re.search(
        r"RMS [\d.e-]+ rad over the aperture; \d+ iteration\(s\), (not )?converged", line
    )
