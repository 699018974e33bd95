"""A square kilometre at a realistic pulse rate, analysed with the defaults.

Run::

    python benchmarks/square_km.py --cache /tmp/km2            # simulate (once), analyse
    python benchmarks/square_km.py --cache /tmp/km2 --seed 12  # another draw

The acquisition is ``benchmarks/look_azimuth.py``'s: a 2-degree X-band circular arc
(9.6 GHz, 640 MHz) at 10 km ground range and 4 km height, 150 m/s, its fast-time window
and pulse rate sized for ``--oversample`` (1.7) times the scene's side, as real
collections are; look azimuth ``--azimuth`` (30 degrees: not the GOTCHA-like look along
``x``). At a side of 1000 m that is 3529 pulses x 6740 samples.

Scene (seeded): the declared square of side ``--side`` (in the file's
``SceneCoordinates/ImageArea``), ``--points`` unit stationary points uniform within 0.9 of
it, ``--clutter`` weak scatterers (amplitude 0.03, random phase) uniform in it, ``--movers``
movers of unit amplitude at 3-15 m/s, uniform within 0.7 of it, each staying in it over
the aperture, heading within 60 degrees of the line of sight (a range speed of at least
half the speed), white noise of -20 dB per phase-history sample of a unit point.

The file is simulated in one process (``simulation.echoes.point_echoes``) and written by
the block writer; the analysis runs in a process of its own, so that its peak RSS
(``ru_maxrss``) is the analysis's: ``analyze_collection`` over ``open_cphd_blocks`` with
``CollectionOptions()`` and the default workers (one thread per core; with
``--wide-defocus-search`` the defocus search's wide span too, its rows marked "(wide)").
Reported: wall
time, the process's CPU time (user + system, all threads), peak RSS, the plan (patches,
pulses kept per patch), movers found accurate on their families (``look_azimuth.py``'s
rule: range within 3 ground-range cells, range speed within 0.5 m/s), false movers, the
stationary points with a listed target within a resolution cell, and the patches' stage
times summed (CPU-bound stages run in the workers' threads: their sum exceeds the wall).
Rows go to ``square_km.json`` in ``--out`` (by side, azimuth, oversample, seed) and the
table to ``square_km.md``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(HERE))

from look_azimuth import (  # noqa: E402
    SNR_DB,
    acquisition,
    draw_mover,
    points_within_a_cell,
    score_movers,
    weak_scatterers,
)

from sarmotion.collection import CollectionOptions, analyze_collection  # noqa: E402
from sarmotion.io import open_cphd_blocks, write_cphd_blocks  # noqa: E402
from sarmotion.simulation import CollectionScene, PointTarget  # noqa: E402


def scene(args: argparse.Namespace) -> tuple[CollectionScene, np.ndarray]:
    """The seeded scene (module notes) and its declared square."""
    acq = acquisition(args.side, args.azimuth, args.oversample)
    rng = np.random.default_rng(args.seed)
    half = 0.5 * args.side
    square = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    points = [
        PointTarget(position_m=p, label=f"point {k}")
        for k, p in enumerate(rng.uniform(-0.9 * half, 0.9 * half, size=(args.points, 2)))
    ]
    weak = weak_scatterers(rng, half, args.clutter)
    t_half = float(np.max(np.abs(acq.trajectory.slow_times_s)))
    look = np.deg2rad(args.azimuth)  # e_r's direction
    movers = []
    for k in range(args.movers):
        p = rng.uniform(-0.7 * half, 0.7 * half, 2)
        movers.append(draw_mover(rng, p, half, t_half, look, 3.0, f"mover {k + 1}"))
    meta = {"source": "simulation", "scene": f"square km benchmark, side {args.side:g} m"}
    sc = CollectionScene(
        acquisition=acq,
        stationary=tuple(points + weak),
        movers=tuple(movers),
        snr_db=SNR_DB,
        seed=args.seed,
        metadata=meta,
    )
    return sc, square


def file_name(args: argparse.Namespace) -> str:
    return (
        f"km_{args.side:g}m_{args.azimuth:g}deg_x{args.oversample:g}_p{args.points}"
        f"_c{args.clutter}_m{args.movers}_s{args.seed}.cphd"
    )


def simulate(args: argparse.Namespace, path: Path) -> float:
    """Write the scene's file (block by block); the seconds it took."""
    sc, square = scene(args)
    t0 = time.perf_counter()
    tmp = path.with_suffix(".partial")
    write_cphd_blocks(tmp, sc, block_pulses=256, image_area_m=square)
    tmp.replace(path)
    return time.perf_counter() - t0


