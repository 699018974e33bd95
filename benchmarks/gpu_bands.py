"""Where the time of a GPU exact image in host memory goes: bands, copy and check.

Run with::

    python benchmarks/gpu_bands.py --out gpu_bands.json

Data: the four GOTCHA degrees (``--gotcha DIR``, ``$SARMOTION_GOTCHA_DIR`` or
``../shared/data/gotcha``) or the traces saved by ``benchmarks/bench_gpu.py
--save-traces FILE.npz`` (``--traces FILE.npz``). Grids: ``N x N`` pixels over the
102.4 m square of ``bench_gpu.py``.

Per size, warm, medians of ``--repeats``:

- per most-bands setting ``k`` (:data:`sarmotion.imaging.cuda.MAX_BANDS`; bands of at
  least half the GPU's threads, :func:`~sarmotion.imaging.cuda.row_bands`, except
  ``k = 16``, with no minimum): the device time of the bands' kernels alone (CUDA events)
  and :func:`~sarmotion.imaging.cuda.backproject_cuda` end to end (the complex128 image
  in page-locked host memory, each band copied and checked while the next is computed);
- the copy of a whole device image into a page-locked block (CUDA events) and into fresh
  pageable memory, and the host's finite check of the image
  (:func:`~sarmotion.imaging.grid.all_finite`).

Under numba's CUDA simulator it checks itself (``--sizes 16 --repeats 1``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_gpu import read_traces  # noqa: E402

from sarmotion.core import C  # noqa: E402
from sarmotion.imaging import ImageGrid  # noqa: E402
from sarmotion.imaging import cuda as gpu  # noqa: E402
from sarmotion.imaging._bp_common import make_setup, table_samples  # noqa: E402
from sarmotion.imaging._cuda_host import pool_for  # noqa: E402
from sarmotion.imaging.grid import all_finite  # noqa: E402

SIDE_M = 102.4
BAND_SETTINGS = (1, 2, 3, 4, 6, 8, 16)


def _median_seconds(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _event_seconds(cuda, fn, repeats: int, stream=0) -> float:
    fn()  # warm
    times = []
    for _ in range(repeats):
        start, stop = cuda.event(), cuda.event()
        start.record(stream)
        fn()
        stop.record(stream)
        stop.synchronize()
        times.append(start.elapsed_time(stop) / 1e3)
    return statistics.median(times)


def one_size(cuda, tr, n: int, repeats: int) -> dict:
    """The measurements of one ``n x n`` grid (module docstring)."""
    grid = ImageGrid.square(size_m=SIDE_M, spacing_m=SIDE_M / n)
    gpu.backproject_cuda(tr, grid)  # compiled, table on the device
    table = gpu.device_table(cuda, tr, 8)
    n_table = table_samples(tr.n_samples, 8)
    h = float(tr.radar.sample_interval_s) * tr.n_samples / n_table
    ant = cuda.to_device(gpu._antennas(make_setup(tr, np.zeros(3), 8)))
    carrier = float(tr.radar.carrier_hz)
    p = gpu.rows_per_thread(carrier, SIDE_M / n, n * n, gpu._min_threads(cuda))
    row: dict = {"n": n, "pixels_per_thread": p, "bands": []}
    default = gpu.MAX_BANDS
    try:
        for k in BAND_SETTINGS:
            gpu.MAX_BANDS = k
            floor = gpu._min_threads(cuda) if k <= default else 0
            bands = gpu.row_bands(n, n, p, gpu.BLOCK_ROWS, floor)
            launches = [gpu._launch_exact(cuda, table, n_table, ant, grid.x_m, grid.y_m[a:b],
                                          2.0 / (C * h), 2.0 * carrier / C, p)
                        for a, b in bands]  # fmt: skip

            def kernels(launches=launches):
                for kernel, args in launches:
                    kernel(table, *args)

            gpu.MAX_BANDS = len(bands)
            gpu.backproject_cuda(tr, grid)
            row["bands"].append({
                "most_bands": k, "bands": len(bands),
                "kernels_seconds": _event_seconds(cuda, kernels, repeats),
                "end_to_end_seconds": _median_seconds(lambda: gpu.backproject_cuda(tr, grid),
                                                      repeats),
            })  # fmt: skip
            print(f"{n}^2, {len(bands)} bands: {row['bands'][-1]}", flush=True)
    finally:
        gpu.MAX_BANDS = default
    image = cuda.device_array((n, n, 2), np.float64)
    host = pool_for(cuda).empty((n, n), np.complex128)
    parts = host.view(np.float64).reshape(n, n, 2)
    stream = cuda.stream()
    row["copy_page_locked_seconds"] = _event_seconds(
        cuda, lambda: image.copy_to_host(parts, stream=stream), repeats, stream
    )
    row["copy_pageable_seconds"] = _median_seconds(lambda: image.copy_to_host(), repeats)
    row["finite_check_seconds"] = _median_seconds(lambda: all_finite(host), repeats)
    print(f"{n}^2: copy page-locked {row['copy_page_locked_seconds'] * 1e3:.2f} ms, pageable "
          f"{row['copy_pageable_seconds'] * 1e3:.2f} ms, finite check "
          f"{row['finite_check_seconds'] * 1e3:.2f} ms", flush=True)  # fmt: skip
    return row


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gotcha", default=None)
    ap.add_argument("--traces", type=Path, default=None)
    ap.add_argument("--sizes", type=int, nargs="+", default=[2048, 4096])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    tr = read_traces(args.traces, args.gotcha)
    cuda = gpu._cuda()
    if not cuda.is_available():
        sys.exit(gpu.NEEDS)
    sim = os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
    device = "CUDA simulator" if sim else cuda.get_current_device().name
    result = {"device": device.decode() if isinstance(device, bytes) else str(device),
              "sizes": [one_size(cuda, tr, n, args.repeats) for n in args.sizes]}  # fmt: skip
    if args.out is not None:
        args.out.write_text(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
