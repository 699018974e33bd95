"""Whole collections at constant target density: patches against one whole-scene analysis.

Run (a few minutes per size on 2 cores; each size in its own process, so that the peak
RSS is that size's)::

    python benchmarks/bench_collection.py --sizes 100 200 400 --out benchmarks/results

Rows are added to (or replace, by size) ``bench_collection.json`` in ``--out`` (the
methods not run keep their earlier results for that size and seed), and the table
``bench_collection.md`` is written from it. ``--pieces k`` runs a size's patches
in ``k`` processes one after the other, each a ``k``-th of the plan's patches (every
``k``-th), and merges their answers as one run would (movers by range history,
stationary targets by cell, then the listing floor and the sidelobe rule): wall is
the sum, RSS the largest. ``--ab-workers 0 2 --rounds 2`` times the patches alone on
one size with each worker count in turn, alternated, with the load average.
``--defocus-search`` also runs each size's patches with the defocus bank
(``AnalysisOptions(defocus_search=True)``, what ``sarmotion analyze`` does in the patches
of a collection by default), reported as a row of its own; the plain ``patches`` row is
the command's ``--no-defocus-search``.
``--pieces k --piece-ids i ...`` runs only those pieces: their time and memory, and the
wall the whole run would take (``k`` over the pieces run times their wall), written to
``bench_collection_sampled.json``; a size too long to run whole is estimated so.

``--rate-factors 1.0 1.7 3.0`` is the throughput at realistic pulse rates: the pulse
spacing sized for that many times the scene (unambiguous cross range ``factor x L``;
the range window stays ``1.3 L``), each size and factor's patches with the command's
defaults (the defocus search on; ``--no-defocus`` off) in a process of its own: wall
time, CPU time (user plus system of the process), peak RSS, km^2 per hour, the pulses
each patch keeps, and the movers. ``--base-src DIR`` runs each also with the package at
``DIR`` (a ``git worktree`` of an earlier commit's ``src``) first in the sys.path,
alternated with today's in the same run. Rows go to ``bench_collection_rates.json``
(added to, by side, factor and code) and the table ``bench_collection_rates.md``.
``--profile-pulses 1300 650 325 --sizes 400 --rate-factors 4`` times one patch's stages
at those pulse counts (``patch_profile``) and fits each stage's exponent in the pulses:
``--profile-mover k`` the patch holding mover ``k``, ``--profile-cpu`` the stages in CPU
seconds of the process, ``--cprofile PREFIX`` each run's ``cProfile`` statistics, and
``--profile-compare BEFORE AFTER`` the table of two such runs' JSON, stage by stage
(``results/bench_collection_profile.md``).

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
within 3 ground-range cells and the range speed within 0.5 m/s; each missed mover with
the largest phase between its range history and a stationary point's, and one under
pi/2 listed as a stationary target where that point images counted accurate, ``score``),
false
movers (a fit
matching no true mover), mover reports (a mover fitted in several patches is reported by
each before the merge), stationary targets found (a listed target within one resolution
cell of a true one), listed, and dropped as sidelobes.

The patches' margins are sized for the scene's movers (``max_speed_mps`` 15 m/s, the
default). Threads against processes for the local cluster were compared on the
two-patch scene of ``tests/collection/test_collection_run.py`` cut into 8 patches of
30 m, 2 workers,
alternated in one run (``--threads-vs-processes``).
"""

from __future__ import annotations

import argparse
import json
import logging
import multiprocessing as mp
import os
import resource
import time
from pathlib import Path

import numpy as np

DENSITY_PER_M2 = 0.5e-3
#: The table's name of each method a row may hold.
METHOD_NAMES = {
    "whole": "whole, --no-defocus-search",
    "patches": "patches, --no-defocus-search",
    "patches_defocus": "patches (defocus search: the default)",
}
GUARD = 1.3


