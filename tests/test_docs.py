"""The documentation site: its tutorials run, its API reference is complete, it builds.

Each tutorial (``docs/tutorials/*.md``) is run as ``tests/test_readme.py`` runs the README:
its fenced ``bash`` blocks in order, in a fresh directory holding the repository's files
with ``shared/`` beside it. A block preceded by ``<!-- docs: not run (REASON) -->`` is shown
but not run. The site is built with ``mkdocs build --strict`` (warnings are errors) and its
API reference must hold every public function of the packages a user starts from.
"""

from __future__ import annotations

import importlib
import inspect
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import ROOT
from test_readme import _run, fresh_directory, readme_blocks, runnable_lines  # noqa: F401

DOCS = ROOT / "docs"
TUTORIALS = sorted((DOCS / "tutorials").glob("*.md"))
#: The packages whose every public function the API reference shows.
API_MODULES = (
    "sarmotion",
    "sarmotion.io",
    "sarmotion.pipeline",
    "sarmotion.collection",
    "sarmotion.tracking",
    "sarmotion.imaging",
)


def test_tutorials_parse():
    names = {p.stem for p in TUTORIALS}
    assert {"gotcha", "cphd-collection", "tracking", "paper-figures", "injecting-movers"} <= names
    for page in TUTORIALS:
        text = page.read_text(encoding="utf-8")
        blocks = readme_blocks(text)
        assert text.count("```bash") == len(blocks), page
        run = [body for body, reason in blocks if reason is None]
        assert run, f"{page.name} has no block that runs"
        for body in run:
            assert runnable_lines(body), body


def test_benchmark_pages_say_how_to_regenerate():
    pages = [p for p in (DOCS / "benchmarks").glob("*.md") if p.name != "index.md"]
    assert pages
    for page in pages:
        blocks = readme_blocks(page.read_text(encoding="utf-8"))
        commands = [line for body, _ in blocks for line in runnable_lines(body)]
        assert any("benchmarks/" in c for c in commands), f"{page.name}: no command"


def test_every_page_is_in_the_navigation():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for page in DOCS.rglob("*.md"):
        assert page.relative_to(DOCS).as_posix() in nav, page


@pytest.mark.slow
@pytest.mark.gotcha
@pytest.mark.parametrize("page", TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_tutorial_runs(page: Path, fresh_directory: Path, gotcha_dir: Path):  # noqa: F811
    for body, reason in readme_blocks(page.read_text(encoding="utf-8")):
        if reason is None:
            for line in runnable_lines(body):
                _run(line, fresh_directory)


def _public_functions(module_name: str) -> list[tuple[str, object]]:
    module = importlib.import_module(module_name)
    out = []
    for name in module.__all__:
        obj = getattr(module, name)
        if inspect.isfunction(obj) or (callable(obj) and not inspect.isclass(obj)):
            out.append((name, obj))
    return out


@pytest.mark.slow
def test_site_builds_with_every_public_function(tmp_path: Path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings_handlers.python")
    site = tmp_path / "site"
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    anchors: set[str] = set()
    for html in (site / "api").rglob("*.html"):
        anchors |= set(re.findall(r'id="([^"]+)"', html.read_text(encoding="utf-8")))
    missing = []
    for module_name in API_MODULES:
        for name, obj in _public_functions(module_name):
            module = sys.modules[module_name]
            shown = {f"{obj.__module__}.{obj.__qualname__}"} | {
                f"{module_name}.{other}"
                for other in module.__all__
                if getattr(module, other) is obj
            }
            if not shown & anchors:
                missing.append(f"{module_name}.{name}")
    assert not missing, f"not in the API reference: {missing}"
