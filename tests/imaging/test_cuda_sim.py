"""The CUDA backprojection kernel under numba's CUDA simulator, without a GPU.

The simulator (``NUMBA_ENABLE_CUDASIM=1``) runs the kernel's Python source thread by
thread on the CPU. It must be chosen before :mod:`numba.cuda` is first imported, so the
kernel runs in a subprocess (this file run as a script) on tiny problems; the tests
compare its images with the exact sum (:func:`~sarmotion.imaging.point_response`, float64,
no interpolation) and with the CPU's :func:`~sarmotion.imaging.backproject`:

- every pixel within the stated bound, ``|I_gpu - I| <= eps sum_j max_t |D_j(t)|``
  (:func:`~sarmotion.imaging.cuda.error_bound`; ``max_t |D_j| <= sum_k |P_jk| / n``);
- a signal-to-error ratio of at least 80 dB (the accuracy the GPU path promises), on
  simulated scenes seen at 0, 30 and 45 degrees, with and without motion compensation,
  and on the first GOTCHA pulses;
- zero, like the CPU's image, where every delay falls outside the fast-time window;
- fast factorised backprojection (``method="ffbp"``, :mod:`~sarmotion.imaging.cuda_ffbp`)
  takes the CPU's path (axis-aligned, looking along ``x`` or ``y``, or rotated, with the
  pixels near a window end computed exactly) and reaches the accuracy of
  :mod:`~sarmotion.imaging.ffbp` against the exact sum: :data:`~sarmotion.imaging.ffbp.
  TARGET_DB` and its own budget less its margin, with and without motion compensation.

In this process (no simulator): the trace table against the trigonometric interpolant,
the pixels-per-thread rule, and the one-line error when no GPU can run.
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import gotcha_directory
from sarmotion.core import C
from sarmotion.imaging._bp_common import table_samples
from sarmotion.imaging.cuda import (
    BLOCK_ROWS,
    MAX_BANDS,
    NEEDS,
    available,
    hermite_table,
    row_bands,
    rows_per_thread,
)

#: The accuracy the GPU path promises against the exact sum (signal-to-error, dB).
MIN_SER_DB = 80.0

# Cases run under the simulator: (name, look azimuth (deg), pixel spacing (m), pixels per
# thread (None: the default rule), velocity (m/s) or None).
SIM_CASES = [
    ("look0", 0.0, 0.25, None, None),
    ("look30", 30.0, 0.1, None, None),
    ("look45_p2", 45.0, 0.1, 2, None),
    ("look45", 45.0, 0.1, None, None),
    ("look30_moving", 30.0, 0.25, None, (6.0, 2.0)),
]


# FFBP cases under the simulator: (name, look azimuth (deg), pulses, grid centre (m),
# side (m), spacing (m), velocity (m/s) or None, the path the CPU takes). Small grids of few
# pulses, where the time model would run exact backprojection for the rotated path (its
# budget is raised in the subprocess: accuracy does not depend on that choice).
FFBP_CASES = [
    ("ffbp_look0", 0.0, 64, (0.0, 0.0), 24.0, 0.5, None, "axis-aligned"),
    ("ffbp_look90", 90.0, 64, (0.0, 0.0), 24.0, 0.5, None, "axis-aligned"),
    ("ffbp_look0_moving", 0.0, 64, (0.0, 0.0), 24.0, 0.5, (6.0, 2.0), "axis-aligned"),
    ("ffbp_look30", 30.0, 64, (0.0, 0.0), 16.0, 0.5, None, "rotated"),
    ("ffbp_window_end", 30.0, 64, (57.2, 33.0), 12.0, 0.5, None, "rotated"),
]


# ============================================================ the simulator side (script)
def _ser_db(ref, x):
    err = float(np.linalg.norm(x - ref))
    return math.inf if err == 0 else 20.0 * math.log10(float(np.linalg.norm(ref)) / err)


def _case(traces, grid, pixels_per_thread, velocity, name):
    from sarmotion.imaging import point_response
    from sarmotion.imaging.cuda import backproject_cuda, error_bound

    img = backproject_cuda(traces, grid, velocity_mps=velocity, pixels_per_thread=pixels_per_thread)
    p = img.metadata["pixels_per_thread"]
    gx, gy = np.meshgrid(grid.x_m, grid.y_m)
    pts = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
    exact = point_response(traces, pts, velocity_mps=velocity).reshape(grid.shape)
    spectrum = traces.phase_history()
    sup = float(np.sum(np.abs(spectrum))) / traces.n_samples  # sum_j sum_k |P_jk| / n
    r_max = float(np.max(np.linalg.norm(traces.positions_m, axis=1))) + 1e3
    eps = error_bound(
        8, traces.radar.carrier_hz, grid.spacing_m[1], p, traces.n_pulses, range_m=r_max
    )
    return {
        "name": name,
        "pixels_per_thread": p,
        "max_error": float(np.max(np.abs(img.values - exact))),
        "bound": eps * sup,
        "ser_db": _ser_db(exact, img.values),
        "signal": float(np.max(np.abs(exact))),
    }


def _simulated(look_deg, seed, extent_m):
    """Eight pulses of six points and a mover in a square of ``extent_m``, 20 dB SNR."""
    from sarmotion.core import Trajectory
    from sarmotion.simulation import random_scene, simulate

    mover = [((0.2 * extent_m, -0.2 * extent_m), (6.0, 2.0))]
    scene = random_scene(n_stationary=6, extent_m=extent_m, movers=mover, rng=seed)
    trajectory = Trajectory.circular(centre_azimuth_deg=look_deg, n_pulses=8)
    return simulate(scene, trajectory=trajectory, snr_db=20.0, rng=seed).traces


def _ffbp_traces(look_deg, n_pulses, seed, centre=(0.0, 0.0), spread_m=15.0):
    """Six points within ``spread_m`` of ``centre`` and a mover there, 4 degrees, 20 dB SNR."""
    from sarmotion.core import Trajectory
    from sarmotion.simulation import PointTarget, Scene, add_noise, simulate

    rng = np.random.default_rng(seed)
    targets = [
        PointTarget(position_m=tuple(np.add(centre, rng.uniform(-spread_m, spread_m, 2))),
                    reflectivity=complex(*rng.normal(size=2)))
        for _ in range(6)
    ] + [PointTarget(position_m=tuple(centre), velocity_mps=(10.0, 5.0))]  # fmt: skip
    trajectory = Trajectory.circular(aperture_deg=4.0, centre_azimuth_deg=look_deg,
                                     n_pulses=n_pulses)  # fmt: skip
    tr = simulate(Scene(name="ffbp", targets=targets), trajectory=trajectory).traces
    return tr.with_data(add_noise(tr.data, snr_db=20.0, rng=seed))


def _ffbp_cases() -> list[dict]:
    """Every FFBP case on the GPU (and its path on the CPU), against the exact sum."""
    from sarmotion.imaging import ImageGrid, backproject, ffbp
    from sarmotion.imaging.cuda import backproject_cuda
    from sarmotion.imaging.exact_sum import exact_sum

    ffbp._ROTATED_BUDGET = 1e3  # the rotated path at these sizes
    results = []
    for k, (name, look, n_pulses, centre, side, spacing, velocity, _) in enumerate(FFBP_CASES):
        traces = _ffbp_traces(look, n_pulses, seed=6100 + k, centre=centre, spread_m=side / 2)
        grid = ImageGrid.square(centre_m=centre, size_m=side, spacing_m=spacing)
        cpu = backproject(traces, grid, method="ffbp", velocity_mps=velocity)
        gpu = backproject_cuda(traces, grid, method="ffbp", velocity_mps=velocity)
        again = backproject_cuda(traces, grid, method="ffbp", velocity_mps=velocity)
        gx, gy = np.meshgrid(grid.x_m, grid.y_m)
        exact = exact_sum(traces, np.stack([gx, gy], axis=-1), velocity_mps=velocity)
        info = gpu.metadata["ffbp"]
        results.append({
            "name": name,
            "cpu_path": cpu.metadata.get("ffbp", {}).get("path"),
            "path": info["path"],
            "variant": gpu.metadata["kernel_variant"],
            "exact_pixels": info.get("exact_pixels", 0),
            "budget_db": info.get("budget_db"),
            "ser_db": _ser_db(exact, gpu.values),
            "repeatable": bool(np.array_equal(gpu.values, again.values)),
        })  # fmt: skip
    return results


def _device_tables() -> list[dict]:
    """The table built on the device against the host's, per pulse (errors over S_j)."""
    from sarmotion.imaging._cuda_table import build_table, entry_error
    from sarmotion.imaging.cuda import _cuda

    rng = np.random.default_rng(91)
    rows = []
    for n, upsample in ((24, 4), (25, 8), (9, 3), (13, 4)):  # 13 bins padded to 14
        data = rng.standard_normal((3, n)) + 1j * rng.standard_normal((3, n))
        data[1] *= 1e3  # pulses of very different levels: the bound is per pulse
        host = hermite_table(data, upsample).astype(np.float64)
        dev = build_table(_cuda(), data, upsample).copy_to_host()
        dev = dev.view(np.float32).reshape(host.shape).astype(np.float64)
        spectrum = np.fft.fftshift(np.fft.fft(np.fft.ifftshift(data, axes=-1), axis=-1), axes=-1)
        s_j = np.sum(np.abs(spectrum), axis=1) / n  # S_j
        err_v = np.max(np.abs(dev[..., :2] - host[..., :2]), axis=(1, 2)) / s_j
        err_d = np.max(np.abs(dev[..., 2:] - host[..., 2:]), axis=(1, 2)) / s_j
        # both tables are rounded to float32 once: 2^-24 of the largest entry each
        rounding = 2.0 * 2.0**-24 * np.max(np.abs(host), axis=(1, 2)) / s_j
        rows.append({"n": n, "upsample": upsample, "err_v": err_v.tolist(),
                     "err_d": err_d.tolist(), "rounding": rounding.tolist(),
                     "bound": entry_error(),
                     "repeat_equal": bool(np.array_equal(dev[:, -1], dev[:, 0]))})  # fmt: skip
    return rows


