"""The g(u) detector, the coherent detector and the clairvoyant bound on the same scenes.

Regenerate the table (in parts, each under 10 min on 2 loaded cores)::

    python benchmarks/coherent_detection.py --part 0 --parts 3 --records /tmp/cd0.json
    python benchmarks/coherent_detection.py --part 1 --parts 3 --records /tmp/cd1.json
    python benchmarks/coherent_detection.py --part 2 --parts 3 --records /tmp/cd2.json
    python benchmarks/coherent_detection.py --from-records /tmp/cd?.json --out benchmarks/results

The scenes are those of ``benchmarks/movers_accuracy.py`` (same seed, default 2026, and
draws). For each, in the same run and on the same separation:

``g(u)``        the analysis with default options (``detect`` and ``estimate_movers``);
``coherent``    the same with ``AnalysisOptions(detector="coherent")``
                (:mod:`sarmotion.motion.coherent`): the ``g(u)`` screen at its null's
                per-candidate 10 % point, then each fit's likelihood ratio against the
                threshold of the same per-scene false-alarm rate (1 %);
``clairvoyant``  on simulated scenes only: the matched filter at each mover's *true*
                parameters on the data with the simulated clutter removed exactly
                (movers and noise left), over the exact noise level, against
                ``10 log10(ln(1 / alpha))`` (:func:`sarmotion.motion.clairvoyant_threshold_db`).

Scoring is that of ``movers_accuracy.py`` (a detection is an estimate matched to the
mover in range speed and range position; an unmatched estimate is a false mover).
``strength`` is the mover's reflectivity over the median per-pulse peak of ``|M|`` (dB).
The table gives P_d by strength bin for the three, per population (simulated point
clutter, real GOTCHA clutter), the strength beyond which each keeps P_d >= 0.5 (linear
interpolation between bins), and the false movers over all scenes.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import movers_accuracy as ma  # noqa: E402

#: Per-scene false-alarm rate of every detector compared.
ALPHA = 0.01
EDGES = [-40, -24, -20, -16, -12, -8, -4, 10]


def _estimates(movers) -> list[dict]:
    return [
        {
            "position_m": m.fit.position_m,
            "velocity_mps": m.fit.velocity_mps,
            "coherent_db": m.evidence.coherent_statistic_db,
        }
        for m in movers
    ]


def clairvoyant(traces, movers, clutter) -> list[float]:
    """``Lambda`` (dB) of each mover at its true parameters, clutter removed exactly."""
    from sarmotion.motion import MatchedFilter, matched_filter_variance
    from sarmotion.simulation import inject

    clean = traces.with_data(np.asarray(traces.data) - clutter)
    alone = inject(traces.with_data(np.zeros(traces.shape, dtype=complex)), movers).data
    sigma2 = float(np.mean(np.abs(clean.data - alone) ** 2))  # the noise, known exactly
    var = matched_filter_variance(traces.acquisition, sigma2)
    mf = MatchedFilter(clean)
    pos = np.array([m.position_m for m in movers], dtype=float)
    vel = np.array([m.velocity_mps[:2] for m in movers], dtype=float)
    values = mf.responses(pos, vel)
    return [float(10 * np.log10(abs(v) ** 2 / var)) for v in values]


def run_one(spec: ma.Spec) -> dict:
    from sarmotion.core import range_speed
    from sarmotion.motion import clairvoyant_threshold_db
    from sarmotion.pipeline import AnalysisOptions, detect, estimate_movers
    from sarmotion.pipeline.detection import find_range_speeds
    from sarmotion.separation import SeparationOptions

    traces, movers, method, info, clutter = ma.make_scene(spec, with_clutter=True)
    ref = float(np.median(np.abs(traces.data).max(axis=1)))
    opts = AnalysisOptions(separation=SeparationOptions(method=method), trajectory=False)
    t0 = time.perf_counter()
    found = detect(traces, opts)
    t1 = time.perf_counter()
    est_g = _estimates(estimate_movers(found).movers)
    t2 = time.perf_counter()
    coh_opts = dataclasses.replace(found.options, detector="coherent")
    screen = find_range_speeds(
        np.asarray(found.moving_sub), coh_opts, acquisition=found.sub.acquisition
    )
    est_c = _estimates(
        estimate_movers(dataclasses.replace(found, options=coh_opts, candidates=screen)).movers
    )
    t3 = time.perf_counter()
    sub = found.sub
    m_g, false_g = ma.score(sub, movers, est_g)
    m_c, false_c = ma.score(sub, movers, est_c)
    whole = found.whole_aperture
    clair = clairvoyant(traces, movers, clutter) if clutter is not None and movers else None
    thr = clairvoyant_threshold_db(ALPHA)
    geom = sub.geometry
    truth = []
    for i, m in enumerate(movers):
        truth.append(
            {
                "u": range_speed(m.velocity_mps, geom),
                "strength_db": float(20 * np.log10(abs(m.reflectivity) / ref)),
                "g": i in m_g,
                "coherent": i in m_c,
                "coherent_db": est_c[m_c[i]["estimate"]]["coherent_db"] if i in m_c else None,
                "clairvoyant_db": None if clair is None else clair[i],
                "clairvoyant": None if clair is None else bool(clair[i] >= thr),
            }
        )
    return {
        "kind": spec.kind,
        "seed": spec.seed,
        "method": method,
        "simulated": clutter is not None,
        "whole_aperture": whole,
        "movers": truth,
        "false_g": false_g,
        "false_coherent": false_c,
        "screen_candidates": int(screen.range_speeds.n_movers),
        "seconds": {"detect": t1 - t0, "g": t2 - t1, "coherent": t3 - t2},
    }


def _pd(sel: list[dict], who: str) -> float:
    vals = [m[who] for m in sel if m[who] is not None]
    return float(np.mean(vals)) if vals else float("nan")


def _half_point(movers: list[dict], who: str) -> float:
    """Strength (dB) beyond which P_d stays >= 0.5: its last upward crossing of 0.5.

    Interpolated between bin centres; the last crossing, not the first, so that a bin of
    a few movers that happen to be found below it does not count.
    """
    cen, pd = [], []
    for lo, hi in zip(EDGES[:-1], EDGES[1:], strict=True):
        sel = [m for m in movers if lo <= m["strength_db"] < hi and m[who] is not None]
        if sel:
            cen.append(0.5 * (lo + hi))
            pd.append(np.mean([m[who] for m in sel]))
    if pd and min(pd) >= 0.5:
        return -np.inf  # already at the weakest bin
    for k in reversed(range(len(pd) - 1)):
        if pd[k] < 0.5 <= pd[k + 1]:
            return float(cen[k] + (0.5 - pd[k]) * (cen[k + 1] - cen[k]) / (pd[k + 1] - pd[k]))
    return float("nan")


def write(records: list[dict], out: Path, seconds: float) -> None:
    from sarmotion.motion import COHERENT_NULL_TAIL, clairvoyant_threshold_db, screen_threshold_db

    out.mkdir(parents=True, exist_ok=True)
    (out / "coherent_detection.json").write_text(json.dumps(records, indent=1, default=float))
    movers = [m | {"kind": r["kind"], "sim": r["simulated"]} for r in records for m in r["movers"]]
    sim = [m for m in movers if m["sim"]]
    real = [m for m in movers if not m["sim"]]
    t = COHERENT_NULL_TAIL
    lines = [
        f"{len(records)} one-degree scenes of benchmarks/movers_accuracy.py (seed 2026), "
        f"{len(movers)} movers ({len(sim)} in simulated point clutter, {len(real)} in real "
        f"GOTCHA clutter); per-scene false-alarm rate {ALPHA:g} for every detector. "
        f"Coherent: screen {screen_threshold_db():.2f} dB on g(u), then the fit's likelihood "
        f"ratio over t0 + s ln(p0 N / alpha) with COHERENT_NULL_TAIL t0 = {t['t0_db']} dB, "
        f"s = {t['scale_db']} dB; clairvoyant: {clairvoyant_threshold_db(ALPHA):.2f} dB at the "
        f"true parameters, clutter removed exactly (simulated scenes only).",
        "",
        "| | g(u) | coherent |",
        "|---|---|---|",
        f"| movers detected | {sum(m['g'] for m in movers)} / {len(movers)} | "
        f"{sum(m['coherent'] for m in movers)} / {len(movers)} |",
        f"| false movers, all {len(records)} scenes | {sum(r['false_g'] for r in records)} | "
        f"{sum(r['false_coherent'] for r in records)} |",
        f"| false movers, scenes without movers | "
        f"{sum(r['false_g'] for r in records if not r['movers'])} | "
        f"{sum(r['false_coherent'] for r in records if not r['movers'])} |",
        "",
        "P_d by strength (dB re the median per-pulse peak of |M|):",
        "",
        "| strength (dB) | movers | g(u) | coherent | simulated movers | g(u) | coherent "
        "| clairvoyant | real movers | g(u) | coherent |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    f = lambda v: "-" if np.isnan(v) else f"{v:.2f}"  # noqa: E731
    for lo, hi in zip(EDGES[:-1], EDGES[1:], strict=True):
        a = [m for m in movers if lo <= m["strength_db"] < hi]
        s = [m for m in a if m["sim"]]
        r = [m for m in a if not m["sim"]]
        if a:
            lines.append(
                f"| [{lo}, {hi}) | {len(a)} | {f(_pd(a, 'g'))} | {f(_pd(a, 'coherent'))} | "
                f"{len(s)} | {f(_pd(s, 'g'))} | {f(_pd(s, 'coherent'))} | "
                f"{f(_pd(s, 'clairvoyant'))} | {len(r)} | {f(_pd(r, 'g'))} | "
                f"{f(_pd(r, 'coherent'))} |"
            )

    def hp(ms: list[dict], who: str) -> str:
        v = _half_point(ms, who)
        if np.isnan(v):
            return "-"
        if np.isinf(v):  # P_d >= 0.5 already in the weakest bin with movers
            lo = max(e for e in EDGES if e <= min(m["strength_db"] for m in ms))
            hi = EDGES[EDGES.index(lo) + 1]
            return f"<= {0.5 * (lo + hi):.0f}"
        return f"{v:.1f}"

    lines += [
        "",
        "Strength beyond which P_d stays >= 0.5 (dB, interpolated between bin centres; "
        "'-': not reached; "
        "'<= x': reached at the centre x of the weakest bin):",
        "",
        "| population | g(u) | coherent | clairvoyant |",
        "|---|---|---|---|",
        f"| simulated point clutter | {hp(sim, 'g')} | {hp(sim, 'coherent')} | "
        f"{hp(sim, 'clairvoyant')} |",
        f"| real GOTCHA clutter | {hp(real, 'g')} | {hp(real, 'coherent')} | - |",
        "",
        "By scene kind (detected g(u) / coherent; false movers g(u) / coherent):",
        "",
        "| kind | scenes | movers | detected | false movers |",
        "|---|---|---|---|---|",
    ]
    for kind in ("clutter", "real", "slow", "pairs", "null_real", "null_sim"):
        rs = [r for r in records if r["kind"] == kind]
        if rs:
            ms = [m for r in rs for m in r["movers"]]
            lines.append(
                f"| {kind} | {len(rs)} | {len(ms)} | {sum(m['g'] for m in ms)} / "
                f"{sum(m['coherent'] for m in ms)} | {sum(r['false_g'] for r in rs)} / "
                f"{sum(r['false_coherent'] for r in rs)} |"
            )
    sec = {k: np.mean([r["seconds"][k] for r in records]) for k in ("detect", "g", "coherent")}
    lines += [
        "",
        f"Mean time per scene: detection (separation) {sec['detect']:.1f} s, g(u) mover stage "
        f"{sec['g']:.1f} s, coherent mover stage {sec['coherent']:.1f} s; mean screened "
        f"candidates {np.mean([r['screen_candidates'] for r in records]):.1f} per scene. "
        + ("" if np.isnan(seconds) else f"{seconds / 60:.1f} min."),
    ]
    (out / "coherent_detection.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--part", type=int, default=0)
    ap.add_argument("--parts", type=int, default=1)
    ap.add_argument("--kinds", default=None, help="comma-separated scene kinds (default all)")
    ap.add_argument("--records", type=Path, help="write this part's records here")
    ap.add_argument("--from-records", type=Path, nargs="+", help="write the table from parts")
    args = ap.parse_args()
    if args.from_records:
        records = [r for p in args.from_records for r in json.loads(p.read_text())]
        records.sort(key=lambda r: r["seed"])
        write(records, args.out, float("nan"))
        return
    specs = ma.scene_specs(args.seed, False)
    if args.kinds:
        specs = [s for s in specs if s.kind in args.kinds.split(",")]
    specs = specs[args.part :: args.parts]
    start = time.perf_counter()
    records = []
    with Pool(args.workers) as pool:
        for k, rec in enumerate(pool.imap_unordered(run_one, specs)):
            records.append(rec)
            ms = rec["movers"]
            print(
                f"[{k + 1}/{len(specs)}] {rec['kind']} seed {rec['seed']}: "
                f"g {sum(m['g'] for m in ms)}/{len(ms)} ({rec['false_g']} false), "
                f"coherent {sum(m['coherent'] for m in ms)} "
                f"({rec['false_coherent']} false), clairvoyant "
                f"{sum(bool(m['clairvoyant']) for m in ms)}; {sum(rec['seconds'].values()):.0f} s",
                flush=True,
            )
    records.sort(key=lambda r: r["seed"])
    if args.records:
        args.records.write_text(json.dumps(records, indent=1, default=float))
    if args.parts == 1:
        write(records, args.out, time.perf_counter() - start)


if __name__ == "__main__":
    main()
