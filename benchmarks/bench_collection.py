"""Whole collections at constant target density: patches against one whole-scene analysis.

Run (a few minutes per size on 2 cores; each size in its own process, so that the peak
RSS is that size's)::

    python benchmarks/bench_collection.py --sizes 100 200 400 --out benchmarks/results

Scene of side ``L`` (m), seeded: 0.5 stationary unit points per 1000 m^2 drawn uniformly
in the ``L x L`` square, 3 movers of ground speed 5-15 m/s (random direction, unit
amplitude, random phase) inside it, one degree of GOTCHA-like circular spotlight
(``Trajectory.circular``) sampled for the whole scene: a ground-range window of
``1.3 L`` (``radar_with_range_window``) and a pulse spacing whose unambiguous cross range
(``sarmotion.collection.unambiguous_scene``) is ``1.3 L``. No noise.

For each size, in the same run: ``analyze_collection`` (patches; ``--workers`` Dask
threads, default one per core; 0: in process) and, up to ``--whole-max`` m,
``pipeline.analyze`` on the whole scene (today's analysis, its default image). Reported:
wall time, peak RSS of the process (``ru_maxrss``; the whole-scene run goes first in a
separate process), throughput (km^2 per hour), movers accurate on their cross-range family
(``sarmotion.pipeline.family_errors``' rule: the truth slid along its own family,
``motion.family_member``, to the fit's cross range; accurate when the range position is
within 3 ground-range cells and the range speed within 0.5 m/s), false movers (a fit
matching no true mover), stationary targets found (a listed target within one resolution
cell of a true one) and listed.

The patches' margins are sized for the scene's movers (``max_speed_mps`` 15 m/s, the
default). Threads against processes for the local cluster were compared on the
two-patch scene of ``tests/test_collection_run.py`` cut into 8 patches of 30 m, 2 workers,
alternated in one run (``--threads-vs-processes``).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import resource
import time
from pathlib import Path

import numpy as np

DENSITY_PER_M2 = 0.5e-3
GUARD = 1.3


def make_scene(side_m: float, seed: int):
    """(traces, stationary (n, 2), movers list of PointTarget) of the benchmark scene."""
    from sarmotion.collection import unambiguous_scene
    from sarmotion.core import Radar, Traces, Trajectory, to_fast_time
    from sarmotion.core.blocks import TracesBlocks
    from sarmotion.simulation import PointTarget, radar_with_range_window, simulate_phase_history

    rng = np.random.default_rng(seed)
    gotcha = Trajectory.circular()
    ground = np.hypot(7100.0, 7300.0) / 7100.0  # slant-to-ground factor at the centre
    radar = radar_with_range_window(GUARD * side_m / ground, radar=Radar())
    probe = TracesBlocks(
        Traces(
            data=np.zeros((gotcha.n_pulses, radar.n_samples), np.complex64),
            trajectory=gotcha,
            radar=radar,
            reference_point_m=(0.0, 0.0, 0.0),
        )
    )
    amb = unambiguous_scene(probe)
    e_c = np.array([0.0, 1.0])
    cross = float(np.ptp(amb @ e_c))
    ppd = 117.0 * GUARD * side_m / cross
    traj = Trajectory.circular(pulses_per_deg=ppd)
    half = 0.5 * side_m
    n_stat = int(round(DENSITY_PER_M2 * side_m**2))
    stat = rng.uniform(-half, half, size=(n_stat, 2))
    targets = [PointTarget(position_m=p) for p in stat]
    movers = []
    for k in range(3):
        speed = rng.uniform(5.0, 15.0)
        phi = rng.uniform(0, 2 * np.pi)
        pos = rng.uniform(-half + 10.0, half - 10.0, 2)
        movers.append(
            PointTarget(
                position_m=pos,
                velocity_mps=speed * np.array([np.cos(phi), np.sin(phi)]),
                reflectivity=np.exp(2j * np.pi * rng.random()),
                label=f"mover {k + 1}",
            )
        )
    ph = simulate_phase_history(targets + movers, traj, radar, (0.0, 0.0, 0.0))
    traces = Traces(
        data=to_fast_time(ph).astype(np.complex64),
        trajectory=traj,
        radar=radar,
        reference_point_m=(0.0, 0.0, 0.0),
        metadata={"source": "simulation", "scene": f"collection-{side_m:g}m-seed{seed}"},
    )
    return traces, stat, movers


def score(traces, fits, movers, stationary_found, stationary_true):
    """(accurate movers, false movers, stationary found) (module notes)."""
    from sarmotion.core import range_speed
    from sarmotion.imaging import resolution
    from sarmotion.motion import central_sub_aperture, family_member

    central = central_sub_aperture(traces, 1.0)
    sub = traces.select_pulses(central.start, central.stop)
    geom = sub.geometry
    cells = resolution(sub)
    used = set()
    accurate = 0
    for m in movers:
        best = None
        for j, (p, v) in enumerate(fits):
            if j in used:
                continue
            dy = float((np.asarray(p[:2]) - m.position_m[:2]) @ cells.cross_range_direction)
            tp, tv, _ = family_member(sub, m.position_m, m.velocity_mps, dy)
            dx = float((np.asarray(p[:2]) - tp[:2]) @ cells.range_direction)
            du = range_speed(v, geom) - range_speed(tv, geom)
            if abs(dx) <= 3 * cells.ground_range_m and abs(du) <= 0.5:
                err = abs(dx) / cells.ground_range_m + abs(du) / 0.5
                if best is None or err < best[0]:
                    best = (err, j)
        if best is not None:
            used.add(best[1])
            accurate += 1
    false = len(fits) - len(used)
    cell = max(cells.ground_range_m, cells.cross_range_m)
    found = 0
    if len(stationary_found):
        sf = np.asarray(stationary_found)
        for p in stationary_true:
            if np.min(np.hypot(*(sf - p).T)) <= cell:
                found += 1
    return accurate, false, found


def _rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def run_whole(side_m: float, seed: int) -> dict:
    from sarmotion.pipeline import analyze

    traces, stat, movers = make_scene(side_m, seed)
    t0 = time.perf_counter()
    result = analyze(traces)
    wall = time.perf_counter() - t0
    fits = [(m.position_m, m.velocity_mps) for m in result.movers]
    acc, false, found = score(traces, fits, movers, [s.position_m for s in result.stationary], stat)
    return {
        "wall_s": wall,
        "rss_gb": _rss_gb(),
        "accurate": acc,
        "false": false,
        "stationary_found": found,
        "stationary_listed": len(result.stationary),
    }


def run_patches(side_m: float, seed: int, workers: int | None) -> dict:
    from sarmotion.collection import analyze_collection

    traces, stat, movers = make_scene(side_m, seed)
    t0 = time.perf_counter()
    result = analyze_collection(traces, n_workers=workers)
    wall = time.perf_counter() - t0
    fits = [(m.position_m, m.velocity_mps) for m, _ in result.movers]
    acc, false, found = score(traces, fits, movers, [s.position_m for s in result.stationary], stat)
    return {
        "wall_s": wall,
        "rss_gb": _rss_gb(),
        "patches": len(result.plan.patches),
        "patch_size_m": result.plan.patch_size_m,
        "accurate": acc,
        "false": false,
        "stationary_found": found,
        "stationary_listed": len(result.stationary),
        "stationary_dropped": result.stationary_dropped,
        "timings_s": result.timings_s,
    }


def threads_vs_processes(rounds: int = 2) -> list[dict]:
    """Wall time of the 8-patch two-core scene on 2 threads and 2 processes, alternated."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from sarmotion.collection import CollectionOptions, analyze_collection
    from sarmotion.core import Radar, Traces, Trajectory, to_fast_time
    from sarmotion.pipeline import AnalysisOptions
    from sarmotion.simulation import PointTarget, simulate_phase_history
    from test_collection_run import MOVER, STATIONARY

    traj, radar = Trajectory.circular(), Radar()
    targets = [PointTarget(position_m=p) for p in STATIONARY] + [MOVER]
    ph = simulate_phase_history(targets, traj, radar, (0.0, 0.0, 0.0))
    tr = Traces(
        data=to_fast_time(ph),
        trajectory=traj,
        radar=radar,
        reference_point_m=(0.0, 0.0, 0.0),
        metadata={"source": "simulation"},
    )
    opts = CollectionOptions(analysis=AnalysisOptions(trajectory=False), patch_size_m=30.0)
    region = (-60.0, -25.0, 60.0, 25.0)
    analyze_collection(tr, opts, region_m=region, n_workers=0)  # compile here first
    rows = []
    for _ in range(rounds):
        for processes in (False, True):
            t0 = time.perf_counter()
            r = analyze_collection(tr, opts, region_m=region, n_workers=2, processes=processes)
            rows.append(
                {
                    "workers": "processes" if processes else "threads",
                    "patches": len(r.plan.patches),
                    "wall_s": time.perf_counter() - t0,
                    "load_average": os.getloadavg()[0],
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    return rows


def _in_process(fn, *args):
    with mp.get_context("spawn").Pool(1) as pool:
        return pool.apply(fn, args)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[100, 200, 400, 800])
    parser.add_argument("--seed", type=int, default=2027)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--whole-max", type=float, default=400.0)
    parser.add_argument(
        "--methods", nargs="+", choices=["whole", "patches"], default=["whole", "patches"]
    )
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--threads-vs-processes", action="store_true")
    args = parser.parse_args()
    if args.threads_vs_processes:
        threads_vs_processes()
        return
    rows = []
    for side in args.sizes:
        traces, stat, _ = make_scene(side, args.seed)
        row = {
            "side_m": side,
            "pulses": traces.n_pulses,
            "samples": traces.n_samples,
            "n_stationary": len(stat),
        }
        del traces
        if "whole" in args.methods and side <= args.whole_max:
            row["whole"] = _in_process(run_whole, side, args.seed)
        if "patches" in args.methods:
            row["patches"] = _in_process(run_patches, side, args.seed, args.workers)
            row["patches"]["km2_per_hour"] = (side / 1000.0) ** 2 / row["patches"]["wall_s"] * 3600
        rows.append(row)
        row["load_average"] = list(os.getloadavg())
        print(json.dumps(row), flush=True)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "bench_collection.json").write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