def make_scene(side_m: float, seed: int, rate_factor: float = GUARD):
    """(traces, stationary (n, 2), movers list of PointTarget) of the benchmark scene.

    The pulse spacing's unambiguous cross range is ``rate_factor`` times the side.
    """
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
    ppd = 117.0 * rate_factor * side_m / cross
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
    """(accurate movers, false movers, stationary found, missed movers) (module notes).

    Each mover not fitted is ``{"label", "stationary_phase_rad", "listed_as_stationary"}``:
    the largest phase between its range history and that of the stationary point with its
    range and range rate at the aperture's centre
    (``acceptance_collection.stationary_twin``). Under pi/2 the mover is that point to any
    single-antenna method, and a stationary target listed within a resolution cell of
    where that point images counts it as accurate (its family's stationary member), as
    the acceptance benchmark does.
    """
    from acceptance_collection import STATIONARY_LIKE_RAD, stationary_twin

    from sarmotion.core import range_speed
    from sarmotion.imaging import resolution
    from sarmotion.motion import central_sub_aperture, family_member

    central = central_sub_aperture(traces, 1.0)
    sub = traces.select_pulses(central.start, central.stop)
    geom = sub.geometry
    cells = resolution(sub)
    cell = max(cells.ground_range_m, cells.cross_range_m)
    sf = np.array([np.asarray(p, dtype=float)[:2] for p in stationary_found]).reshape(-1, 2)
    used = set()
    accurate = 0
    missed = []
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
        else:
            phase, twin = stationary_twin(traces, m)
            near = np.hypot(*(sf - twin).T) if sf.size else np.array([np.inf])
            listed = bool(phase < STATIONARY_LIKE_RAD and np.min(near) <= cell)
            accurate += listed
            missed.append(
                {"label": m.label, "stationary_phase_rad": phase, "listed_as_stationary": listed}
            )
    false = len(fits) - len(used)
    found = 0
    if sf.size:
        for p in stationary_true:
            if np.min(np.hypot(*(sf - p).T)) <= cell:
                found += 1
    return accurate, false, found, missed


