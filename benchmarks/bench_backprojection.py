"""Backprojection speed and accuracy, every accuracy figure against the exact sum.

Run with::

    pytest benchmarks/bench_backprojection.py --benchmark-only
    python benchmarks/bench_backprojection.py          # the FastSAR comparison table only
    python benchmarks/bench_backprojection.py 1024 2048 --exact-only --rounds 5  # see --help

(``--benchmark-only`` overrides the ``--benchmark-skip`` of the project configuration;
``--benchmark-enable`` does not.)

Data: the four GOTCHA degrees (469 pulses x 424 samples; ``$SARMOTION_GOTCHA_DIR`` or
``../shared/data/gotcha``), or, without them, a simulated GOTCHA-like 4-degree aperture
(468 pulses, three points and a mover). 0.25 m pixels, numba's default threads (the
FastSAR comparison: 2 threads each).

Accuracy is always the signal-to-error ratio against the exact sum
(:func:`sarmotion.imaging.exact_sum.exact_sum`: every pulse's band-limited trace evaluated
at the pixel's delay by a direct sum over the phase history, no interpolation), on
:data:`N_CHECK` pixels drawn at random (seeded) from the image: the SER estimated on a
sample of pixels (the whole image at 256^2).

- ``test_exact``: the compiled float32 kernel at 128^2 ... 1024^2 (``extra_info``:
  ``pixel_pulses_per_second_{median,best}``, ``ser_db_vs_exact_sum``);
- ``test_float64_kernel``: the float64 compiled kernel (the fallback), same sizes;
- ``test_exact_in_swath``: 1024^2 at 0.1 m, every pixel inside the fast-time window;
- ``test_ffbp``: fast factorised backprojection at 1024^2 and 2048^2 against exact
  backprojection in the same run, the two alternating (7 pairs): ``speed_up`` (median
  wall clock, exact / FFBP), ``speed_up_cpu`` (median CPU time, all threads),
  ``ser_db_vs_exact_sum`` of both;
- ``test_ffbp_oblique``: the same at an oblique look, the GOTCHA degrees turned by 30 and
  45 degrees about the scene centre (the rotated path of FFBP);
- ``test_ffbp_simulated``: the same on simulated points (six at random, one mover, 20 dB
  SNR) seen over 4 degrees at 0, 30 and 45 degree looks, 1024^2 at 0.25 m;

Every FFBP row also records ``budget_db`` (the error budget of
:mod:`sarmotion.imaging.ffbp` for that image) and the pixels computed exactly near the
ends of the fast-time window (``exact_pixels``);
- ``test_against_fastsar``: sarmotion exact and FFBP against FastSAR (the ``bench`` extra,
  ``fastsar==0.1.8``) exact (``ExactFormer``, cubic, its default upsampling 8) and
  factorised (``ImageFormer``) at 256^2, 1024^2, 2048^2 over one 51.2 m square
  (:data:`FASTSAR_EXTENT_M`): the same phase history, antenna positions, reference ranges
  and grid, ``window=False``, 2 threads each
  (``OMP_NUM_THREADS=2``, ``OMP_WAIT_POLICY=passive`` unless set), the four called in turn
  in every round (15 rounds at 256^2, where a call takes tens of milliseconds and one
  descheduling would move a median of few; 3 above); medians of the rounds,
  ``pixel_pulses_per_second``, SER against the exact
  sum (FastSAR's images divided by ``n_samples``, the normalisation of ``eq:image`` here),
  the 1-minute load average before and after. Skipped, saying so, without FastSAR.
  Later calls on the same traces and grid reuse sarmotion's upsampled-trace table and
  FFBP plan (another image of the same data). FastSAR's formers are built once per
  geometry and grid and take the phase history at every call, so the like-for-like rows
  are ``..., new data``: a new traces object each call (its trace table built again, the
  FFBP plan of the geometry kept). ``sarmotion FFBP, cold`` keeps neither (the plan cache
  cleared too: the first image of new data on a new geometry).

Each benchmark first runs once outside the timing (JIT cache load, thread start-up, the
upsampled-trace table, which later calls on the same traces reuse). ``extra_info`` also
records the 1-minute load average: on a shared machine the wall-clock rates fall with it.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "2")  # before FastSAR loads its OpenMP kernels
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

import numba  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from sarmotion.core import Trajectory  # noqa: E402
from sarmotion.imaging import ImageGrid, backproject  # noqa: E402
from sarmotion.imaging._bp_common import make_setup  # noqa: E402
from sarmotion.imaging._bp_kernels import run_numba_f64  # noqa: E402
from sarmotion.imaging.exact_sum import exact_sum  # noqa: E402

SPACING_M = 0.25
SIZES = (128, 256, 512, 1024)
FASTSAR_SIZES = (256, 1024, 2048)
#: Side of the FastSAR comparison's grids (m): FastSAR's exact former refuses a grid whose
#: range span from a pulse exceeds the unambiguous range ``c / (2 df)`` (102 m on GOTCHA)
#: less a margin, so every size covers the same 51.2 m square, 0.2 m to 0.025 m pixels.
FASTSAR_EXTENT_M = 51.2
#: Pixels of each image on which the exact sum is evaluated.
N_CHECK = 65536


def _gotcha_files() -> list[Path]:
    env = os.environ.get("SARMOTION_GOTCHA_DIR")
    root = Path(__file__).resolve().parents[1]
    for d in ([Path(env)] if env else []) + [root.parent / "shared" / "data" / "gotcha"]:
        files = sorted(d.glob("data_3dsar_pass1_az00*_HH.mat")) if d.is_dir() else []
        if len(files) == 4:
            return files
    return []


def _load_traces():
    from sarmotion.io import read_gotcha
    from sarmotion.simulation import PointTarget, Scene, simulate

    files = _gotcha_files()
    if files:
        return read_gotcha(files)
    scene = Scene(
        name="bench",
        targets=[
            PointTarget(position_m=(7.3, -4.1)),
            PointTarget(position_m=(-20.0, 15.0), reflectivity=0.5j),
            PointTarget(position_m=(0.0, 0.0), velocity_mps=(10.0, 5.0)),
        ],
    )
    return simulate(scene, trajectory=Trajectory.circular(aperture_deg=4.0)).traces


@pytest.fixture(scope="module")
def traces():
    return _load_traces()


def _ser_db(ref: np.ndarray, x: np.ndarray) -> float:
    err = float(np.linalg.norm(x - ref))
    return math.inf if err == 0 else 20.0 * math.log10(float(np.linalg.norm(ref)) / err)


_REFERENCES: dict = {}


def _reference(traces, grid: ImageGrid) -> tuple[np.ndarray, np.ndarray]:
    """Flat indices of :data:`N_CHECK` seeded random pixels and the exact sum there."""
    key = (id(traces), grid.shape, float(grid.x_m[0]), float(grid.y_m[0]), grid.spacing_m)
    entry = _REFERENCES.get(key)
    if entry is None or entry[0] is not traces:  # ids of collected objects are reused
        ny, nx = grid.shape
        rng = np.random.default_rng(20261126)
        idx = np.sort(rng.choice(ny * nx, size=min(N_CHECK, ny * nx), replace=False))
        pts = np.stack([grid.x_m[idx % nx], grid.y_m[idx // nx]], axis=-1)
        entry = _REFERENCES[key] = (traces, idx, exact_sum(traces, pts))
    return entry[1], entry[2]


def _ser_vs_exact(traces, grid: ImageGrid, values: np.ndarray) -> float:
    idx, ref = _reference(traces, grid)
    return _ser_db(ref, values.reshape(-1)[idx])


def _float64_kernel(traces, grid):
    return run_numba_f64(make_setup(traces, None, 6), grid, None)


def _rates(benchmark, traces, n: int) -> None:
    work = n * n * traces.n_pulses
    stats = benchmark.stats.stats
    benchmark.extra_info.update(
        {
            "grid": f"{n}x{n}",
            "spacing_m": SPACING_M,
            "pulses": traces.n_pulses,
            "samples": traces.n_samples,
            "threads": numba.get_num_threads(),
            "pixel_pulses_per_second_median": work / stats.median,
            "pixel_pulses_per_second_best": work / stats.min,
            "load_average_1min": os.getloadavg()[0],
        }
    )


@pytest.mark.parametrize("n", SIZES)
def test_exact(benchmark, traces, n):
    grid = ImageGrid.square(size_m=n * SPACING_M, spacing_m=SPACING_M)
    img = backproject(traces, grid)
    benchmark.pedantic(backproject, args=(traces, grid), rounds=15 if n < 512 else 5, iterations=1)
    _rates(benchmark, traces, n)
    benchmark.extra_info["ser_db_vs_exact_sum"] = _ser_vs_exact(traces, grid, img.values)
    benchmark.extra_info["upsample"] = img.metadata["upsample"]
    benchmark.extra_info["kernel_variant"] = img.metadata["kernel_variant"]


@pytest.mark.parametrize("n", SIZES)
def test_float64_kernel(benchmark, traces, n):
    grid = ImageGrid.square(size_m=n * SPACING_M, spacing_m=SPACING_M)
    img = _float64_kernel(traces, grid)
    benchmark.pedantic(_float64_kernel, args=(traces, grid), rounds=5 if n < 1024 else 3,
                       iterations=1)  # fmt: skip
    _rates(benchmark, traces, n)
    benchmark.extra_info["ser_db_vs_exact_sum"] = _ser_vs_exact(traces, grid, img)


def test_exact_in_swath(benchmark, traces):
    n = 1024
    grid = ImageGrid.square(size_m=n * 0.1, spacing_m=0.1)
    backproject(traces, grid)
    benchmark.pedantic(backproject, args=(traces, grid), rounds=5, iterations=1)
    _rates(benchmark, traces, n)
    benchmark.extra_info["spacing_m"] = 0.1


def _timed(f) -> tuple[float, float]:
    """Wall-clock and CPU (the process, all threads) seconds of one call."""
    w0, c0 = time.perf_counter(), time.process_time()
    f()
    return time.perf_counter() - w0, time.process_time() - c0


@pytest.mark.parametrize("n", (1024, 2048))
def test_ffbp(benchmark, traces, n):
    grid = ImageGrid.square(size_m=n * SPACING_M, spacing_m=SPACING_M)
    benchmark.extra_info.update(_ffbp_row(benchmark, traces, grid, rounds=5))


def _turned(traces, deg: float):
    """The acquisition turned by ``deg`` about the reference point (ranges unchanged)."""
    t = math.radians(deg)
    c, s = math.cos(t), math.sin(t)
    o = traces.reference_point_m
    p = traces.trajectory.positions_m.copy()
    d = p[:, :2] - o[:2]
    p[:, 0] = o[0] + c * d[:, 0] - s * d[:, 1]
    p[:, 1] = o[1] + s * d[:, 0] + c * d[:, 1]
    trajectory = Trajectory(positions_m=p, slow_times_s=traces.trajectory.slow_times_s)
    return dataclasses.replace(traces, trajectory=trajectory)


def _ffbp_row(benchmark, tr, grid: ImageGrid, rounds: int = 3) -> dict:
    """FFBP against exact on ``grid``, alternating (7 pairs): speed-up, SER, load."""
    exact = backproject(tr, grid)
    fast = backproject(tr, grid, method="ffbp")
    load = [os.getloadavg()[0]]
    pairs = [
        (_timed(lambda: backproject(tr, grid)),
         _timed(lambda: backproject(tr, grid, method="ffbp")))
        for _ in range(7)
    ]  # fmt: skip
    load.append(os.getloadavg()[0])
    wall_e, cpu_e = (float(np.median([p[0][k] for p in pairs])) for k in (0, 1))
    wall_f, cpu_f = (float(np.median([p[1][k] for p in pairs])) for k in (0, 1))
    benchmark.pedantic(backproject, args=(tr, grid), kwargs={"method": "ffbp"}, rounds=rounds,
                       iterations=1)  # fmt: skip
    info = fast.metadata.get("ffbp", {})
    return {
        "grid": f"{grid.shape[1]}x{grid.shape[0]}",
        "exact_seconds_median": wall_e,
        "ffbp_seconds_median": wall_f,
        "speed_up": wall_e / wall_f,
        "exact_cpu_seconds_median": cpu_e,
        "ffbp_cpu_seconds_median": cpu_f,
        "speed_up_cpu": cpu_e / cpu_f,
        "ser_db_vs_exact": _ser_db(exact.values, fast.values),
        "ser_db_vs_exact_sum": _ser_vs_exact(tr, grid, fast.values),
        "exact_ser_db_vs_exact_sum": _ser_vs_exact(tr, grid, exact.values),
        "budget_db": info.get("budget_db"),
        "ffbp_path": info.get("path"),
        "exact_pixels": info.get("exact_pixels"),
        "ffbp": info,
        "threads": numba.get_num_threads(),
        "load_average_1min": load,
    }


@pytest.mark.parametrize("deg", (30.0, 45.0))
@pytest.mark.parametrize("n", (1024, 2048))
def test_ffbp_oblique(benchmark, traces, n, deg):
    grid = ImageGrid.square(size_m=n * SPACING_M, spacing_m=SPACING_M)
    benchmark.extra_info.update(_ffbp_row(benchmark, _turned(traces, deg), grid))
    benchmark.extra_info["turned_deg"] = deg


def _simulated_points(look_deg: float, seed: int):
    """Six points at random (seeded) and a mover, 20 dB SNR, 4 degrees about ``look_deg``."""
    from sarmotion.simulation import PointTarget, Scene, add_noise, simulate

    rng = np.random.default_rng(seed)
    targets = [
        PointTarget(position_m=tuple(rng.uniform(-100.0, 100.0, 2)),
                    reflectivity=complex(*rng.normal(size=2)))
        for _ in range(6)
    ] + [PointTarget(position_m=(0.0, 0.0), velocity_mps=(10.0, 5.0))]  # fmt: skip
    trajectory = Trajectory.circular(aperture_deg=4.0, centre_azimuth_deg=look_deg)
    tr = simulate(Scene(name="bench", targets=targets), trajectory=trajectory).traces
    return tr.with_data(add_noise(tr.data, snr_db=20.0, rng=seed))


@pytest.mark.parametrize("look_deg", (0.0, 30.0, 45.0))
def test_ffbp_simulated(benchmark, look_deg):
    n = 1024
    grid = ImageGrid.square(size_m=n * SPACING_M, spacing_m=SPACING_M)
    tr = _simulated_points(look_deg, seed=20261126 + int(look_deg))
    benchmark.extra_info.update(_ffbp_row(benchmark, tr, grid))
    benchmark.extra_info["look_deg"] = look_deg


# ------------------------------------------------------------------- FastSAR comparison
def _fastsar_formers(fastsar, traces, grid: ImageGrid, backend: str = "cpu"):
    """FastSAR's exact (cubic) and factorised formers on ``grid``, ``window=False``.

    FastSAR's grid is ``x_i = (i - nx/2) spx`` (and ``y``) about ``center`` (``ExactFormer``)
    or the origin (``ImageFormer``): the grids here are centred squares, so they agree.
    """
    ny, nx = grid.shape
    dx, dy = grid.spacing_m
    if not (math.isclose(grid.x_m[0], -nx / 2 * dx) and math.isclose(grid.y_m[0], -ny / 2 * dy)):
        raise ValueError("the FastSAR comparison needs a grid x_i = (i - nx/2) dx")
    if np.any(traces.reference_point_m != 0.0):
        raise ValueError("the FastSAR comparison needs the reference point at the origin")
    f = traces.frequencies_hz
    common = dict(
        ant=traces.positions_m, fmin=float(f[0]), df=float(traces.radar.frequency_step_hz),
        K=traces.n_samples, nx=nx, ny=ny, spx=dx, spy=dy, backend=backend, window=False,
        ref=np.linalg.norm(traces.positions_m - traces.reference_point_m, axis=1),
    )  # fmt: skip
    exact = fastsar.ExactFormer(**common, interp="cubic")
    factorised = fastsar.ImageFormer(**common)
    return exact, factorised


#: The imagers of ``--exact-only``: the exact formers alone.
EXACT_IMAGERS = ("sarmotion exact", "sarmotion exact, new data", "FastSAR exact (cubic)")


def compare_with_fastsar(traces, n: int, rounds: int, imagers_kept=None) -> dict:
    """One row of the comparison (module docstring): rates, SER against the exact sum, load.

    ``imagers_kept``: the names of the imagers to run (default all). Besides the wall-clock
    rates, ``pixel_pulses_per_cpu_second_median`` divides the work by each call's CPU time
    (the process, all threads): on a machine shared with other jobs the wall clock counts
    their time too.
    """
    import fastsar

    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    grid = ImageGrid.square(size_m=FASTSAR_EXTENT_M, spacing_m=FASTSAR_EXTENT_M / n)
    P = np.ascontiguousarray(traces.phase_history(), dtype=np.complex64)
    fs_exact, fs_factorised = _fastsar_formers(fastsar, traces, grid)
    scale = 1.0 / traces.n_samples
    from sarmotion.imaging import ffbp

    def cold() -> np.ndarray:
        # nothing kept from the last call: a new traces object (its trace table built
        # again) and no plan (the tree, filters and schedule planned again)
        ffbp.PLANS.clear()
        return backproject(traces.with_data(traces.data), grid, method="ffbp").values

    imagers = {
        "sarmotion exact": lambda: backproject(traces, grid).values,
        "sarmotion exact, new data": lambda: (
            backproject(traces.with_data(traces.data), grid).values
        ),
        "sarmotion FFBP": lambda: backproject(traces, grid, method="ffbp").values,
        "sarmotion FFBP, new data": lambda: (
            backproject(traces.with_data(traces.data), grid, method="ffbp").values
        ),
        "sarmotion FFBP, cold": cold,
        "FastSAR exact (cubic)": lambda: np.asarray(fs_exact(P)).T * scale,
        "FastSAR factorised": lambda: np.asarray(fs_factorised(P)).T * scale,
    }
    if imagers_kept is not None:
        imagers = {name: f for name, f in imagers.items() if name in imagers_kept}
    load = [os.getloadavg()[0]]
    ser = {name: _ser_vs_exact(traces, grid, f()) for name, f in imagers.items()}  # + warm-up
    times: dict[str, list[float]] = {name: [] for name in imagers}
    cpu: dict[str, list[float]] = {name: [] for name in imagers}
    for _ in range(rounds):  # alternating: every imager once per round
        for name, f in imagers.items():
            wall, cpu_s = _timed(f)
            times[name].append(wall)
            cpu[name].append(cpu_s)
    load.append(os.getloadavg()[0])
    work = n * n * traces.n_pulses
    rates = {name: work / float(np.median(t)) for name, t in times.items()}
    cpu_rates = {name: work / float(np.median(t)) for name, t in cpu.items()}

    def ratio(a: str, b: str, r: dict = rates) -> float:
        return r[a] / r[b] if a in r and b in r else math.nan

    return {
        "grid": f"{n}x{n}",
        "spacing_m": FASTSAR_EXTENT_M / n,
        "rounds": rounds,
        "threads": numba.get_num_threads(),
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
        "ser_db_vs_exact_sum": ser,
        "pixel_pulses_per_second_median": rates,
        "pixel_pulses_per_second_best": {n_: work / min(t) for n_, t in times.items()},
        "pixel_pulses_per_cpu_second_median": cpu_rates,
        "seconds": times,
        "cpu_seconds": cpu,
        "exact_speed_ratio": ratio("sarmotion exact", "FastSAR exact (cubic)"),
        "ffbp_speed_ratio": ratio("sarmotion FFBP", "FastSAR factorised"),
        "exact_new_data_speed_ratio": ratio("sarmotion exact, new data", "FastSAR exact (cubic)"),
        "ffbp_new_data_speed_ratio": ratio("sarmotion FFBP, new data", "FastSAR factorised"),
        "ffbp_cold_speed_ratio": ratio("sarmotion FFBP, cold", "FastSAR factorised"),
        "exact_cpu_speed_ratio": ratio("sarmotion exact", "FastSAR exact (cubic)", cpu_rates),
        "exact_new_data_cpu_speed_ratio": ratio(
            "sarmotion exact, new data", "FastSAR exact (cubic)", cpu_rates
        ),
        "load_average_1min": load,
    }


@pytest.mark.parametrize("n", FASTSAR_SIZES)
def test_against_fastsar(benchmark, traces, n):
    pytest.importorskip(
        "fastsar", reason="FastSAR is not installed (pip install 'sarmotion[bench]')"
    )
    row = compare_with_fastsar(traces, n, rounds=15 if n <= 256 else 3)
    grid = ImageGrid.square(size_m=FASTSAR_EXTENT_M, spacing_m=FASTSAR_EXTENT_M / n)
    benchmark.pedantic(backproject, args=(traces, grid), rounds=1, iterations=1)
    benchmark.extra_info.update(row)


def _table(rows: list[dict]) -> str:
    names = list(rows[0]["ser_db_vs_exact_sum"])
    grids = " / ".join(r["grid"] for r in rows)
    head = f"| imager | SER vs exact sum (dB) | pixel-pulses/s: {grids} | per CPU-second: {grids}"
    lines = [head + " |", "|---|---|---|---|"]
    for name in names:
        sers = ", ".join(f"{r['ser_db_vs_exact_sum'][name]:.1f}" for r in rows)
        rates = " / ".join(f"{r['pixel_pulses_per_second_median'][name]:.2e}" for r in rows)
        cpu = " / ".join(f"{r['pixel_pulses_per_cpu_second_median'][name]:.2e}" for r in rows)
        lines.append(f"| {name} | {sers} | {rates} | {cpu} |")
    loads = "; ".join(
        f"{r['grid']}: {r['load_average_1min'][0]:.1f}-{r['load_average_1min'][1]:.1f}"
        for r in rows
    )
    ratios = "; ".join(
        f"{r['grid']}: exact {r['exact_speed_ratio']:.2f}x (new data "
        f"{r['exact_new_data_speed_ratio']:.2f}x)"
        + ("" if math.isnan(r["ffbp_speed_ratio"]) else
           f", FFBP {r['ffbp_speed_ratio']:.2f}x (new data "
           f"{r['ffbp_new_data_speed_ratio']:.2f}x, cold {r['ffbp_cold_speed_ratio']:.2f}x)")
        for r in rows
    )  # fmt: skip
    cpu_ratios = "; ".join(
        f"{r['grid']}: exact {r['exact_cpu_speed_ratio']:.2f}x (new data "
        f"{r['exact_new_data_cpu_speed_ratio']:.2f}x)"
        for r in rows
    )
    return "\n".join(lines) + (
        f"\n\nsarmotion / FastSAR: {ratios}\nper CPU-second: {cpu_ratios}\nload average: {loads}"
    )


def flops_per_pixel_pulse(isa: str | None) -> dict[str, int]:
    """Operations per pixel and pulse of the inner loop's IR (the unchecked window variant,
    or the gathers' variant where ``isa`` is ``None``).

    ``flops``: floating-point additions, subtractions and multiplications, a fused
    multiply-add counted as two; ``fma``, ``add_mul`` the instructions behind them;
    ``other``: the other vector instructions per lane (rounding, conversions, comparisons,
    selects, sign flips, permutes), which take the same ports on most x86 CPUs.
    """
    from sarmotion.imaging import _simd

    ir = _simd._build_ir(isa=isa, checked=isa is None)
    body = ir[ir.index("px:") : ir.index("row.end:")]
    vector = f"<{_simd.LANES} x "
    count = {"fma": 0, "add_mul": 0, "other": 0}
    for line in body.splitlines():
        if "=" not in line or vector not in line:
            continue
        op = line.split("=", 1)[1].split()
        if "@llvm.fmuladd" in line:
            count["fma"] += 1
        elif op[0] in ("fadd", "fsub", "fmul"):
            count["add_mul"] += 1
        elif op[0] not in ("load", "getelementptr", "phi", "bitcast", "extractelement",
                           "insertelement"):  # fmt: skip
            count["other"] += 1
    count["flops"] = 2 * count["fma"] + count["add_mul"]
    return count


def _main(argv: list[str] | None = None) -> None:
    import argparse
    import importlib.util
    import json
    import sys

    from sarmotion.imaging import _simd

    parser = argparse.ArgumentParser(
        description="sarmotion's imagers against FastSAR's (module docstring of "
        "benchmarks/bench_backprojection.py): one table row per imager, medians of the "
        "rounds, wall clock and per CPU-second. Emulate another x86 CPU with "
        'NUMBA_CPU_NAME=haswell NUMBA_CPU_FEATURES="" (numba, and the inner loop\'s '
        'instruction set with it) and FFBP_CPU_FLAGS="-O3 -march=haswell" (FastSAR).'
    )
    parser.add_argument("sizes", nargs="*", type=int, default=list(FASTSAR_SIZES),
                        help="image sides in pixels (default: %(default)s)")  # fmt: skip
    parser.add_argument("--rounds", type=int, default=None,
                        help="rounds of each imager (default 15 up to 256, else 3)")  # fmt: skip
    parser.add_argument("--exact-only", action="store_true",
                        help="the exact formers alone: " + ", ".join(EXACT_IMAGERS))  # fmt: skip
    parser.add_argument("--json", type=Path, default=None, help="also write the rows here")
    args = parser.parse_args(argv)
    if importlib.util.find_spec("fastsar") is None:
        sys.exit("FastSAR is not installed (pip install 'sarmotion[bench]'): nothing to compare")
    flops = flops_per_pixel_pulse(_simd.ISA)
    sys.stdout.write(
        f"numba target: {numba.config.CPU_NAME or 'host'}, features "
        f"{'host' if numba.config.CPU_FEATURES is None else repr(numba.config.CPU_FEATURES)}"
        f"; inner loop's table read: {_simd.ISA or 'gathers'}; FastSAR flags: "
        f"{os.environ.get('FFBP_CPU_FLAGS', 'its default')}\n"
        f"inner loop per pixel and pulse: {flops['flops']} flops ({flops['fma']} fused "
        f"multiply-adds, {flops['add_mul']} adds and multiplies), {flops['other']} other "
        "vector operations\n\n"
    )
    tr = _load_traces()
    kept = EXACT_IMAGERS if args.exact_only else None
    out = [
        compare_with_fastsar(tr, n, rounds=args.rounds or (15 if n <= 256 else 3),
                             imagers_kept=kept)
        for n in args.sizes
    ]  # fmt: skip
    sys.stdout.write(_table(out) + "\n")
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    _main()
