"""Any look azimuth: the analysed region covers the declared scene, movers on their families.

Run (each case in a process of its own, so that its peak RSS is its own)::

    python benchmarks/look_azimuth.py --sides 100 --azimuths 0 30 45 60 90 135 210 300
    python benchmarks/look_azimuth.py --sides 400 --azimuths 45

Rows are added to (or replace, by side and azimuth) ``look_azimuth.json`` in ``--out``
(default ``benchmarks/results``), and the table ``look_azimuth.md`` is written from it.

Acquisition: a 2-degree X-band circular arc (9.6 GHz, GOTCHA's 640 MHz: 0.23 m
slant-range cells, 0.48 m cross range) at 10 km ground range and 4 km height, 150 m/s,
centred on
the *look azimuth* ``phi``: the antenna at azimuth ``phi`` from the scene centre, so the
ground range direction ``e_r`` is ``phi`` from ``x`` and the radar looks along
``-e_r`` (``phi = 0`` is the GOTCHA-like look along ``x`` the collection path was built
on). The fast-time window and the pulse rate are sized for ``--oversample`` (1.6) times
the scene's side, in slant range and cross range, as real collections are (1.5 to 1.8).

Scene of side ``L``, square along ``x`` and ``y`` about the reference point, declared
in the file as its ``SceneCoordinates/ImageArea`` (the block writer,
``sarmotion.io.write_cphd_blocks``): 8 unit stationary points (4 of them 0.05 L inside
the corners), ``--clutter`` weak scatterers (amplitude 0.03, random phase; 2000 at
100 m, ``2000 (L / 100)`` beyond) uniform in the square, 4 movers of 5-15 m/s of unit
amplitude (one near a corner, one near an edge, two inside; each stays in the square
over the aperture; heading within 60 degrees of the line of sight, so that the range
speed is at least half the speed: the slow-range-speed regime is
``benchmarks/movers_accuracy.py``'s), white noise of -20 dB per phase-history sample of
a unit point. The scene is the same in ``x``, ``y`` at every azimuth but the movers'
headings, drawn relative to the look.

The file is analysed with the library's defaults (``analyze_collection`` over
``open_cphd_blocks``; ``n_workers=0``, one process). Reported per case:

- **patches**, and in brackets those beyond the declared square that search for movers
  only (a mover's range speed shifts its image in cross range; ``collection/plan.py``);
- **covered**: share of 40 000 points drawn uniformly in the declared square that the
  analysis images: inside a core of the square's patches (several patches), or inside
  today's single analysis's image (one patch);
- **movers**: true movers found accurate on their cross-range families (the rule of
  ``benchmarks/bench_collection.py``: the truth slid along its family to the fit's
  cross range, ``pipeline.family_errors``; range position within 3 ground-range cells
  and range speed within 0.5 m/s), and false movers (fits matching no true mover);
- **stationary**: share of the 8 stationary points with a listed stationary target
  within one resolution cell in ground range and in cross range;
- wall time of the analysis (s) and the case process's peak RSS (MiB, ``ru_maxrss``:
  the simulation and the file's writing included).
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "src"))

from sarmotion.collection import CollectionOptions, analyze_collection  # noqa: E402
from sarmotion.core import Acquisition, C, Radar, Trajectory  # noqa: E402
from sarmotion.imaging import resolution  # noqa: E402
from sarmotion.io import open_cphd_blocks, write_cphd_blocks  # noqa: E402
from sarmotion.pipeline import family_errors  # noqa: E402
from sarmotion.simulation import CollectionScene, PointTarget  # noqa: E402

GROUND_M, HEIGHT_M, APERTURE_DEG, SPEED_MPS = 10e3, 4e3, 2.0, 150.0
CARRIER_HZ, BAND_HZ = 9.6e9, 640e6
SNR_DB = -20.0
CLUTTER_AMPLITUDE = 0.03
RANGE_CELLS, RANGE_SPEED_MPS = 3.0, 0.5


def acquisition(side_m: float, azimuth_deg: float, oversample: float) -> Acquisition:
    """The arc centred on ``azimuth_deg``, sampled for ``oversample`` times the side."""
    cos_el = GROUND_M / math.hypot(GROUND_M, HEIGHT_M)
    window = oversample * side_m * cos_el  # slant range (m)
    df = C / (2.0 * window)
    radar = Radar(
        carrier_hz=CARRIER_HZ,
        bandwidth_hz=BAND_HZ,
        n_samples=math.ceil(BAND_HZ / df),
        frequency_step_hz=df,
    )
    per_rad = cos_el * 2.0 * oversample * side_m / radar.wavelength_m
    count = math.ceil(np.deg2rad(APERTURE_DEG) * per_rad)
    traj = Trajectory.circular(
        altitude_m=HEIGHT_M,
        ground_radius_m=GROUND_M,
        speed_mps=SPEED_MPS,
        pulses_per_deg=count / APERTURE_DEG,
        aperture_deg=APERTURE_DEG,
        centre_azimuth_deg=azimuth_deg,
        n_pulses=count,
    )
    return Acquisition(trajectory=traj, radar=radar, reference_point_m=np.zeros(3))


def weak_scatterers(rng: np.random.Generator, half_m: float, count: int) -> list[PointTarget]:
    """``count`` scatterers of amplitude ``CLUTTER_AMPLITUDE``, random phase, uniform in the
    square of half-side ``half_m``."""
    return [
        PointTarget(position_m=p, reflectivity=CLUTTER_AMPLITUDE * np.exp(2j * np.pi * ph))
        for p, ph in zip(
            rng.uniform(-half_m, half_m, size=(count, 2)), rng.uniform(0, 1, count), strict=True
        )
    ]


def draw_mover(
    rng: np.random.Generator,
    position_m,
    half_m: float,
    t_half_s: float,
    look_rad: float,
    slowest_mps: float,
    label: str,
) -> PointTarget:
    """A unit mover at ``position_m``, staying in the square over the aperture.

    Speed uniform from ``slowest_mps`` to 15 m/s (less where the square's edge is nearer
    than 0.9 of what that speed covers in ``t_half_s``), heading within 60 degrees of the
    line of sight (``look_rad``, either way): a range speed of at least half the speed,
    not the slow-range-speed regime.
    """
    room = half_m - np.max(np.abs(position_m))
    speed = rng.uniform(slowest_mps, min(15.0, max(slowest_mps, 0.9 * room / t_half_s)))
    phi = look_rad + rng.choice([0.0, np.pi]) + rng.uniform(-np.pi / 3, np.pi / 3)
    return PointTarget(
        position_m=position_m,
        velocity_mps=(speed * np.cos(phi), speed * np.sin(phi)),
        reflectivity=np.exp(2j * np.pi * rng.uniform()),
        label=label,
    )


def points_within_a_cell(acq, result, points) -> int:
    """How many of ``points`` have a listed stationary target within a resolution cell."""
    cells = resolution(acq)
    e_r = result.range_direction
    e_c = np.array([-e_r[1], e_r[0]])
    listed = np.array([t.position_m for t in result.stationary]).reshape(-1, 2)
    near = 0
    for t in points:
        d = listed - t.position_m[:2]
        if d.size and np.any(
            (np.abs(d @ e_r) <= cells.ground_range_m) & (np.abs(d @ e_c) <= cells.cross_range_m)
        ):
            near += 1
    return near


def scene(side_m: float, azimuth_deg: float, oversample: float, clutter: int, seed: int):
    """The seeded scene (module notes) and its declared square."""
    acq = acquisition(side_m, azimuth_deg, oversample)
    rng = np.random.default_rng(seed)
    half = 0.5 * side_m
    square = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    corners = 0.9 * square
    inner = rng.uniform(-0.7 * half, 0.7 * half, size=(4, 2))
    points = [PointTarget(position_m=p) for p in np.vstack([corners, inner])]
    weak = weak_scatterers(rng, half, clutter)
    t_half = float(np.max(np.abs(acq.trajectory.slow_times_s)))
    movers = []
    places = [
        (0.8 * half, -0.8 * half),  # near a corner
        (-0.85 * half, 0.1 * half),  # near an edge
        tuple(rng.uniform(-0.5 * half, 0.5 * half, 2)),
        tuple(rng.uniform(-0.5 * half, 0.5 * half, 2)),
    ]
    look = np.deg2rad(azimuth_deg)  # e_r's direction
    for k, p in enumerate(places):
        movers.append(draw_mover(rng, p, half, t_half, look, 5.0, f"mover {k + 1}"))
    meta = {"source": "simulation", "scene": f"look azimuth {azimuth_deg:g} deg, side {side_m:g} m"}
    sc = CollectionScene(
        acquisition=acq,
        stationary=tuple(points + weak),
        movers=tuple(movers),
        snr_db=SNR_DB,
        seed=seed,
        metadata=meta,
    )
    return sc, square, points


def score_movers(acq, truths, fits) -> tuple[int, list[dict], int]:
    """True movers found accurate on their families, those missed, and false fits."""
    cells = resolution(acq)
    found, used, missed = 0, set(), []
    for truth in truths:
        hit = None
        for j, m in enumerate(fits):
            e = family_errors(acq, m, truth)
            ok = abs(e[0]) <= RANGE_CELLS * cells.ground_range_m and abs(e[1]) <= RANGE_SPEED_MPS
            if ok and j not in used:
                hit = j
                break
        if hit is not None:
            found += 1
            used.add(hit)
        else:
            missed.append(
                {
                    "label": truth.label,
                    "position_m": [float(v) for v in truth.position_m[:2]],
                    "velocity_mps": [float(v) for v in truth.velocity_mps],
                }
            )
    return found, missed, len(fits) - len(used)


def run_case(
    side_m: float,
    azimuth_deg: float,
    oversample: float,
    clutter: int,
    seed: int,
    reference: bool = False,
    cache: Path | None = None,
) -> dict:
    """One case, in this process: simulate, write (or take the cached file), analyse, score."""
    sc, square, points = scene(side_m, azimuth_deg, oversample, clutter, seed)
    acq = sc.acquisition
    with tempfile.TemporaryDirectory() as tmp:
        name = f"look_{side_m:g}m_{azimuth_deg:g}deg_x{oversample:g}_c{clutter}_s{seed}.cphd"
        path = (cache or Path(tmp)) / name
        t0 = time.perf_counter()
        cached = path.exists()
        if not cached:
            write_cphd_blocks(path, sc, block_pulses=256, image_area_m=square)
        simulate_s = time.perf_counter() - t0
        t1 = time.perf_counter()
        src = open_cphd_blocks(path)
        result = analyze_collection(src, CollectionOptions(), n_workers=0)
        wall = time.perf_counter() - t1
    rss_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    plan = result.plan
    rng = np.random.default_rng(1)
    probe = rng.uniform(-0.5 * side_m, 0.5 * side_m, size=(40_000, 2))
    if plan.single:
        x0, x1, y0, y1 = result.mosaic_extent_m
        held = (np.abs(probe[:, 0] - 0.5 * (x0 + x1)) <= 0.5 * (x1 - x0)) & (
            np.abs(probe[:, 1] - 0.5 * (y0 + y1)) <= 0.5 * (y1 - y0)
        )
    else:
        # the region's cores (those beyond it search for movers only)
        held = np.any([p.inside(probe) for p in plan.patches if not p.movers_only], axis=0)
    found, missed, false = score_movers(acq, sc.movers, [m for m, _ in result.movers])
    near = points_within_a_cell(acq, result, points)
    row: dict = {}
    if reference:  # today's analysis of the whole traces, its image the declared square
        from sarmotion.pipeline import AnalysisOptions, analyze

        t2 = time.perf_counter()
        whole = analyze(sc.traces(), AnalysisOptions(image_size_m=side_m))
        row["reference_wall_s"] = time.perf_counter() - t2
        got, _, wrong = score_movers(acq, sc.movers, list(whole.movers))
        row["reference_movers_found"], row["reference_false_movers"] = got, wrong
    return row | {
        "side_m": side_m,
        "azimuth_deg": azimuth_deg,
        "oversample": oversample,
        "clutter": clutter,
        "seed": seed,
        "n_pulses": int(acq.n_pulses),
        "n_samples": int(acq.radar.n_samples),
        "patches": len(plan.patches),
        "patches_beyond": sum(bool(p.movers_only) for p in plan.patches),
        "single": bool(plan.single),
        "patch_size_m": plan.patch_size_m,
        "declared_outside_share": plan.declared_outside_share,
        "covered": float(np.mean(held)),
        "movers": len(sc.movers),
        "movers_found": found,
        "false_movers": false,
        "missed": missed,
        "fits": [
            {
                "position_m": [float(v) for v in m.position_m[:2]],
                "velocity_mps": [float(v) for v in m.velocity_mps],
            }
            for m, _ in result.movers
        ],
        "stationary": len(points),
        "stationary_near": near,
        "stationary_listed": len(result.stationary),
        "simulate_write_s": simulate_s,
        "cached_file": cached,
        "wall_s": wall,
        "rss_mib": rss_mib,
    }


def table(rows: list[dict]) -> str:
    head = (
        "| side (m) | look az (deg) | pulses x samples | patches (beyond) | covered "
        "| movers found "
        "| false | whole-trace analysis: found / false | stationary within a cell "
        "| wall (s) | RSS (MiB) |\n"
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    )
    lines = []
    for r in sorted(rows, key=lambda r: (r["side_m"], r["azimuth_deg"])):
        ref = "-"
        if "reference_movers_found" in r:
            ref = f"{r['reference_movers_found']}/{r['movers']} / {r['reference_false_movers']}"
        lines.append(
            f"| {r['side_m']:g} | {r['azimuth_deg']:g} | {r['n_pulses']} x {r['n_samples']} "
            f"| {r['patches']}{' (single)' if r['single'] else ''}"
            f"{f' ({beyond})' if (beyond := r.get('patches_beyond')) else ''} "
            f"| {100 * r['covered']:.2f} % "
            f"| {r['movers_found']}/{r['movers']} | {r['false_movers']} | {ref} "
            f"| {r['stationary_near']}/{r['stationary']} | {r['wall_s']:.1f} | {r['rss_mib']:.0f} |"
        )
    return head + "\n".join(lines) + "\n"


def write_table(path: Path, rows: list[dict]) -> None:
    """Write ``rows``' table into ``path``, keeping the text after an earlier table."""
    text = path.read_text() if path.exists() else ""
    start = text.find("| side (m)")
    end = text.find("\n\n", start) if start >= 0 else -1
    rest = text[end:] if end >= 0 else "\n"
    path.write_text(text[: max(start, 0)] + table(rows).rstrip("\n") + rest)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sides", type=float, nargs="+", default=[100.0])
    parser.add_argument(
        "--azimuths", type=float, nargs="+", default=[0, 30, 45, 60, 90, 135, 210, 300]
    )
    parser.add_argument("--oversample", type=float, default=1.6)
    parser.add_argument("--clutter", type=int, default=None)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--out", type=Path, default=HERE / "results")
    parser.add_argument(
        "--reference",
        action="store_true",
        help="also analyse the whole traces at once (pipeline.analyze, image the declared "
        "square): the movers it finds, beside the collection's",
    )
    parser.add_argument(
        "--cache",
        type=Path,
        default=None,
        help="keep the simulated CPHD files in this folder and reuse them (the scene is "
        "the seed's; the RSS then leaves the simulation out)",
    )
    parser.add_argument("--case", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:  # one case, its row on stdout
        side, az = args.sides[0], args.azimuths[0]
        clutter = args.clutter if args.clutter is not None else int(2000 * max(1.0, side / 100))
        row = run_case(side, az, args.oversample, clutter, args.seed, args.reference, args.cache)
        print(json.dumps(row))
        return
    args.out.mkdir(parents=True, exist_ok=True)
    store = args.out / "look_azimuth.json"
    rows = json.loads(store.read_text()) if store.exists() else []
    for side in args.sides:
        for az in args.azimuths:
            cmd = [sys.executable, __file__, "--case", "--sides", str(side), "--azimuths", str(az)]
            cmd += ["--oversample", str(args.oversample), "--seed", str(args.seed)]
            if args.clutter is not None:
                cmd += ["--clutter", str(args.clutter)]
            if args.reference:
                cmd += ["--reference"]
            if args.cache is not None:
                args.cache.mkdir(parents=True, exist_ok=True)
                cmd += ["--cache", str(args.cache)]
            out = subprocess.run(cmd, capture_output=True, text=True, check=False)
            if out.returncode != 0:
                print(out.stderr[-3000:], file=sys.stderr)
                continue
            row = json.loads(out.stdout.strip().splitlines()[-1])
            print(json.dumps(row), flush=True)
            rows = [r for r in rows if (r["side_m"], r["azimuth_deg"]) != (side, az)] + [row]
            store.write_text(json.dumps(rows, indent=1) + "\n")
            write_table(args.out / "look_azimuth.md", rows)
    print(table(rows))


if __name__ == "__main__":
    main()
