"""``analyze`` on the GPU against the CPU: the same movers from the 4 GOTCHA degrees.

Run with::

    python benchmarks/gpu_analyze.py --out gpu_analyze.json

Data: the four GOTCHA degrees (469 pulses x 424 samples; ``--gotcha DIR``,
``$SARMOTION_GOTCHA_DIR`` or ``../shared/data/gotcha``) or the same traces saved by
``benchmarks/bench_gpu.py --save-traces FILE.npz`` and read back with ``--traces FILE.npz``
(for a machine where :mod:`sarmotion.io` cannot be imported), with the two movers that
``benchmarks/bench_analyze.py`` injects (8 and 12 dB under the median per-pulse peak).

The analysis runs with default options on ``device="cpu"`` and on ``device="cuda"``
(every image of the analysis backprojected on the GPU, :mod:`sarmotion.imaging.cuda`),
each twice (the first run compiles; the second is timed warm). Reported per device: wall
time per stage, each mover's range position, range speed and cross-range speed with their
standard errors (Cramér–Rao bound), and, between the devices, each mover's differences in
units of its standard errors and the signal-to-error of the GPU's stationary and
preliminary images against the CPU's. The movers agree when the devices give as many
movers and each difference is under ``--tolerance-sigma`` standard errors.

Under numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``) the script runs too, slowly:
``--pulses`` and ``--image-size`` shrink the analysis for a check of the script itself.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_analyze import gotcha_two_movers  # noqa: E402
from bench_gpu import _ser_db, _version, read_traces  # noqa: E402

from sarmotion.core import Traces  # noqa: E402
from sarmotion.pipeline import AnalysisOptions, analyze  # noqa: E402


def _movers(result) -> list[dict]:
    geom = result.traces.geometry
    ref = np.asarray(result.traces.reference_point_m, dtype=np.float64)
    out = []
    for m in result.movers:
        b = m.bound
        offset = np.zeros(3)
        offset[:2] = np.asarray(m.position_m[:2]) - ref[:2]
        out.append({
            "position_m": [float(v) for v in m.position_m[:2]],
            "velocity_mps": [float(v) for v in m.velocity_mps[:2]],
            "range_position_m": float(offset @ geom.m_o),
            "range_speed_mps": float(m.range_speed_mps),
            "cross_range_speed_mps": float(m.cross_range_speed_mps),
            "std": {"range_position_m": b.range_position_m, "range_speed_mps": b.range_speed_mps,
                    "cross_range_speed_mps": b.cross_range_speed_mps},
            "statistic_db": float(m.evidence.statistic_db),
        })  # fmt: skip
    return out


def _run(traces: Traces, options: AnalysisOptions) -> tuple[object, float, dict]:
    t0 = time.perf_counter()
    result = analyze(traces, options)
    return result, time.perf_counter() - t0, dict(result.timings_s)


def compare(cpu: list[dict], gpu: list[dict]) -> list[dict]:
    """Each GPU mover's differences from the CPU's, in the CPU's standard errors."""
    rows = []
    for c, g in zip(cpu, gpu, strict=False):
        rows.append({
            key: (g[key] - c[key]) / c["std"][key]
            for key in ("range_position_m", "range_speed_mps", "cross_range_speed_mps")
        })  # fmt: skip
    return rows


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gotcha", default=None)
    ap.add_argument("--traces", type=Path, default=None)
    ap.add_argument("--pulses", type=int, default=None, help="first N pulses only")
    ap.add_argument("--image-size", type=float, default=None, help="image side (m)")
    ap.add_argument("--tolerance-sigma", type=float, default=0.1)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)

    base = read_traces(args.traces, args.gotcha)
    if args.pulses:
        base = base.select_pulses(0, args.pulses)
    traces = gotcha_two_movers(base)
    extra = {} if args.image_size is None else {"image_size_m": args.image_size}

    report: dict = {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": _version("numba"),
        "numba_cuda": _version("numba-cuda"),
        "pulses": traces.n_pulses,
        "samples": traces.n_samples,
        "load_average_1min": os.getloadavg()[0],
        "devices": {},
    }
    results = {}
    for device in ("cpu", "cuda"):
        options = AnalysisOptions(device=device, **extra)
        _, cold, _ = _run(traces, options)
        result, warm, stages = _run(traces, options)
        results[device] = result
        report["devices"][device] = {
            "cold_seconds": cold, "warm_seconds": warm, "stages_s": stages,
            "movers": _movers(result),
        }  # fmt: skip
        print(f"{device}: cold {cold:.2f} s, warm {warm:.2f} s, {len(result.movers)} movers",
              flush=True)  # fmt: skip
        for m in report["devices"][device]["movers"]:
            print(f"  range {m['range_position_m']:+.4f} m, range speed "
                  f"{m['range_speed_mps']:+.4f} m/s, cross-range {m['cross_range_speed_mps']:+.4f}"
                  f" m/s, {m['statistic_db']:.1f} dB", flush=True)  # fmt: skip
    cpu, gpu = report["devices"]["cpu"]["movers"], report["devices"]["cuda"]["movers"]
    diffs = compare(cpu, gpu)
    worst = max((abs(v) for d in diffs for v in d.values()), default=0.0)
    report["differences_sigma"] = diffs
    report["same_movers"] = len(cpu) == len(gpu) and worst <= args.tolerance_sigma
    for name in ("stationary_image", "preliminary_image"):
        ref = getattr(results["cpu"], name).values
        report[f"{name}_ser_db"] = _ser_db(ref, getattr(results["cuda"], name).values)
    print(f"same movers: {report['same_movers']} (worst {worst:.3g} sigma); stationary image "
          f"{report['stationary_image_ser_db']:.1f} dB, preliminary "
          f"{report['preliminary_image_ser_db']:.1f} dB (GPU against CPU)", flush=True)  # fmt: skip
    if args.out is not None:
        args.out.write_text(json.dumps(report, indent=1))
    return report


if __name__ == "__main__":
    main()
