"""Null scenes of the look-azimuth benchmark: false movers of the collection without movers.

Run (about 2 min a scene on 2 cores, both rules)::

    python benchmarks/look_azimuth_null.py --cases 0:101 30:102 45:103 60:104 90:105 \\
        135:106 210:107 300:108

Each case ``AZIMUTH:SEED`` is ``benchmarks/look_azimuth.py``'s 100 m scene at that look
azimuth and seed (8 unit points, 2000 clutter scatterers, noise) without its movers,
written as a CPHD and cut into patches by the library's plan. Every patch is analysed
(in process) under two rules on the same traces:

- ``new``: the plan's (each patch's image its halo, its share of the false-alarm rate,
  :mod:`sarmotion.collection.plan` notes);
- ``old``: the previous rule, each patch's image its core's box and ``alpha / n``.

Reported per case and rule: false movers (every mover is false; the patches' reports
merged by range history), the ``g(u)`` candidates that passed a patch's detector, and
the largest candidate statistic over its threshold (dB; candidates outside the
stationary band and no wider than a point mover's peak). Rows are printed as JSON and
written to ``look_azimuth_null.json`` in ``--out``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))

import look_azimuth as la  # noqa: E402

from sarmotion.collection import CollectionOptions, plan_patches  # noqa: E402
from sarmotion.collection.extract import extract_patches  # noqa: E402
from sarmotion.collection.merge import merge_movers  # noqa: E402
from sarmotion.collection.run import _analysed, analyze_patch  # noqa: E402
from sarmotion.io import open_cphd_blocks, write_cphd_blocks  # noqa: E402
from sarmotion.pipeline import AnalysisOptions  # noqa: E402


def run_case(azimuth_deg: float, seed: int, side_m: float = 100.0) -> list[dict]:
    """Both rules on one null scene; one row each."""
    sc, square, _ = la.scene(side_m, azimuth_deg, 1.6, int(2000 * max(1.0, side_m / 100)), seed)
    sc = dataclasses.replace(sc, movers=())
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "null.cphd"
        write_cphd_blocks(path, sc, block_pulses=256, image_area_m=square)
        src = open_cphd_blocks(path)
        new = plan_patches(src, CollectionOptions())
        n = len(new.patches)
        old_patches = tuple(
            dataclasses.replace(p, halo_m=None, false_alarm_share=1.0 / n) for p in new.patches
        )
        old = dataclasses.replace(new, patches=old_patches)
        traces = extract_patches(src, new.patches)
        analysed = _analysed(src, AnalysisOptions().sub_aperture_deg)
        for name, plan in (("old", old), ("new", new)):
            t0 = time.process_time()
            records, margins, passed = [], [], 0
            for p, tr in zip(plan.patches, traces, strict=True):
                slim, res = analyze_patch(tr, p, AnalysisOptions())
                records += list(slim.movers)
                det = res.detection
                st = det.statistics
                ok = (np.abs(st.speeds_mps) >= det.min_speed_mps) & (
                    st.width_resolutions <= det.max_width
                )
                if ok.any():
                    margins.append(float(np.max(st.statistic_db[ok]) - det.threshold_db))
                passed += int(det.range_speeds.speeds_mps.size)
            merged = merge_movers(records, analysed, src.radar.range_resolution_m)
            rows.append(
                {
                    "azimuth_deg": azimuth_deg,
                    "seed": seed,
                    "rule": name,
                    "patches": n,
                    "false_movers": len(merged),
                    "candidates_passed": passed,
                    "max_statistic_over_threshold_db": max(margins, default=None),
                    "cpu_s": time.process_time() - t0,
                }
            )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=["45:103"], help="AZIMUTH:SEED ...")
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args()
    rows = []
    for case in args.cases:
        az, seed = case.split(":")
        for row in run_case(float(az), int(seed)):
            print(json.dumps(row), flush=True)
            rows.append(row)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "look_azimuth_null.json").write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
