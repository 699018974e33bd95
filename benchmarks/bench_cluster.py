"""What a Dask cluster costs a collection per patch: the task overhead and the traces' transfer.

Run (about a minute on 2 cores)::

    python benchmarks/bench_cluster.py --out benchmarks/results

A collection sends each patch's traces to a worker as a task's argument
(``collection.run``: the workers never open the input file) and gets back the patch's
answers. On a cluster of worker *processes* (``--scheduler``, or local processes as
``sarmotion track --processes`` starts them, ``_cluster.local_cluster``: TLS on loopback)
that costs, per patch, the scheduler's round trip plus the traces' serialisation and
transfer. This benchmark measures both, on the project's own local cluster of 2 worker
processes, with tasks that do no work:

- the round trip of an empty task (``submit`` to ``result``), sequential: the latency a
  patch waits on before its work starts;
- the throughput of ``--tasks`` empty tasks submitted at once: what the scheduler
  sustains, the overhead a cluster of many workers would see per patch;
- a task carrying a patch's :class:`~sarmotion.core.Traces` of ``n`` pulses by ``m``
  samples (complex64, ``8 n m`` bytes) and returning a number: seconds per task and per
  MB, for the patch sizes of ``--patch-shapes``.

Compared with a patch's analysis (seconds to minutes, ``bench_collection.py``), the
overhead says how many workers a cluster can keep busy: the scheduler sustains about
``1 / overhead`` tasks a second, so ``W`` workers stay busy while a patch's analysis
takes more than ``W x overhead``. The rows go to ``bench_cluster.json`` and the table
``bench_cluster.md`` in ``--out``, with the load average (the figures are upper bounds on
a busy machine).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np


def _traces(n_pulses: int, n_samples: int):
    """Random traces of that shape on a 2-degree GOTCHA-like arc (the payload of a patch)."""
    from dataclasses import replace

    from sarmotion.core import Radar, Traces, Trajectory

    radar = replace(Radar(), n_samples=n_samples)
    trajectory = Trajectory.circular(n_pulses=n_pulses, aperture_deg=2.0)
    rng = np.random.default_rng(0)
    shape = (n_pulses, n_samples)
    data = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)).astype(np.complex64)
    return Traces(data=data, radar=radar, trajectory=trajectory, reference_point_m=np.zeros(3))


def _nothing(*_args) -> int:
    return 0


def _size(traces) -> float:
    return float(traces.data.shape[0])


def _timed(fn, repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def run(tasks: int, repeats: int, shapes: list[tuple[int, int]]) -> dict:
    import logging
    import warnings

    from distributed import Client, wait

    logging.getLogger("distributed").setLevel(logging.WARNING)
    # a task's traces are its argument by design (the workers never open the input)
    warnings.filterwarnings("ignore", message="Sending large graph")

    from sarmotion._cluster import local_cluster

    rows: dict = {"load_before": os.getloadavg()[0], "workers": 2, "transfers": []}
    with local_cluster(2, processes=True) as cluster, Client(cluster) as client:
        client.submit(_nothing, pure=False).result()  # workers up and connected
        rows["round_trip_s"] = _timed(lambda: client.submit(_nothing, pure=False).result(), repeats)

        def burst() -> None:
            wait(client.map(_nothing, range(tasks), pure=False))

        rows["burst_s"] = _timed(burst, 3)
        for n, m in shapes:
            tr = _traces(n, m)
            mb = tr.data.nbytes / 1e6
            times = _timed(lambda tr=tr: client.submit(_size, tr, pure=False).result(), repeats)
            rows["transfers"].append({"pulses": n, "samples": m, "mb": mb, "seconds": times})
    rows["load_after"] = os.getloadavg()[0]
    rows["tasks"] = tasks
    return rows


def _per_mb(rows: dict) -> tuple[float, float]:
    """``(ms per MB, ms at 0 MB)``: the least-squares line through the transfers' medians."""
    mb = np.array([r["mb"] for r in rows["transfers"]])
    ms = np.array([np.median(r["seconds"]) * 1e3 for r in rows["transfers"]])
    slope, intercept = np.polyfit(mb, ms, 1)
    return float(slope), float(intercept)


def table(rows: dict) -> str:
    rt = np.array(rows["round_trip_s"]) * 1e3
    burst = np.array(rows["burst_s"]) / rows["tasks"] * 1e3
    lines = [
        "# The task overhead of a cluster of worker processes (bench_cluster.py)",
        "",
        "    python benchmarks/bench_cluster.py --out benchmarks/results",
        "",
        f"Two local worker processes (TLS on loopback, `_cluster.local_cluster`), load average "
        f"{rows['load_before']:.1f} before and {rows['load_after']:.1f} after (other work on "
        "the 2-core machine: upper bounds). Minimum / median / maximum over the repeats.",
        "",
        "| what | min | median | max |",
        "|---|---:|---:|---:|",
        f"| empty task, round trip (ms) | {rt.min():.1f} | {np.median(rt):.1f} | {rt.max():.1f} |",
        f"| {rows['tasks']} empty tasks at once, per task (ms) | {burst.min():.2f} | "
        f"{np.median(burst):.2f} | {burst.max():.2f} |",
    ]
    for r in rows["transfers"]:
        t = np.array(r["seconds"]) * 1e3
        lines.append(
            f"| a patch's traces, {r['pulses']} x {r['samples']} ({r['mb']:.1f} MB), "
            "round trip (ms) "
            f"| {t.min():.1f} | {np.median(t):.1f} | {t.max():.1f} |"
        )
    lines += [
        "",
        "The transfers' medians against their size (least squares): {:.1f} ms per MB of traces "
        "plus {:.1f} ms a task.".format(*_per_mb(rows)),
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", type=int, default=200, help="empty tasks in a burst")
    parser.add_argument("--repeats", type=int, default=20, help="repeats of each round trip")
    parser.add_argument(
        "--patch-shapes",
        nargs="+",
        default=["250x630", "1324x630", "3400x1300"],
        help="patch traces as PULSESxSAMPLES (defaults: a short patch, the 400 m file's at "
        "1.7 x its scene's pulse rate, a 1 km^2 file's at decimation 1)",
    )
    parser.add_argument("--out", type=Path, required=True, help="folder for the json and md")
    args = parser.parse_args()
    shapes = [tuple(int(v) for v in s.lower().split("x")) for s in args.patch_shapes]
    rows = run(args.tasks, args.repeats, shapes)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench_cluster.json").write_text(json.dumps(rows, indent=1))
    text = table(rows)
    (args.out / "bench_cluster.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
