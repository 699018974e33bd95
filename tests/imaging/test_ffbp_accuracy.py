"""Fast factorised backprojection against the exact sum, to its error budget.

:mod:`sarmotion.imaging.ffbp` states its error budget: the mean-square in-band error of
each interpolation (:func:`~sarmotion.imaging.ffbp.merge_error`,
:func:`~sarmotion.imaging.ffbp.resample_error`), half of the rows interpolated at each of
the tree's stages, the stages and the resampling's two axes adding in power; its defaults
(:data:`~sarmotion.imaging.ffbp.TAPS`, :data:`~sarmotion.imaging.ffbp.RESAMPLE_TAPS`) are
the fewest taps whose budget reaches ``TARGET_DB + BUDGET_MARGIN_DB``. Here:

- the error formulas are the error power of interpolating seeded flat-band signals;
- the defaults are the fewest taps that meet the budget, and each depth of a tree the
  fewest its own bands need;
- FFBP images of simulated points at 0, 30 and 45 degree looks and of GOTCHA (its own
  look, and turned by 45 degrees) reach ``TARGET_DB`` against the exact sum
  (:func:`~sarmotion.imaging.exact_sum.exact_sum`, which is ``point_response`` inside the
  fast-time window, ``tests/imaging/test_backprojection_accuracy.py``) on every pixel, and their
  own budget within its margin. The oblique looks run the rotated path at a size where the
  time model would run exact backprojection (the accuracy does not depend on that choice).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarmotion.core import Trajectory
from sarmotion.imaging import ImageGrid, backproject, ffbp
from sarmotion.imaging.exact_sum import exact_sum
from sarmotion.io import read_gotcha
from sarmotion.simulation import PointTarget, Scene, add_noise, simulate
from turned import turned

#: Side of the test images (pixels at 0.25 m): small, so the exact sum on every pixel stays
#: a few seconds.
N = 96


def _ser_db(ref: np.ndarray, x: np.ndarray) -> float:
    return 20.0 * math.log10(np.linalg.norm(ref) / np.linalg.norm(x - ref))


def _tones(rng, band: float, n_tones: int = 400):
    """Frequencies uniform in ``[-band, band]`` (cycles per sample) and random phases."""
    return rng.uniform(-band, band, n_tones), np.exp(2j * np.pi * rng.uniform(size=n_tones))


def _at(tones, t: np.ndarray) -> np.ndarray:
    f, a = tones
    return np.exp(2j * np.pi * np.outer(t, f)) @ a


@pytest.mark.parametrize(("band", "taps"), [(0.5 / 1.4, 14), (0.5 / 1.4, 10), (0.3, 8)])
def test_merge_error_is_the_half_sample_error_of_a_flat_band(band, taps):
    # The half-sample filter run over the samples of flat-band signals (sums of random
    # tones) against the signals half a sample on: the error power relative to the
    # signal's is merge_error (Parseval), within the scatter of 20 draws of 400 tones
    # (1 dB).
    rng = np.random.default_rng(424242)
    g = ffbp.half_sample_filter(band, taps)
    err = sig = 0.0
    for _ in range(20):
        tones = _tones(rng, band)
        x = _at(tones, np.arange(256.0))
        y = np.convolve(x, g[::-1], mode="valid")  # y[m] = sum_t g[t] x[m + t]
        truth = _at(tones, np.arange(y.size) + (taps - 1) / 2.0)
        err += float(np.sum(np.abs(y - truth) ** 2))
        sig += float(np.sum(np.abs(truth) ** 2))
    measured = 10.0 * math.log10(err / sig)
    assert measured == pytest.approx(10.0 * math.log10(ffbp.merge_error(band, taps)), abs=1.0)


@pytest.mark.parametrize(("band", "taps"), [(0.5 / 1.6, 10), (0.5 / 1.6, 8), (0.5 / 2.87, 6)])
def test_resample_error_is_the_resampling_error_of_a_flat_band(band, taps):
    # The tabulated fractional filters, linearly interpolated between phases as the
    # kernel does, at uniformly random read positions of flat-band signals: the error
    # power is resample_error, within the scatter of 20 draws (1 dB).
    rng = np.random.default_rng(535353)
    table = ffbp.fractional_filters(band, taps).astype(np.float64)
    phases = table.shape[0] - 1
    err = sig = 0.0
    for _ in range(20):
        tones = _tones(rng, band)
        x = _at(tones, np.arange(64.0))
        pos = rng.uniform(taps, 64 - taps, 200)
        i = np.floor(pos).astype(int)
        p = (pos - i) * phases
        j = np.minimum(p.astype(int), phases - 1)
        w = table[j] + (p - j)[:, None] * (table[j + 1] - table[j])
        y = np.sum(w * x[i[:, None] + np.arange(taps) - (taps // 2 - 1)], axis=1)
        truth = _at(tones, pos)
        err += float(np.sum(np.abs(y - truth) ** 2))
        sig += float(np.sum(np.abs(truth) ** 2))
    measured = 10.0 * math.log10(err / sig)
    assert measured == pytest.approx(10.0 * math.log10(ffbp.resample_error(band, taps)), abs=1.0)


def test_default_taps_are_the_fewest_that_meet_the_budget():
    allowed = ffbp.error_allowed()
    share = ffbp.FACTORISATION_SHARE
    stages, alpha = ffbp.MAX_STAGES, ffbp.DEFAULT_ALPHA
    # The factorisation: every stage at the widest band, within its share.
    assert ffbp.default_taps() == ffbp.TAPS
    assert ffbp.factorisation_error(stages, alpha) <= share * allowed
    assert ffbp.factorisation_error(stages, alpha, ffbp.TAPS - 2) > share * allowed
    # The rotated path's resampling, at the widest bands its grid leaves, 1 / (2 * 1.6)
    # along u and 1 / (2 * 2.05 alpha) along v, within the rest.
    over_u, over_v = ffbp.RESAMPLE_OVERSAMPLING
    band_u, band_v = 0.5 / over_u, 0.5 / (over_v * alpha)
    tu, tv = ffbp.RESAMPLE_TAPS

    def resampling(tu: int, tv: int) -> float:
        return ffbp.resample_error(band_u, tu) + ffbp.resample_error(band_v, tv)

    assert resampling(tu, tv) <= (1.0 - share) * allowed
    assert resampling(tu - 2, tv) > (1.0 - share) * allowed
    assert resampling(tu, tv - 2) > (1.0 - share) * allowed


def test_each_depth_takes_the_fewest_taps_its_bands_need():
    # _filters: the fewest even taps whose merge error over every node's own band is
    # within the allowance, and that error.
    nodes = []
    for slot, band in enumerate((0.05, 0.2, 0.3)):
        node = ffbp._Node(0, 2, dv=1.0, ratio=2, centre=0.0, half=band, slot=slot)
        nodes.append(node)
    allowed = 1e-7
    g, worst = ffbp._filters(nodes, allowed)
    taps = g.shape[2]
    assert worst == pytest.approx(ffbp.merge_error(0.3, taps)) and worst <= allowed
    assert ffbp.merge_error(0.3, taps - 2) > allowed
    # Narrow bands alone need fewer taps.
    g_narrow, _ = ffbp._filters(nodes[:1], allowed)
    assert g_narrow.shape[2] < taps


def _points(grid: ImageGrid) -> np.ndarray:
    x, y = np.meshgrid(grid.x_m, grid.y_m)
    return np.stack([x, y], axis=-1)


def _check(traces, monkeypatch, path: str, alpha: float | None = None) -> None:
    """FFBP on N x N pixels at 0.25 m: the path, and the accuracy against the exact sum."""
    if path == "rotated":
        monkeypatch.setattr(ffbp, "_ROTATED_BUDGET", 1e3)  # run it at this size
    grid = ImageGrid.square(size_m=N * 0.25, spacing_m=0.25)
    fast = backproject(traces, grid, method="ffbp", ffbp_oversampling=alpha)
    info = fast.metadata["ffbp"]
    assert info["path"] == path
    if alpha is not None:
        assert info["alpha"] == alpha and info["most_taps"] == ffbp.default_taps(alpha)
    ser = _ser_db(exact_sum(traces, _points(grid)), fast.values)
    assert ser >= ffbp.TARGET_DB
    assert ser >= info["budget_db"] - ffbp.BUDGET_MARGIN_DB, (ser, info["budget_db"])


def _simulated(look_deg: float, seed: int):
    """Points at random positions, one mover, 20 dB SNR, 4 degrees centred on ``look_deg``."""
    rng = np.random.default_rng(seed)
    targets = [
        PointTarget(position_m=tuple(rng.uniform(-15.0, 15.0, 2)),
                    reflectivity=complex(*rng.normal(size=2)))
        for _ in range(6)
    ] + [PointTarget(position_m=(0.0, 0.0), velocity_mps=(10.0, 5.0))]  # fmt: skip
    trajectory = Trajectory.circular(aperture_deg=4.0, centre_azimuth_deg=look_deg)
    tr = simulate(Scene(name="ffbp", targets=targets), trajectory=trajectory).traces
    return tr.with_data(add_noise(tr.data, snr_db=20.0, rng=seed))


@pytest.mark.parametrize(("look_deg", "path"), [(0.0, "axis-aligned"), (30.0, "rotated"),
                                                (45.0, "rotated")])  # fmt: skip
def test_ffbp_of_simulated_points_reaches_its_accuracy(look_deg, path, monkeypatch):
    _check(_simulated(look_deg, seed=7700 + int(look_deg)), monkeypatch, path)


@pytest.mark.parametrize("alpha", ffbp.ALPHAS)
def test_ffbp_reaches_its_accuracy_at_every_planned_oversampling(alpha, monkeypatch):
    # The planner keeps the cheapest of ffbp.ALPHAS, each with the taps its budget needs
    # (ffbp.default_taps): every one of them reaches the target.
    _check(_simulated(0.0, seed=7700), monkeypatch, "axis-aligned", alpha)


@pytest.fixture(scope="module")
def gotcha(gotcha_files):
    return read_gotcha(gotcha_files)


@pytest.mark.gotcha
@pytest.mark.parametrize(("deg", "path", "alpha"), [(0.0, "axis-aligned", None),
                                                    (0.0, "axis-aligned", ffbp.ALPHAS[-1]),
                                                    (45.0, "rotated", None)])  # fmt: skip
def test_ffbp_of_gotcha_reaches_its_accuracy(gotcha, deg, path, alpha, monkeypatch):
    _check(turned(gotcha, deg) if deg else gotcha, monkeypatch, path, alpha)
