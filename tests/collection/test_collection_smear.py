"""A mover's echo in the stationary image: its smear dropped, a true point on it kept.

The rule (:func:`sarmotion.collection.merge.drop_mover_images`) drops a stationary
listing on a found mover's echo only when that echo can make at least half its level
there (``SMEAR_MARGIN``): the echo's level at ``p`` is at most the mover's amplitude
times the mean over the pulses of the compressed pulse's envelope at their range
difference. Checked on the images the analysis makes (:func:`~sarmotion.imaging.
backproject` of noise-free GOTCHA-like data): every bright local maximum of a mover's
own smear is dropped, and a unit stationary point that a fast mover's echo crosses for a
few pulses is kept (the rule before, the coincidence alone, dropped it).
"""

from __future__ import annotations

import numpy as np
import pytest

from point_scenes import point_traces
from sarmotion.collection.merge import MoverRecord, StationaryRecord, drop_mover_images
from sarmotion.imaging import ImageGrid, backproject
from sarmotion.simulation import PointTarget

FAST = PointTarget(position_m=(5.0, -8.0), velocity_mps=(6.0, 3.0))
SPACING = 0.25


def _record(mover: PointTarget, amplitude: float = 1.0) -> MoverRecord:
    return MoverRecord(
        patch=0,
        position_m=np.r_[np.asarray(mover.position_m, float)[:2], 0.0],
        velocity_mps=np.asarray(mover.velocity_mps, float),
        sigma_range_m=np.inf,
        sigma_range_speed_mps=np.inf,
        snr_db=-np.inf,
        document={},
        amplitude=amplitude,
    )


def _drop(tr, points, levels, mover: PointTarget, amplitude: float = 1.0):
    records = [
        StationaryRecord(patch=0, position_m=(float(x), float(y)), level=float(v))
        for (x, y), v in zip(points, levels, strict=True)
    ]
    kept, _ = drop_mover_images(
        records,
        [_record(mover, amplitude)],
        trajectory=tr.trajectory,
        range_resolution_m=tr.radar.range_resolution_m,
        wavelength_m=tr.radar.wavelength_m,
        rate_period_mps=0.5 * tr.radar.wavelength_m / tr.trajectory.pulse_interval_s,
        gaussian_range=tr.radar.pulse == "gaussian",
    )
    keep = {id(r) for r in kept}
    return np.array([id(r) not in keep for r in records])


@pytest.fixture(scope="module")
def smear():
    """The fast mover alone: its stationary image ``|I| / n_pulses`` over 60 m."""
    tr = point_traces([FAST])
    grid = ImageGrid.square(centre_m=(0.0, 0.0), size_m=60.0, spacing_m=SPACING)
    level = backproject(tr, grid).magnitude / tr.n_pulses
    return tr, grid, level


def _pixels(grid, level, mask):
    iy, ix = np.nonzero(mask)
    return np.stack([grid.x_m[ix], grid.y_m[iy]], axis=1), level[iy, ix]


def test_every_maximum_of_a_movers_smear_on_its_echo_is_dropped():
    """The local maxima of a mover's own stationary image within 30 dB of its brightest
    that lie on its echo (its range and aliased range rate met at some pulse): each one
    the echo alone made, each dropped at the level it images at (the smears of Scene 1's
    mover in a whole analysis: ``test_collection_analysis.py``)."""
    mover = FAST
    tr = point_traces([mover])
    grid = ImageGrid.square(centre_m=(0.0, 0.0), size_m=60.0, spacing_m=SPACING)
    level = backproject(tr, grid).magnitude / tr.n_pulses
    pad = np.pad(level, 1, constant_values=np.inf)
    neighbours = np.stack(
        [pad[1 + dy : 1 + dy + level.shape[0], 1 + dx : 1 + dx + level.shape[1]]
         for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    )  # fmt: skip
    peaks = (level > neighbours.max(axis=0)) & (level >= 10 ** (-30 / 20) * level.max())
    points, levels = _pixels(grid, level, peaks)
    on_echo = _drop(tr, points, np.zeros(len(points)), mover)
    assert on_echo.sum() >= 3
    assert np.all(_drop(tr, points[on_echo], levels[on_echo], mover))


def test_a_unit_point_crossed_by_a_fast_movers_echo_is_kept(smear):
    """Where the fast mover's echo meets a stationary point's range and (aliased) range
    rate at some pulse, it stays within a range cell for a few pulses: a unit point
    there images at about 1, far above what the echo can make, and is kept; the same
    place at the smear's own level is dropped."""
    tr, grid, level = smear
    coarse = np.zeros_like(level, dtype=bool)
    coarse[::8, ::8] = True
    points, _ = _pixels(grid, level, coarse)
    on_echo = _drop(tr, points, np.zeros(len(points)), FAST)  # level 0: on the echo
    far = np.hypot(*(points - np.asarray(FAST.position_m)[:2]).T) > 10.0
    candidates = points[on_echo & far]
    assert len(candidates) > 0
    p = candidates[0]
    both = point_traces([FAST, PointTarget(position_m=tuple(p))])
    near = ImageGrid.square(centre_m=tuple(p), size_m=2.0, spacing_m=SPACING)
    unit = float(backproject(both, near).magnitude.max()) / both.n_pulses
    assert unit == pytest.approx(1.0, abs=0.2)
    assert not _drop(tr, [p], [unit], FAST)[0]
    iy, ix = np.argmin(np.abs(grid.y_m - p[1])), np.argmin(np.abs(grid.x_m - p[0]))
    assert _drop(tr, [p], [level[iy, ix]], FAST)[0]
