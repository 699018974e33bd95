"""The fast imaging paths against their slow references: the float32 tile kernel against the
float64 numpy reference, fast factorised backprojection against exact backprojection,
the cache of upsampled traces. No timing here (see benchmarks/bench_backprojection.py)."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from llvmlite import binding as llvm

from sarmotion.core import Trajectory
from sarmotion.imaging import (
    ImageGrid,
    _bp_kernels,
    _bp_table,
    _ffbp_kernels,
    _simd,
    backproject,
    ffbp,
)
from sarmotion.imaging._block_pool import BLOCK_GRANULE, BlockPool
from sarmotion.imaging._bp_common import kernel_constants, table_samples
from sarmotion.imaging._simd import LANES
from sarmotion.imaging.ffbp import half_sample_filter
from sarmotion.io import read_gotcha
from sarmotion.simulation import PointTarget, Scene, add_noise, simulate


def _ser_db(ref: np.ndarray, x: np.ndarray) -> float:
    err = np.linalg.norm(x - ref)
    return math.inf if err == 0 else 20.0 * math.log10(np.linalg.norm(ref) / err)


def _scene(aperture_deg: float = 4.0, centre_azimuth_deg: float = 0.0, **traj):
    targets = [
        PointTarget(position_m=(7.3, -4.1)),
        PointTarget(position_m=(-20.0, 15.0), reflectivity=0.5j),
        PointTarget(position_m=(30.0, 25.0), reflectivity=-0.7),
        PointTarget(position_m=(0.0, 0.0), velocity_mps=(10.0, 5.0)),
    ]
    trajectory = Trajectory.circular(
        aperture_deg=aperture_deg, centre_azimuth_deg=centre_azimuth_deg, **traj
    )
    tr = simulate(Scene(name="fast", targets=targets), trajectory=trajectory).traces
    return tr.with_data(add_noise(tr.data, snr_db=20.0, rng=7))


@pytest.fixture(scope="module")
def four_degrees():
    return _scene()


# --------------------------------------------------------------- float32 kernel
@pytest.mark.parametrize("spacing_m", [0.25, 1.0])
@pytest.mark.parametrize("velocity", [None, (11.0, -6.5)])
def test_float32_kernel_matches_the_numpy_reference(four_degrees, spacing_m, velocity):
    # 0.25 m: 32 x 64 tiles of 8 x 16 m; 1 m: tiles of 64 m, the largest phase offsets the
    # bounds allow. Partial tiles on both axes (90 x 70 pixels).
    grid = ImageGrid.from_extent(
        x_range_m=(-45 * spacing_m, 44.5 * spacing_m),
        y_range_m=(-30 * spacing_m, 39.5 * spacing_m),
        spacing_m=spacing_m,
    )
    fast = backproject(four_degrees, grid, velocity_mps=velocity)
    assert fast.metadata["kernel_variant"] == "numba-float32"
    ref = backproject(four_degrees, grid, velocity_mps=velocity, kernel="numpy").values
    # Same interpolation, float32 against float64: the float32 errors bounded in
    # sarmotion.imaging.backprojection stay ~20 dB under the interpolation's; >= 100 dB.
    assert _ser_db(ref, fast.values) >= 100.0


@pytest.mark.gotcha
def test_float32_kernel_on_gotcha(gotcha_files):
    tr = read_gotcha(gotcha_files)
    grid = ImageGrid.square(size_m=24.0, spacing_m=0.25)
    fast = backproject(tr, grid).values
    ref = backproject(tr, grid, kernel="numpy").values
    assert _ser_db(ref, fast) >= 100.0  # as above


@pytest.mark.parametrize(
    ("look_deg", "spacing_m", "path"),
    [(0.0, 0.25, "window, lanes along y"), (90.0, 0.25, "window, lanes along x"),
     (45.0, 1.0, "gathers")],
)  # fmt: skip
def test_float32_kernel_reads_the_table_by_windows_or_gathers(look_deg, spacing_m, path):
    # The table is read by windows of 2 LANES entries where neighbouring lanes read
    # neighbouring entries, else gathered (sarmotion.imaging._simd); the lanes run along
    # the axis where the range changes slowest. Every path sums the same pieces.
    tr = _scene(centre_azimuth_deg=look_deg)
    grid = ImageGrid.from_extent(x_range_m=(-45 * spacing_m, 44.5 * spacing_m),
                                 y_range_m=(-40 * spacing_m, 39.5 * spacing_m),
                                 spacing_m=spacing_m)  # fmt: skip
    n_up = table_samples(tr.n_samples, 6)
    consts = kernel_constants(tr.radar.sample_interval_s, tr.radar.carrier_hz, tr.n_samples,
                              n_up)  # fmt: skip
    span_x, span_y = _bp_kernels.lane_spans(tr.positions_m, grid.x_m, grid.y_m, consts[0])
    if path == "gathers":  # the premise: no axis keeps the lanes within a window
        assert min(span_x, span_y) > 2 * LANES
    else:
        assert min(span_x, span_y) < LANES / 2
        assert (span_y < span_x) == path.endswith("along y")
    fast = backproject(tr, grid)
    assert fast.metadata["kernel_variant"] == "numba-float32"
    ref = backproject(tr, grid, kernel="numpy").values
    assert _ser_db(ref, fast.values) >= 100.0  # as in the test above


def test_inner_loop_ir_with_and_without_windows():
    # Every variant of the inner loop is valid IR (the window paths need AVX-512 or AVX2;
    # other CPUs compile the gathers alone); the unchecked window variants have no gathers.
    for isa, checked in ((None, True), ("avx512", True), ("avx512", False), ("avx2", True),
                         ("avx2", False)):  # fmt: skip
        ir = _simd._build_ir(isa=isa, checked=checked)
        llvm.parse_assembly(ir).verify()
        assert ("vpermi2var" in ir) == (isa == "avx512")
        assert ("avx2.permps" in ir) == (isa == "avx2")
        assert ("@llvm.masked.gather" in ir.split("declare")[0]) == checked
    with pytest.raises(ValueError, match="instruction set"):
        _simd._build_ir(isa="sse2")


# One pulse on one tile through tile_pulse, in a fresh interpreter whose numba compiles for
# the CPU named in its environment; prints the instruction set chosen and writes the sums
# (checked and unchecked variants) of seeded rows whose lanes span a given number of table
# entries each, and the inner loop's assembly.
_ONE_PULSE_SCRIPT = """
import sys
import numba
import numpy as np
from sarmotion.imaging import _simd