def run_simulator(out: Path, gotcha_dir: str | None) -> None:
    """Run every case under the simulator; write the results as JSON to ``out``."""
    assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
    from sarmotion.imaging import ImageGrid, backproject

    results = []
    for k, (name, look, spacing, p, velocity) in enumerate(SIM_CASES):
        grid = ImageGrid.square(size_m=12 * spacing, spacing_m=spacing)
        traces = _simulated(look, seed=5100 + k, extent_m=10 * spacing)  # targets in the grid
        results.append(_case(traces, grid, p, velocity, name))
    # Outside the fast-time window (+-51 m of slant range, ~+-72 m of ground range).
    traces = _simulated(0.0, seed=5200, extent_m=4.0)
    far = ImageGrid.from_extent(x_range_m=(90.0, 120.0), y_range_m=(-6.0, 6.0), spacing_m=2.0)
    from sarmotion.imaging.cuda import backproject_cuda

    outside = {
        "name": "outside",
        "gpu_max": float(np.max(np.abs(backproject_cuda(traces, far).values))),
        "cpu_max": float(np.max(np.abs(backproject(traces, far).values))),
    }
    # Traces changed in place after a first image: the second image uses the new data.
    traces = _simulated(30.0, seed=5300, extent_m=2.0)
    grid = ImageGrid.square(size_m=2.4, spacing_m=0.2)
    backproject_cuda(traces, grid)
    traces.data[: traces.n_pulses // 2] *= -2.0j
    changed = _case(traces, grid, None, None, "changed_in_place")
    # The command line with --device cuda, against the exact sum of the same inputs.
    from sarmotion.cli.inputs import read_inputs
    from sarmotion.cli.main import run
    from sarmotion.imaging import point_response
    from sarmotion.io import load_image

    cli_out = out.parent / "cli"
    code = run(["image", "hyperbola", "--out", str(cli_out), "--device", "cuda", "--size",
                "2.4", "--spacing", "0.2"])  # fmt: skip
    image = load_image(cli_out / "image.h5")
    gx, gy = np.meshgrid(image["x_m"], image["y_m"])
    traces, _ = read_inputs(["hyperbola"])
    exact = point_response(traces, np.stack([gx.ravel(), gy.ravel(), 0 * gx.ravel()], axis=1))
    cli = {"code": code, "ser_db": _ser_db(exact.reshape(gx.shape), image["values"])}
    # --method ffbp on a grid too small to factorise: exact on the GPU, recorded as such.
    code = run(["image", "hyperbola", "--out", str(cli_out), "--device", "cuda", "--size",
                "2.4", "--spacing", "0.2", "--method", "ffbp", "--force"])  # fmt: skip
    image = load_image(cli_out / "image.h5")
    cli["ffbp"] = {"code": code, "imaging": image["metadata"]["imaging"],
                   "ser_db": _ser_db(exact.reshape(gx.shape), image["values"])}  # fmt: skip
    if gotcha_dir is not None:
        from sarmotion.io import read_gotcha

        files = sorted(Path(gotcha_dir).glob("data_3dsar_pass1_az00*_HH.mat"))
        traces = read_gotcha(files).select_pulses(0, 8)
        grid = ImageGrid.square(centre_m=(3.0, -2.0), size_m=1.6, spacing_m=0.1)
        results.append(_case(traces, grid, None, None, "gotcha"))
        results.append(_case(traces, grid, 1, None, "gotcha_p1"))  # the float64 path alone
    results.append(changed)
    out.write_text(json.dumps({"cases": results, "outside": outside, "cli": cli,
                               "ffbp": _ffbp_cases(), "tables": _device_tables(),
                               "banding": _banding()}))  # fmt: skip


def _banding() -> dict:
    """Row bands against one launch (the simulator sets no minimum of threads per band).

    41 rows at 2 pixels per thread: three bands of 16, 16 and 9 rows, the last thread of
    the last band holding one pixel, as in one launch.
    """
    from sarmotion.imaging import ImageGrid
    from sarmotion.imaging import cuda as gpu

    traces = _simulated(0.0, seed=5400, extent_m=1.0)
    grid = ImageGrid.from_extent(x_range_m=(-0.5, 0.5), y_range_m=(-2.0, 2.0), spacing_m=0.1)
    banded = gpu.backproject_cuda(traces, grid, pixels_per_thread=2).values
    out, _ = gpu._image_on_device(gpu._cuda(), traces, grid, np.zeros(3), 8, 2)
    single = out.copy_to_host().view(np.complex128)[..., 0]
    bands = gpu.row_bands(grid.shape[0], grid.shape[1], 2, gpu.BLOCK_ROWS, 0)
    try:  # float32 sums past 3.4e38
        gpu.backproject_cuda(traces.with_data(traces.data * 1e38), grid)
        overflow = ""
    except ValueError as err:
        overflow = str(err)
    return {"bands": bands, "rows": grid.shape[0], "equal": bool(np.array_equal(banded, single)),
            "overflow": overflow}  # fmt: skip


# ================================================================== the tests (pytest)
def _simulate_in_subprocess(tmp_path: Path, gotcha_dir: Path | None) -> dict:
    out = tmp_path / "cuda_sim.json"
    # The script imports ``conftest`` from the tests' root, as pytest does.
    tests = str(Path(__file__).resolve().parents[1])
    path = os.pathsep.join(p for p in (tests, os.environ.get("PYTHONPATH")) if p)
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1", PYTHONPATH=path)
    args = [sys.executable, __file__, str(out)] + ([str(gotcha_dir)] if gotcha_dir else [])
    proc = subprocess.run(args, env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(out.read_text())


@pytest.fixture(scope="module")
def simulated(tmp_path_factory) -> dict:
    if importlib.util.find_spec("numba.cuda") is None:
        pytest.skip("numba.cuda is absent (numba without CUDA support and no numba-cuda)")
    return _simulate_in_subprocess(tmp_path_factory.mktemp("cuda_sim"), gotcha_directory())


def _case_named(simulated, name, request):
    if name.startswith("gotcha"):
        request.getfixturevalue("gotcha_dir")  # skips, or fails in CI, without the data
    return {c["name"]: c for c in simulated["cases"]}[name]


CASE_NAMES = [c[0] for c in SIM_CASES] + ["changed_in_place", "gotcha", "gotcha_p1"]


@pytest.mark.parametrize("name", CASE_NAMES)
def test_every_pixel_within_the_stated_bound(simulated, name, request):
    case = _case_named(simulated, name, request)
    assert case["signal"] > 0
    assert case["max_error"] <= case["bound"], case


@pytest.mark.parametrize("name", CASE_NAMES)
def test_signal_to_error_against_the_exact_sum(simulated, name, request):
    case = _case_named(simulated, name, request)
    assert case["ser_db"] >= MIN_SER_DB, case


def test_the_cases_cover_every_pixels_per_thread(simulated):
    used = {c["name"]: c["pixels_per_thread"] for c in simulated["cases"]}
    assert used["look0"] == 4 and used["look30"] == 8 and used["look45_p2"] == 2


def test_command_line_device_cuda(simulated):
    cli = simulated["cli"]
    assert cli["code"] == 0
    assert cli["ser_db"] >= MIN_SER_DB
    ffbp = cli["ffbp"]
    assert ffbp["code"] == 0 and ffbp["ser_db"] >= MIN_SER_DB
    assert ffbp["imaging"] == {"method": "ffbp", "kernel_variant": "cuda-hermite",
                               "device": "cuda", "ffbp_path": "exact"}  # fmt: skip


def test_zero_outside_the_fast_time_window_like_the_cpu(simulated):
    out = simulated["outside"]
    assert out["gpu_max"] == 0.0
    assert out["cpu_max"] == 0.0


@pytest.mark.parametrize("case", FFBP_CASES, ids=[c[0] for c in FFBP_CASES])
def test_ffbp_on_the_gpu_reaches_its_accuracy(simulated, case):
    from sarmotion.imaging.ffbp import BUDGET_MARGIN_DB, TARGET_DB

    got = {c["name"]: c for c in simulated["ffbp"]}[case[0]]
    assert got["path"] == got["cpu_path"] == case[-1], got
    assert got["variant"] == "cuda-ffbp"
    assert got["ser_db"] >= TARGET_DB, got
    assert got["ser_db"] >= got["budget_db"] - BUDGET_MARGIN_DB, got
    assert got["repeatable"]  # the second image reuses the plan and its device arrays


def test_row_bands_give_the_image_of_one_launch(simulated):
    banding = simulated["banding"]
    assert len(banding["bands"]) > 1
    assert banding["bands"][0][0] == 0 and banding["bands"][-1][1] == banding["rows"]
    assert banding["equal"]


def test_an_overflowing_gpu_image_is_refused(simulated):
    assert "NaN or infinite" in simulated["banding"]["overflow"]


@pytest.mark.parametrize(
    "ny, nx, p", [(4096, 4096, 8), (2048, 2048, 8), (1000, 37, 2), (7, 5, 1), (448, 4000, 8)]
)
@pytest.mark.parametrize("min_threads", [0, 135168])
def test_row_bands_tile_the_rows_in_whole_blocks(ny, nx, p, min_threads):
    bands = row_bands(ny, nx, p, BLOCK_ROWS, min_threads)
    assert 1 <= len(bands) <= MAX_BANDS
    assert bands[0][0] == 0 and bands[-1][1] == ny
    assert all(a[1] == b[0] for a, b in zip(bands[:-1], bands[1:], strict=True))
    assert all(r0 % (BLOCK_ROWS * p) == 0 and r1 > r0 for r0, r1 in bands)
    if len(bands) > 1 and min_threads:  # every band fills half the GPU
        assert all((r1 - r0) * nx / p >= min_threads for r0, r1 in bands)


def test_a_small_image_is_one_band():
    assert row_bands(1024, 1024, 4, BLOCK_ROWS, 135168) == [(0, 1024)]


def test_table_built_on_the_device_within_its_bound(simulated):
    # Each value within 2^-19 S_j of the exact table (the host's, float64 FFTs, within
    # float32 rounding of it), h D' within 2^-19 (pi / U) S_j; position N repeats 0.
    for row in simulated["tables"]:
        for ev, ed, r in zip(row["err_v"], row["err_d"], row["rounding"], strict=True):
            assert ev <= row["bound"] + r, row
            assert ed <= row["bound"] * math.pi / row["upsample"] + r, row
        assert row["repeat_equal"]


def test_ffbp_cases_cover_the_window_ends(simulated):
    exact = {c["name"]: c["exact_pixels"] for c in simulated["ffbp"]}
    assert exact["ffbp_window_end"] > 0
    assert exact["ffbp_look0"] == 0


# ------------------------------------------------------------------ without the simulator
@pytest.mark.parametrize("n", [24, 26])
def test_table_holds_the_band_limited_trace_and_its_derivative(n):
    # 24 bins are a fast length; 26 = 2 x 13 are padded to 27 (table_samples): the same
    # trace over the same period on 4 x 27 points
    rng = np.random.default_rng(77)
    upsample = 4
    data = rng.standard_normal((3, n)) + 1j * rng.standard_normal((3, n))
    table = hermite_table(data, upsample)
    big = table_samples(n, upsample)
    assert big == upsample * {24: 24, 26: 27}[n]
    assert table.shape == (3, big + 1, 4)
    np.testing.assert_array_equal(table[:, big], table[:, 0])
    # D(t) = (1/n) sum_k P_k exp(2i pi (k - n//2) t / (n dt)), t = (m - big//2) n dt / big.
    spec = np.fft.fftshift(np.fft.fft(np.fft.ifftshift(data, axes=-1), axis=-1), axes=-1)
    freq = np.arange(n) - n // 2
    m = np.arange(big)
    phase = np.exp(2j * np.pi * np.outer(m - big // 2, freq) / big)  # (big, n)
    value = spec @ phase.T / n
    slope = spec @ (phase * (2j * np.pi * freq / big)).T / n
    scale = np.max(np.abs(value))
    got_v = table[:, :big, 0] + 1j * table[:, :big, 1]
    got_d = table[:, :big, 2] + 1j * table[:, :big, 3]
    # float32 storage: half an ulp of the largest value, 2^-24 relative.
    assert np.max(np.abs(got_v - value)) <= 2.0**-23 * scale
    assert np.max(np.abs(got_d - slope)) <= 2.0**-23 * np.max(np.abs(slope))
    if big == upsample * n:  # the samples at the original instants are the data themselves
        np.testing.assert_allclose(got_v[:, big // 2 - upsample * (n // 2) :: upsample], data,
                                   atol=2.0**-22 * scale)  # fmt: skip


@pytest.mark.parametrize("carrier_hz", [1.0e9, 9.6e9, 35e9])
@pytest.mark.parametrize("spacing_m", [0.01, 0.1, 0.25, 0.5, 2.0])
def test_pixels_per_thread_keep_the_phase_bound(carrier_hz, spacing_m):
    per_m = 2 * math.pi * (2 * carrier_hz / C) * 10 * 2.0**-24
    p = rows_per_thread(carrier_hz, spacing_m)
    assert p in (1, 2, 4, 8)
    if p > 1:
        assert per_m * (p - 1) / 2 * spacing_m <= 1e-4
    if p < 8:  # the next larger count breaks the bound
        assert per_m * (2 * p - 1) / 2 * spacing_m > 1e-4
    # occupancy: fewer pixels per thread when the image is small
    q = rows_per_thread(carrier_hz, spacing_m, n_pixels=1000, min_threads=400)
    assert q <= min(p, 2)


def test_numpy_alias_is_in_place_before_numba_cuda_is_imported():
    # numpy 2.5 has no np.row_stack, which numba-cuda 0.30 uses at import: remove it and
    # record whether it is back when numba.cuda is first imported.
    code = """
import importlib.abc, sys
import numpy as np
vars(np).pop("row_stack", None)
served = getattr(np, "__getattr__", None)
def hide(name):  # numpy 2.x serves the deprecated name from its module __getattr__
    if name == "row_stack" or served is None:
        raise AttributeError(name)
    return served(name)
np.__getattr__ = hide
np.__all__ = [n for n in np.__all__ if n != "row_stack"]
assert not hasattr(np, "row_stack")
seen = []
class Watch(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "numba.cuda":
            seen.append(hasattr(np, "row_stack"))
sys.meta_path.insert(0, Watch())
from sarmotion.imaging import cuda
cuda.available()
print(seen)
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip() == "[True]"


def test_no_gpu_gives_one_line():
    from sarmotion.imaging import ImageGrid
    from sarmotion.imaging.cuda import backproject_cuda
    from sarmotion.simulation import load_scene, simulate

    if available():
        pytest.skip("a CUDA device (or the simulator) is present")
    traces = simulate(load_scene("scene1")).traces
    with pytest.raises(RuntimeError) as err:
        backproject_cuda(traces, ImageGrid.square(size_m=4.0, spacing_m=1.0))
    message = str(err.value)
    assert message.startswith(NEEDS)
    assert "\n" not in message


def test_command_line_without_gpu_one_line_exit_2(tmp_path, capsys):
    from sarmotion.cli.main import EXIT_BAD_INPUT, run

    if available():
        pytest.skip("a CUDA device (or the simulator) is present")
    out = tmp_path / "img"
    code = run(["image", "hyperbola", "--out", str(out), "--device", "cuda"])
    err = capsys.readouterr().err
    assert code == EXIT_BAD_INPUT
    assert err.count("\n") == 1 and NEEDS in err
    assert not out.exists()


if __name__ == "__main__":
    run_simulator(Path(sys.argv[1]), sys.argv[2] if len(sys.argv) > 2 else None)
