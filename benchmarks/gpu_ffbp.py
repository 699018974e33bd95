"""FFBP on the GPU (:mod:`sarmotion.imaging.cuda_ffbp`): accuracy and time in one run.

Run with::

    python benchmarks/gpu_ffbp.py --out gpu_ffbp.json

Data: the four GOTCHA degrees (469 pulses x 424 samples; ``--gotcha DIR``,
``$SARMOTION_GOTCHA_DIR`` or ``../shared/data/gotcha``) or the traces saved by
``benchmarks/bench_gpu.py --save-traces FILE.npz`` (``--traces FILE.npz``), as collected
(0 degrees, looking along ``x``) and turned by 45 degrees about the reference point.
Grids: ``N x N`` pixels over a 51.2 m square about the scene centre. Under numba's CUDA
simulator the script checks itself at tiny sizes (``--pulses 2 --sizes 16 --looks 0``).

Reported, warm, median of ``--repeats``:

- ``table``: the trace table built on the GPU (:mod:`sarmotion.imaging._cuda_table`)
  against the host's (:func:`~sarmotion.imaging.cuda.hermite_table`, float64 FFTs): the
  largest error of a value and of a derivative over ``sum_k |P_jk| / n`` per pulse (its
  bound is :func:`~sarmotion.imaging._cuda_table.entry_error`), and both build times;
- per look and size: FFBP on the GPU, exact backprojection on the GPU and FFBP on the
  CPU (all threads), end to end (the complex128 image in host memory), with their
  signal-to-error against the exact sum (:func:`~sarmotion.imaging.point_response`) on
  ``--reference-pixels`` seeded pixels and FFBP's path and error budget; and the GPU's
  device time: the exact kernel, and FFBP's tree (every level's leaves and merges,
  CUDA events around :meth:`~sarmotion.imaging.cuda_ffbp.CudaKernels.run_levels`).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent / "tests")]
from bench_gpu import _device_run, _ser_db, read_traces  # noqa: E402

from sarmotion.imaging import ImageGrid, backproject, point_response  # noqa: E402
from sarmotion.imaging import cuda as gpu  # noqa: E402
from turned import turned  # noqa: E402

SIDE_M = 51.2


def _median(fn, repeats: int):
    fn()
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def table_check(cuda, tr) -> dict:
    """The device-built table against the host's, per pulse, and both build times."""
    from sarmotion.imaging._cuda_table import build_table, entry_error

    data = np.ascontiguousarray(tr.data)
    host = gpu.hermite_table(data, 8).astype(np.float64)

    def on_device():
        out = build_table(cuda, data, 8)
        cuda.synchronize()
        return out

    t_dev, dev = _median(on_device, 3)
    t_host, _ = _median(lambda: gpu.hermite_table(data, 8), 3)
    dev = dev.copy_to_host().view(np.float32).reshape(host.shape).astype(np.float64)
    spec = np.fft.fftshift(np.fft.fft(np.fft.ifftshift(data, axes=-1), axis=-1), axes=-1)
    s_j = np.sum(np.abs(spec), axis=1) / data.shape[1]
    err_v = np.max(np.abs(dev[..., :2] - host[..., :2]), axis=(1, 2)) / s_j
    err_d = np.max(np.abs(dev[..., 2:] - host[..., 2:]), axis=(1, 2)) / s_j
    return {"device_seconds": t_dev, "host_seconds": t_host, "max_error_value": float(err_v.max()),
            "max_error_derivative": float(err_d.max()), "bound": entry_error()}  # fmt: skip