@numba.njit
def one(tab, nxv, nyv, txv, tyv, scalars, windowed):
    acc_re = np.zeros(nyv.size * nxv.size, np.float32)
    acc_im = np.zeros(nyv.size * nxv.size, np.float32)
    f0, i0f, a1, a2, a3, a4, si, sq, hi = scalars
    _simd.tile_pulse(nxv, nyv, txv, tyv, tab, 0, acc_re, acc_im, nxv.size, nyv.size, nxv.size,
                     tab.shape[1] // 8, f0, i0f, a1, a2, a3, a4, si, sq, hi, windowed)
    return acc_re + 1j * acc_im.astype(np.complex128)

rng = np.random.default_rng(11)
n_up = 2000
tab = rng.standard_normal((1, 8 * (n_up + 2 + 32))).astype(np.float32)
out = {}
for per_lane in (0.05, -0.15, 0.3, 0.45, 1.0, 3.0):
    nxv = (np.arange(4 * 16) * per_lane * 0.04).astype(np.float32)
    nyv = (np.arange(8) * 0.04).astype(np.float32)
    txv = rng.uniform(-2, 2, nxv.size).astype(np.float32)
    tyv = rng.uniform(-2, 2, nyv.size).astype(np.float32)
    s = np.array([0.3, 1000.0, 1.0, -1e-5, 0.0, 0.0, 25.0, 0.7, n_up], np.float32)
    out[f"checked {per_lane}"] = one(tab, nxv, nyv, txv, tyv, s, False)
    out[f"unchecked {per_lane}"] = one(tab, nxv, nyv, txv, tyv, s, True)
np.savez(sys.argv[1], **out)
asm = "".join(one.inspect_asm().values())
open(sys.argv[2], "w").write(asm)
print(_simd.ISA)
"""


def _one_pulse_in(tmp_path, name: str, cpu: str, features: str = "") -> tuple[str, dict, str]:
    import os
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_CPU_NAME=cpu, NUMBA_CPU_FEATURES=features)
    sums, asm = tmp_path / f"{name}.npz", tmp_path / f"{name}.s"
    proc = subprocess.run([sys.executable, "-c", _ONE_PULSE_SCRIPT, str(sums), str(asm)],
                          env=env, capture_output=True, text=True, timeout=600)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    with np.load(sums) as f:
        return proc.stdout.strip(), dict(f), asm.read_text()


def _function_asm(asm: str, name: str) -> str:
    start = asm.index(name + ":")
    return asm[start : asm.index(".Lfunc_end", start)]


def test_avx2_window_read_matches_the_gathers():
    # numba compiling for Haswell (AVX2, no AVX-512: NUMBA_CPU_NAME=haswell with the
    # features LLVM gives it) reads the table by 8-entry windows and vpermps, with no
    # 512-bit register; for AVX with FMA but no AVX2 (Sandy Bridge with FMA: the same
    # fused products) it gathers alone. Both sum the same pieces with the same arithmetic
    # (bit for bit here; one float32 rounding of the sums' scale allowed): the checked
    # variants at every lane span (windows where they fit, gathers where not), the
    # unchecked AVX2 variant where the window holds a step's lanes (up to 0.45 entries a
    # lane: 3.2 entries over 8 lanes). Where it does not, the unchecked variant reads
    # other entries and its sums move by the table's own scale.
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        isa, avx2, asm = _one_pulse_in(Path(d), "haswell", "haswell")
        generic_isa, generic, _ = _one_pulse_in(Path(d), "generic", "sandybridge", "+fma")
    assert isa == "avx2" and generic_isa == "None"
    for name in (_simd._function_name(LANES, "avx2", True),
                 _simd._function_name(LANES, "avx2", False)):  # fmt: skip
        body = _function_asm(asm, name)
        assert "zmm" not in body and "vpermt2ps" not in body and "vpermi2ps" not in body
        assert body.count("vpermps") + body.count("vpermd") == 16  # 8 planes, 2 halves
        if name.endswith("windowed_avx2"):
            assert "gather" not in body
    for key, ref in generic.items():
        scale = np.max(np.abs(ref))
        assert scale > 0.1
        error = np.max(np.abs(avx2[key] - ref))
        if key.startswith("unchecked") and abs(float(key.split()[1])) > 0.45:
            assert error > 0.1 * scale, key  # not a case the kernel runs
        else:
            assert error <= 2.0**-24 * scale, key


@numba.njit
def _one_pulse(tab, nxv, nyv, txv, tyv, scalars, windowed):
    acc_re = np.zeros(nyv.size * nxv.size, np.float32)
    acc_im = np.zeros(nyv.size * nxv.size, np.float32)
    f0, i0f, a1, a2, a3, a4, si, sq, hi = scalars
    _simd.tile_pulse(nxv, nyv, txv, tyv, tab, 0, acc_re, acc_im, nxv.size, nyv.size, nxv.size,
                     tab.shape[1] // 8, f0, i0f, a1, a2, a3, a4, si, sq, hi, windowed)  # fmt: skip
    return acc_re, acc_im


def test_the_unchecked_window_variant_sums_the_same_pieces():
    # Where every step's lanes lie in their window, the variant without the check reads
    # the same entries and sums the same expressions as the checked one: equal to float32
    # rounding (the compiler may contract the two functions' products differently).
    rng = np.random.default_rng(7)
    n_up = 2000
    tab = rng.standard_normal((1, 8 * (n_up + 2 + 32))).astype(np.float32)
    nxv = (np.arange(4 * LANES) * 2e-3).astype(np.float32)  # 0.05 entries per lane
    nyv = (np.arange(8) * 0.04).astype(np.float32)  # one entry per row
    txv = rng.uniform(-2, 2, nxv.size).astype(np.float32)
    tyv = rng.uniform(-2, 2, nyv.size).astype(np.float32)
    scalars = np.array([0.3, 1000.0, 1.0, -1e-5, 0.0, 0.0, 25.0, 0.7, n_up], np.float32)
    checked = _one_pulse(tab, nxv, nyv, txv, tyv, scalars, False)
    unchecked = _one_pulse(tab, nxv, nyv, txv, tyv, scalars, True)
    a = checked[0] + 1j * checked[1].astype(np.complex128)
    b = unchecked[0] + 1j * unchecked[1].astype(np.complex128)
    scale = np.max(np.abs(a))
    assert scale > 0.1
    assert np.max(np.abs(a - b)) <= 4 * 2.0**-24 * scale
    # one entry off in the window would move a value by the table's own scale
    shifted = _one_pulse(tab[:, 1:].copy(), nxv, nyv, txv, tyv, scalars, True)
    assert np.max(np.abs(shifted[0] - unchecked[0])) > 0.1 * scale


def _step_floors_fit_the_window(q: np.ndarray, hi: float) -> bool:
    """Whether every LANES-pixel step of rows ``q`` (table positions) reads its window.

    Both windows: AVX-512's (``2 LANES`` entries from 4 below the smaller end lane's entry)
    and AVX2's (per 8 lanes, 8 entries from 3 below the smaller of their end lanes' entries).
    """
    ix = np.floor(q).astype(np.int64)
    if ix.min() < 1 or ix.max() >= hi:
        return False
    fits = True
    for width, margin, window in ((LANES, 4, 2 * LANES), (8, 3, 8)):
        steps = ix.reshape(ix.shape[0], -1, width)
        mn = np.maximum(np.minimum(steps[..., 0], steps[..., -1]) - margin, 0)[..., None]
        fits &= bool(np.all((steps >= mn) & (steps < mn + window)))
    return fits


def test_the_unchecked_window_variant_is_chosen_only_where_every_step_fits():
    # lanes_in_window's bounds (the tile within h of its anchor, the range's change along
    # a step) hold against the float64 table positions of every pixel of seeded tiles:
    # when it says yes, every step's lanes lie in the window they read.
    rng = np.random.default_rng(2031)
    idx_scale, hi = 25.0, 2600.0  # entries per metre, the table's end
    chosen = refused = 0
    for _ in range(400):
        nr, ncp = int(rng.choice([4, 8, 16, 32])), LANES * int(rng.integers(1, 5))
        dx, dy = rng.choice([0.01, 0.05, 0.2, 0.5], size=2) * rng.choice([-1.0, 1.0], size=2)
        c0, r0 = 0, 0
        cc, rc = ncp // 2 - int(rng.integers(0, 2)), nr // 2
        antenna = rng.normal(0.0, 1.0, 3) * [8000.0, 8000.0, 500.0] + [0.0, 0.0, 6000.0]
        ref = np.linalg.norm(antenna) + rng.uniform(-60.0, 60.0)
        cols = (np.arange(ncp) - cc) * dx
        rows = (np.arange(nr) - rc) * dy
        offset = rng.uniform(-50.0, 50.0, 2)  # the anchor pixel's position
        px = offset[0] + cols[None, :] - antenna[0]
        py = offset[1] + rows[:, None] - antenna[1]
        r = np.sqrt(px**2 + py**2 + antenna[2] ** 2)
        q = (r - ref) * idx_scale + hi / 2
        q0 = q[rc, cc]
        hx = max(cc - c0, c0 + ncp - 1 - cc) * abs(dx)
        hy = max(rc - r0, r0 + nr - 1 - rc) * abs(dy)
        h = np.hypot(hx, hy)
        lane_run = (LANES - 1) * abs(dx) * idx_scale
        ok = _simd.lanes_in_window(
            q0, r[rc, cc], abs(px[0, cc]), h, hx, lane_run, h * idx_scale + 1.0, hi
        )
        if ok:
            chosen += 1
            assert _step_floors_fit_the_window(q, hi)
        else:
            refused += 1
    assert chosen > 50 and refused > 50  # both sides drawn


def test_window_edge_mask_skips_only_blocks_without_edges(four_degrees):
    # The mask of pixels near an end of the fast-time window, computed block by block with
    # the range's extremes over each block first, equals the pixel-by-pixel test.
    tr = four_degrees
    n_up = table_samples(tr.n_samples, 6)
    consts = kernel_constants(tr.radar.sample_interval_s, tr.radar.carrier_hz, tr.n_samples,
                              n_up)  # fmt: skip
    d_lo = (1.0 - consts[1]) / consts[0]
    d_hi = (n_up - consts[1]) / consts[0]
    half = 2.0 * max(-d_lo, d_hi)  # ground metres: the window's ends cross the grid
    x = np.arange(-half, half, 0.7)
    y = np.arange(-half, half, 0.9)[::-1].copy()
    p = tr.positions_m[:: max(1, tr.n_pulses // 5)]
    ref = np.linalg.norm(p - tr.reference_point_m, axis=1)
    margin = 0.5
    mask = _ffbp_kernels.window_edges(x, y, p[:, 0].copy(), p[:, 1].copy(), p[:, 2] ** 2, ref,
                                      d_lo, d_hi, margin)  # fmt: skip
    d = np.sqrt((x[None, None, :] - p[:, 0, None, None]) ** 2
                + (y[None, :, None] - p[:, 1, None, None]) ** 2
                + p[:, 2, None, None] ** 2) - ref[:, None, None]  # fmt: skip
    lo = d.min(axis=0) - margin
    hi = d.max(axis=0) + margin
    want = ((lo <= d_lo) & (d_lo <= hi)) | ((lo <= d_hi) & (d_hi <= hi))
    assert 0 < want.sum() < want.size  # the premise: edges and blocks without them
    np.testing.assert_array_equal(mask, want)


def test_near_range_geometry_uses_the_float64_kernel():
    # Antenna 300 m from the scene: the range series cannot be bounded on any tile, and
    # the float64 kernel takes over, with the same accuracy.
    tr = _scene(aperture_deg=4.0, altitude_m=200.0, ground_radius_m=250.0)
    grid = ImageGrid.square(size_m=20.0, spacing_m=0.5)
    img = backproject(tr, grid)
    assert img.metadata["kernel_variant"] == "numba-float64"
    ref = backproject(tr, grid, kernel="numpy").values
    assert _ser_db(ref, img.values) >= 200.0  # float64 both: rounding only


def test_tile_bounds():
    pos = np.array([[7000.0, 0.0, 7300.0], [7000.0, 400.0, 7300.0]])
    x = np.arange(-64.0, 64.0, 0.25)
    assert _bp_kernels.tile_shape(pos, x, x, 256.0) == _bp_kernels.TILES[0]  # the largest
    # 2 m pixels: 64-pixel tiles would span 128 m; smaller tiles keep the phase offsets.
    x2 = np.arange(-200.0, 200.0, 2.0)
    assert _bp_kernels.tile_shape(pos, x2, x2, 256.0) in ((32, 32), (16, 16))
    near = np.array([[30.0, 0.0, 20.0]])
    assert _bp_kernels.tile_shape(near, x, x, 256.0) is None


def test_trace_table_cache(four_degrees):
    grid = ImageGrid.square(size_m=10.0, spacing_m=0.5)
    _bp_table.TABLES.clear()
    a = backproject(four_degrees, grid).values
    table = _bp_table.TABLES.get(four_degrees, 8)
    assert _bp_table.TABLES.get(four_degrees, 8) is table  # reused
    assert _bp_table.TABLES.get(four_degrees, 4) is not table  # other upsampling
    # A traces object with other data gets its own table; a change of the data in place is
    # noticed (the data is compared with a copy) and the table rebuilt.
    other = four_degrees.with_data(four_degrees.data * 2.0)
    np.testing.assert_allclose(backproject(other, grid).values, 2.0 * a, rtol=1e-6, atol=1e-9)
    copy = four_degrees.with_data(four_degrees.data.copy())
    backproject(copy, grid)
    copy.data[:] *= -1.0
    np.testing.assert_allclose(backproject(copy, grid).values, -a, rtol=1e-6, atol=1e-9)
    # The packed table holds the float64 cubic pieces to float32 rounding (2^-24 of each
    # part, so at most 2^-24 |c| per coefficient).
    full = _bp_table.hermite_coefficients(four_degrees.data, 8)
    got = _bp_table.unpack_table(table)
    assert np.all(np.abs(got - full) <= 2.0**-24 * np.abs(full) * (1.0 + 1e-9))
    assert np.all(got[:, [0, -1]] == 0)


@pytest.mark.parametrize(
    ("shape", "factor"), [((37, 101), 6), ((16, 64), 8), ((5, 7), 1), ((3, 9), 1)]
)  # pieces: 647, 511, 7 (none in whole steps of 8) and 8 (no scalar tail)
def test_trace_table_blocks_and_threads(shape, factor, monkeypatch):
    # Built by blocks in threads: the same bits whatever the threads, each coefficient the
    # float32 rounding of the float64 one (a pulse count that is not a multiple of the
    # block, zero pulses, an exact zero step).
    rng = np.random.default_rng(5)
    data = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    data[1] = 0.0
    data[2, :3] = 1.0
    monkeypatch.setattr(_bp_table, "BLOCK_PULSES", 4)
    table = _bp_table.make_table(data, factor)
    full = _bp_table.hermite_coefficients(data, factor)
    np.testing.assert_array_equal(_bp_table.unpack_table(table), full.astype(np.complex64))
    with monkeypatch.context() as m:
        m.setattr(_bp_table.numba, "get_num_threads", lambda: 1)
        alone = _bp_table.make_table(data, factor)
    np.testing.assert_array_equal(alone.values.view(np.uint32), table.values.view(np.uint32))


def test_trace_table_memory_is_reused_and_fully_written(monkeypatch):
    # A table's values come from reused blocks: the next table of the same size takes the
    # block of one no longer held, and every float of it is written again (a block left
    # full of NaN gives the same bits as fresh memory: the zero entries and padding too).
    pool = BlockPool(lambda size: np.zeros(size, np.uint8), limit_bytes=64 << 20)
    monkeypatch.setattr(_bp_table, "TABLE_BLOCKS", pool)
    rng = np.random.default_rng(11)
    data = rng.standard_normal((40, 300)) + 1j * rng.standard_normal((40, 300))
    first = _bp_table.make_table(data, 8)
    assert first.values.nbytes >= BLOCK_GRANULE and type(first.values.base).__name__ == "_Lease"
    expected = first.values.copy()
    address = first.values.ctypes.data
    first.values[...] = np.nan
    del first
    again = _bp_table.make_table(data, 8)
    assert again.values.ctypes.data == address
    np.testing.assert_array_equal(again.values.view(np.uint32), expected.view(np.uint32))
    held = again  # while a table is held its block is not handed out again
    other = _bp_table.make_table(-data, 8)
    assert other.values.ctypes.data != held.values.ctypes.data
    np.testing.assert_array_equal(other.values, -expected)  # linear in the data, exactly


# -------------------------------------------------------------------------- FFBP
@pytest.mark.parametrize(("band", "max_error"), [(0.2, 2e-4), (1 / 3, 2e-2)])
def test_half_sample_filter(band, max_error):
    # Worst response error over the band, reached at its edges (measured: 1.4e-4 at 0.2
    # cycles/sample; 1.3e-2 at 1/3, the band edge of the default oversampling 1.5, where
    # little of a sub-image's energy lies).
    g = half_sample_filter(band, 8)
    offsets = np.arange(8) - 3.5
    f = np.linspace(-band, band, 301)
    response = np.exp(2j * np.pi * np.outer(f, offsets)) @ g
    assert np.max(np.abs(response - 1.0)) < max_error
    np.testing.assert_allclose(g, g[::-1], atol=1e-12)  # symmetric: a pure half-sample delay


def test_half_sample_filter_taps():
    # More taps fit the band better: worst response error at 0.4 cycles/sample (alpha 1.25)
    # 9.6e-2 with 8 taps, below 1e-2 with 16 (measured 6.3e-3).
    f = np.linspace(-0.4, 0.4, 301)
    errors = []
    for taps in (8, 16):
        g = half_sample_filter(0.4, taps)
        assert g.shape == (taps,)
        response = np.exp(2j * np.pi * np.outer(f, np.arange(taps) - (taps - 1) / 2.0)) @ g
        errors.append(np.max(np.abs(response - 1.0)))
    assert errors[1] < 1e-2 < errors[0]


@pytest.mark.parametrize("azimuth_deg", [0.0, 90.0])
def test_ffbp_matches_exact_backprojection(azimuth_deg):
    # Look along x (u = x) and along y (the transposed frame).
    tr = _scene(centre_azimuth_deg=azimuth_deg)
    grid = ImageGrid.square(size_m=96.0, spacing_m=0.25)
    exact = backproject(tr, grid).values
    fast = backproject(tr, grid, method="ffbp")
    assert fast.metadata["kernel_variant"] == "ffbp"
    assert fast.metadata["ffbp"]["levels"] >= 3  # a real factorisation, not exact in disguise
    # The accuracy the defaults are chosen for (ffbp.TARGET_DB; the budget's derivation and
    # the test against the exact sum: tests/imaging/test_ffbp_accuracy.py).
    assert _ser_db(exact, fast.values) >= ffbp.TARGET_DB
    # The points are where exact backprojection puts them.
    assert fast.peak()[:2] == pytest.approx(backproject(tr, grid).peak()[:2], abs=1e-9)


@pytest.mark.parametrize("u", [(10.0, 5.0), (-8.0, 3.0), (15.0, 0.0)])
def test_ffbp_with_motion_compensation(four_degrees, u):
    # The motion-compensated image (antennas at r(s) - s u) to the same accuracy.
    grid = ImageGrid.square(size_m=64.0, spacing_m=0.25)
    exact = backproject(four_degrees, grid, velocity_mps=u).values
    fast = backproject(four_degrees, grid, velocity_mps=u, method="ffbp").values
    assert _ser_db(exact, fast) >= ffbp.TARGET_DB


@pytest.mark.gotcha
def test_ffbp_on_gotcha_in_strips(gotcha_files):
    # 513 x 1601 pixels at 0.25 m, 400 m along the rows' axis: two strips of rows
    # evaluated together, depth by depth; the fast-time window ends inside the image (its
    # pixels there are computed exactly).
    tr = read_gotcha(gotcha_files)
    grid = ImageGrid.from_extent(x_range_m=(-64.0, 64.0), y_range_m=(-200.0, 200.0),
                                 spacing_m=0.25)  # fmt: skip
    fast = backproject(tr, grid, method="ffbp")
    assert fast.metadata["kernel_variant"] == "ffbp"
    assert fast.metadata["ffbp"]["strips"] >= 2
    assert fast.metadata["ffbp"]["exact_pixels"] > 0
    assert _ser_db(backproject(tr, grid).values, fast.values) >= ffbp.TARGET_DB


def test_ffbp_strip_whose_root_does_not_split(four_degrees, monkeypatch):
    # A strip whose whole aperture is one leaf is backprojected on its image rows and read
    # unfiltered, next to strips that factorise: the first of two strips, forced here.
    plan, strip_plans = ffbp._plan, ffbp._strip_plans
    first_v0 = []

    def one_leaf_first(n_pulses, band, dv_top, v0_top, nv_top, alpha, taps):
        levels = plan(n_pulses, band, dv_top, v0_top, nv_top, alpha, taps)
        if not first_v0 or v0_top == first_v0[0]:
            first_v0.append(v0_top)
            levels[0][0].children = []
            return levels[:1]
        return levels

    leaf_rows = []

    def halves(pos, us, y, *args):  # each half of the rows planned on its own
        half = y.size // 2
        choices = args[-1][:1]  # one oversampling for both halves (one set of margins)
        _, b1, p1, choice = strip_plans(pos, us, y[:half], *args[:-1], choices)
        _, b2, p2, _ = strip_plans(pos, us, y[half:], *args[:-1], choices)
        leaf_rows.append(int(b1[1]))
        return 0.0, np.concatenate([b1[:-1], b2 + half]), p1 + p2, choice

    monkeypatch.setattr(ffbp, "_plan", one_leaf_first)
    monkeypatch.setattr(ffbp, "_strip_plans", halves)
    monkeypatch.setattr(ffbp, "PLANS", ffbp.PlanCache(1))  # planned here, not reused
    grid = ImageGrid.square(size_m=64.0, spacing_m=0.25)
    fast = backproject(four_degrees, grid, method="ffbp")
    assert fast.metadata["kernel_variant"] == "ffbp"
    assert fast.metadata["ffbp"]["strips"] >= 2
    exact = backproject(four_degrees, grid).values
    n = leaf_rows[0]
    # The leaf strip is exact backprojection (float32, demodulated and remodulated; 137 dB
    # measured) ...
    assert _ser_db(exact[:n], fast.values[:n]) >= 60.0
    # ... and the factorised ones to the accuracy of FFBP.
    assert _ser_db(exact[n:], fast.values[n:]) >= ffbp.TARGET_DB


def test_ffbp_runs_exact_where_it_cannot_save_work():
    tr = _scene(centre_azimuth_deg=45.0)  # look along the diagonal: no cheap factorisation
    grid = ImageGrid.square(size_m=32.0, spacing_m=0.25)
    img = backproject(tr, grid, method="ffbp")
    assert img.metadata["kernel_variant"] == "numba-float32"
    assert "fallback" in img.metadata["ffbp"]
    np.testing.assert_array_equal(img.values, backproject(tr, grid).values)


def test_ffbp_progress_and_validation(four_degrees):
    calls = []
    grid = ImageGrid.square(size_m=64.0, spacing_m=0.25)
    backproject(four_degrees, grid, method="ffbp", progress=lambda *a: calls.append(a))
    assert calls and calls[-1][1] == calls[-1][2] and all(c[0] == "backprojection" for c in calls)
    with pytest.raises(ValueError, match="method"):
        backproject(four_degrees, grid, method="fast")
    with pytest.raises(ValueError, match="kernel='numba'"):
        backproject(four_degrees, grid, method="ffbp", kernel="numpy")
    with pytest.raises(ValueError, match="ffbp_oversampling"):
        backproject(four_degrees, grid, method="ffbp", ffbp_oversampling=1.0)