def analyse(args: argparse.Namespace, path: Path) -> dict:
    """Analyse the file with the defaults; the row (module notes)."""
    sc, _ = scene(args)
    acq = sc.acquisition
    last = [0.0]

    def progress(stage: str, done: int, total: int) -> None:
        now = time.perf_counter()
        if now - last[0] > 30.0 or done == total:
            last[0] = now
            print(f"  {stage}: {done}/{total}", file=sys.stderr, flush=True)

    cpu0 = time.process_time()
    t0 = time.perf_counter()
    opts = CollectionOptions()
    if args.wide_defocus_search:
        opts = dataclasses.replace(
            opts, analysis=dataclasses.replace(opts.analysis, wide_defocus_search=True)
        )
    result = analyze_collection(open_cphd_blocks(path), opts, progress=progress)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    rss_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    plan = result.plan
    found, missed, false = score_movers(acq, sc.movers, [m for m, _ in result.movers])
    points = [t for t in sc.stationary if abs(t.reflectivity) == 1.0]
    near = points_within_a_cell(acq, result, points)
    stages: dict[str, float] = {}
    for pr in result.patches:
        for k, v in pr.timings_s.items():
            stages[k] = stages.get(k, 0.0) + float(v)
    kept = sorted(int(p.pulses.size) for p in plan.patches)
    return {
        "label": args.label,
        "wide_defocus_search": bool(args.wide_defocus_search),
        "side_m": args.side,
        "azimuth_deg": args.azimuth,
        "oversample": args.oversample,
        "seed": args.seed,
        "points": args.points,
        "clutter": args.clutter,
        "n_pulses": int(acq.n_pulses),
        "n_samples": int(acq.radar.n_samples),
        "patches": len(plan.patches),
        "patches_beyond": sum(bool(p.movers_only) for p in plan.patches),
        "pulses_kept": [kept[0], kept[len(kept) // 2], kept[-1]] if kept else [],
        "movers": len(sc.movers),
        "movers_found": found,
        "false_movers": false,
        "missed": missed,
        "fits": [
            {
                "position_m": [float(v) for v in m.position_m[:2]],
                "velocity_mps": [float(v) for v in m.velocity_mps],
                "patches": [int(i) for i in where],
            }
            for m, where in result.movers
        ],
        "stationary": len(points),
        "stationary_near": near,
        "stationary_listed": len(result.stationary),
        "wall_s": wall,
        "cpu_s": cpu,
        "rss_mib": rss_mib,
        "timings_s": {k: float(v) for k, v in result.timings_s.items()},
        "patch_stages_s": stages,
    }


def table(rows: list[dict]) -> str:
    head = (
        "| code | side (m) | look az (deg) | rate and window (x side) | pulses x samples "
        "| patches (beyond) | pulses kept (min/median/max) | movers found | false "
        "| stationary within a cell | wall (s) | CPU (s) | peak RSS (MiB) | km²/h |\n"
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    )
    lines = []
    for r in rows:
        kept = "/".join(str(v) for v in r["pulses_kept"])
        lines.append(
            f"| {r.get('label', '')}{' (wide)' if r.get('wide_defocus_search') else ''} "
            f"| {r['side_m']:g} | {r['azimuth_deg']:g} "
            f"| {r['oversample']:g} | {r['n_pulses']} x {r['n_samples']} "
            f"| {r['patches']} ({r['patches_beyond']}) | {kept} "
            f"| {r['movers_found']}/{r['movers']} | {r['false_movers']} "
            f"| {r['stationary_near']}/{r['stationary']} | {r['wall_s']:.0f} | {r['cpu_s']:.0f} "
            f"| {r['rss_mib']:.0f} | {3600.0 * (r['side_m'] / 1000.0) ** 2 / r['wall_s']:.2f} |"
        )
    return head + "\n".join(lines) + "\n"


def write_table(path: Path, rows: list[dict]) -> None:
    """Write ``rows``' table into ``path``, keeping the text around an earlier table."""
    text = path.read_text() if path.exists() else ""
    start = text.find("| code | side (m)")
    if start < 0:
        head = (
            "# A square kilometre at a realistic pulse rate\n\n"
            "Written by `benchmarks/square_km.py` (its notes say what each column is).\n\n"
        )
        path.write_text(head + table(rows))
        return
    end = text.find("\n\n", start)
    rest = text[end:] if end >= 0 else "\n"
    path.write_text(text[:start] + table(rows).rstrip("\n") + rest)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", type=float, default=1000.0, help="scene side (m)")
    parser.add_argument("--azimuth", type=float, default=30.0, help="look azimuth (deg)")
    parser.add_argument(
        "--oversample", type=float, default=1.7, help="window and pulse rate per side"
    )
    parser.add_argument("--points", type=int, default=120, help="unit stationary points")
    parser.add_argument("--clutter", type=int, default=5000, help="weak scatterers")
    parser.add_argument("--movers", type=int, default=8)
    parser.add_argument("--seed", type=int, default=11)
    parser.add_argument("--cache", type=Path, required=True, help="folder of simulated files")
    parser.add_argument("--out", type=Path, default=HERE / "results")
    parser.add_argument(
        "--label", default="", help="the code's name in the table (e.g. a commit); rows by it"
    )
    parser.add_argument(
        "--wide-defocus-search",
        action="store_true",
        help="the defocus search also over twice the central degree (not the default)",
    )
    parser.add_argument("--analyse-only", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    path = args.cache / file_name(args)
    if args.analyse_only:
        print(json.dumps(analyse(args, path)))
        return
    if not path.exists():
        print(f"simulating {path.name} ...", file=sys.stderr, flush=True)
        print(f"  written in {simulate(args, path):.0f} s", file=sys.stderr, flush=True)
    cmd = [sys.executable, __file__, "--analyse-only"] + sys.argv[1:]
    out = subprocess.run(cmd, stdout=subprocess.PIPE, text=True, check=True)
    row = json.loads(out.stdout.strip().splitlines()[-1])
    print(json.dumps(row), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    store = args.out / "square_km.json"
    rows = json.loads(store.read_text()) if store.exists() else []
    key = ("label", "wide_defocus_search", "side_m", "azimuth_deg", "oversample", "seed")
    rows = [r for r in rows if tuple(r.get(k, "") for k in key) != tuple(row[k] for k in key)] + [
        row
    ]
    store.write_text(json.dumps(rows, indent=1) + "\n")
    write_table(args.out / "square_km.md", rows)
    print(table(rows))


if __name__ == "__main__":
    main()
