"""Scale-out of the sub-aperture analyses on Dask (sarmotion.tracking.scale).

Run with::

    pytest benchmarks/bench_tracking.py --benchmark-only -p no:cacheprovider -s

Workload: Scene 1's twenty stationary targets and two movers over 4 degrees of the
GOTCHA circle (468 pulses), cut into seven 1-degree sub-apertures (overlap 0.5), each
analysed with 60 m images and no phase-space trajectories. Each configuration gets a
warm cluster (every worker has run one sub-aperture, so numba's compilation is not
timed), then the seven sub-apertures are timed. Reported in ``extra_info`` and printed:
sub-apertures per second with 1 and 2 workers, as threads of one process and as
processes, and the scaling efficiency ``rate(2) / (2 rate(1))``. The time in
pytest-benchmark's table is one of these runs, the seven sub-apertures on two thread
workers (seconds), timed by ``benchmark.pedantic``.

Measured on the 2-core machine while other jobs kept its load average near 10 (so low
and noisy): threads 0.061 / 0.063 sub-apertures/s with 1 / 2 workers (efficiency 0.51),
processes 0.029 / 0.041 (0.71); 13 min in all.
"""

from __future__ import annotations

import dataclasses
import time

import pytest

from sarmotion.pipeline import AnalysisOptions
from sarmotion.simulation import load_scene, simulate
from sarmotion.tracking import map_sub_apertures, sub_aperture_slices

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def workload():
    scene = load_scene("scene1")
    scene = dataclasses.replace(
        scene, trajectory_spec={**scene.trajectory_spec, "aperture_deg": 4.0}
    )
    traces = simulate(scene).traces
    options = AnalysisOptions(trajectory=False, image_size_m=60.0).resolved(traces)
    return traces, sub_aperture_slices(traces, 1.0, 0.5), options


def _rate(workload, n_workers: int, processes: bool, benchmark=None) -> float:
    """Sub-apertures per second on a warm cluster; timed by ``benchmark`` when given."""
    traces, slices, options = workload
    with (
        distributed.LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=processes,
            dashboard_address=None,
            **({"host": "127.0.0.1"} if processes else {}),
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        list(map_sub_apertures(traces, slices[:n_workers], options, scheduler=client))  # warm
        done: list = []

        def run() -> None:
            done[:] = map_sub_apertures(traces, slices, options, scheduler=client)

        if benchmark is None:
            start = time.perf_counter()
            run()
            seconds = time.perf_counter() - start
        else:
            benchmark.pedantic(run, rounds=1, iterations=1)
            seconds = benchmark.stats.stats.mean
        out = done
    assert [s.index for s in out] == list(range(len(slices)))
    return len(slices) / seconds


def test_sub_apertures_per_second(benchmark, workload):
    rates = {}
    for processes in (False, True):
        for n in (1, 2):
            timer = benchmark if (n, processes) == (2, False) else None
            rates[(n, processes)] = _rate(workload, n, processes, timer)
    for processes in (False, True):
        kind = "processes" if processes else "threads"
        r1, r2 = rates[(1, processes)], rates[(2, processes)]
        benchmark.extra_info[f"{kind}_1_worker_per_s"] = round(r1, 4)
        benchmark.extra_info[f"{kind}_2_workers_per_s"] = round(r2, 4)
        benchmark.extra_info[f"{kind}_efficiency"] = round(r2 / (2 * r1), 3)
        print(
            f"{kind}: {r1:.3f} sub-apertures/s with 1 worker, {r2:.3f} with 2, "
            f"scaling efficiency {r2 / (2 * r1):.2f}"
        )
    best = max((False, True), key=lambda p: rates[(2, p)])
    benchmark.extra_info["best"] = "processes" if best else "threads"
