"""The README's shell blocks run top to bottom in a fresh directory, as a new user runs them.

Each fenced ``bash`` block of README.md is run in order, in one fresh directory that holds
the repository's files (linked, so that the outputs land in the temporary directory) with
``shared/`` beside it, as a clone sits beside the shared data. The package is already
installed in the test environment, so ``python -m pip install ... && CMD`` runs ``CMD``,
and the test suite itself (``python -m pytest``) is not started again. A block preceded by
``<!-- readme: not run (REASON) -->`` is shown to the reader but not run: it needs a
cluster or takes minutes (the reason says which). The quick start is run twice: running it
again must work.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import ROOT, gotcha_directory

README = ROOT / "README.md"
_FENCE = re.compile(
    r"(?P<marker><!-- readme: not run \((?P<reason>[^)]*)\) -->\s*\n)?```bash\n(?P<body>.*?)```",
    re.S,
)
_INSTALL = re.compile(r"^python -m pip install \S+(?: \S+)*? && ")


def readme_blocks(text: str) -> list[tuple[str, str | None]]:
    """``(body, reason_not_run)`` of every ``bash`` block of ``text``, in order."""
    return [(m["body"], m["reason"]) for m in _FENCE.finditer(text)]


def runnable_lines(body: str) -> list[str]:
    """The block's commands as the test runs them: installs dropped, continuations joined."""
    joined = body.replace("\\\n", " ")
    lines = []
    for line in joined.splitlines():
        line = line.split("  #", 1)[0].strip()
        if not line or line.startswith("#"):
            continue
        line = _INSTALL.sub("", line)
        if line.startswith("python -m pip install"):
            continue
        if line in ("python -m pytest", "pytest"):
            continue
        lines.append(line)
    return lines


def test_blocks_parse():
    blocks = readme_blocks(README.read_text(encoding="utf-8"))
    assert blocks, "README.md has no bash block"
    quick_start = runnable_lines(blocks[0][0])
    assert quick_start == ["sarmotion demo"], quick_start
    for body, reason in blocks:
        if reason is None:
            assert runnable_lines(body) or "pytest" in body, body


@pytest.fixture
def fresh_directory(tmp_path: Path) -> Path:
    """A directory holding links to the repository's files, with ``shared/`` beside it."""
    work = tmp_path / "sarmotion"
    work.mkdir()
    for entry in ROOT.iterdir():
        if entry.name.startswith(".") or entry.name in ("sarmotion-demo", "build"):
            continue
        (work / entry.name).symlink_to(entry)
    gotcha = gotcha_directory()
    if gotcha is not None:
        shared = tmp_path / "shared" / "data"
        shared.mkdir(parents=True)
        (shared / "gotcha").symlink_to(gotcha)
    return work


def _run(line: str, cwd: Path) -> None:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    bin_dir = str(Path(sys.executable).parent)
    env["PATH"] = bin_dir + os.pathsep + env.get("PATH", "")
    proc = subprocess.run(
        line, shell=True, cwd=cwd, env=env, capture_output=True, text=True, timeout=900
    )
    assert proc.returncode == 0, (
        f"README command failed ({proc.returncode}): {line}\n{proc.stdout[-2000:]}\n"
        f"{proc.stderr[-2000:]}"
    )


@pytest.mark.slow
@pytest.mark.gotcha
def test_readme_runs_top_to_bottom(fresh_directory: Path, gotcha_dir: Path):
    blocks = readme_blocks(README.read_text(encoding="utf-8"))
    for i, (body, reason) in enumerate(blocks):
        if reason is not None:
            continue
        for line in runnable_lines(body):
            _run(line, fresh_directory)
        if i == 0:
            for line in runnable_lines(body):  # the quick start, a second time
                _run(line, fresh_directory)