def tree_device_seconds(cuda, tr, grid, repeats: int) -> float | None:
    """Median device time of FFBP's tree on the GPU (CUDA events), None if not factorised."""
    from sarmotion.imaging import cuda_ffbp

    kernels = cuda_ffbp._kernels_for(cuda)
    run_levels = kernels.run_levels
    times: list[float] = []

    def timed(*args):
        start, stop = cuda.event(), cuda.event()
        start.record()
        planes = run_levels(*args)
        stop.record()
        stop.synchronize()
        times.append(start.elapsed_time(stop) / 1e3)
        return planes

    kernels.run_levels = timed
    try:
        for _ in range(repeats + 1):
            gpu.backproject_cuda(tr, grid, method="ffbp")
    finally:
        del kernels.run_levels
    return statistics.median(times[1:]) if len(times) > 1 else None


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gotcha", default=None)
    ap.add_argument("--traces", type=Path, default=None)
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048, 4096])
    ap.add_argument("--pulses", type=int, default=None, help="the first pulses only")
    ap.add_argument("--looks", type=float, nargs="+", default=[0.0, 45.0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--reference-pixels", type=int, default=4096)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    tr0 = read_traces(args.traces, args.gotcha)
    if args.pulses:
        tr0 = tr0.select_pulses(0, args.pulses)
    cuda = gpu._cuda()
    if not cuda.is_available():
        sys.exit(gpu.NEEDS)
    sim = os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
    device = "CUDA simulator" if sim else cuda.get_current_device().name
    device = device.decode() if isinstance(device, bytes) else str(device)
    result: dict = {"device": device, "pulses": tr0.n_pulses, "samples": tr0.n_samples,
                    "side_m": SIDE_M, "load_average_1min": os.getloadavg()[0]}  # fmt: skip
    result["table"] = table_check(cuda, tr0)
    print(f"{device}: table {result['table']}", flush=True)
    rng = np.random.default_rng(20261127)
    result["images"] = []
    for deg in args.looks:
        tr = turned(tr0, deg) if deg else tr0
        for n in args.sizes:
            grid = ImageGrid.square(size_m=SIDE_M, spacing_m=SIDE_M / n)
            work = n * n * tr.n_pulses
            k = min(args.reference_pixels, n * n)
            iy, ix = np.unravel_index(rng.choice(n * n, size=k, replace=False), (n, n))
            exact = point_response(tr, np.stack([grid.x_m[ix], grid.y_m[iy], np.zeros(k)], 1))
            row: dict = {"look_deg": deg, "n": n}
            for name, fn in (
                ("gpu_ffbp", lambda g=grid, t=tr: gpu.backproject_cuda(t, g, method="ffbp")),
                ("gpu_exact", lambda g=grid, t=tr: gpu.backproject_cuda(t, g)),
                ("cpu_ffbp", lambda g=grid, t=tr: backproject(t, g, method="ffbp")),
            ):
                seconds, img = _median(fn, args.repeats)
                info = img.metadata.get("ffbp", {})
                row[name] = {"seconds": seconds, "pixel_pulses_per_second": work / seconds,
                             "ser_db": _ser_db(exact, img.values[iy, ix]),
                             "path": info.get("path"),
                             "budget_db": info.get("budget_db")}  # fmt: skip
            med, _, _, _ = _device_run(cuda, tr, grid, None, gpu.BLOCK_ROWS, args.repeats)
            row["gpu_exact_device_seconds"] = med
            row["gpu_ffbp_tree_device_seconds"] = tree_device_seconds(cuda, tr, grid, args.repeats)
            tree = row["gpu_ffbp_tree_device_seconds"] or math.nan
            parts = [f"{name} {row[name]['pixel_pulses_per_second']:.3g} px-pulses/s "
                     f"{row[name]['ser_db']:.1f} dB ({row[name]['path']})"
                     for name in ("gpu_ffbp", "gpu_exact", "cpu_ffbp")]  # fmt: skip
            print(f"{deg:g} deg {n}^2: {', '.join(parts)}; device: exact {med * 1e3:.2f} ms, "
                  f"FFBP tree {tree * 1e3:.2f} ms", flush=True)  # fmt: skip
            result["images"].append(row)
            if args.out is not None:
                args.out.write_text(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
