"""Exact backprojection against the exact sum (no interpolation), to its stated accuracy.

The reference is :func:`sarmotion.imaging.exact_sum.exact_sum`: each pixel's backprojection
sum with every pulse's band-limited trace evaluated exactly at the pixel's delay (a direct
sum over the phase history's frequencies). The module :mod:`sarmotion.imaging.backprojection`
derives the interpolation's mean-square error for a flat band and uniformly spread read
positions, :func:`~sarmotion.imaging.backprojection.accuracy_db`; the images must reach it
within 3 dB (real spectra and positions are not exactly flat and uniform), and the float32
kernel must not lose more than the float64 reference (0.5 dB).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarmotion.core import Trajectory
from sarmotion.imaging import ImageGrid, backproject, point_response
from sarmotion.imaging.backprojection import accuracy_db
from sarmotion.imaging.exact_sum import exact_sum
from sarmotion.io import read_gotcha
from sarmotion.simulation import PointTarget, Scene, add_noise, simulate

MARGIN_DB = 3.0


def _ser_db(ref: np.ndarray, x: np.ndarray) -> float:
    return 20.0 * math.log10(np.linalg.norm(ref) / np.linalg.norm(x - ref))


def _points(grid: ImageGrid) -> np.ndarray:
    x, y = np.meshgrid(grid.x_m, grid.y_m)
    return np.stack([x, y], axis=-1)


def _check(traces, grid, upsample, velocity=None):
    ref = exact_sum(traces, _points(grid), velocity_mps=velocity, upsample=upsample)
    fast = backproject(traces, grid, upsample=upsample, velocity_mps=velocity)
    assert fast.metadata["kernel_variant"] == "numba-float32"
    slow = backproject(traces, grid, upsample=upsample, velocity_mps=velocity, kernel="numpy")
    want = accuracy_db(upsample) - MARGIN_DB
    ser_slow = _ser_db(ref, slow.values)
    ser_fast = _ser_db(ref, fast.values)
    assert ser_slow >= want, (ser_slow, want)
    assert ser_fast >= min(want, ser_slow - 0.5), (ser_fast, ser_slow)
    return ser_fast


@pytest.fixture(scope="module")
def gotcha(gotcha_files):
    return read_gotcha(gotcha_files)


def _simulated(look_deg: float, seed: int):
    """Points at random positions, one mover, 20 dB SNR, 4 degrees centred on ``look_deg``."""
    rng = np.random.default_rng(seed)
    targets = [
        PointTarget(position_m=tuple(rng.uniform(-14.0, 14.0, 2)),
                    reflectivity=complex(*rng.normal(size=2)))
        for _ in range(6)
    ] + [PointTarget(position_m=(0.0, 0.0), velocity_mps=(10.0, 5.0))]  # fmt: skip
    trajectory = Trajectory.circular(aperture_deg=4.0, centre_azimuth_deg=look_deg)
    tr = simulate(Scene(name="accuracy", targets=targets), trajectory=trajectory).traces
    return tr.with_data(add_noise(tr.data, snr_db=20.0, rng=seed))


@pytest.mark.gotcha
def test_exact_sum_is_the_point_response(gotcha):
    # Inside the fast-time window the exact sum is point_response (every pulse summed), up
    # to the rounding of float64 delays at ~10 km (~1e-9 rad per term): 1e-8 of the sum of
    # the terms' moduli.
    pts = np.array([[0.3, -1.7], [5.0, 4.25], [-7.5, 2.0]])
    a = exact_sum(gotcha, pts)
    b = point_response(gotcha, pts)
    moduli = np.abs(gotcha.phase_history()).mean(axis=1).sum()
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-8 * moduli)


@pytest.mark.gotcha
@pytest.mark.parametrize("upsample", [6, 8])
def test_gotcha_image_reaches_its_accuracy(gotcha, upsample):
    # 128 x 128 pixels at 0.25 m about the scene centre, the four GOTCHA degrees.
    grid = ImageGrid.square(size_m=32.0, spacing_m=0.25)
    _check(gotcha, grid, upsample)


@pytest.mark.parametrize("look_deg", [0.0, 30.0, 45.0])
def test_simulated_points_reach_the_accuracy(look_deg):
    tr = _simulated(look_deg, seed=int(look_deg) + 101)
    grid = ImageGrid.from_extent(x_range_m=(-16.0, 16.0), y_range_m=(-12.0, 14.0), spacing_m=0.25)
    _check(tr, grid, 6)


def test_motion_compensated_image_reaches_the_accuracy():
    tr = _simulated(30.0, seed=2027)
    grid = ImageGrid.square(size_m=20.0, spacing_m=0.25)
    _check(tr, grid, 6, velocity=(10.0, 5.0))


def test_accuracy_formula_orders_the_upsampling():
    # The flat-band formula: 80 dB of power per octave of upsampling (error ~ h^4).
    assert accuracy_db(8) - accuracy_db(4) == pytest.approx(80.0 * math.log10(2.0))
