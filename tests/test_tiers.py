"""The test tiers: the slow lists of ``conftest.py`` name tests that exist.

A name that matches nothing (a test renamed or moved) would silently put its test back in
the fast tier; the lists are checked against the test files' source.
"""

from __future__ import annotations

import re

from conftest import ROOT, SLOW_FILES, SLOW_TESTS

TESTS = ROOT / "tests"
FILES = {p.name: p for p in TESTS.rglob("test_*.py")}


def test_slow_files_exist():
    for name in SLOW_FILES:
        assert name in FILES, name


def test_slow_tests_exist():
    missing = []
    for entry in sorted(SLOW_TESTS):
        name, _, test = entry.partition("::")
        path = FILES.get(name)
        function = test.rsplit("::", 1)[-1]
        if path is None or not re.search(
            rf"^\s*(?:async )?def {re.escape(function)}\(", path.read_text(encoding="utf-8"), re.M
        ):
            missing.append(entry)
    assert not missing, f"slow tests that no file defines: {missing}"


def test_fast_tier_is_the_default():
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    addopts = config["tool"]["pytest"]["ini_options"]["addopts"]
    assert "-m 'not slow'" in addopts, addopts


def test_every_module_imports_in_a_fresh_interpreter():
    """The fast tier reaches every module: at the least, each one imports on its own.

    The CUDA kernels' modules run only in the slow tier (under numba's CUDA simulator);
    here they, and every other module, must at least import without a GPU.
    """
    import pkgutil
    import subprocess
    import sys

    import sarmotion

    names = sorted(m.name for m in pkgutil.walk_packages(sarmotion.__path__, "sarmotion."))
    assert len(names) > 50, names
    script = "import importlib, sys\nfor n in sys.argv[1:]:\n    importlib.import_module(n)\n"
    proc = subprocess.run(
        [sys.executable, "-c", script, *names], capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
