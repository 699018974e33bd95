"""GPU exact backprojection (:mod:`sarmotion.imaging.cuda`): speed and accuracy in one run.

Run with::

    python benchmarks/bench_gpu.py --out bench_gpu.json

Data: the four GOTCHA degrees (469 pulses x 424 samples; ``--gotcha DIR``,
``$SARMOTION_GOTCHA_DIR`` or ``../shared/data/gotcha``), or the same traces saved by
``--save-traces FILE.npz`` and read back with ``--traces FILE.npz`` (for a machine where
:mod:`sarmotion.io` cannot be imported). Grids: ``N x N`` pixels over the same
102.4 m square about the scene centre (spacing ``102.4 / N`` m), every pixel inside the
fast-time window, so every pixel sums every pulse.

For each size, warm (the kernel compiled and the trace table on the device), median of
``--repeats`` runs:

- ``device``: the GPU image left on the device (launch to synchronisation, CUDA
  events), with the default pixels per thread, and ``variants``: every pixels-per-thread
  and block-rows choice;
- ``end_to_end``: :func:`~sarmotion.imaging.cuda.backproject_cuda`, the complex128 image
  in host memory (a page-locked block of :mod:`~sarmotion.imaging._cuda_host`'s pool,
  reused once the previous image is released; the image in row bands, each copied while
  the next is computed, :func:`~sarmotion.imaging.cuda.row_bands`), ``end_to_end_pageable``:
  the same with the pool off, each image copied into fresh pageable memory, and
  ``end_to_end_one_band``: pooled, one band (the copy after the whole image);
- ``ser_db``: signal-to-error ratio against the exact sum
  (:func:`~sarmotion.imaging.point_response`, float64, no interpolation) on
  ``--reference-pixels`` pixels drawn at random (seeded), the same for every method;
- at ``--cpu-size``, the CPU's :func:`~sarmotion.imaging.backproject` (numba, all
  threads) in the same run: time and SER on the same pixels;
- ``ffbp``: fast factorised backprojection on the GPU (``method="ffbp"``,
  :mod:`~sarmotion.imaging.cuda_ffbp`), end to end, its path and SER on the same pixels;
- ``new_data``: exact and FFBP end to end on a new traces object at every call (the
  trace table built again, on the GPU by :mod:`~sarmotion.imaging._cuda_table`; FFBP's
  plan kept for the geometry), as a former that takes the phase history at every call
  works.

With ``--fastsar`` (FastSAR, ``pip install 'sarmotion[bench]'``, and CuPy), the same
sizes over a 51.2 m square, sarmotion's exact and FFBP also on new data at every call
(FastSAR's exact former refuses a grid wider than the
unambiguous range less a margin, ``bench_backprojection.FASTSAR_EXTENT_M``) in the same
run: sarmotion's kernel (image on the device, and end to end, pooled and pageable)
against FastSAR's CUDA exact (cubic) and factorised formers (the phase history on the
device, the complex64 image returned in host memory, as FastSAR's call does),
``window=False``, each warm, median of ``--repeats``, with their signal-to-error against
the exact sum.

Under numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``) the same script checks itself
at tiny sizes (``--sizes 16 --pulses 8 --reference-pixels 64 --cpu-size 16``).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import math
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from sarmotion.core import Radar, Traces, Trajectory
from sarmotion.imaging import ImageGrid, backproject, point_response
from sarmotion.imaging import cuda as gpu

SIDE_M = 102.4


def _gotcha_files(directory: str | None) -> list[Path]:
    root = Path(__file__).resolve().parents[1]
    env = os.environ.get("SARMOTION_GOTCHA_DIR")
    for d in [Path(p) for p in (directory, env) if p] + [
        root.parent / "shared" / "data" / "gotcha"
    ]:
        files = sorted(d.glob("data_3dsar_pass1_az00*_HH.mat")) if d.is_dir() else []
        if len(files) == 4:
            return files
    return []


def save_traces(tr: Traces, path: Path) -> None:
    np.savez(
        path,
        data=tr.data,
        positions_m=tr.positions_m,
        slow_times_s=tr.slow_times_s,
        reference_point_m=tr.reference_point_m,
        radar=json.dumps(dataclasses.asdict(tr.radar)),
    )


def load_traces(path: Path) -> Traces:
    z = np.load(path)
    return Traces(
        data=z["data"],
        trajectory=Trajectory(positions_m=z["positions_m"], slow_times_s=z["slow_times_s"]),
        radar=Radar(**json.loads(str(z["radar"]))),
        reference_point_m=z["reference_point_m"],
    )


def read_traces(path: Path | None, gotcha: str | None) -> Traces:
    """The traces saved at ``path`` (:func:`save_traces`), else the four GOTCHA degrees."""
    if path is not None:
        return load_traces(path)
    from sarmotion.io import read_gotcha

    files = _gotcha_files(gotcha)
    if not files:
        sys.exit("no GOTCHA files (--gotcha DIR or $SARMOTION_GOTCHA_DIR) and no --traces")
    return read_gotcha(files)


def _ser_db(ref: np.ndarray, x: np.ndarray) -> float:
    err = float(np.linalg.norm(x - ref))
    return math.inf if err == 0 else 20.0 * math.log10(float(np.linalg.norm(ref)) / err)


def _rate(work: int, seconds: float) -> float:
    """Pixel-pulses per second (nan when the simulator reports no time)."""
    return work / seconds if seconds > 0 else math.nan


def _median_time(fn, repeats: int) -> tuple[float, list[float]]:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times


@contextlib.contextmanager
def _pageable(cuda):
    """Images copied into fresh pageable memory (the pool of page-locked blocks off)."""
    from sarmotion.imaging._cuda_host import pool_for

    pool = pool_for(cuda)
    limit, pool.limit_bytes = pool.limit_bytes, 0
    try:
        yield
    finally:
        pool.limit_bytes = limit


@contextlib.contextmanager
def _one_band():
    """The exact image computed in one launch, then copied (no overlap of the two)."""
    bands, gpu.MAX_BANDS = gpu.MAX_BANDS, 1
    try:
        yield
    finally:
        gpu.MAX_BANDS = bands


def _device_run(cuda, tr, grid, p, rows, repeats):
    """Median device time (s) of one image left on the GPU, and the image (host)."""
    u = np.zeros(3)
    out, p = gpu._image_on_device(cuda, tr, grid, u, 8, p, rows)  # warm: compile
    cuda.synchronize()
    times = []
    for _ in range(repeats):
        start, stop = cuda.event(), cuda.event()
        start.record()
        out, p = gpu._image_on_device(cuda, tr, grid, u, 8, p, rows)
        stop.record()
        stop.synchronize()
        times.append(start.elapsed_time(stop) / 1e3)
    return statistics.median(times), times, out.copy_to_host().view(np.complex128)[..., 0], p


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gotcha", default=None)
    ap.add_argument("--traces", type=Path, default=None)
    ap.add_argument("--save-traces", type=Path, default=None)
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048, 4096])
    ap.add_argument("--pulses", type=int, default=None)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--reference-pixels", type=int, default=4096)
    ap.add_argument("--cpu-size", type=int, default=1024)
    ap.add_argument(
        "--variants",
        type=int,
        nargs="*",
        default=[1, 2, 4, 8],
        help="pixels per thread to time besides the default",
    )
    ap.add_argument("--block-rows", type=int, nargs="*", default=[4, 8])
    ap.add_argument("--fastsar", action="store_true", help="compare with FastSAR's CUDA formers")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)

    tr = read_traces(args.traces, args.gotcha)
    if args.save_traces is not None:
        save_traces(tr, args.save_traces)
        print(f"saved {args.save_traces}")
        return {}
    if args.pulses:
        tr = tr.select_pulses(0, args.pulses)

    cuda = gpu._cuda()
    if not cuda.is_available():
        sys.exit(gpu.NEEDS)
    sim = os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
    device = "CUDA simulator" if sim else cuda.get_current_device().name
    if isinstance(device, bytes):
        device = device.decode()
    phase_history = tr.phase_history()
    rng = np.random.default_rng(20261126)
    result: dict = {
        "device": device,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba_cuda": _version("numba-cuda"),
        "numba": _version("numba"),
        "pulses": tr.n_pulses,
        "samples": tr.n_samples,
        "upsample": 8,
        "side_m": SIDE_M,
        "load_average_1min": os.getloadavg()[0],
        "sizes": [],
    }
    print(f"{device}: {tr.n_pulses} pulses x {tr.n_samples} samples", flush=True)
    for n in args.sizes:
        grid = ImageGrid.square(size_m=SIDE_M, spacing_m=SIDE_M / n)
        work = n * n * tr.n_pulses
        k = min(args.reference_pixels, n * n)
        flat = rng.choice(n * n, size=k, replace=False)
        iy, ix = np.unravel_index(flat, (n, n))
        pts = np.stack([grid.x_m[ix], grid.y_m[iy], np.zeros(k)], axis=1)
        t0 = time.perf_counter()
        exact = point_response(tr, pts, phase_history=phase_history)
        t_exact = time.perf_counter() - t0
        entry: dict = {"n": n, "spacing_m": SIDE_M / n, "reference_pixels": k,
                       "exact_seconds": t_exact, "variants": []}  # fmt: skip
        for p, rows in [(p, rows) for p in args.variants for rows in args.block_rows]:
            med, times, img, _ = _device_run(cuda, tr, grid, p, rows, args.repeats)
            v = {"pixels_per_thread": p, "block_rows": rows, "seconds_median": med,
                 "seconds": times, "pixel_pulses_per_second": _rate(work, med),
                 "ser_db": _ser_db(exact, img[iy, ix])}  # fmt: skip
            entry["variants"].append(v)
            print(f"  {n}^2 P={p} rows={rows}: {_rate(work, med):.3g} pixel-pulses/s, "
                  f"{v['ser_db']:.1f} dB", flush=True)  # fmt: skip
        med, times, img, p = _device_run(cuda, tr, grid, None, gpu.BLOCK_ROWS, args.repeats)
        entry["device"] = {"pixels_per_thread": p, "block_rows": gpu.BLOCK_ROWS,
                           "seconds_median": med, "seconds": times,
                           "pixel_pulses_per_second": _rate(work, med),
                           "ser_db": _ser_db(exact, img[iy, ix])}  # fmt: skip
        gpu.backproject_cuda(tr, grid)
        med, times = _median_time(lambda g=grid: gpu.backproject_cuda(tr, g), args.repeats)
        entry["end_to_end"] = {"seconds_median": med, "seconds": times,
                               "pixel_pulses_per_second": _rate(work, med)}  # fmt: skip
        with _pageable(cuda):
            gpu.backproject_cuda(tr, grid)
            med, times = _median_time(lambda g=grid: gpu.backproject_cuda(tr, g), args.repeats)
        entry["end_to_end_pageable"] = {"seconds_median": med, "seconds": times,
                                        "pixel_pulses_per_second": _rate(work, med)}  # fmt: skip
        with _one_band():
            gpu.backproject_cuda(tr, grid)
            med, times = _median_time(lambda g=grid: gpu.backproject_cuda(tr, g), args.repeats)
        entry["end_to_end_one_band"] = {"seconds_median": med, "seconds": times,
                                        "pixel_pulses_per_second": _rate(work, med)}  # fmt: skip
        if n == args.cpu_size:
            cpu = backproject(tr, grid).values
            med, times = _median_time(lambda g=grid: backproject(tr, g), min(args.repeats, 3))
            entry["cpu"] = {"seconds_median": med, "seconds": times,
                            "pixel_pulses_per_second": _rate(work, med),
                            "ser_db": _ser_db(exact, cpu[iy, ix]),
                            "threads": _threads()}  # fmt: skip
        entry["ffbp"] = _ffbp_row(tr, grid, work, exact, iy, ix, args.repeats)
        entry["new_data"] = _new_data_rows(tr, grid, work, args.repeats)
        f, nd = entry["ffbp"], entry["new_data"]
        print(f"  {n}^2 FFBP ({f['path']}): {f['pixel_pulses_per_second']:.3g} pixel-pulses/s "
              f"end to end, {f['ser_db']:.1f} dB; new data: exact "
              f"{nd['exact']['pixel_pulses_per_second']:.3g}, FFBP "
              f"{nd['ffbp']['pixel_pulses_per_second']:.3g}", flush=True)  # fmt: skip
        d, e = entry["device"], entry["end_to_end"]
        line = (f"{n}^2 ({SIDE_M / n:.4g} m): device {d['pixel_pulses_per_second']:.3g} "
                f"pixel-pulses/s (P={d['pixels_per_thread']}), end-to-end "
                f"{e['pixel_pulses_per_second']:.3g} (pageable "
                f"{entry['end_to_end_pageable']['pixel_pulses_per_second']:.3g}, one band "
                f"{entry['end_to_end_one_band']['pixel_pulses_per_second']:.3g}), "
                f"SER {d['ser_db']:.1f} dB")  # fmt: skip
        if "cpu" in entry:
            c = entry["cpu"]
            line += (f"; CPU {c['pixel_pulses_per_second']:.3g} pixel-pulses/s "
                     f"({c['threads']} threads), {c['ser_db']:.1f} dB")  # fmt: skip
        print(line, flush=True)
        result["sizes"].append(entry)
        if args.out is not None:
            args.out.write_text(json.dumps(result, indent=1))
    if args.fastsar:
        result["fastsar"] = [
            _against_fastsar(cuda, tr, n, rng, args.reference_pixels, args.repeats)
            for n in args.sizes
        ]  # fmt: skip
        if args.out is not None:
            args.out.write_text(json.dumps(result, indent=1))
    return result


def _ffbp_row(tr, grid, work, exact, iy, ix, repeats) -> dict:
    """FFBP on the GPU, warm, end to end (complex128 image in host memory)."""
    img = gpu.backproject_cuda(tr, grid, method="ffbp")
    med, times = _median_time(lambda: gpu.backproject_cuda(tr, grid, method="ffbp"), repeats)
    info = img.metadata.get("ffbp", {})
    return {"seconds_median": med, "seconds": times, "pixel_pulses_per_second": _rate(work, med),
            "ser_db": _ser_db(exact, img.values[iy, ix]), "path": info.get("path", "exact"),
            "budget_db": info.get("budget_db"), "levels": info.get("levels"),
            "exact_pixels": info.get("exact_pixels")}  # fmt: skip


def _new_data_rows(tr, grid, work, repeats) -> dict:
    """Exact and FFBP on a new traces object at every call (the table built each time)."""
    rows = {}
    for method in ("exact", "ffbp"):
        fresh = [tr.with_data(tr.data.copy()) for _ in range(repeats + 1)]
        gpu.backproject_cuda(fresh.pop(), grid, method=method)  # warm: compiled, planned

        def call(m=method, fresh=fresh):
            gpu.backproject_cuda(fresh.pop(), grid, method=m)

        med, times = _median_time(call, repeats)
        rows[method] = {"seconds_median": med, "seconds": times,
                        "pixel_pulses_per_second": _rate(work, med)}  # fmt: skip
    return rows


def _against_fastsar(cuda, tr, n, rng, reference_pixels, repeats) -> dict:
    """One size of the FastSAR comparison (module docstring), FastSAR's failures recorded."""
    from bench_backprojection import FASTSAR_EXTENT_M, _fastsar_formers

    grid = ImageGrid.square(size_m=FASTSAR_EXTENT_M, spacing_m=FASTSAR_EXTENT_M / n)
    work = n * n * tr.n_pulses
    k = min(reference_pixels, n * n)
    iy, ix = np.unravel_index(rng.choice(n * n, size=k, replace=False), (n, n))
    pts = np.stack([grid.x_m[ix], grid.y_m[iy], np.zeros(k)], axis=1)
    exact = point_response(tr, pts)
    med, _, img, p = _device_run(cuda, tr, grid, None, gpu.BLOCK_ROWS, repeats)
    entry: dict = {"n": n, "spacing_m": FASTSAR_EXTENT_M / n, "formers": {}}
    entry["formers"]["sarmotion (image on the device)"] = {
        "pixel_pulses_per_second": _rate(work, med),
        "ser_db": _ser_db(exact, img[iy, ix]),
    }
    gpu.backproject_cuda(tr, grid)
    med, _ = _median_time(lambda: gpu.backproject_cuda(tr, grid), repeats)
    entry["formers"]["sarmotion (complex128 image in host memory)"] = {
        "pixel_pulses_per_second": _rate(work, med)}  # fmt: skip
    with _pageable(cuda):
        gpu.backproject_cuda(tr, grid)
        med, _ = _median_time(lambda: gpu.backproject_cuda(tr, grid), repeats)
    entry["formers"]["sarmotion (complex128 image in fresh pageable memory)"] = {
        "pixel_pulses_per_second": _rate(work, med)}  # fmt: skip
    f = _ffbp_row(tr, grid, work, exact, iy, ix, repeats)
    entry["formers"]["sarmotion FFBP (complex128 image in host memory)"] = {
        "pixel_pulses_per_second": f["pixel_pulses_per_second"], "ser_db": f["ser_db"],
        "path": f["path"]}  # fmt: skip
    for method, row in _new_data_rows(tr, grid, work, repeats).items():
        entry["formers"][f"sarmotion {method}, new data (host memory)"] = {
            "pixel_pulses_per_second": row["pixel_pulses_per_second"]}  # fmt: skip
    try:
        import cupy as cp
        import fastsar

        exact_former, factorised = _fastsar_formers(fastsar, tr, grid, backend="cuda")
        formers = {"FastSAR exact (cubic)": exact_former, "FastSAR factorised": factorised}
        history = cp.asarray(np.ascontiguousarray(tr.phase_history(), dtype=np.complex64))
        scale = 1.0 / tr.n_samples
    except Exception as exc:  # FastSAR or CuPy missing, or refusing the grid
        entry["fastsar_error"] = f"{type(exc).__name__}: {exc}"
        print(f"{n}^2: FastSAR not compared ({entry['fastsar_error']})", flush=True)
        return entry
    for name, former in formers.items():
        try:

            def run(former=former):
                out = former(history)
                cp.cuda.Device().synchronize()
                return out

            values = run()
            values = cp.asnumpy(values) if hasattr(values, "get") else np.asarray(values)
            med, _ = _median_time(run, repeats)
            entry["formers"][name] = {
                "pixel_pulses_per_second": _rate(work, med),
                "ser_db": _ser_db(exact, values.T[iy, ix] * scale),
            }  # fmt: skip
        except Exception as exc:
            entry["formers"][name] = {"error": f"{type(exc).__name__}: {exc}"}
    for name, row in entry["formers"].items():
        print(f"{n}^2 over {FASTSAR_EXTENT_M} m, {name}: {row}", flush=True)
    return entry


def _version(name: str) -> str | None:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(name)
    except PackageNotFoundError:
        return None


def _threads() -> int:
    import numba

    return numba.get_num_threads()


if __name__ == "__main__":
    main()
