"""Null scenes of the look-azimuth benchmark: false movers of a collection without movers.

Run (about 30 s a scene on 2 cores, both rules)::

    python benchmarks/look_azimuth_null.py --seeds 24 --alpha 0.3

Each case is ``benchmarks/look_azimuth.py``'s scene at one look azimuth (the eight of
that benchmark in turn) and its own seed (``--first-seed`` on), without its movers:
unit points, distributed clutter and noise, written as a CPHD with its ``ImageArea``
and cut into patches by the library's plan. Every patch is analysed (in process, the
collection's false-alarm rate ``--alpha``) under two rules for its share of that rate,
on the same traces:

- ``union``: every patch a test of its own (``alpha_p = alpha |H_p| / sum_q |K_q|``,
  the union bound over the patches' reports; the plan's rule before patches holding
  the same echoes were counted once);
- ``grouped``: the plan's (:func:`sarmotion.collection.plan.false_alarm_shares`):
  patches that hold the same echoes (every Doppler, one range window) are one test.

Reported per rule: the share of scenes with at least one false mover (the patches'
reports merged by range history: every mover is false), with its binomial 95 %
interval, against ``alpha``; per scene the patches, their shares and the false movers.
Rows are printed as JSON; the table goes to ``look_azimuth_null.md`` in ``--out``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
import time
from pathlib import Path

from scipy.stats import binomtest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))

import look_azimuth as la  # noqa: E402

import sarmotion.collection.plan as plan_module  # noqa: E402
from sarmotion.collection import CollectionOptions, plan_patches  # noqa: E402
from sarmotion.collection.extract import extract_patches  # noqa: E402
from sarmotion.collection.merge import merge_movers  # noqa: E402
from sarmotion.collection.run import _analysed, analyze_patch  # noqa: E402
from sarmotion.io import open_cphd_blocks, write_cphd_blocks  # noqa: E402
from sarmotion.pipeline import AnalysisOptions  # noqa: E402

AZIMUTHS_DEG = (0.0, 30.0, 45.0, 60.0, 90.0, 135.0, 210.0, 300.0)


def _union_plan(src):
    """The plan with every patch its own test (the union bound over all patches)."""
    grouped = plan_module.false_alarm_shares

    def own(rects, tests, width_m):
        return grouped(rects, [((i,), c, h) for i, (_, c, h) in enumerate(tests)], width_m)

    plan_module.false_alarm_shares = own
    try:
        return plan_patches(src, CollectionOptions())
    finally:
        plan_module.false_alarm_shares = grouped


def run_case(azimuth_deg: float, seed: int, side_m: float, alpha: float) -> list[dict]:
    """Both rules on one null scene; one row each."""
    clutter = int(2000 * max(1.0, side_m / 100))
    sc, square, _ = la.scene(side_m, azimuth_deg, 1.6, clutter, seed)
    sc = dataclasses.replace(sc, movers=())
    options = AnalysisOptions(false_alarm_rate=alpha)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "null.cphd"
        write_cphd_blocks(path, sc, block_pulses=256, image_area_m=square)
        src = open_cphd_blocks(path)
        plans = {"union": _union_plan(src), "grouped": plan_patches(src, CollectionOptions())}
        traces = extract_patches(src, plans["grouped"].patches)
        analysed = _analysed(src, options.sub_aperture_deg)
        for name, plan in plans.items():
            t0 = time.process_time()
            records = []
            for p, tr in zip(plan.patches, traces, strict=True):
                slim, _ = analyze_patch(tr, p, options)
                records += list(slim.movers)
            merged = merge_movers(records, analysed, src.radar.range_resolution_m)
            rows.append(
                {
                    "azimuth_deg": azimuth_deg,
                    "seed": seed,
                    "side_m": side_m,
                    "alpha": alpha,
                    "rule": name,
                    "patches": len(plan.patches),
                    "shares": [round(p.false_alarm_share, 4) for p in plan.patches],
                    "false_movers": len(merged),
                    "cpu_s": round(time.process_time() - t0, 1),
                }
            )
    return rows


def table(rows: list[dict]) -> str:
    """The share of null scenes with a false mover, per rule, against ``alpha``."""
    out = [
        "| rule | alpha | scenes (seeds) | with a false mover | share (95 % interval) "
        "| false movers | patches' shares |",
        "|---|---|---|---|---|---|---|",
    ]
    keys = sorted({(r["rule"], r["alpha"]) for r in rows}, key=lambda k: (k[1], k[0]))
    for rule, alpha in keys:
        sel = [r for r in rows if (r["rule"], r["alpha"]) == (rule, alpha)]
        n, k = len(sel), sum(r["false_movers"] > 0 for r in sel)
        lo, hi = binomtest(k, n).proportion_ci(0.95, method="exact")  # Clopper-Pearson
        shares = [s for r in sel for s in r["shares"]]
        out.append(
            f"| {rule} | {alpha:g} | {n} ({min(r['seed'] for r in sel)}-"
            f"{max(r['seed'] for r in sel)}) | {k} | {k / n:.2f} ({lo:.2f}-{hi:.2f}) "
            f"| {sum(r['false_movers'] for r in sel)} | {min(shares):.2f}-{max(shares):.2f} |"
        )
    return "\n".join(out) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8, help="null scenes (azimuths in turn)")
    parser.add_argument("--first-seed", type=int, default=101)
    parser.add_argument("--side", type=float, default=100.0, help="scene side (m)")
    parser.add_argument("--alpha", type=float, default=0.3, help="collection false-alarm rate")
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args()
    rows = []
    for i in range(args.seeds):
        az = AZIMUTHS_DEG[i % len(AZIMUTHS_DEG)]
        for row in run_case(az, args.first_seed + i, args.side, args.alpha):
            print(json.dumps(row), flush=True)
            rows.append(row)
    args.out.mkdir(parents=True, exist_ok=True)
    store = args.out / "look_azimuth_null.json"
    if store.exists():  # the rows of other rates and sides stay
        kept = json.loads(store.read_text())
        rows = [r for r in kept if (r["alpha"], r["side_m"]) != (args.alpha, args.side)] + rows
    store.write_text(json.dumps(rows, indent=1) + "\n")
    text = (
        "`python benchmarks/look_azimuth_null.py --seeds N --alpha ALPHA` (module notes): "
        "the share of null scenes (100 m, the eight look azimuths in turn; the look-azimuth "
        "benchmark's own scenes use seed 7) where the "
        "collection reports a mover, per rule for the patches' shares of its false-alarm "
        "rate `alpha`.\n\n"
    )
    (args.out / "look_azimuth_null.md").write_text(text + table(rows))
    print(table(rows))


if __name__ == "__main__":
    main()
