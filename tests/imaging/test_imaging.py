"""Backprojection imaging: focusing, resolution, motion compensation, kernels, validation.

All scenes use the default GOTCHA circular geometry (L ~ 10.2 km, elevation ~ 45.8 deg,
B = 624 MHz, lambda_o = 3.1 cm) with noise-free simulated traces unless stated; the only
random inputs are seeded.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarmotion.core import C, Radar, Traces, Trajectory
from sarmotion.imaging import (
    Image,
    ImageGrid,
    backproject,
    backproject_phase_history,
    backproject_points,
    resolution,
    width_3db,
)
from sarmotion.imaging._bp_common import table_samples
from sarmotion.imaging._bp_table import hermite_coefficients, upsample_fast_time
from sarmotion.imaging.grid import all_finite, checked_values
from sarmotion.simulation import PointTarget, Scene, add_noise, simulate, simulate_phase_history

TARGET = (7.3, -4.1)  # off the reference point (origin) and off the pixel lattice
MOVER_VELOCITY = 28.0 / math.sqrt(2.0) * np.array([1.0, 1.0])  # |u| = 28 m/s (sect:scales)


def _traces(targets, *, aperture_deg=4.0, radar=None) -> Traces:
    scene = Scene(name="test", targets=targets)
    traj = Trajectory.circular(aperture_deg=aperture_deg)
    return simulate(scene, trajectory=traj, radar=radar).traces


def _ser_db(ref: np.ndarray, fast: np.ndarray) -> float:
    err = np.linalg.norm(fast - ref)  # 0 when both read the same float32 table
    return math.inf if err == 0 else 20.0 * math.log10(np.linalg.norm(ref) / err)


@pytest.fixture(scope="module")
def point_4deg() -> Traces:
    """A unit stationary point at TARGET, 4-degree aperture (468 pulses)."""
    return _traces([PointTarget(position_m=TARGET)], aperture_deg=4.0)


@pytest.fixture(scope="module")
def point_1deg() -> Traces:
    """A unit stationary point at TARGET, 1-degree aperture (117 pulses)."""
    return _traces([PointTarget(position_m=TARGET)], aperture_deg=1.0)


@pytest.fixture(scope="module")
def clutter() -> Traces:
    """Three stationary points and a mover plus white noise (SNR 10 dB), 1 degree, seeded."""
    targets = [
        PointTarget(position_m=TARGET),
        PointTarget(position_m=(-12.0, 9.5), reflectivity=0.7j),
        PointTarget(position_m=(15.2, 14.0), reflectivity=-0.4),
        PointTarget(position_m=(0.0, 0.0), velocity_mps=MOVER_VELOCITY),
    ]
    tr = _traces(targets, aperture_deg=1.0)
    return tr.with_data(add_noise(tr.data, snr_db=10.0, rng=20240607))


# ------------------------------------------------------------------- upsampling
@pytest.mark.parametrize("n_samples", [424, 101])
def test_upsampling_is_the_band_limited_trace(n_samples: int) -> None:
    # The upsampled trace must equal D(t) = (1/n) sum_k P_k exp(2i pi (f_k - nu_o) t), the
    # continuous trace of the phase history, on t'_m = (m - N//2) dt / 8; in particular
    # the original samples (t = 0 at index n//2, even and odd n). Tolerance 1e-12 of the
    # peak: FFT rounding (~1e-15) times sqrt(N).
    radar = Radar(
        carrier_hz=9.6e9,
        bandwidth_hz=n_samples * 1.4e6,
        n_samples=n_samples,
        frequency_step_hz=1.4e6,
    )
    traj = Trajectory.circular(aperture_deg=0.05)
    ph = simulate_phase_history([PointTarget(position_m=TARGET)], traj, radar, (0.0, 0.0))
    data = Traces.from_phase_history(ph, trajectory=traj, radar=radar, reference_point_m=(0, 0))
    up = upsample_fast_time(data.data, 8)
    big = 8 * n_samples
    t_up = (np.arange(big) - big // 2) * radar.sample_interval_s / 8
    nu = radar.frequencies_hz - radar.carrier_hz
    direct = ph @ np.exp(2j * np.pi * np.outer(nu, t_up)) / n_samples
    assert np.max(np.abs(up - direct)) < 1e-12 * np.max(np.abs(direct))
    idx = big // 2 + 8 * (np.arange(n_samples) - n_samples // 2)
    np.testing.assert_allclose(up[:, idx], data.data, rtol=0, atol=1e-13)
    # The kernels' table of cubic pieces, over the same period on its own grid
    # t_m = (m - N//2) h, h = n dt / N (N = table_samples: 8 n_fast, the bins padded to a
    # fast length, 432 for 424): entry m + 1 starts at sample m (c0, against the direct
    # sum), its derivative is h D'(t_m) (c1), the piece ends on sample m + 1 with slope
    # h D'(t_{m+1}); entries 0 and N + 1 are zero.
    coef = hermite_coefficients(data.data, 8)
    big = table_samples(n_samples, 8)
    assert coef.shape[1] == big + 2 and big >= 8 * n_samples
    h = n_samples * radar.sample_interval_s / big
    t_tab = (np.arange(big) - big // 2) * h
    phasors = np.exp(2j * np.pi * np.outer(nu, t_tab))
    values = ph @ phasors / n_samples
    np.testing.assert_allclose(coef[:, 1:-1, 0], values, rtol=0, atol=1e-12)
    slope = ph @ (2j * np.pi * h * nu[:, None] * phasors)
    np.testing.assert_allclose(coef[:, 1:-1, 1], slope / n_samples, rtol=0, atol=1e-12)
    end = coef[:, 1:-1].sum(axis=-1)
    np.testing.assert_allclose(end[:, :-1], values[:, 1:], rtol=0, atol=1e-12)
    end_slope = coef[:, 1:-1, 1] + 2 * coef[:, 1:-1, 2] + 3 * coef[:, 1:-1, 3]
    np.testing.assert_allclose(end_slope[:, :-1], slope[:, 1:] / n_samples, rtol=0, atol=1e-12)
    assert np.all(coef[:, [0, -1]] == 0)


# --------------------------------------------------------------------- focusing
@pytest.mark.parametrize("aperture", ["point_4deg", "point_1deg"])
def test_stationary_point_focuses_at_its_position(aperture: str, request) -> None:
    tr = request.getfixturevalue(aperture)
    grid = ImageGrid.square(centre_m=(7.0, -4.0), size_m=8.0, spacing_m=0.1)
    img = backproject(tr, grid)
    x, y, value = img.peak()
    dx, dy = grid.spacing_m
    # Within one pixel (0.1 m, a third of the 0.32 m resolution).
    assert abs(x - TARGET[0]) <= dx and abs(y - TARGET[1]) <= dy
    # Coherent sum of n unit pulses on a pixel at the target: |I| = n up to the sampling of
    # the main lobe by the 0.1 m pixels; 10 % margin.
    assert 0.9 * tr.n_pulses < abs(value) <= tr.n_pulses * (1 + 1e-9)
    # Sub-pixel refinement lands within a quarter pixel.
    xr, yr, _ = img.peak(refine=True)
    assert math.hypot(xr - TARGET[0], yr - TARGET[1]) < 0.25 * dx


@pytest.mark.parametrize("n_samples", [424, 101])
def test_focusing_with_even_and_odd_trace_lengths(n_samples: int) -> None:
    # t = 0 sits at index n//2 for both parities; an off-by-one trace sample shifts the
    # image by c dt / 2 = 0.25 m slant (0.36 m ground), > 1 pixel of 0.1 m. (Sub-sample
    # slips of the upsampled axis are caught by the upsampling and kernel tests.)
    radar = Radar(
        carrier_hz=9.6e9,
        bandwidth_hz=n_samples * 6.0e6,
        n_samples=n_samples,
        frequency_step_hz=6.0e6,
    )
    tr = _traces([PointTarget(position_m=TARGET)], aperture_deg=2.0, radar=radar)
    grid = ImageGrid.square(centre_m=(7.0, -4.0), size_m=4.0, spacing_m=0.1)
    for kernel in ("numba", "numpy"):
        x, y, _ = backproject(tr, grid, kernel=kernel).peak()
        assert abs(x - TARGET[0]) <= 0.1 and abs(y - TARGET[1]) <= 0.1, kernel


# ------------------------------------------------------------------- resolution
def test_resolution_formulas(point_1deg: Traces) -> None:
    res = resolution(point_1deg)
    geo = point_1deg.geometry
    # Independent oracle: GOTCHA circle, H = 7.3 km, R = 7.1 km, 117 pulses per degree.
    elevation = math.atan2(7300.0, 7100.0)
    assert res.elevation_rad == pytest.approx(elevation, rel=1e-6)
    assert res.slant_range_m == pytest.approx(C / (2 * point_1deg.radar.bandwidth_hz))
    assert res.ground_range_m == pytest.approx(res.slant_range_m / math.cos(elevation), rel=1e-6)
    a = 7100.0 * math.radians(116 / 117)  # 117 pulses: 116 steps of 1/117 degree
    lam = C / point_1deg.radar.carrier_hz
    assert res.cross_range_m == pytest.approx(lam * geo.range_m / (2 * a), rel=1e-6)
    assert res.cross_range_m == pytest.approx(1.29, abs=0.01)  # paper: lambda L / a = 2.5 m
    np.testing.assert_allclose(res.range_direction, [1.0, 0.0], atol=1e-9)  # azimuth 0
    np.testing.assert_allclose(res.cross_range_direction, [0.0, 1.0], atol=1e-9)


@pytest.mark.parametrize("aperture", ["point_4deg", "point_1deg"])
def test_main_lobe_widths_match_theory(aperture: str, request) -> None:
    tr = request.getfixturevalue(aperture)
    res = resolution(tr, point_m=TARGET)
    grid = ImageGrid.square(centre_m=TARGET, size_m=6.0, spacing_m=0.1)
    img = backproject(tr, grid)
    x, y, _ = img.peak(refine=True)
    w_range = width_3db(img, (x, y), res.range_direction, traces=tr, half_length_m=1.5)
    w_cross = width_3db(
        img, (x, y), res.cross_range_direction, traces=tr, half_length_m=3 * res.cross_range_m
    )
    # The "rect" spectrum and the uniform aperture give sinc main lobes, -3 dB width
    # 0.886 x the resolution c/(2B)/cos(el) and lambda L/(2a); the acceptance bound is 25 %.
    assert w_range == pytest.approx(res.ground_range_m, rel=0.25)
    assert w_cross == pytest.approx(res.cross_range_m, rel=0.25)
    # ... and the sinc factor itself is found to 3 % (pixel-free exact profiles).
    assert w_range / res.ground_range_m == pytest.approx(0.886, rel=0.03)
    assert w_cross / res.cross_range_m == pytest.approx(0.886, rel=0.03)
    # The same widths from the image by spline interpolation of |I| (3 to 11 pixels per
    # width): within 5 %.
    w_img = width_3db(img, (x, y), res.range_direction, half_length_m=1.0)
    assert w_img == pytest.approx(w_range, rel=0.05)


# -------------------------------------------------------------- moving targets
def test_motion_compensation_focuses_a_mover() -> None:
    tr = _traces([PointTarget(position_m=(0.0, 0.0), velocity_mps=MOVER_VELOCITY)])
    still = _traces([PointTarget(position_m=(0.0, 0.0))])
    grid = ImageGrid.square(size_m=40.0, spacing_m=0.25)
    stationary_peak = abs(backproject(still, grid).peak()[2])
    plain = backproject(tr, grid)
    comp = backproject(tr, grid, velocity_mps=MOVER_VELOCITY)
    x, y, value = comp.peak()
    # Compensated at the true velocity: focused at the true position (s = 0), one pixel.
    assert abs(x) <= 0.25 and abs(y) <= 0.25
    # ... with the peak of a stationary target of the same reflectivity at the same pixel
    # (both ~ the coherent sum of 468 unit pulses; 5 % for interpolation differences).
    assert abs(value) == pytest.approx(stationary_peak, rel=0.05)
    # Uncompensated: the range speed (~14 m/s) shifts the Doppler far out of the 40 m
    # scene and the range walk smears it: no focused peak (< 5 % of the focused one).
    assert abs(plain.peak()[2]) < 0.05 * abs(value)
    np.testing.assert_array_equal(comp.velocity_mps, MOVER_VELOCITY)
    np.testing.assert_array_equal(plain.velocity_mps, [0.0, 0.0])


# ---------------------------------------------------------------------- kernels
@pytest.mark.parametrize("dtype", [np.complex64, np.complex128])
@pytest.mark.parametrize("velocity", [None, (11.0, -6.5)])
def test_numba_kernel_matches_numpy_reference(clutter: Traces, dtype, velocity) -> None:
    tr = clutter.with_data(clutter.data.astype(dtype))
    # 70 x 45 pixels: partial tiles on both axes of the 64 x 64 tiling; the grid reaches
    # past the fast-time window (range +-51 m) so out-of-window samples are exercised.
    grid = ImageGrid.from_extent(x_range_m=(-55.0, 48.5), y_range_m=(-20.0, 46.0), spacing_m=1.5)
    fast = backproject(tr, grid, velocity_mps=velocity, kernel="numba").values
    ref = backproject(tr, grid, velocity_mps=velocity, kernel="numpy").values
    # The same interpolation; the compiled kernel's float32 offsets stay ~20 dB under the
    # interpolation error (module bound): >= 100 dB. A float32 range (1e-3 m error at
    # 10 km, 0.2 rad) would fall to ~15 dB.
    assert _ser_db(ref, fast) >= 100.0
    assert grid.x_m[0] < -51 and grid.x_m[-1] < 51  # the window edge lies inside the grid


def test_samples_outside_the_window_contribute_nothing(point_1deg: Traces) -> None:
    # A grid far beyond the fast-time window (|range| > 51 m): every delay falls outside.
    grid = ImageGrid.square(centre_m=(200.0, 0.0), size_m=10.0, spacing_m=1.0)
    for kernel in ("numba", "numpy"):
        assert np.all(backproject(point_1deg, grid, kernel=kernel).values == 0), kernel


def test_phase_history_entry_point_equals_traces(clutter: Traces) -> None:
    grid = ImageGrid.square(centre_m=(0.0, 5.0), size_m=30.0, spacing_m=0.5)
    u = (3.0, -2.0)
    a = backproject(clutter, grid, velocity_mps=u)
    b = backproject_phase_history(
        clutter.phase_history(),
        frequencies_hz=clutter.frequencies_hz,
        positions_m=clutter.positions_m,
        slow_times_s=clutter.slow_times_s,
        reference_point_m=clutter.reference_point_m,
        grid=grid,
        velocity_mps=u,
    )
    # Same traces up to one FFT round trip (~1e-15 relative).
    assert _ser_db(a.values, b.values) > 200.0
    np.testing.assert_array_equal(b.velocity_mps, u)


def test_backproject_points_matches_the_image(point_1deg: Traces) -> None:
    grid = ImageGrid.square(centre_m=TARGET, size_m=4.0, spacing_m=0.5)
    img = backproject(point_1deg, grid, kernel="numpy")
    pts = backproject_points(point_1deg, grid.points_m())
    np.testing.assert_allclose(pts, img.values, rtol=0, atol=1e-9 * np.abs(img.values).max())


@pytest.mark.parametrize("kernel", ["numba", "numpy"])
def test_progress_is_reported_per_step(point_4deg: Traces, kernel: str) -> None:
    calls: list[tuple[int, int]] = []
    grid = ImageGrid.square(size_m=40.0, spacing_m=0.25)  # 160 x 160: 3 bands of tiles
    backproject(point_4deg, grid, kernel=kernel, progress=lambda stage, d, t: calls.append((d, t)))
    total = calls[0][1]
    done = [d for d, _ in calls]
    assert all(t == total for _, t in calls) and done[-1] == total
    assert done == sorted(set(done)) and 2 <= len(calls) <= 50


# ------------------------------------------------------------------- grid/image
def test_grid_constructors_and_indexing() -> None:
    g = ImageGrid.square(centre_m=(1.0, -2.0), size_m=10.0, spacing_m=0.25)
    assert g.shape == (40, 40) and g.spacing_m == pytest.approx((0.25, 0.25))
    assert g.x_m[20] == 1.0 and g.y_m[20] == -2.0  # the centre is pixel n // 2
    assert g.extent == pytest.approx((-4.125, 5.875, -7.125, 2.875))
    assert g.nearest_index((1.3, -2.6)) == (18, 21)
    assert g.position(18, 21) == pytest.approx((1.25, -2.5))
    p = g.points_m()
    assert p.shape == (40, 40, 3) and np.all(p[..., 2] == 0)
    assert p[18, 21, 0] == g.x_m[21] and p[18, 21, 1] == g.y_m[18]
    e = ImageGrid.from_extent(x_range_m=(-1.0, 2.0), y_range_m=(0.0, 1.0), spacing_m=0.5)
    np.testing.assert_allclose(e.x_m, [-1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0])
    assert e.shape == (3, 7)


def test_image_helpers(clutter: Traces) -> None:
    grid = ImageGrid.square(size_m=40.0, spacing_m=0.25)
    img = backproject(clutter, grid)
    db = img.magnitude_db(floor_db=-60.0)
    assert db.max() == 0.0 and db.min() >= -60.0
    found = img.peaks(3, min_separation_m=3.0)
    expected = [TARGET, (-12.0, 9.5), (15.2, 14.0)]  # brightest first (|sigma| 1, .7, .4)
    assert len(found) == 3
    for (x, y, _), (tx, ty) in zip(found, expected, strict=True):
        assert abs(x - tx) <= 0.25 and abs(y - ty) <= 0.25
    assert abs(found[0][2]) == abs(img.peak()[2])


# ------------------------------------------------------------------- validation
def test_grid_validation() -> None:
    with pytest.raises(ValueError, match="x_m"):
        ImageGrid(x_m=np.zeros((2, 2)), y_m=np.arange(3.0))
    with pytest.raises(ValueError, match="y_m.*increasing"):
        ImageGrid(x_m=np.arange(3.0), y_m=[2.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="x_m.*uniform"):
        ImageGrid(x_m=[0.0, 1.0, 3.0], y_m=np.arange(3.0))
    with pytest.raises(ValueError, match="x_m.*finite"):
        ImageGrid(x_m=[0.0, np.nan, 2.0], y_m=np.arange(3.0))
    with pytest.raises(ValueError, match="y_m.*at least 2"):
        ImageGrid(x_m=np.arange(3.0), y_m=[1.0])
    with pytest.raises(ValueError, match="spacing_m"):
        ImageGrid.square(spacing_m=0.0)
    with pytest.raises(ValueError, match="x_range_m"):
        ImageGrid.from_extent(x_range_m=(1.0, 0.0), y_range_m=(0.0, 1.0), spacing_m=0.1)
    with pytest.raises(ValueError, match="point_m.*outside"):
        ImageGrid.square(size_m=2.0).nearest_index((5.0, 0.0))
    g = ImageGrid.square(size_m=2.0, spacing_m=0.5)
    with pytest.raises(ValueError, match="values"):
        Image(values=np.zeros((3, 4)), grid=g)
    with pytest.raises(ValueError, match="velocity_mps"):
        Image(values=np.zeros(g.shape), grid=g, velocity_mps=[np.nan, 0.0])


def test_backproject_validation(point_1deg: Traces) -> None:
    g = ImageGrid.square(size_m=2.0, spacing_m=0.5)
    with pytest.raises(ValueError, match="velocity_mps.*finite"):
        backproject(point_1deg, g, velocity_mps=(np.nan, 1.0))
    with pytest.raises(ValueError, match="velocity_mps.*shape"):
        backproject(point_1deg, g, velocity_mps=(1.0, 2.0, 3.0, 4.0))
    with pytest.raises(ValueError, match="velocity_mps.*ground"):
        backproject(point_1deg, g, velocity_mps=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="upsample"):
        backproject(point_1deg, g, upsample=0)
    with pytest.raises(TypeError, match="upsample"):
        backproject(point_1deg, g, upsample=2.5)
    with pytest.raises(ValueError, match="kernel"):
        backproject(point_1deg, g, kernel="cuda")
    with pytest.raises(TypeError, match="grid"):
        backproject(point_1deg, np.zeros((4, 4)))
    with pytest.raises(TypeError, match="traces"):
        backproject(point_1deg.data, g)
    with pytest.raises(ValueError, match="points_m"):
        backproject_points(point_1deg, np.zeros((4, 5)))
    ph = point_1deg.phase_history()
    kw = dict(
        positions_m=point_1deg.positions_m,
        slow_times_s=point_1deg.slow_times_s,
        reference_point_m=(0.0, 0.0),
        grid=g,
    )
    with pytest.raises(ValueError, match="frequencies_hz.*shape"):
        backproject_phase_history(ph, frequencies_hz=point_1deg.frequencies_hz[:-1], **kw)
    bad = point_1deg.frequencies_hz.copy()
    bad[5] += 1e5
    with pytest.raises(ValueError, match="frequencies_hz.*uniform"):
        backproject_phase_history(ph, frequencies_hz=bad, **kw)
    with pytest.raises(ValueError, match="phase_history"):
        backproject_phase_history(ph[0], frequencies_hz=point_1deg.frequencies_hz, **kw)


def test_width_3db_validation(point_1deg: Traces) -> None:
    g = ImageGrid.square(centre_m=TARGET, size_m=2.0, spacing_m=0.25)
    img = backproject(point_1deg, g)
    with pytest.raises(ValueError, match="direction"):
        width_3db(img, TARGET, (0.0, 0.0))
    with pytest.raises(ValueError, match="half_length_m"):  # profile too short for -3 dB
        width_3db(img, TARGET, (0.0, 1.0), traces=point_1deg, half_length_m=0.2)
    with pytest.raises(ValueError, match="leaves the image"):
        width_3db(img, TARGET, (1.0, 0.0), half_length_m=5.0)


def test_width_3db_default_length(point_1deg: Traces) -> None:
    # Default half length with traces: 2 x the coarser resolution (cross range, 1.29 m).
    g = ImageGrid.square(centre_m=TARGET, size_m=2.0, spacing_m=0.25)
    img = backproject(point_1deg, g)
    res = resolution(point_1deg, point_m=TARGET)
    w = width_3db(img, TARGET, res.cross_range_direction, traces=point_1deg)
    assert w == pytest.approx(0.886 * res.cross_range_m, rel=0.03)


def test_device_keyword(point_1deg: Traces) -> None:
    from sarmotion.imaging import cuda

    grid = ImageGrid.square(centre_m=TARGET, size_m=2.0, spacing_m=0.5)
    with pytest.raises(ValueError, match="device"):
        backproject(point_1deg, grid, device="tpu")
    if cuda.available():  # the GPU image, the same sum within both kernels' bounds
        gpu = backproject(point_1deg, grid, device="cuda").values
        assert _ser_db(backproject(point_1deg, grid).values, gpu) >= 80.0
    else:  # one line naming what is missing
        with pytest.raises(RuntimeError, match=r"sarmotion\[gpu\] extra and an NVIDIA GPU"):
            backproject(point_1deg, grid, device="cuda")


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, complex(0, np.nan), complex(np.inf, 1)])
def test_all_finite_finds_any_non_finite_part(bad):
    values = np.ones((5, 7), np.complex128)
    assert all_finite(values) and all_finite(values.real)
    values[3, 2] = bad
    assert not all_finite(values)
    assert not all_finite(values.T)  # not contiguous


def test_an_image_refuses_non_finite_values_unless_its_producer_checked():
    grid = ImageGrid.square(size_m=0.4, spacing_m=0.1)
    values = np.ones(grid.shape, np.complex128)
    values[1, 1] = np.nan
    with pytest.raises(ValueError, match="NaN or infinite"):
        Image(values=values, grid=grid)
    with checked_values():  # the producer's own check stands for this one
        assert np.isnan(Image(values=values, grid=grid).values[1, 1])
    with pytest.raises(ValueError, match="NaN or infinite"):  # only inside the block
        Image(values=values, grid=grid)


def test_an_outline_row_by_row_is_the_point_test():
    # outline_columns (each row's x interval) and in_outline (each point's parallelogram
    # coordinates) select the same pixels, for parallelograms in any direction and
    # rectangles along the axes (whose sides a row or column may run along)
    from sarmotion.imaging import in_outline, outline_columns

    rng = np.random.default_rng(1)
    grid = ImageGrid.square(size_m=50.0, spacing_m=0.5)
    xx, yy = np.meshgrid(grid.x_m, grid.y_m)
    tried = 0
    for trial in range(200):
        o, u, v = rng.uniform(-30.0, 30.0, (3, 2))
        if trial % 5 == 0:  # sides on the pixels' rows and columns
            u = np.array([rng.integers(2, 40) * 0.5, 0.0])
            v = np.array([0.0, rng.integers(2, 40) * 0.5])
            o = np.round(o * 2.0) / 2.0
        if abs(u[0] * v[1] - u[1] * v[0]) < 1e-3:
            continue
        q = np.array([o, o + u, o + u + v, o + v])
        lo, hi = outline_columns(grid, q)
        rows = (xx >= lo[:, None]) & (xx <= hi[:, None])
        assert np.array_equal(rows, in_outline(np.stack([xx, yy], axis=-1), q)), trial
        tried += 1
    assert tried > 150


def test_a_grid_window_holds_the_box_and_two_pixels_at_least():
    grid = ImageGrid.square(size_m=10.0, spacing_m=1.0)  # x, y = -5 .. 4
    rows, cols = grid.window((-2.0, 0.5, 1.0, 3.0))
    assert grid.x_m[cols].tolist() == [-2.0, -1.0, 0.0, 1.0]
    assert grid.y_m[rows].tolist() == [1.0, 2.0, 3.0]
    rows, cols = grid.window((-2.0, 0.5, 1.0, 3.0), pad=1)
    assert grid.x_m[cols].tolist() == [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0]
    rows, cols = grid.window((4.0, -5.0, 4.0, -5.0), pad=3)  # a pixel at the corner
    assert (cols.stop - cols.start, rows.stop - rows.start) == (4, 4)
    rows, cols = grid.window((0.2, 0.2, 0.4, 0.4))  # between pixels: the two nearest
    assert grid.x_m[cols].tolist() == [0.0, 1.0]
    rows, cols = grid.window((50.0, 50.0, 60.0, 60.0))  # beside the grid: its last two
    assert grid.x_m[cols].tolist() == [3.0, 4.0] and grid.y_m[rows].tolist() == [3.0, 4.0]
