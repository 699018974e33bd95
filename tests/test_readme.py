"""The README's shell blocks run top to bottom in a fresh directory, as a new user runs them.

Each fenced ``bash`` block of README.md is run in order, in one fresh directory that holds
the repository's files (linked, so that the outputs land in the temporary directory) with
``shared/`` beside it, as a clone sits beside the shared data. The package is already
installed in the test environment, so ``python -m pip install ... && CMD`` runs ``CMD``,
and the test suite itself (``python -m pytest``) is not started again. A block preceded by
``<!-- readme: not run (REASON) -->`` (or ``<!-- docs: not run (REASON) -->`` in the
documentation's pages, ``tests/test_docs.py``) is shown to the reader but not run: it needs
a cluster or takes minutes (the reason says which); the README has none, every one of its
blocks runs. The quick start is run twice: running it again must work. Its ``toml`` block
is a scene file that loads and analyses, and its ``python`` block runs.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT, gotcha_directory

README = ROOT / "README.md"
_FENCE = re.compile(
    r"(?P<marker><!-- (?:readme|docs): not run \((?P<reason>[^)]*)\) -->\s*\n)?"
    r"```bash\n(?P<body>.*?)```",
    re.S,
)
_CODE = re.compile(r"```(?P<lang>toml|python)\n(?P<body>.*?)```", re.S)
#: The README is a guide: what it is, install, a tour, the inputs, links; the rest is on the
#: documentation site (docs/).
MAX_README_LINES = 300
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


def code_blocks(text: str, lang: str) -> list[str]:
    """The bodies of the fenced ``lang`` blocks of ``text``, in order."""
    return [m["body"] for m in _CODE.finditer(text) if m["lang"] == lang]


def test_blocks_parse():
    text = README.read_text(encoding="utf-8")
    blocks = readme_blocks(text)
    assert blocks, "README.md has no bash block"
    assert text.count("```bash") == len(blocks), "a bash block the pattern does not read"
    quick_start = runnable_lines(blocks[0][0])
    assert quick_start == ["sarmotion demo"], quick_start
    assert "python -m pytest" in blocks[0][0]
    for body, reason in blocks:
        assert reason is None, f"a README block that does not run ({reason}): {body}"
        assert runnable_lines(body) or "pytest" in body, body


def test_readme_is_short():
    lines = README.read_text(encoding="utf-8").count("\n")
    assert lines <= MAX_README_LINES, f"README.md has {lines} lines"


def test_readme_scene_file_loads(tmp_path: Path):
    """The README's example scene file is valid: it loads, as the format describes."""
    from sarmotion.simulation import load_scene

    (body,) = code_blocks(README.read_text(encoding="utf-8"), "toml")
    path = tmp_path / "crossing.toml"
    path.write_text(body, encoding="utf-8")
    scene = load_scene(path)
    assert scene.name == "crossing"
    assert len(scene.stationary) == 2 and len(scene.moving) == 1
    (mover,) = scene.moving
    np.testing.assert_array_equal(mover.velocity_mps, [4.0, -6.0])
    np.testing.assert_array_equal(mover.position_m[:2], [10.0, 15.0])


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


@pytest.mark.slow
def test_readme_python_and_scene_file_run(fresh_directory: Path):
    """The README's Python block runs, and its scene file analyses as the README says."""
    text = README.read_text(encoding="utf-8")
    for i, body in enumerate(code_blocks(text, "python")):
        script = fresh_directory / f"readme_block_{i}.py"
        script.write_text(body, encoding="utf-8")
        _run(f"python {script.name}", fresh_directory)
    (body,) = code_blocks(text, "toml")
    (fresh_directory / "crossing.toml").write_text(body, encoding="utf-8")
    _run("sarmotion analyze crossing.toml --out crossing", fresh_directory)
    results = json.loads((fresh_directory / "crossing" / "results.json").read_text())
    assert "truth" in results, "a scene file's analysis compares with its truth"
    assert results["missed_movers"] == 0 and results["false_movers"] == 0, results["truth"]
