"""Benchmark of the whole analysis (sarmotion.pipeline.analyze) on Scene 1.

Run with::

    pytest benchmarks/bench_analyze.py --benchmark-only -p no:cacheprovider

Scene 1: GOTCHA, one degree (117 pulses x 424 samples), 20 stationary targets and two
movers, noise-free, default options (combined separation, 88 m preliminary image at
0.25 m, trajectories on). ``extra_info`` holds the seconds of each stage of the fastest
round (``AnalysisResult.timings_s``), the number of movers found and the image size.
Targets on a 2-core machine: Scene 1 within 2 s, the 4 GOTCHA degrees with two injected
movers (below) within 4 s; the asserts only catch a run gone wrong (30 s).

Scene 1's targets over 4 degrees (468 pulses, a whole GOTCHA file's span): movers are
estimated on the central degree and focused on all pulses (sarmotion.motion.aperture); the
``movers_s`` stage includes that refinement.

The 4 GOTCHA degrees (469 pulses, RPCA separation) with two injected movers, 8 and 12 dB
below the median per-pulse peak of the data (skipped without the files;
``SARMOTION_GOTCHA_DIR`` or ``../shared/data/gotcha``).

``test_kernels_against_plain_references`` times, in the same run, each compiled kernel of
the analysis against the plain form it replaced (``extra_info``: seconds of both and
their ratio, medians of 5): ``g(u)`` on the detector's grid (numpy phasors, padded FFT;
``g_grid`` is the analysis's shift-table path with the table built in the timing,
``g_grid_transform_per_trial`` the compiled modulation and one FFT per trial),
the matched filter at 256 parameter sets (numpy phasor array), and 50 point-response
sums over Scene 1's 4 degrees (row-major compiled sums).
"""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path

import numpy as np
import pytest
import scipy.fft as sfft

from sarmotion.pipeline import AnalysisOptions, analyze
from sarmotion.simulation import PointTarget, inject, load_scene, simulate


@pytest.fixture(scope="module")
def scene1_traces():
    traces = simulate(load_scene("scene1")).traces
    analyze(
        traces, AnalysisOptions(max_movers=1, trajectory=False)
    )  # compile the numba kernels once
    return traces


def _bench(benchmark, traces, rounds):
    """Time ``analyze(traces)``; stage seconds of the fastest round into extra_info."""
    results = []

    def run():
        result = analyze(traces)
        results.append(result)
        return result

    result = benchmark.pedantic(run, rounds=rounds, iterations=1)
    fastest = min(results, key=lambda r: r.timings_s["total"])
    for stage, seconds in fastest.timings_s.items():
        benchmark.extra_info[f"{stage}_s"] = round(seconds, 3)
    benchmark.extra_info["n_pulses"] = traces.n_pulses
    benchmark.extra_info["n_movers"] = len(result.movers)
    benchmark.extra_info["image_shape"] = list(result.preliminary_image.grid.shape)
    return result, fastest


def test_analyze_scene1(benchmark, scene1_traces):
    result, fastest = _bench(benchmark, scene1_traces, rounds=3)
    assert len(result.movers) == 2
    assert fastest.timings_s["total"] < 30.0


@pytest.fixture(scope="module")
def scene1_4deg_traces(scene1_traces):
    scene = load_scene("scene1")
    spec = {**scene.trajectory_spec, "aperture_deg": 4.0}
    return simulate(dataclasses.replace(scene, trajectory_spec=spec)).traces


def test_analyze_scene1_four_degrees(benchmark, scene1_4deg_traces):
    result, _ = _bench(benchmark, scene1_4deg_traces, rounds=2)
    assert len(result.movers) == 2


def _gotcha_files() -> list[Path]:
    env = os.environ.get("SARMOTION_GOTCHA_DIR")
    root = Path(__file__).resolve().parents[1]
    for d in ([Path(env)] if env else []) + [root.parent / "shared" / "data" / "gotcha"]:
        files = sorted(d.glob("data_3dsar_pass1_az00*_HH.mat")) if d.is_dir() else []
        if len(files) == 4:
            return files
    return []


def gotcha_two_movers(base):
    """The GOTCHA traces with two movers injected, 8 and 12 dB under the median per-pulse peak."""
    from sarmotion.core import ground_velocity

    geom = base.geometry
    ref = float(np.median(np.abs(base.data).max(axis=1)))
    movers = [
        PointTarget(
            position_m=(8.0, -12.0),
            velocity_mps=ground_velocity(4.5, 3.0, geom),
            reflectivity=ref * 10 ** (-8 / 20) * np.exp(0.7j),
        ),
        PointTarget(
            position_m=(-15.0, 6.0),
            velocity_mps=ground_velocity(-7.0, -2.0, geom),
            reflectivity=ref * 10 ** (-12 / 20) * np.exp(2.1j),
        ),
    ]
    return inject(base, movers)