def _rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def _cpu_s() -> float:
    """User plus system CPU time of this process, all its threads (s)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def run_whole(side_m: float, seed: int) -> dict:
    from sarmotion.pipeline import AnalysisOptions, analyze

    traces, stat, movers = make_scene(side_m, seed)
    t0 = time.perf_counter()
    # without the defocus search, as the stored rows were measured (its cost and finds are
    # in the patches' rows)
    result = analyze(traces, AnalysisOptions(defocus_search=False))
    wall = time.perf_counter() - t0
    fits = [(m.position_m, m.velocity_mps) for m in result.movers]
    acc, false, found, missed = score(
        traces, fits, movers, [s.position_m for s in result.stationary], stat
    )
    return {
        "wall_s": wall,
        "rss_gb": _rss_gb(),
        "accurate": acc,
        "missed": missed,
        "false": false,
        "stationary_found": found,
        "stationary_listed": len(result.stationary),
    }


def _cells(traces):
    from sarmotion.imaging import resolution
    from sarmotion.motion import central_sub_aperture

    central = central_sub_aperture(traces, 1.0)
    return resolution(traces.select_pulses(central.start, central.stop))


def run_patches(
    side_m: float,
    seed: int,
    workers: int | None,
    piece=(0, 1),
    defocus_search: bool = False,
    rate_factor: float = GUARD,
    src: str | None = None,
) -> dict:
    """The collection on the scene; ``piece = (i, k)``: only every ``k``-th patch from ``i``.

    ``src``: the package's source folder to import (first in ``sys.path``); default the
    installed one.
    """
    import dataclasses
    import sys

    if src is not None:
        sys.path.insert(0, src)

    import distributed  # noqa: F401  (its logging set up first, then quietened)

    from sarmotion.collection import CollectionOptions, analyze_collection, plan_patches
    from sarmotion.core.blocks import TracesBlocks
    from sarmotion.pipeline import AnalysisOptions

    logging.getLogger("distributed").setLevel(logging.WARNING)  # the local cluster's
    traces, stat, movers = make_scene(side_m, seed, rate_factor)
    import sarmotion

    t0 = time.perf_counter()
    cpu0 = _cpu_s()
    plan = plan_patches(TracesBlocks(traces))
    i, k = piece
    part = dataclasses.replace(plan, patches=plan.patches[i::k]) if k > 1 else plan
    options = CollectionOptions(analysis=AnalysisOptions(defocus_search=defocus_search))
    result = analyze_collection(traces, options, plan=part, n_workers=workers)
    wall = time.perf_counter() - t0
    cpu = _cpu_s() - cpu0
    stage: dict[str, float] = {}
    for r in result.patches:
        for key, v in r.timings_s.items():
            stage[key] = stage.get(key, 0.0) + v
    return {
        "wall_s": wall,
        "cpu_s": cpu,
        "rss_gb": _rss_gb(),
        "package": str(Path(sarmotion.__file__).parent),
        "input_pulses": traces.n_pulses,
        "input_samples": traces.n_samples,
        "prf_hz": 1.0 / traces.trajectory.pulse_interval_s,
        "pulses_kept": [int(p.pulses.size) for p in part.patches],
        "ratio": [[int(getattr(p, "interpolation", 1)), int(p.decimation)] for p in part.patches],
        "patches": len(part.patches),
        "patch_size_m": plan.patch_size_m,
        "pulses_per_patch": [
            int(min(p.pulses.size for p in plan.patches)),
            int(max(p.pulses.size for p in plan.patches)),
        ],
        "samples_per_patch": [
            int(min(p.n_samples for p in plan.patches)),
            int(max(p.n_samples for p in plan.patches)),
        ],
        "movers": [
            (
                m.position_m.tolist(),
                m.velocity_mps.tolist(),
                m.sigma_range_m,
                m.sigma_range_speed_mps,
                m.snr_db,
                m.patch,
            )
            for m, _ in result.movers
        ],
        "mover_reports": sum(len(r.movers) for r in result.patches),
        "stationary": [(t.position_m, t.level, t.patch) for t in result.stationary],
        "stationary_sidelobes": result.stationary_sidelobes,
        "stationary_dropped": result.stationary_dropped,
        "timings_s": result.timings_s,
        "patch_stage_s": stage,
        "load_average": os.getloadavg()[0],
    }


def _score_patches(side_m: float, seed: int, parts: list[dict], rate_factor: float = GUARD) -> dict:
    """One run's answer from its pieces (module notes), scored."""
    from sarmotion.collection import MoverRecord, StationaryRecord
    from sarmotion.collection.merge import drop_sidelobes, merge_movers, merge_stationary
    from sarmotion.collection.plan import _analysed_pulses
    from sarmotion.core import Trajectory
    from sarmotion.core.blocks import TracesBlocks
    from sarmotion.pipeline import AnalysisOptions

    traces, stat, movers = make_scene(side_m, seed, rate_factor)
    cells = _cells(traces)
    recs = [
        MoverRecord(
            patch=pa,
            position_m=np.asarray(p),
            velocity_mps=np.asarray(v),
            sigma_range_m=sx,
            sigma_range_speed_mps=su,
            snr_db=snr,
            document={},
        )
        for part in parts
        for p, v, sx, su, snr, pa in part["movers"]
    ]
    sl = _analysed_pulses(TracesBlocks(traces), AnalysisOptions().sub_aperture_deg)
    traj = traces.trajectory
    analysed = Trajectory(positions_m=traj.positions_m[sl], slow_times_s=traj.slow_times_s[sl])
    merged = (
        merge_movers(recs, analysed, traces.radar.range_resolution_m)
        if len(parts) > 1
        else [(r, [r.patch]) for r in recs]
    )
    fits = [(m.position_m, m.velocity_mps) for m, _ in merged]
    targets = [
        StationaryRecord(patch=pa, position_m=tuple(p), level=lv)
        for part in parts
        for p, lv, pa in part["stationary"]
    ]
    sidelobes = sum(part["stationary_sidelobes"] for part in parts)
    if len(parts) > 1:
        targets = merge_stationary(
            targets,
            range_direction=cells.range_direction,
            range_cell_m=cells.ground_range_m,
            cross_cell_m=cells.cross_range_m,
        )
        floor = max((t.level for t in targets), default=0.0) * 10 ** (
            AnalysisOptions().stationary_threshold_db / 20
        )
        targets = [t for t in targets if t.level >= floor]
        targets, more = drop_sidelobes(
            targets,
            antenna_m=traj.positions_m[int(np.argmin(np.abs(traj.slow_times_s)))],
            range_cell_m=cells.ground_range_m,
            cross_cell_m=cells.cross_range_m,
            pixel_m=AnalysisOptions().spacing_m,
        )
        sidelobes += more
    acc, false, found, missed = score(traces, fits, movers, [t.position_m for t in targets], stat)
    first = parts[0]
    return {
        "wall_s": sum(p["wall_s"] for p in parts),
        "rss_gb": max(p["rss_gb"] for p in parts),
        "pieces": len(parts),
        "patches": sum(p["patches"] for p in parts),
        "patch_size_m": first["patch_size_m"],
        "pulses_per_patch": first["pulses_per_patch"],
        "samples_per_patch": first["samples_per_patch"],
        "accurate": acc,
        "missed": missed,
        "false": false,
        "mover_reports": sum(p["mover_reports"] for p in parts),
        "stationary_found": found,
        "stationary_listed": len(targets),
        "stationary_sidelobes": sidelobes,
        "stationary_dropped": sum(p["stationary_dropped"] for p in parts),
        "patch_stage_s": {
            k: sum(p["patch_stage_s"].get(k, 0.0) for p in parts) for k in first["patch_stage_s"]
        },
        "load_average": [p["load_average"] for p in parts],
    }


