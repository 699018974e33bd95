"""``sarmotion demo`` can be run again: it replaces its own earlier output, nothing else."""

from __future__ import annotations

import pytest

import sarmotion.cli.analyze as cli_analyze
from sarmotion.cli.main import run


@pytest.fixture
def calls(monkeypatch, tmp_path):
    """The ``force`` each demo run passes on (the analysis itself is not run)."""
    seen: list[bool] = []
    monkeypatch.setattr(cli_analyze, "run_analyze", lambda *a, force, **k: seen.append(force))
    monkeypatch.chdir(tmp_path)
    return seen


def test_demo_replaces_its_own_earlier_output(calls, tmp_path):
    assert run(["demo"]) == 0
    (tmp_path / "sarmotion-demo").mkdir()
    (tmp_path / "sarmotion-demo" / "results.json").write_text("{}")
    assert run(["demo"]) == 0
    assert calls == [False, True]


def test_demo_elsewhere_needs_force(calls, tmp_path):
    other = tmp_path / "elsewhere"
    other.mkdir()
    (other / "results.json").write_text("{}")
    assert run(["demo", "--out", str(other)]) == 0
    assert run(["demo", "--out", str(other), "--force"]) == 0
    assert calls == [False, True]
