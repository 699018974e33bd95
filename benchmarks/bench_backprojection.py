"""Backprojection throughput in pixel-pulses per second: compiled kernel vs numpy reference.

Run with::

    pytest benchmarks/bench_backprojection.py --benchmark-only

(``--benchmark-only`` overrides the ``--benchmark-skip`` of the project configuration;
``--benchmark-enable`` does not.)

The acquisition is GOTCHA-like: 468 pulses (4 degrees) x 424 samples, upsample 8, three
point targets. Each benchmark first runs the image once outside the timing (JIT compile
or cache load, thread-pool start-up). ``extra_info`` records the pixel-pulse rate from the
fastest and the median round; the time includes the per-call upsampling of the traces.
The numba/numpy signal-to-error ratio of the same image is recorded too.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from sarmotion.core import Trajectory
from sarmotion.imaging import ImageGrid, backproject
from sarmotion.simulation import PointTarget, Scene, simulate

SPACING_M = 0.25


@pytest.fixture(scope="module")
def traces():
    scene = Scene(
        name="bench",
        targets=[
            PointTarget(position_m=(7.3, -4.1)),
            PointTarget(position_m=(-20.0, 15.0), reflectivity=0.5j),
            PointTarget(position_m=(0.0, 0.0), velocity_mps=(10.0, 5.0)),
        ],
    )
    tr = simulate(scene, trajectory=Trajectory.circular(aperture_deg=4.0)).traces
    assert tr.shape == (468, 424)
    return tr


def _run(benchmark, traces, n: int, kernel: str, rounds: int):
    grid = ImageGrid.square(size_m=n * SPACING_M, spacing_m=SPACING_M)
    backproject(traces, grid, kernel=kernel)  # warm-up: compile / load cache, start threads
    img = benchmark.pedantic(
        backproject, args=(traces, grid), kwargs={"kernel": kernel}, rounds=rounds, iterations=1
    )
    work = n * n * traces.n_pulses
    stats = benchmark.stats.stats
    benchmark.extra_info.update(
        {
            "kernel": kernel,
            "grid": f"{n}x{n}",
            "pulses": traces.n_pulses,
            "samples": traces.n_samples,
            "upsample": 8,
            "threads": numba.get_num_threads() if kernel == "numba" else 1,
            "pixel_pulses_per_second_best": work / stats.min,
            "pixel_pulses_per_second_median": work / stats.median,
        }
    )
    return img


@pytest.mark.parametrize("n", [128, 256, 512])
def test_numba(benchmark, traces, n):
    _run(benchmark, traces, n, "numba", rounds=10 if n < 512 else 5)


def test_numpy_reference(benchmark, traces):
    img = _run(benchmark, traces, 128, "numpy", rounds=3)
    fast = backproject(traces, img.grid, kernel="numba").values
    err = np.linalg.norm(fast - img.values)
    benchmark.extra_info["ser_numba_vs_numpy_db"] = 20 * math.log10(
        np.linalg.norm(img.values) / err
    )
