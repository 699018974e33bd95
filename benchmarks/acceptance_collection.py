"""The acceptance collection: a large scene written as CPHD block by block, analysed, scored.

Run (the full size: a few minutes to generate, the analysis up to the 15 min criterion)::

    python benchmarks/acceptance_collection.py --side 1000 --pulses 4000 --samples 4000 \\
        --work /tmp/acceptance --out benchmarks/results

Scene (``sarmotion.simulation.collection``), seeded: a square of side ``L`` centred on the
reference point, 0.5 stationary unit points per 1000 m^2 (the constant density of
``bench_collection.py``), movers of ground speed 5-15 m/s (unit amplitude, random phase
and direction), ``--corner`` of them within 2 m (in x and y) of a crossing of the patch
borders of the plan ``sarmotion.collection.plan_patches`` gives for the scene's region,
``--border`` within 2 m of a border, the others anywhere, at least 30 m apart; white noise
at ``--snr-db`` per phase-history sample of one unit point target. The acquisition: one
degree of GOTCHA-like circular spotlight, a range window of ``1.3 L`` on the ground and a
pulse spacing for ``1.3 L`` of cross range, or more samples and pulses to reach
``--samples`` and ``--pulses`` (a longer range window, a higher pulse rate over the same
degree). The phase history is computed and written a block of pulses at a time
(``sarmotion.io.write_cphd_blocks``), never held whole; the truth (stationary points,
movers' positions and velocities at the aperture centre) goes to ``truth.json`` beside
the file.

Analysis: ``sarmotion analyze FILE --workers W`` in a child process, the command's
default region (the data's whole unambiguous scene; a mover's image lands where its
Doppler puts it, often outside the square of the scene), or with ``--square-region``
``--region -L/2 -L/2 L/2 L/2`` (the plan, and so the movers placed on its borders,
follow the region). The CPHD is read block by block; the patches search their stationary
band, the command's default, unless ``--no-defocus-search`` (``results/
acceptance_collection.md`` is that run, from before the search was the default,
``..._defocus.md`` the default). Its wall time and peak RSS (``wait4``'s ``ru_maxrss`` of
that child) are measured, and the load average sampled every 5 s while it runs.
Generation is timed separately, in this process.

Score (the issue's acceptance criteria):

- every mover found and accurate on its cross-range family: ``pipeline.family_errors``
  (the truth slid along its own family to the fit's cross range), accurate when the range
  position is within 3 ground-range cells and the range speed within 0.5 m/s, the rule of
  ``bench_collection.py``; each fit matches at most one true mover, the closest. A mover
  whose range history stays within ``STATIONARY_LIKE_RAD`` (pi/2, the quarter-wave depth
  of focus) of a stationary point's over the aperture is that point to any
  single-antenna method (its family holds a stationary member): it counts as found when
  a stationary target is listed within one resolution cell of where that point images
  (``stationary_twin``), and the table says so; a stationary-like mover fitted as a
  mover counts as any other;
- no false mover: no fit left unmatched;
- >= 95 % of the stationary points with a listed stationary target within one resolution
  cell (the larger of the ground-range and cross-range cells at the reference point);
- peak RSS <= 4 GB; wall <= 15 min.

Writes ``acceptance_collection.json`` and ``.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: The acceptance criteria of the issue.
MAX_RSS_GB = 4.0
MAX_WALL_S = 15 * 60.0
MIN_STATIONARY_SHARE = 0.95
#: Family rule of bench_collection.py: range position in ground-range cells, range speed.
RANGE_CELLS = 3.0
RANGE_SPEED_MPS = 0.5


def build_scene(args: argparse.Namespace):
    """(scene, plan of the scene's region) for the arguments (module notes)."""
    from sarmotion.collection import CollectionOptions, plan_patches
    from sarmotion.simulation import CollectionScene, collection_acquisition, random_collection

    side = float(args.side)
    acq = collection_acquisition(
        side, n_pulses=args.pulses, n_samples=args.samples, aperture_deg=args.aperture_deg
    )
    square = (-side / 2, -side / 2, side / 2, side / 2)
    probe = CollectionScene(acquisition=acq, stationary=(), movers=())
    options = CollectionOptions(max_speed_mps=args.max_speed)
    plan = plan_patches(probe, options, region_m=None if args.whole else square)
    region = None if args.whole else square
    # inner patch borders within the scene
    xs = sorted({p.core_m[0] for p in plan.patches if square[0] < p.core_m[0] < square[2]})
    ys = sorted({p.core_m[1] for p in plan.patches if square[1] < p.core_m[1] < square[3]})
    scene = random_collection(
        acq,
        side,
        seed=args.seed,
        density_per_m2=args.density,
        n_movers=args.movers,
        speed_range_mps=(5.0, min(15.0, args.max_speed)),
        lines_m=(xs, ys),
        n_corner=args.corner if xs and ys else 0,
        n_border=args.border if xs or ys else 0,
        snr_db=args.snr_db,
    )
    return scene, plan, region


def generate(scene, path: Path, block_pulses: int) -> dict:
    """Write the scene's CPHD and truth; wall time and this process's peak RSS."""
    from sarmotion.io import write_cphd_blocks, write_json

    t0 = time.perf_counter()
    write_cphd_blocks(path, scene, block_pulses=block_pulses)
    wall = time.perf_counter() - t0
    write_json(path.with_name("truth.json"), scene.truth())
    return {
        "wall_s": wall,
        "rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
        "file_gb": path.stat().st_size / 2**30,
        "block_pulses": block_pulses,
        "load_average": list(os.getloadavg()),
    }


def analyse(
    path: Path, out: Path, region, workers: int, timeout_s: float, extra: tuple[str, ...] = ()
) -> dict:
    """``sarmotion analyze`` in a child process: wall, peak RSS, load while it ran."""
    cmd = [sys.executable, "-m", "sarmotion", "-q", "analyze", str(path), "--out", str(out)]
    if region is not None:
        cmd += ["--region", *(f"{v:g}" for v in region)]
    cmd += ["--workers", str(workers), "--force", *extra]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    loads: list[float] = []
    done = threading.Event()

    def sample() -> None:
        while not done.wait(5.0):
            loads.append(os.getloadavg()[0])

    sampler = threading.Thread(target=sample, daemon=True)
    t0 = time.perf_counter()
    logs = out.with_name("analyze.stdout"), out.with_name("analyze.stderr")
    with logs[0].open("wb") as so, logs[1].open("wb") as se:
        proc = subprocess.Popen(cmd, env=env, stdout=so, stderr=se)
    sampler.start()
    timer = threading.Timer(timeout_s, proc.kill)
    timer.start()
    _, status, usage = os.wait4(proc.pid, 0)
    stdout, stderr = (f.read_text(errors="replace") for f in logs)
    wall = time.perf_counter() - t0
    timer.cancel()
    done.set()
    proc.returncode = os.waitstatus_to_exitcode(status)
    return {
        "command": " ".join(cmd[1:]),
        "exit": proc.returncode,
        "timed_out": wall >= timeout_s,
        "wall_s": wall,
        "rss_gb": usage.ru_maxrss / 2**20,
        "cpu_s": usage.ru_utime + usage.ru_stime,
        "load_average_during": {
            "mean": float(np.mean(loads)) if loads else None,
            "max": float(np.max(loads)) if loads else None,
            "samples": len(loads),
        },
        "stdout_tail": stdout[-3000:],
        "stderr_tail": stderr[-3000:],
    }


def image_cross_range(acq, mover) -> float:
    """Cross-range coordinate (m) where the mover's image lands, aliased by the pulse rate.

    A stationary point's Doppler at ``s = 0`` (relative to the reference point) grows
    linearly with its cross-range offset ``y``; the mover's Doppler differs from that of
    a stationary point at its position by ``f_c (dtau_m/ds - dtau_p/ds)``, which displaces
    its image by that difference over the Doppler rate per metre, wrapped into the
    unambiguous window (width: pulse rate over that rate) centred on the reference point.
    """
    from sarmotion.core.geometry import travel_time
    from sarmotion.imaging import resolution

    traj = acq.trajectory
    s = traj.slow_times_s
    j = int(np.argmin(np.abs(s)))
    sl = slice(j - 1, j + 2)
    pos, ss = traj.positions_m[sl], s[sl]
    e_c = np.r_[resolution(acq).cross_range_direction[:2], 0.0]

    def rate(points) -> float:
        tau = np.array([travel_time(pos[k : k + 1], points[k])[0] for k in range(3)])
        return float((tau[2] - tau[0]) / (ss[2] - ss[0]))

    p0 = mover.position_m
    still = rate([p0] * 3)
    moving = rate(mover.positions_at(ss))
    per_m = rate([p0 + e_c] * 3) - still
    y = float((p0 - acq.reference_point_m) @ e_c) + (moving - still) / per_m
    width = 1.0 / (traj.pulse_interval_s * acq.radar.carrier_hz * abs(per_m))
    return float((y + width / 2) % width - width / 2)


#: A mover whose range history stays within this phase (rad) of a stationary point's
#: over the aperture is that point to the data: the quarter-wave depth-of-focus rule.
STATIONARY_LIKE_RAD = np.pi / 2


def stationary_phase_rad(acq, mover) -> float:
    """Largest phase (rad) between the mover's range history and a stationary point's.

    The stationary point is the one with the mover's range and range rate at ``s = 0``
    (where its image lands); their histories then differ by the range acceleration
    (the cross-range speed), ``4 pi / lambda max_s |R_m(s) - R_p(s)|`` over the pulses.
    Below :data:`STATIONARY_LIKE_RAD` the mover is, over this aperture, a stationary
    point to any single-antenna method: its family holds a (nearly) stationary member.
    """
    return stationary_twin(acq, mover)[0]


def stationary_twin(acq, mover) -> tuple[float, np.ndarray]:
    """(:func:`stationary_phase_rad`, where that stationary point images (x, y) m).

    The point's range coordinate along the ground-range direction at the aperture's
    centre, and the mover's image cross range (:func:`image_cross_range`, aliased by the
    pulse rate as the image is).
    """
    from scipy.optimize import fsolve

    from sarmotion.imaging import resolution

    traj = acq.trajectory
    s = traj.slow_times_s
    pos = traj.positions_m
    j = int(np.argmin(np.abs(s)))
    rdot = np.gradient(pos, s, axis=0)[j]
    p0 = np.r_[np.asarray(mover.position_m, float)[:2], 0.0]
    v = np.r_[np.asarray(mover.velocity_mps, float)[:2], 0.0]
    moving = np.linalg.norm(pos - (p0 + s[:, None] * v), axis=1)
    d = pos[j] - p0
    r0 = float(np.linalg.norm(d))
    rate0 = float(d @ (rdot - v)) / r0

    def equations(xy):
        q = np.r_[xy, 0.0]
        e = pos[j] - q
        n = float(np.linalg.norm(e))
        return [n - r0, float(e @ rdot) / n - rate0]

    q = np.r_[fsolve(equations, p0[:2], xtol=1e-12), 0.0]
    still = np.linalg.norm(pos - q, axis=1)
    phase = float(4 * np.pi / acq.radar.wavelength_m * np.max(np.abs(moving - still)))
    cells = resolution(acq)
    ref = np.asarray(acq.reference_point_m, float)[:2]
    e_r, e_c = cells.range_direction[:2], cells.cross_range_direction[:2]
    image = ref + float((q[:2] - ref) @ e_r) * e_r + image_cross_range(acq, mover) * e_c
    return phase, image


def score(scene, doc: dict) -> dict:
    """The criteria on the movers and stationary points (module notes)."""
    from sarmotion.imaging import resolution
    from sarmotion.pipeline import family_errors
    from sarmotion.simulation import PointTarget

    acq = scene.acquisition
    cells = resolution(acq)
    fits = [
        PointTarget(position_m=m["position_m"][:2], velocity_mps=m["velocity_mps"])
        for m in doc["movers"]
    ]
    pairs = []
    for i, truth in enumerate(scene.movers):
        for j, fit in enumerate(fits):
            e = family_errors(acq, fit, truth)
            if abs(e[0]) <= RANGE_CELLS * cells.ground_range_m and abs(e[1]) <= RANGE_SPEED_MPS:
                cost = abs(e[0]) / cells.ground_range_m + abs(e[1]) / RANGE_SPEED_MPS
                pairs.append((cost, i, j, e))
    pairs.sort(key=lambda p: p[0])
    matched: dict[int, tuple[int, np.ndarray]] = {}
    used: set[int] = set()
    for _, i, j, e in pairs:
        if i not in matched and j not in used:
            matched[i] = (j, e)
            used.add(j)
    cell = max(cells.ground_range_m, cells.cross_range_m)
    listed = np.array([s["position_m"][:2] for s in doc["stationary"]], dtype=float).reshape(-1, 2)
    movers = []
    for i, truth in enumerate(scene.movers):
        phase, twin = stationary_twin(acq, truth)
        near = np.hypot(*(listed - twin).T) if listed.size else np.array([np.inf])
        row = {
            "label": truth.label,
            "position_m": [float(v) for v in truth.position_m[:2]],
            "velocity_mps": [float(v) for v in truth.velocity_mps],
            "found": i in matched,
            "image_cross_range_m": image_cross_range(acq, truth),
            "stationary_phase_rad": phase,
            # a stationary-like mover is that stationary point to the data: listed as a
            # stationary target where that point images, it is on its family
            "listed_as_stationary": bool(
                i not in matched and phase < STATIONARY_LIKE_RAD and np.min(near) <= cell
            ),
        }
        if i in matched:
            j, e = matched[i]
            row.update(
                fit=j,
                patch=doc["movers"][j].get("patch"),
                patches=doc["movers"][j].get("patches"),
                range_error_m=float(e[0]),
                range_speed_error_mps=float(e[1]),
                cross_speed_error_mps=float(e[2]),
            )
        movers.append(row)
    false = [
        {
            "position_m": doc["movers"][j]["position_m"],
            "velocity_mps": doc["movers"][j]["velocity_mps"],
        }
        for j in range(len(fits))
        if j not in used
    ]
    truth_stat = np.array([t.position_m[:2] for t in scene.stationary]).reshape(-1, 2)
    found = 0
    near_truth = np.zeros(len(listed), dtype=bool)
    for p in truth_stat:
        if listed.size:
            d = np.hypot(*(listed - p).T)
            found += bool(np.min(d) <= cell)
            near_truth |= d <= cell
    return {
        "movers": movers,
        "movers_accurate": len(matched),
        "movers_listed_as_stationary": sum(m["listed_as_stationary"] for m in movers),
        "movers_true": len(scene.movers),
        "false_movers": false,
        "cell_m": cell,
        "ground_range_cell_m": cells.ground_range_m,
        "stationary_true": len(truth_stat),
        "stationary_found": found,
        "stationary_share": found / max(len(truth_stat), 1),
        "stationary_listed": len(listed),
        "stationary_listed_without_truth": int(np.sum(~near_truth)),
        "stationary_dropped": doc.get("stationary_dropped"),
    }


def criteria(result: dict) -> dict:
    a, s = result["analysis"], result.get("score")
    out = {
        "wall_le_15_min": a["exit"] == 0 and a["wall_s"] <= MAX_WALL_S,
        "peak_rss_le_4_gb": a["rss_gb"] <= MAX_RSS_GB,
    }
    if s is not None:
        out["every_mover_accurate"] = (
            s["movers_accurate"] + s.get("movers_listed_as_stationary", 0) == s["movers_true"]
        )
        out["no_false_mover"] = not s["false_movers"]
        out["stationary_ge_95_percent"] = s["stationary_share"] >= MIN_STATIONARY_SHARE
    return out


def markdown(result: dict) -> str:
    g, a, s, c = result["generation"], result["analysis"], result.get("score"), result["criteria"]
    sc = result["scene"]
    lines = [
        "# Acceptance collection",
        "",
        f"Scene: {sc['side_m']:g} m x {sc['side_m']:g} m, {sc['n_pulses']} pulses x "
        f"{sc['n_samples']} samples, {sc['n_stationary']} stationary points, "
        f"{sc['n_movers']} movers, SNR {sc['snr_db']} dB per sample of a unit point, seed "
        f"{sc['seed']}; {sc['patches']} patches of {sc['patch_size_m']:.1f} m.",
        "",
        f"Generation: {g['wall_s']:.0f} s, peak RSS {g['rss_gb']:.2f} GB, file "
        f"{g['file_gb']:.2f} GB, load {g['load_average'][0]:.1f}.",
        "",
        f"Analysis (`{a['command']}`): exit {a['exit']}, wall {a['wall_s']:.0f} s, CPU "
        f"{a['cpu_s']:.0f} s, peak RSS {a['rss_gb']:.2f} GB, load during the run mean "
        f"{a['load_average_during']['mean'] or float('nan'):.1f}, max "
        f"{a['load_average_during']['max'] or float('nan'):.1f} "
        f"({result['cores']} cores).",
        "",
        "| criterion | result | pass |",
        "|---|---|---|",
    ]
    rows = {
        "wall_le_15_min": f"{a['wall_s']:.0f} s" + (" (stopped)" if a["timed_out"] else ""),
        "peak_rss_le_4_gb": f"{a['rss_gb']:.2f} GB",
    }
    if s is not None:
        still = s.get("movers_listed_as_stationary", 0)
        rows["every_mover_accurate"] = f"{s['movers_accurate']} of {s['movers_true']}" + (
            f" as movers, {still} stationary-like listed as a stationary target where it "
            "images (its family's stationary member)"
            if still
            else ""
        )
        rows["no_false_mover"] = f"{len(s['false_movers'])} false"
        rows["stationary_ge_95_percent"] = (
            f"{s['stationary_found']} of {s['stationary_true']} "
            f"({100 * s['stationary_share']:.1f} %) within {s['cell_m']:.2f} m; "
            f"{s['stationary_listed']} listed, {s['stationary_listed_without_truth']} "
            "with no true point within a cell"
        )
    for key, text in rows.items():
        lines.append(f"| {key.replace('_', ' ')} | {text} | {'yes' if c[key] else 'NO'} |")
    if s is not None:
        lines += [
            "",
            "| mover | truth (x, y) m | velocity m/s | image cross range m | phase from "
            "stationary rad | found | patches | range err m | range speed err m/s |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for m in s["movers"]:
            err = (
                f"{m['range_error_m']:+.2f} | {m['range_speed_error_mps']:+.2f}"
                if m["found"]
                else "- | -"
            )
            found = "yes" if m["found"] else "NO"
            if m.get("listed_as_stationary"):
                found = "as a stationary target"
            lines.append(
                f"| {m['label']} | ({m['position_m'][0]:.1f}, {m['position_m'][1]:.1f}) | "
                f"({m['velocity_mps'][0]:.1f}, {m['velocity_mps'][1]:.1f}) | "
                f"{m['image_cross_range_m']:.0f} | {m['stationary_phase_rad']:.1f}"
                f"{' (stationary-like)' if m['stationary_phase_rad'] < STATIONARY_LIKE_RAD else ''}"
                f" | {found} | "
                f"{m.get('patches', '-')} | {err} |"
            )
        for f in s["false_movers"]:
            lines.append(
                f"| false | ({f['position_m'][0]:.1f}, {f['position_m'][1]:.1f}) | "
                f"({f['velocity_mps'][0]:.1f}, {f['velocity_mps'][1]:.1f}) | "
                "- | - | - | - | - | - |"
            )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--side", type=float, default=1000.0, help="scene side (m)")
    parser.add_argument("--pulses", type=int, default=4000)
    parser.add_argument("--samples", type=int, default=4000)
    parser.add_argument("--aperture-deg", type=float, default=1.0)
    parser.add_argument(
        "--square-region",
        dest="whole",
        action="store_false",
        help="analyse only the scene's square (--region -L/2 -L/2 L/2 L/2) instead of the "
        "data's whole unambiguous scene, the command's default: movers whose images land "
        "outside the square are then not found",
    )
    parser.add_argument("--density", type=float, default=0.5e-3, help="stationary per m^2")
    parser.add_argument("--movers", type=int, default=10)
    parser.add_argument("--corner", type=int, default=4)
    parser.add_argument("--border", type=int, default=3)
    parser.add_argument("--snr-db", type=float, default=-20.0)
    parser.add_argument("--max-speed", type=float, default=15.0)
    parser.add_argument("--seed", type=int, default=2028)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--no-defocus-search",
        dest="defocus_search",
        action="store_false",
        help="analyse with --no-defocus-search (the patches' default searches their "
        "stationary band)",
    )
    parser.add_argument("--block-pulses", type=int, default=128)
    parser.add_argument("--timeout", type=float, default=MAX_WALL_S + 60.0)
    parser.add_argument("--work", type=Path, required=True, help="folder for the CPHD and output")
    parser.add_argument("--out", type=Path, default=None, help="folder for the results")
    parser.add_argument("--name", default="acceptance_collection")
    parser.add_argument("--reuse", action="store_true", help="keep an existing CPHD file")
    parser.add_argument(
        "--score-only", action="store_true", help="score the previous run's output again"
    )
    parser.add_argument(
        "--generate-only", action="store_true", help="write the CPHD file and its truth only"
    )
    args = parser.parse_args()

    scene, plan, region = build_scene(args)
    args.work.mkdir(parents=True, exist_ok=True)
    path = args.work / "collection.cphd"
    print(f"scene: {scene.acquisition.shape}, {len(plan.patches)} patches", flush=True)
    if (args.reuse or args.score_only) and path.exists():
        generation = json.loads((args.work / "generation.json").read_text())
        kept = json.loads((args.work / "truth.json").read_text())
        if kept["movers"] != json.loads(json.dumps(scene.truth()["movers"])):
            raise SystemExit(
                f"{path} holds another scene (the movers sit on the borders of the plan "
                "of the analysed region, so --whole changes them): generate it again"
            )
    else:
        generation = generate(scene, path, args.block_pulses)
        (args.work / "generation.json").write_text(json.dumps(generation))
    print(json.dumps(generation), flush=True)
    if args.generate_only:
        return
    if args.score_only:
        analysis = json.loads((args.work / "analysis.json").read_text())
    else:
        extra = () if args.defocus_search else ("--no-defocus-search",)
        analysis = analyse(path, args.work / "out", region, args.workers, args.timeout, extra)
        (args.work / "analysis.json").write_text(json.dumps(analysis))
    print(json.dumps({k: v for k, v in analysis.items() if "tail" not in k}), flush=True)
    result = {
        "cores": os.cpu_count(),
        "scene": {
            "side_m": args.side,
            "seed": args.seed,
            "density_per_m2": args.density,
            "snr_db": args.snr_db,
            "n_pulses": scene.n_pulses,
            "n_samples": scene.radar.n_samples,
            "n_stationary": len(scene.stationary),
            "n_movers": len(scene.movers),
            "patches": len(plan.patches),
            "patch_size_m": plan.patch_size_m,
            "aperture_deg": args.aperture_deg,
            "region_m": list(plan.region_m),
        },
        "generation": generation,
        "analysis": analysis,
    }
    results_json = args.work / "out" / "results.json"
    if analysis["exit"] == 0 and results_json.exists():
        doc = json.loads(results_json.read_text())
        result["score"] = score(scene, doc)
        result["timings_s"] = doc.get("timings_s")
    result["criteria"] = criteria(result)
    print(json.dumps(result["criteria"]), flush=True)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / f"{args.name}.json").write_text(json.dumps(result, indent=2) + "\n")
        (args.out / f"{args.name}.md").write_text(markdown(result))


if __name__ == "__main__":
    main()
