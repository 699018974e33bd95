"""The test tiers: the slow lists of ``conftest.py`` name tests that exist.

A name that matches nothing (a test renamed or moved) would silently put its test back in
the fast tier; the lists are checked against the test files' source.
"""

from __future__ import annotations

import re

from conftest import ROOT, SLOW_FILES, SLOW_TESTS

TESTS = ROOT / "tests"


def test_slow_files_exist():
    for name in SLOW_FILES:
        assert (TESTS / name).is_file(), name


def test_slow_tests_exist():
    missing = []
    for entry in sorted(SLOW_TESTS):
        name, _, test = entry.partition("::")
        path = TESTS / name
        function = test.rsplit("::", 1)[-1]
        if not path.is_file() or not re.search(
            rf"^\s*(?:async )?def {re.escape(function)}\(", path.read_text(encoding="utf-8"), re.M
        ):
            missing.append(entry)
    assert not missing, f"slow tests that no file defines: {missing}"


def test_fast_tier_is_the_default():
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    addopts = config["tool"]["pytest"]["ini_options"]["addopts"]
    assert "-m 'not slow'" in addopts, addopts
