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
import struct
import subprocess
import sys
import termios
import time
from pathlib import Path

import pytest

from sarmotion.cli.common import Progress

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "MPLBACKEND": "Agg"}


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
