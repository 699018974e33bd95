"""An image of noise alone offers no stationary candidate; the combined separation then
leaves the data whole, and the stationary image is zero."""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.core import Radar, Traces, Trajectory, to_fast_time
from sarmotion.imaging import backproject, resolution, scene_grid
from sarmotion.pipeline.stages import stationary_image
from sarmotion.separation import noise_only, separate_combined, stationary_candidates
from sarmotion.simulation import PointTarget, simulate_phase_history


def _gaussian(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return rng.standard_normal(shape) + 1j * rng.standard_normal(shape)


@pytest.mark.parametrize("false_alarm", [0.02, 0.1])
def test_noise_images_are_taken_for_targets_at_the_stated_rate(false_alarm):
    """Independent complex Gaussian pixels: the rule's false alarms are about ``a``.

    The union bound ``n e^{-T}`` is the exact rate ``1 - (1 - e^{-T})^n`` to first order;
    over 2000 seeded images the observed rate lies within 4 binomial standard deviations
    of ``a`` (the median estimate's spread barely moves it).
    """
    rng = np.random.default_rng(20261126)
    n, side = 2000, 48
    flagged = sum(
        not noise_only(_gaussian(rng, (side, side)), n_cells=side * side, false_alarm=false_alarm)
        for _ in range(n)
    )
    rate = flagged / n
    sigma = np.sqrt(false_alarm * (1 - false_alarm) / n)
    assert abs(rate - false_alarm) <= 4 * sigma, rate


def test_a_point_above_the_noise_maximum_is_not_noise():
    """A single pixel at twice the threshold's power is a target in every seeded draw."""
    rng = np.random.default_rng(7)
    side, a = 48, 1e-3
    threshold = 2.0 * np.log(side * side / a)  # |I|^2 of unit-variance noise has mean 2
    for _ in range(200):
        img = _gaussian(rng, (side, side))
        img[10, 20] = np.sqrt(2.0 * threshold)
        assert not noise_only(img, n_cells=side * side, false_alarm=a)


@pytest.mark.parametrize("outside", [0.0, 1e-9])
def test_pixels_the_data_do_not_reach_do_not_lower_the_noise(outside):
    """An image reaching beyond the data (a patch's halo): the zero pixels, or the rounding
    left there by a factorised sum, are not noise. With them in the median (0 for more than
    half the image) every noise image passed for one holding targets."""
    rng = np.random.default_rng(3)
    side, a, n = 64, 1e-3, 300
    flagged = 0
    for _ in range(n):
        img = _gaussian(rng, (side, side))
        img[:, : int(0.6 * side)] = outside * img[:, : int(0.6 * side)]
        flagged += not noise_only(img, n_cells=side * side, false_alarm=a)
    # a = 1e-3 over 300 images: 0 expected, 3 at most with room (binomial tail < 1e-3)
    assert flagged <= 3


def test_noise_peaks_beside_a_weak_target_are_no_candidates(noise_traces):
    """A point 3 dB above the level noise alone reaches makes the image no noise image;
    the noise peaks within ``threshold_db`` of it are below the level, and not candidates
    (the images are linear in the data: the point's amplitude is set from the two)."""
    from sarmotion.separation import NOISE_FALSE_ALARM, noise_level
    from sarmotion.separation.candidates import _n_cells

    grid = scene_grid(noise_traces, size_m=40.0)
    point = PointTarget(position_m=(5.0, -3.0))
    ph = simulate_phase_history([point], noise_traces.trajectory, noise_traces.radar, (0, 0, 0))
    alone = backproject(noise_traces.with_data(to_fast_time(ph)), grid).values
    noise = backproject(noise_traces, grid).values
    res = resolution(noise_traces)
    cells = _n_cells(grid.x_m, grid.y_m, res.ground_range_m, res.cross_range_m)
    level = noise_level(np.abs(noise) ** 2, n_cells=cells, false_alarm=NOISE_FALSE_ALARM)
    k = np.sqrt(2.0 * level) / np.abs(alone).max()
    img = noise + k * alone
    kw = {"x_m": grid.x_m, "y_m": grid.y_m, "traces": noise_traces, "threshold_db": -20.0}
    assert not noise_only(img, n_cells=cells, false_alarm=NOISE_FALSE_ALARM)
    cand = stationary_candidates(img, **kw)
    assert 1 <= len(cand) <= 2  # the point (a noise peak may add to a sidelobe)
    assert np.hypot(*(cand[0, :2] - point.position_m[:2])) < 1.0
    # the level off: the noise peaks within 20 dB of the point are candidates
    assert len(stationary_candidates(img, noise_false_alarm=None, **kw)) > 10


def test_noise_only_rejects_a_rate_outside_0_1():
    with pytest.raises(ValueError, match="false_alarm"):
        noise_only(np.ones((4, 4)), n_cells=16, false_alarm=1.0)


@pytest.fixture(scope="module")
def noise_traces() -> Traces:
    traj, radar = Trajectory.circular(), Radar()
    rng = np.random.default_rng(11)
    shape = (traj.positions_m.shape[0], radar.n_samples)
    return Traces(
        data=(0.01 * _gaussian(rng, shape)).astype(np.complex128),
        trajectory=traj,
        radar=radar,
        reference_point_m=(0.0, 0.0, 0.0),
        metadata={"source": "simulation"},
    )


def test_noise_scene_has_no_candidate_and_a_target_scene_has(noise_traces):
    grid = scene_grid(noise_traces, size_m=40.0)
    img = backproject(noise_traces, grid)
    kw = {"x_m": grid.x_m, "y_m": grid.y_m, "traces": noise_traces, "threshold_db": -20.0}
    assert stationary_candidates(img.values, **kw).shape == (0, 3)
    # the rule off: the noise peaks within 20 dB of the brightest are candidates
    assert len(stationary_candidates(img.values, noise_false_alarm=None, **kw)) > 10

    point = PointTarget(position_m=(5.0, -3.0))
    ph = simulate_phase_history([point], noise_traces.trajectory, noise_traces.radar, (0, 0, 0))
    scene = noise_traces.with_data(noise_traces.data + to_fast_time(ph))
    img = backproject(scene, grid)
    cand = stationary_candidates(img.values, **kw)
    assert len(cand) >= 1
    assert np.hypot(*(cand[0, :2] - point.position_m[:2])) < 1.0


def test_combined_on_noise_leaves_the_data_whole_and_images_zero(noise_traces):
    grid = scene_grid(noise_traces, size_m=40.0)
    img = backproject(noise_traces, grid)
    sep = separate_combined(noise_traces, image_values=img.values, x_m=grid.x_m, y_m=grid.y_m)
    assert len(sep.stationary_points_m) == 0
    assert np.array_equal(sep.moving, noise_traces.data)
    assert not np.any(sep.stationary)
    still = stationary_image(noise_traces, sep, (), grid)
    assert still.values.shape == grid.shape and not np.any(still.values)
