"""Shared fixtures: small seeded scenes and the location of the GOTCHA data set.

The test run writes nothing into the source tree: numba's on-disk cache (``cache=True``
kernels) and Python's bytecode go under one directory in the system's temporary
directory, set here before any test imports sarmotion (and so numba) and passed on, in
the environment, to the commands the tests start. A ``NUMBA_CACHE_DIR`` or
``PYTHONPYCACHEPREFIX`` already set is kept. The directory persists between runs, so the
kernels compile once, not once per run; numba keys its entries by the source file's full
path and time stamp, so checkouts side by side do not share them.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

_CACHE = Path(tempfile.gettempdir()) / "sarmotion-test-cache"
os.environ.setdefault("NUMBA_CACHE_DIR", str(_CACHE / "numba"))
os.environ.setdefault("PYTHONPYCACHEPREFIX", str(_CACHE / "pycache"))
if sys.pycache_prefix is None:
    sys.pycache_prefix = os.environ["PYTHONPYCACHEPREFIX"]


def gotcha_directory() -> Path | None:
    """The GOTCHA data directory: $SARMOTION_GOTCHA_DIR, else ../shared/data/gotcha."""
    env = os.environ.get("SARMOTION_GOTCHA_DIR")
    candidates = [Path(env)] if env else []
    candidates.append(ROOT.parent / "shared" / "data" / "gotcha")
    for c in candidates:
        if c.is_dir() and any(c.glob("data_3dsar_pass1_az00*_HH.mat")):
            return c
    return None


@pytest.fixture(scope="session")
def gotcha_dir() -> Path:
    """Directory holding the GOTCHA pass-1 HH .mat files.

    Skips with a reason when absent, unless SARMOTION_REQUIRE_GOTCHA=1 (set by CI), in
    which case the test fails.
    """
    d = gotcha_directory()
    if d is None:
        msg = (
            "GOTCHA data not found: set SARMOTION_GOTCHA_DIR or place the files in "
            f"{ROOT.parent / 'shared' / 'data' / 'gotcha'}"
        )
        if os.environ.get("SARMOTION_REQUIRE_GOTCHA") == "1":
            pytest.fail(msg)
        pytest.skip(msg)
    return d


@pytest.fixture(scope="session")
def gotcha_files(gotcha_dir: Path) -> list[Path]:
    """The four 1-degree GOTCHA files, in azimuth order."""
    return sorted(gotcha_dir.glob("data_3dsar_pass1_az00*_HH.mat"))