def threads_vs_processes(rounds: int = 2) -> list[dict]:
    """Wall time of the 8-patch two-core scene on 2 threads and 2 processes, alternated."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from test_collection_run import MOVER, STATIONARY

    from sarmotion.collection import CollectionOptions, analyze_collection
    from sarmotion.core import Radar, Traces, Trajectory, to_fast_time
    from sarmotion.pipeline import AnalysisOptions
    from sarmotion.simulation import PointTarget, simulate_phase_history

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


def _sampled(parts: list[dict], pieces: int) -> dict:
    """Time and memory of some of a size's pieces, and the whole run's wall they imply."""
    wall = sum(p["wall_s"] for p in parts)
    return {
        "pieces_run": len(parts),
        "pieces": pieces,
        "patches_run": sum(p["patches"] for p in parts),
        "wall_s_run": wall,
        "wall_s_estimated": wall * pieces / len(parts),
        "rss_gb": max(p["rss_gb"] for p in parts),
        "pulses_per_patch": parts[0]["pulses_per_patch"],
        "samples_per_patch": parts[0]["samples_per_patch"],
        "patch_stage_s": parts[0]["patch_stage_s"],
        "timings_s": [p["timings_s"] for p in parts],
        "load_average": [p["load_average"] for p in parts],
    }


def _table(rows: list[dict]) -> str:
    """Markdown table of the rows (module notes)."""
    head = (
        "| side | pulses x samples | method | patches (pulses x samples each) | wall | "
        "peak RSS | km^2/h | movers accurate | false | stationary found / true | listed "
        "(sidelobes dropped) | load |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    )
    out = []
    for r in sorted(rows, key=lambda r: r["side_m"]):
        for method in ("whole", "patches", "patches_defocus"):
            m = r.get(method)
            if m is None:
                continue
            load = m.get("load_average", r.get("load_average"))
            load = max(load) if isinstance(load, list) else load
            if method.startswith("patches"):
                pp = m.get("pulses_per_patch", ["?", "?"])
                ss = m.get("samples_per_patch", ["?", "?"])
                pieces = f", {m['pieces']} pieces" if m.get("pieces", 1) > 1 else ""
                how = f"{m['patches']} ({pp[0]}-{pp[1]} x {ss[0]}-{ss[1]}{pieces})"
                listed = f"{m['stationary_listed']} ({m.get('stationary_sidelobes', 0)})"
            else:
                how, listed = "1 (whole scene)", str(m["stationary_listed"])
            km2h = (r["side_m"] / 1000) ** 2 / m["wall_s"] * 3600
            phases = ", ".join(
                f"{x['stationary_phase_rad']:.2f}"
                for x in m.get("missed", [])
                if not x.get("listed_as_stationary")
            )
            missed = f" (missed: {phases} rad)" if phases else ""
            if any(x.get("listed_as_stationary") for x in m.get("missed", [])):
                missed += " (stationary-like, listed as stationary)"
            out.append(
                f"| {r['side_m']:g} m | {r['pulses']} x {r['samples']} | "
                f"{METHOD_NAMES[method]} | {how} | "
                f"{m['wall_s']:.1f} s | {m['rss_gb']:.2f} GB | {km2h:.2f} | "
                f"{m['accurate']}/3{missed} | "
                f"{m['false']} | {m['stationary_found']}/{r['n_stationary']} | {listed} | "
                f"{load:.1f} |"
            )
    return head + "\n".join(out) + "\n"


def ab_workers(side_m: float, seed: int, workers: list[int], rounds: int) -> list[dict]:
    """Patches' wall time with each worker count in turn, alternated, each in its own process."""
    rows = []
    for _ in range(rounds):
        for w in workers:
            before = os.getloadavg()[0]
            r = _in_process(run_patches, side_m, seed, w)
            rows.append(
                {
                    "side_m": side_m,
                    "workers": w,
                    "wall_s": r["wall_s"],
                    "patches_s": r["timings_s"]["patches"],
                    "rss_gb": r["rss_gb"],
                    "load_before": before,
                    "load_after": os.getloadavg()[0],
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    return rows


def rate_table(
    sides: list[float],
    factors: list[float],
    seed: int,
    workers: int | None,
    defocus_search: bool,
    base_src: str | None,
    out: Path | None,
) -> list[dict]:
    """Throughput at each side and pulse-rate factor, today's code and ``base_src``'s."""
    codes = [("now", None)] + ([("base", base_src)] if base_src else [])
    rows = []
    pair = 0
    for side in sides:
        for factor in factors:
            pair += 1
            for code, src in codes if pair % 2 else codes[::-1]:
                before = os.getloadavg()[0]
                part = _in_process(
                    run_patches, side, seed, workers, (0, 1), defocus_search, factor, src
                )
                scored = _score_patches(side, seed, [part], factor)
                kept = np.asarray(part["pulses_kept"])
                row = {
                    "side_m": side,
                    "rate_factor": factor,
                    "code": code,
                    "package": part["package"],
                    "seed": seed,
                    "defocus_search": defocus_search,
                    "input_pulses": part["input_pulses"],
                    "input_samples": part["input_samples"],
                    "prf_hz": part["prf_hz"],
                    "patches": part["patches"],
                    "pulses_kept": [int(kept.min()), int(np.median(kept)), int(kept.max())],
                    "ratios": sorted({f"{a}/{b}" for a, b in part["ratio"]}),
                    "samples_per_patch": part["samples_per_patch"],
                    "wall_s": part["wall_s"],
                    "cpu_s": part["cpu_s"],
                    "rss_gb": part["rss_gb"],
                    "km2_per_hour": (side / 1000.0) ** 2 / part["wall_s"] * 3600,
                    "patch_stage_s": part["patch_stage_s"],
                    "accurate": scored["accurate"],
                    "missed": scored["missed"],
                    "false": scored["false"],
                    "stationary_found": scored["stationary_found"],
                    "n_stationary": int(round(DENSITY_PER_M2 * side**2)),
                    "stationary_listed": scored["stationary_listed"],
                    "load_before": before,
                    "load_after": os.getloadavg()[0],
                }
                rows.append(row)
                print(json.dumps(row), flush=True)
                if out is not None:
                    out.mkdir(parents=True, exist_ok=True)
                    path = out / "bench_collection_rates.json"
                    old = json.loads(path.read_text()) if path.exists() else []
                    key = ("side_m", "rate_factor", "code", "defocus_search")
                    old = [r for r in old if any(r.get(k) != row[k] for k in key)]
                    doc = sorted(
                        old + [row], key=lambda r: (r["side_m"], r["rate_factor"], r["code"])
                    )
                    path.write_text(json.dumps(doc, indent=2) + "\n")
                    (out / "bench_collection_rates.md").write_text(_rate_md(doc))
    return rows


def _rate_md(rows: list[dict]) -> str:
    """Markdown table of ``rate_table``'s rows."""
    head = (
        "| side | pulse-rate factor | code | input pulses x samples (PRF) | patches | "
        "pulses kept per patch (min/median/max) | p/q | wall | CPU | peak RSS | km^2/h | "
        "movers accurate | false | stationary found / true | load |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    )
    out = []
    for r in rows:
        k = r["pulses_kept"]
        ratios = ", ".join(r["ratios"][:3]) + (" ..." if len(r["ratios"]) > 3 else "")
        out.append(
            f"| {r['side_m']:g} m | {r['rate_factor']:g} | {r['code']} | "
            f"{r['input_pulses']} x {r['input_samples']} ({r['prf_hz']:.0f} Hz) | "
            f"{r['patches']} | {k[0]}/{k[1]}/{k[2]} | {ratios} | {r['wall_s']:.0f} s | "
            f"{r['cpu_s']:.0f} s | {r['rss_gb']:.2f} GB | {r['km2_per_hour']:.3f} | "
            f"{r['accurate']}/3 | {r['false']} | {r['stationary_found']}/{r['n_stationary']} | "
            f"{max(r['load_before'], r['load_after']):.1f} |"
        )
    return head + "\n".join(out) + "\n"


def patch_profile(
    side_m: float,
    seed: int,
    rate_factor: float,
    pulses: list[int],
    src: str | None = None,
    mover: int = 0,
    cprofile: str | None = None,
    cpu_stages: bool = False,
) -> list[dict]:
    """One patch's analysis at several pulse counts: its stage timings and their exponent.

    The scene's pulse rate is sized for ``rate_factor`` times the side; the patch whose
    band keeps mover ``mover``'s echo (0, 1 or 2; ``run.in_band`` of its true motion)
    keeps every ``q``-th pulse, ``q = max(1, round(n_pulses /
    n))`` for each count ``n`` of ``pulses`` (integer decimations: exact for its aliased
    movers; the same pass band and filter rule), and is analysed as a collection's patch
    is (:func:`~sarmotion.collection.run.analyze_patch`, the command's defaults, after one
    untimed run), on the threads the process has. Each row keeps the patch's answers (its
    movers with their bounds, its stationary targets) to compare two codes' on the same
    data; ``cprofile``: a file prefix, each timed run's ``cProfile`` statistics written to
    ``{cprofile}_{pulses}.prof``. With ``cpu_stages`` the stage times are the process's
    CPU seconds (all its threads: the pipeline's timer reads ``time.process_time``), which
    other jobs on a shared machine inflate far less than wall-clock time.
    """
    import dataclasses
    import sys
    import types

    if src is not None:
        sys.path.insert(0, src)
    if cpu_stages:
        import sarmotion.pipeline._timing as timing

        timing.time = types.SimpleNamespace(perf_counter=time.process_time)
    from sarmotion.collection import CollectionOptions, extract_patches, plan_patches
    from sarmotion.collection.extract import make_traces
    from sarmotion.collection.plan import BAND_GUARD
    from sarmotion.collection.resample import design, output_grid
    from sarmotion.collection.run import analyze_patch, in_band
    from sarmotion.core.blocks import TracesBlocks

    traces, _, movers = make_scene(side_m, seed, rate_factor)
    source = TracesBlocks(traces)
    plan = plan_patches(source)
    # the patch whose band keeps the mover's echo (its Doppler shifts it in cross range by
    # about R / V per m/s of range speed: not the patch that holds its position)
    truth = types.SimpleNamespace(
        position_m=np.asarray(movers[mover].position_m, float),
        velocity_mps=np.asarray(movers[mover].velocity_mps, float)[:2],
    )
    patch = next(
        p
        for p in plan.patches
        if in_band(make_traces(p, source, np.zeros((p.pulses.size, p.n_samples), np.complex64)), p)(
            truth
        )
    )
    prf = 1.0 / traces.trajectory.pulse_interval_s
    opts = CollectionOptions().analysis
    rows = []
    for n in pulses:
        up, down = 1, max(1, round(traces.n_pulses / n))
        taps = design(up, patch.passband_hz, prf, 60.0, guard=BAND_GUARD)
        this = dataclasses.replace(
            patch,
            interpolation=up,
            decimation=down,
            taps=taps,
            pulses=output_grid(traces.n_pulses, up, down, taps.size),
        )
        (tr,) = extract_patches(source, [this])
        analyze_patch(tr, this, opts)  # compiled and warmed
        prof = None
        if cprofile is not None:
            import cProfile

            prof = cProfile.Profile()
            prof.enable()
        t0, c0 = time.perf_counter(), _cpu_s()
        res, _ = analyze_patch(tr, this, opts)
        wall, cpu = time.perf_counter() - t0, _cpu_s() - c0
        if prof is not None:
            prof.disable()
            prof.dump_stats(f"{cprofile}_{tr.n_pulses}.prof")
        rows.append(
            {
                "side_m": side_m,
                "rate_factor": rate_factor,
                "pulses": tr.n_pulses,
                "samples": tr.n_samples,
                "ratio": f"{up}/{down}",
                "package": str(Path(sys.modules["sarmotion"].__file__).parent),
                "stage_clock": "cpu" if cpu_stages else "wall",
                "wall_s": wall,
                "cpu_s": cpu,
                "movers": len(res.movers),
                "mover_answers": [
                    {
                        "position_m": m.position_m.tolist(),
                        "velocity_mps": m.velocity_mps.tolist(),
                        "sigma_range_m": m.sigma_range_m,
                        "sigma_range_speed_mps": m.sigma_range_speed_mps,
                        "snr_db": m.snr_db,
                    }
                    for m in res.movers
                ],
                "stationary": [[*t.position_m, t.level] for t in res.stationary],
                "timings_s": res.timings_s,
            }
        )
        print(json.dumps(rows[-1]), flush=True)
    return rows


def _profile_md(rows: list[dict]) -> str:
    """Per-stage table of ``patch_profile``'s rows and each stage's exponent in pulses."""
    stages = [k for k in rows[0]["timings_s"] if all(k in r["timings_s"] for r in rows)]
    n = np.array([r["pulses"] for r in rows], dtype=float)
    head = "| stage | " + " | ".join(f"{int(v)} pulses (s)" for v in n) + " | exponent |\n"
    head += "|---|" + "---|" * (len(rows) + 1) + "\n"
    out = []
    for k in stages:
        t = np.array([r["timings_s"][k] for r in rows])
        ok = t > 1e-3
        slope = np.polyfit(np.log(n[ok]), np.log(t[ok]), 1)[0] if ok.sum() >= 2 else np.nan
        out.append(f"| {k} | " + " | ".join(f"{v:.2f}" for v in t) + f" | {slope:.2f} |")
    return head + "\n".join(out) + "\n"


def _profile_compare_md(before: list[dict], after: list[dict]) -> str:
    """Per-stage table of two codes' ``patch_profile`` rows (same pulses), with exponents."""
    n = np.array([r["pulses"] for r in after], dtype=float)
    stages = [k for k in after[0]["timings_s"] if all(k in r["timings_s"] for r in before + after)]

    def slope(t: np.ndarray) -> float:
        ok = t > 1e-3
        return float(np.polyfit(np.log(n[ok]), np.log(t[ok]), 1)[0]) if ok.sum() >= 2 else np.nan

    head = (
        "| stage | "
        + " | ".join(f"{int(v)} pulses before / after (s)" for v in n)
        + " | exponent before / after |\n"
    )
    head += "|---|" + "---|" * (len(n) + 1) + "\n"
    out = []
    rows = [(k, [r["timings_s"][k] for r in before], [r["timings_s"][k] for r in after])
            for k in stages]  # fmt: skip
    rows.append(("process CPU", [r["cpu_s"] for r in before], [r["cpu_s"] for r in after]))
    for k, tb, ta in rows:
        tb, ta = np.array(tb), np.array(ta)
        if max(tb.max(), ta.max()) < 5e-3:
            continue
        cells = " | ".join(f"{b:.2f} / {a:.2f}" for b, a in zip(tb, ta, strict=True))
        out.append(f"| {k} | {cells} | {slope(tb):.2f} / {slope(ta):.2f} |")
    return head + "\n".join(out) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[100, 200, 400, 800])
    parser.add_argument("--seed", type=int, default=2027)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--whole-max", type=float, default=400.0)
    parser.add_argument(
        "--methods", nargs="+", choices=["whole", "patches"], default=["whole", "patches"]
    )
    parser.add_argument("--pieces", type=int, default=1)
    parser.add_argument("--piece-ids", type=int, nargs="+", default=None)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--threads-vs-processes", action="store_true")
    parser.add_argument("--ab-workers", type=int, nargs="+", default=None)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument(
        "--defocus-search",
        action="store_true",
        help="also run the patches with AnalysisOptions(defocus_search=True)",
    )
    parser.add_argument(
        "--rate-factors",
        type=float,
        nargs="+",
        default=None,
        help="pulse spacing sized for these multiples of the scene: the km^2/h table",
    )
    parser.add_argument(
        "--base-src", default=None, help="with --rate-factors: also run the package at DIR"
    )
    parser.add_argument(
        "--no-defocus", action="store_true", help="with --rate-factors: defocus search off"
    )
    parser.add_argument(
        "--profile-pulses",
        type=int,
        nargs="+",
        default=None,
        help="one patch's stage timings at these pulse counts (first size, first factor)",
    )
    parser.add_argument(
        "--profile-mover",
        type=int,
        default=0,
        help="with --profile-pulses: the patch holding this mover (0, 1 or 2)",
    )
    parser.add_argument(
        "--profile-cpu",
        action="store_true",
        help="with --profile-pulses: stage times in CPU seconds of the process",
    )
    parser.add_argument(
        "--profile-compare",
        nargs=2,
        type=Path,
        default=None,
        metavar=("BEFORE", "AFTER"),
        help="print the per-stage table of two --profile-pulses JSON files and exit",
    )
    parser.add_argument(
        "--cprofile",
        default=None,
        help="with --profile-pulses: write each run's cProfile statistics to PREFIX_N.prof",
    )
    args = parser.parse_args()
    if args.profile_compare:
        before, after = (json.loads(p.read_text()) for p in args.profile_compare)
        print(_profile_compare_md(before, after))
        return
    if args.profile_pulses:
        factor = args.rate_factors[0] if args.rate_factors else 3.0
        rows = _in_process(
            patch_profile,
            args.sizes[0],
            args.seed,
            factor,
            args.profile_pulses,
            args.base_src,
            args.profile_mover,
            args.cprofile,
            args.profile_cpu,
        )
        print(_profile_md(rows))
        if args.out is not None:
            args.out.mkdir(parents=True, exist_ok=True)
            (args.out / "bench_collection_profile.json").write_text(
                json.dumps(rows, indent=2) + "\n"
            )
        return
    if args.rate_factors:
        base = str(Path(args.base_src).resolve()) if args.base_src else None
        rate_table(
            args.sizes,
            args.rate_factors,
            args.seed,
            args.workers,
            not args.no_defocus,
            base,
            args.out,
        )
        return
    if args.threads_vs_processes:
        threads_vs_processes()
        return
    if args.ab_workers:
        rows = ab_workers(args.sizes[0], args.seed, args.ab_workers, args.rounds)
        if args.out is not None:
            args.out.mkdir(parents=True, exist_ok=True)
            path = args.out / "bench_collection_workers.json"
            old = json.loads(path.read_text()) if path.exists() else []
            path.write_text(json.dumps(old + rows, indent=2) + "\n")
        return
    rows = []
    for side in args.sizes:
        traces, stat, _ = make_scene(side, args.seed)
        row = {
            "side_m": side,
            "pulses": traces.n_pulses,
            "samples": traces.n_samples,
            "n_stationary": len(stat),
            "seed": args.seed,
        }
        del traces
        if "whole" in args.methods and side <= args.whole_max:
            row["whole"] = _in_process(run_whole, side, args.seed)
            row["whole"]["load_average"] = os.getloadavg()[0]
        if "patches" in args.methods:
            ids = args.piece_ids if args.piece_ids is not None else range(args.pieces)
            parts = [
                _in_process(run_patches, side, args.seed, args.workers, (i, args.pieces))
                for i in ids
            ]
            if len(parts) < args.pieces:  # a sample of the pieces: time and memory only
                row["patches"] = _sampled(parts, args.pieces)
                row["load_average"] = list(os.getloadavg())
                print(json.dumps(row), flush=True)
                if args.out is not None:
                    path = args.out / "bench_collection_sampled.json"
                    old = json.loads(path.read_text()) if path.exists() else []
                    path.write_text(json.dumps(old + [row], indent=2) + "\n")
                continue
            row["patches"] = _score_patches(side, args.seed, parts)
            row["patches"]["workers"] = args.workers
            row["patches"]["km2_per_hour"] = (side / 1000.0) ** 2 / row["patches"]["wall_s"] * 3600
        if args.defocus_search:
            part = _in_process(run_patches, side, args.seed, args.workers, (0, 1), True)
            row["patches_defocus"] = _score_patches(side, args.seed, [part])
            row["patches_defocus"]["workers"] = args.workers
            row["patches_defocus"]["km2_per_hour"] = (
                (side / 1000.0) ** 2 / row["patches_defocus"]["wall_s"] * 3600
            )
        rows.append(row)
        row["load_average"] = list(os.getloadavg())
        print(json.dumps(row), flush=True)
        if args.out is not None:
            args.out.mkdir(parents=True, exist_ok=True)
            path = args.out / "bench_collection.json"
            old = json.loads(path.read_text()) if path.exists() else {}
            sizes = old.get("sizes", []) if isinstance(old, dict) else old
            kept = [r for r in sizes if r["side_m"] != side]
            for prev in (r for r in sizes if r["side_m"] == side):
                # methods not run this time keep their earlier rows (same scene and seed)
                for key in ("whole", "patches", "patches_defocus"):
                    if key not in row and key in prev and prev.get("seed") == row["seed"]:
                        row[key] = prev[key]
            doc = {
                "note": __doc__.split("\n")[0],
                "sizes": sorted(kept + [row], key=lambda r: r["side_m"]),
            }
            path.write_text(json.dumps(doc, indent=2) + "\n")
            md = args.out / "bench_collection.md"
            # the notes above the table (how and when it was run) are kept
            text = md.read_text() if md.exists() else ""
            notes = text[: text.find("| side |")] if "| side |" in text else ""
            md.write_text(notes + _table(doc["sizes"]))


if __name__ == "__main__":
    main()
