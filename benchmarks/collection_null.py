"""Movers declared on real data without known movers, cut into patches: the collection's null.

Run (about 5 min on 2 cores)::

    python benchmarks/collection_null.py --out benchmarks/results

Data: the four real GOTCHA degrees (pass 1 HH; ``$SARMOTION_GOTCHA_DIR`` or
``../shared/data/gotcha``), a parking lot with no mover known to be in it. One analysis
covers them in one piece; here ``sarmotion analyze`` cuts the data's default region (the
unambiguous scene, nothing being declared; its bounding box in the table) into patches
of each ``--patch-sizes`` (m), with
without the defocus search, with it (the default) and with its wide span
(``--wide-defocus-search``), the collection's false-alarm rate 0.01 shared by its
patches. Every mover declared is listed with the evidence that made it (the ``g(u)``
statistic, or the defocus bank's statistic, smear margin and focus gain over the best
stationary point). With ``--region`` the patches cut that region instead.

A declared mover is not proven false: nothing says the lot was still. What the table
shows is how many the analysis declares, where, and on what evidence, as the patching
changes; a mover that is real would be declared under every patching that holds it.

Writes ``collection_null.json`` and ``.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _gotcha_files() -> list[Path]:
    env = os.environ.get("SARMOTION_GOTCHA_DIR")
    for d in ([Path(env)] if env else []) + [ROOT.parent / "shared" / "data" / "gotcha"]:
        files = sorted(d.glob("data_3dsar_pass1_az00*_HH.mat")) if d.is_dir() else []
        if len(files) == 4:
            return files
    return []


def run_one(files: list[Path], patch_size_m: float, defocus: str, region, work: Path) -> dict:
    """One ``sarmotion analyze`` of the patches; its declared movers and wall time.

    ``defocus``: ``"no"``, ``"yes"`` (the default search) or ``"wide"`` (with its wide
    span, ``--wide-defocus-search``).
    """
    out = work / f"p{patch_size_m:g}_{defocus}"
    cmd = [sys.executable, "-m", "sarmotion", "analyze", *map(str, files), "--out", str(out)]
    cmd += ["--patch-size", f"{patch_size_m:g}", "--quiet"]
    cmd.append("--no-defocus-search" if defocus == "no" else "--defocus-search")
    if defocus == "wide":
        cmd.append("--wide-defocus-search")
    if region is not None:
        cmd += ["--region", *(f"{v:g}" for v in region)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {proc.stderr.strip()[-500:]}")
    doc = json.loads((out / "results.json").read_text())
    movers = []
    for m in doc["movers"]:
        det = m.get("detection") or {}
        dfc = det.get("defocus") or {}
        movers.append(
            {
                "patch": m.get("patch"),
                "position_m": m["position_m"][:2],
                "velocity_mps": m["velocity_mps"],
                "range_speed_mps": m.get("range_speed_mps"),
                "cross_range_speed_mps": m.get("cross_range_speed_mps"),
                "snr_db": m.get("snr_db"),
                "g_statistic_db": det.get("statistic_db"),
                "g_threshold_db": det.get("threshold_db"),
                "focus_gain_db": det.get("focus_gain_db"),
                "defocus_statistic_db": dfc.get("statistic_db"),
                "defocus_threshold_db": dfc.get("threshold_db"),
                "smear_margin_db": dfc.get("smear_margin_db"),
            }
        )
    return {
        "patch_size_m": patch_size_m,
        "defocus_search": defocus,
        "region_m": doc["region_m"],
        "patches": len(doc["plan"]["patches"]),
        "movers": movers,
        "wall_s": wall,
        "load_average": os.getloadavg()[0],
    }


def _mode(row: dict) -> str:
    """The row's defocus mode; rows written before the wide span hold a boolean."""
    mode = row["defocus_search"]
    return {True: "yes", False: "no"}.get(mode, mode) if isinstance(mode, bool) else mode


def _f(v, fmt=".1f"):
    return "-" if v is None else format(v, fmt)


def write(rows: list[dict], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "collection_null.json").write_text(json.dumps(rows, indent=1))
    lines = [
        "# Movers declared on the four real GOTCHA degrees cut into patches",
        "",
        "`python benchmarks/collection_null.py` (module notes): default region "
        f"{', '.join(f'{v:.1f}' for v in rows[0]['region_m'])} m; the collection's "
        "false-alarm rate 0.01 shared by its patches.",
        "",
        "| patch side | defocus search | patches | movers declared | wall (load) |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['patch_size_m']:g} m | {_mode(r)} | "
            f"{r['patches']} | {len(r['movers'])} | {r['wall_s']:.0f} s ({r['load_average']:.1f}) |"
        )
    declared = [(r, m) for r in rows for m in r["movers"]]
    if declared:
        lines += [
            "",
            "| patch side | defocus | patch | position (m) | range / cross-range speed (m/s) "
            "| g(u) stat / thr (dB) | defocus stat / thr (dB) | smear margin (dB) "
            "| focus gain (dB) |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for r, m in declared:
            lines.append(
                f"| {r['patch_size_m']:g} m | {_mode(r)} | "
                f"{m['patch']} | ({m['position_m'][0]:.1f}, {m['position_m'][1]:.1f}) | "
                f"{_f(m['range_speed_mps'], '.2f')} / {_f(m['cross_range_speed_mps'], '.2f')} | "
                f"{_f(m['g_statistic_db'])} / {_f(m['g_threshold_db'])} | "
                f"{_f(m['defocus_statistic_db'])} / {_f(m['defocus_threshold_db'])} | "
                f"{_f(m['smear_margin_db'])} | {_f(m['focus_gain_db'])} |"
            )
    (out / "collection_null.md").write_text("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--patch-sizes", type=float, nargs="+", default=[30.0, 40.0, 50.0, 60.0])
    parser.add_argument("--region", type=float, nargs=4, default=None)
    parser.add_argument(
        "--defocus",
        nargs="+",
        choices=["no", "yes", "wide"],
        default=["no", "yes", "wide"],
        help="the defocus search's modes to run: off, the default, with its wide span",
    )
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()
    files = _gotcha_files()
    if not files:
        sys.exit("no GOTCHA files ($SARMOTION_GOTCHA_DIR or ../shared/data/gotcha)")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for size in args.patch_sizes:
            for defocus in args.defocus:
                row = run_one(files, size, defocus, args.region, Path(tmp))
                rows.append(row)
                print(
                    f"{size:g} m, defocus {defocus}: {row['patches']} patches, "
                    f"{len(row['movers'])} movers, {row['wall_s']:.0f} s",
                    flush=True,
                )
    write(rows, args.out)


if __name__ == "__main__":
    main()
