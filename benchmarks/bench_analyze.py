"""Benchmark of the whole analysis (sarmotion.pipeline.analyze) on Scene 1.

Run with::

    pytest benchmarks/bench_analyze.py --benchmark-only -p no:cacheprovider

Scene 1: GOTCHA, one degree (117 pulses x 424 samples), 20 stationary targets and two
movers, noise-free, default options (combined separation, 88 m preliminary image at
0.25 m, trajectories on). ``extra_info`` holds the seconds of each stage of the fastest
round (``AnalysisResult.timings_s``), the number of movers found and the image size.
Target: the whole analysis under 30 s on a 2-core machine.

Scene 1's targets over 4 degrees (468 pulses, a whole GOTCHA file's span): movers are
estimated on the central degree and focused on all pulses (sarmotion.motion.aperture); the
``movers_s`` stage includes that refinement.
"""

from __future__ import annotations

import dataclasses

import pytest

from sarmotion.pipeline import AnalysisOptions, analyze
from sarmotion.simulation import load_scene, simulate


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
