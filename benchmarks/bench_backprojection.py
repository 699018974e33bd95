"""Backprojection speed and accuracy, every figure against its reference in the same run.

Run with::

    pytest benchmarks/bench_backprojection.py --benchmark-only

(``--benchmark-only`` overrides the ``--benchmark-skip`` of the project configuration;
``--benchmark-enable`` does not.)

Data: the four GOTCHA degrees (469 pulses x 424 samples; ``$SARMOTION_GOTCHA_DIR`` or
``../shared/data/gotcha``), or, without them, a simulated GOTCHA-like 4-degree aperture
(468 pulses, three points and a mover). Upsample 8, 0.25 m pixels, numba's default threads.

- ``test_exact``: the compiled float32 kernel at 128^2 ... 1024^2 (``extra_info``:
  ``pixel_pulses_per_second_{median,best}``, the signal-to-error ratio against the float64
  numpy reference at 128^2 and 256^2, against the float64 compiled kernel, itself ~190 dB
  from the reference, above);
- ``test_float64_kernel``: the float64 compiled kernel the float32 one replaced, same
  sizes (the "before" figures);
- ``test_exact_in_swath``: 1024^2 at 0.1 m, every pixel inside the fast-time window (a
  0.25 m 1024^2 grid is 256 m wide, the window reaches ~+-70 m of ground range);
- ``test_ffbp``: fast factorised backprojection at 1024^2 and 2048^2 against exact
  backprojection in the same run, the two alternating (7 pairs): ``speed_up`` (median
  wall clock, exact / FFBP), ``speed_up_cpu`` (median CPU time, all threads) and
  ``ser_db_vs_exact``;
- ``test_ffbp_oblique``: the same at an oblique look, the GOTCHA degrees turned by 30 and
  45 degrees about the scene centre (the rotated path of FFBP), same figures plus
  ``ffbp_path`` and ``exact_pixels`` (pixels near the fast-time window's ends computed
  exactly).

Each benchmark first runs once outside the timing (JIT cache load, thread start-up, the
upsampled-trace table, which later calls on the same traces reuse). ``extra_info`` also
records the 1-minute load average: on a shared machine the wall-clock rates fall with it.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from pathlib import Path

import numba
import numpy as np
import pytest

from sarmotion.core import Trajectory
from sarmotion.imaging import ImageGrid, backproject
from sarmotion.imaging import backprojection as bp
from sarmotion.io import read_gotcha
from sarmotion.simulation import PointTarget, Scene, simulate

SPACING_M = 0.25
SIZES = (128, 256, 512, 1024)


def _gotcha_files() -> list[Path]:
    env = os.environ.get("SARMOTION_GOTCHA_DIR")
    root = Path(__file__).resolve().parents[1]
    for d in ([Path(env)] if env else []) + [root.parent / "shared" / "data" / "gotcha"]:
        files = sorted(d.glob("data_3dsar_pass1_az00*_HH.mat")) if d.is_dir() else []
        if len(files) == 4:
            return files
    return []


@pytest.fixture(scope="module")
def traces():
    files = _gotcha_files()
    if files:
        return read_gotcha(files)
    scene = Scene(
        name="bench",
        targets=[
            PointTarget(position_m=(7.3, -4.1)),
            PointTarget(position_m=(-20.0, 15.0), reflectivity=0.5j),
            PointTarget(position_m=(0.0, 0.0), velocity_mps=(10.0, 5.0)),
        ],
    )
    return simulate(scene, trajectory=Trajectory.circular(aperture_deg=4.0)).traces


def _ser_db(ref: np.ndarray, x: np.ndarray) -> float:
    err = float(np.linalg.norm(x - ref))
    return math.inf if err == 0 else 20.0 * math.log10(float(np.linalg.norm(ref)) / err)


def _float64_kernel(traces, grid):
    return bp._run_numba_f64(bp._setup(traces, None, 8), grid, None)


def _rates(benchmark, traces, n: int) -> None:
    work = n * n * traces.n_pulses
    stats = benchmark.stats.stats
    benchmark.extra_info.update(
        {
            "grid": f"{n}x{n}",
            "spacing_m": SPACING_M,
            "pulses": traces.n_pulses,
            "samples": traces.n_samples,
            "threads": numba.get_num_threads(),
            "pixel_pulses_per_second_median": work / stats.median,
            "pixel_pulses_per_second_best": work / stats.min,
            "load_average_1min": os.getloadavg()[0],
        }
    )


@pytest.mark.parametrize("n", SIZES)
def test_exact(benchmark, traces, n):
    grid = ImageGrid.square(size_m=n * SPACING_M, spacing_m=SPACING_M)
    img = backproject(traces, grid)
    benchmark.pedantic(backproject, args=(traces, grid), rounds=15 if n < 512 else 5, iterations=1)
    _rates(benchmark, traces, n)
    if n <= 256:
        ref = backproject(traces, grid, kernel="numpy").values
        benchmark.extra_info["ser_db_vs_numpy_float64_reference"] = _ser_db(ref, img.values)
    else:
        ref = _float64_kernel(traces, grid)
        benchmark.extra_info["ser_db_vs_float64_compiled_kernel"] = _ser_db(ref, img.values)
    benchmark.extra_info["kernel_variant"] = img.metadata["kernel_variant"]


@pytest.mark.parametrize("n", SIZES)
def test_float64_kernel(benchmark, traces, n):
    grid = ImageGrid.square(size_m=n * SPACING_M, spacing_m=SPACING_M)
    _float64_kernel(traces, grid)
    benchmark.pedantic(_float64_kernel, args=(traces, grid), rounds=5 if n < 1024 else 3,
                       iterations=1)  # fmt: skip
    _rates(benchmark, traces, n)


def test_exact_in_swath(benchmark, traces):
    n = 1024
    grid = ImageGrid.square(size_m=n * 0.1, spacing_m=0.1)
    backproject(traces, grid)
    benchmark.pedantic(backproject, args=(traces, grid), rounds=5, iterations=1)
    _rates(benchmark, traces, n)
    benchmark.extra_info["spacing_m"] = 0.1


def _timed(f) -> tuple[float, float]:
    """Wall-clock and CPU (the process, all threads) seconds of one call."""
    w0, c0 = time.perf_counter(), time.process_time()
    f()
    return time.perf_counter() - w0, time.process_time() - c0


@pytest.mark.parametrize("n", (1024, 2048))
def test_ffbp(benchmark, traces, n):
    grid = ImageGrid.square(size_m=n * SPACING_M, spacing_m=SPACING_M)
    exact = backproject(traces, grid)
    fast = backproject(traces, grid, method="ffbp")
    # Exact and FFBP alternate, so both see the same load; medians of 7 pairs.
    pairs = [
        (_timed(lambda: backproject(traces, grid)),
         _timed(lambda: backproject(traces, grid, method="ffbp")))
        for _ in range(7)
    ]  # fmt: skip
    wall_e, cpu_e = (float(np.median([p[0][k] for p in pairs])) for k in (0, 1))
    wall_f, cpu_f = (float(np.median([p[1][k] for p in pairs])) for k in (0, 1))
    benchmark.pedantic(backproject, args=(traces, grid), kwargs={"method": "ffbp"}, rounds=5,
                       iterations=1)  # fmt: skip
    benchmark.extra_info.update(
        {
            "grid": f"{n}x{n}",
            "exact_seconds_median": wall_e,
            "ffbp_seconds_median": wall_f,
            "speed_up": wall_e / wall_f,
            "exact_cpu_seconds_median": cpu_e,
            "ffbp_cpu_seconds_median": cpu_f,
            "speed_up_cpu": cpu_e / cpu_f,
            "ser_db_vs_exact": _ser_db(exact.values, fast.values),
            "ffbp": fast.metadata["ffbp"],
            "threads": numba.get_num_threads(),
            "load_average_1min": os.getloadavg()[0],
        }
    )


def _turned(traces, deg: float):
    """The acquisition turned by ``deg`` about the reference point (ranges unchanged)."""
    t = math.radians(deg)
    c, s = math.cos(t), math.sin(t)
    o = traces.reference_point_m
    p = traces.trajectory.positions_m.copy()
    d = p[:, :2] - o[:2]
    p[:, 0] = o[0] + c * d[:, 0] - s * d[:, 1]
    p[:, 1] = o[1] + s * d[:, 0] + c * d[:, 1]
    trajectory = Trajectory(positions_m=p, slow_times_s=traces.trajectory.slow_times_s)
    return dataclasses.replace(traces, trajectory=trajectory)


@pytest.mark.parametrize("deg", (30.0, 45.0))
@pytest.mark.parametrize("n", (1024, 2048))
def test_ffbp_oblique(benchmark, traces, n, deg):
    tr = _turned(traces, deg)
    grid = ImageGrid.square(size_m=n * SPACING_M, spacing_m=SPACING_M)
    exact = backproject(tr, grid)
    fast = backproject(tr, grid, method="ffbp")
    load = [os.getloadavg()[0]]
    pairs = [
        (_timed(lambda: backproject(tr, grid)),
         _timed(lambda: backproject(tr, grid, method="ffbp")))
        for _ in range(7)
    ]  # fmt: skip
    load.append(os.getloadavg()[0])
    wall_e, cpu_e = (float(np.median([p[0][k] for p in pairs])) for k in (0, 1))
    wall_f, cpu_f = (float(np.median([p[1][k] for p in pairs])) for k in (0, 1))
    benchmark.pedantic(backproject, args=(tr, grid), kwargs={"method": "ffbp"}, rounds=3,
                       iterations=1)  # fmt: skip
    info = fast.metadata.get("ffbp", {})
    benchmark.extra_info.update(
        {
            "grid": f"{n}x{n}",
            "turned_deg": deg,
            "exact_seconds_median": wall_e,
            "ffbp_seconds_median": wall_f,
            "speed_up": wall_e / wall_f,
            "exact_cpu_seconds_median": cpu_e,
            "ffbp_cpu_seconds_median": cpu_f,
            "speed_up_cpu": cpu_e / cpu_f,
            "ser_db_vs_exact": _ser_db(exact.values, fast.values),
            "ffbp_path": info.get("path"),
            "exact_pixels": info.get("exact_pixels"),
            "ffbp": info,
            "threads": numba.get_num_threads(),
            "load_average_1min": load,
        }
    )