@pytest.fixture(scope="module")
def gotcha_movers_traces():
    from sarmotion.io import read_gotcha

    files = _gotcha_files()
    if not files:
        pytest.skip("GOTCHA data not found")
    traces = gotcha_two_movers(read_gotcha(files))
    analyze(traces, AnalysisOptions(max_movers=1, trajectory=False))  # compile once
    return traces


def test_analyze_gotcha_four_degrees_two_movers(benchmark, gotcha_movers_traces):
    result, _ = _bench(benchmark, gotcha_movers_traces, rounds=3)
    assert len(result.movers) == 2


def _median_seconds(func, repeats=5):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _plain_g(aligner, velocities):
    """``g`` as numpy forms it: float32 phasors of the reduced cycles, padded FFT, reduce."""
    out = np.empty(velocities.shape[0])
    for i0 in range(0, velocities.shape[0], aligner.chunk):
        cycles = aligner.delays(velocities[i0 : i0 + aligner.chunk])[:, :, None] * aligner.freq
        cycles -= np.rint(cycles)
        phase = (2.0 * np.pi * cycles).astype(np.float32)
        x = (np.cos(phase) + 1j * np.sin(phase)).astype(np.complex64) * aligner.spectrum[None]
        padded = np.zeros(x.shape[:2] + (aligner.n_fft,), dtype=np.complex64)
        padded[..., aligner.slots] = x
        y = sfft.ifft(padded, axis=-1, workers=-1)
        out[i0 : i0 + aligner.chunk] = np.abs(y).sum(axis=1, dtype=np.float64).max(axis=-1)
    return out


def _plain_matched_filter(traces, weighted, norm, positions, velocities):
    v3 = np.concatenate([velocities, np.zeros((len(velocities), 1))], axis=1)
    ref = np.linalg.norm(traces.positions_m - traces.reference_point_m, axis=1)
    where = positions[:, None, :] + traces.slow_times_s[None, :, None] * v3[:, None]
    rng = np.linalg.norm(traces.positions_m[None] - where, axis=2)
    cycles = (2.0 * (rng - ref[None]) / 299792458.0)[:, :, None] * traces.frequencies_hz
    cycles -= np.rint(cycles)
    return np.einsum("vjk,jk->v", np.exp(2j * np.pi * cycles), weighted) / norm


def test_kernels_against_plain_references(benchmark, scene1_traces, scene1_4deg_traces):
    from sarmotion.core import ground_velocity
    from sarmotion.core.spectral import FrequencyPlanes, phased_row_sums
    from sarmotion.motion import MatchedFilter, range_speed_resolution
    from sarmotion.motion._aligned import _Aligner, _g_reduce
    from sarmotion.motion.range_speed import _range_trials

    traces = scene1_traces
    geom = traces.geometry
    aligner = _Aligner(traces, traces.reference_point_m)
    step = 0.5 * range_speed_resolution(traces)
    vel = _range_trials(-30.0 + step * np.arange(int(60.0 / step) + 1), geom, None)
    pairs = {
        "g_grid": (
            lambda: _Aligner(traces, traces.reference_point_m).g_values(vel),  # table included
            lambda: _plain_g(aligner, vel),
        ),
        "g_grid_transform_per_trial": (
            lambda: aligner.map_chunks(vel, _g_reduce),
            lambda: _plain_g(aligner, vel),
        ),
    }
    gen = np.random.default_rng(0)
    pos = np.c_[gen.uniform(-10, 10, (256, 2)), np.zeros(256)]
    mvel = np.array([ground_velocity(a, b, geom) for a, b in gen.uniform(-20, 20, (256, 2))])
    mf = MatchedFilter(traces)
    pairs["matched_filter_256"] = (
        lambda: mf.responses(pos, mvel),
        lambda: _plain_matched_filter(traces, mf.weighted, mf.norm, pos, mvel),
    )
    wide = scene1_4deg_traces
    P = wide.phase_history()
    planes = FrequencyPlanes(P)
    delays = [gen.uniform(-1e-7, 1e-7, wide.n_pulses) for _ in range(50)]
    f0, df = float(wide.frequencies_hz[0]), float(wide.radar.frequency_step_hz)
    rows = np.ascontiguousarray(P, dtype=np.complex128)
    pairs["point_sums_50_x_468_pulses"] = (
        lambda: [planes.sums(d, f0, df) for d in delays],
        lambda: [phased_row_sums(rows, d, f0, df) for d in delays],
    )

    def run():
        for name, (fast, plain) in pairs.items():
            fast(), plain()  # compiled and warm
            t_fast, t_plain = _median_seconds(fast), _median_seconds(plain)
            benchmark.extra_info[f"{name}_s"] = round(t_fast, 4)
            benchmark.extra_info[f"{name}_plain_s"] = round(t_plain, 4)
            benchmark.extra_info[f"{name}_speedup"] = round(t_plain / t_fast, 2)

    benchmark.pedantic(run, rounds=1, iterations=1)
    benchmark.extra_info["load_average_1min"] = round(os.getloadavg()[0], 2)
