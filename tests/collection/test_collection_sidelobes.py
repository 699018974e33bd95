"""Stationary listings of a collection: a brighter target's sidelobes dropped, weak targets kept.

The rule (:func:`sarmotion.collection.drop_sidelobes`) is checked on the image the
analysis makes (:func:`~sarmotion.imaging.backproject` of simulated GOTCHA-like data):
every local maximum of the image within 25 dB of the brightest is listed, as a patch
lists them, and the rule must leave exactly the true targets, weak ones beside a strong
one included.
"""

from __future__ import annotations

import numpy as np
import pytest

from point_scenes import cell_offset, point_traces, weak_beside_strong
from sarmotion.collection import StationaryRecord, drop_sidelobes
from sarmotion.imaging import ImageGrid, backproject, resolution
from sarmotion.simulation import PointTarget

SPACING = 0.25


def _listing(targets):
    """Every local maximum within 25 dB of the brightest, as records, and the cells."""
    tr = point_traces(targets)
    cells = resolution(tr)
    img = backproject(tr, ImageGrid.square(centre_m=(0.0, 0.0), size_m=24.0, spacing_m=SPACING))
    mag = img.magnitude
    peak = float(mag.max())
    records = []
    for x, y, _ in img.peaks(400, min_separation_m=cells.ground_range_m):
        iy, ix = img.grid.nearest_index((x, y))
        if mag[iy, ix] >= peak * 10 ** (-25 / 20):
            records.append(StationaryRecord(patch=0, position_m=(x, y), level=float(mag[iy, ix])))
    return tr, cells, records


def _check(targets):
    tr, cells, records = _listing(targets)
    antenna = tr.trajectory.positions_m[tr.n_pulses // 2]
    kept, dropped = drop_sidelobes(
        records,
        antenna_m=antenna,
        range_cell_m=cells.ground_range_m,
        cross_cell_m=cells.cross_range_m,
        pixel_m=SPACING,
    )
    truth = np.array([t.position_m[:2] for t in targets])
    listed = np.array([t.position_m for t in kept])
    cell = max(cells.ground_range_m, cells.cross_range_m)
    # every true target is kept ...
    for p in truth:
        assert np.min(np.hypot(*(listed - p).T)) <= cell, p
    # ... and every kept listing is a true target: the sidelobes went
    for q in listed:
        assert np.min(np.hypot(*(truth - q).T)) <= cell, q
    assert dropped == len(records) - len(kept)
    assert dropped > 0  # the strong target's sidelobes were listed, and dropped


def test_weak_targets_beside_a_strong_one_are_kept_its_sidelobes_dropped():
    _, cells, _ = _listing([PointTarget(position_m=(0.0, 0.0))])
    strong = PointTarget(position_m=(0.0, 0.0), reflectivity=1.0)
    weak = [
        # on the cross-range sidelobe ridge, above its envelope there
        PointTarget(position_m=cell_offset(cells, 0.0, 3.5), reflectivity=10 ** (-6 / 20)),
        # on the range ridge
        PointTarget(position_m=cell_offset(cells, -6.0, 0.0), reflectivity=10 ** (-9 / 20)),
        # off both ridges, far below the first sidelobe
        PointTarget(position_m=cell_offset(cells, 7.0, -2.5), reflectivity=10 ** (-18 / 20)),
    ]
    _check([strong, *weak])


@pytest.mark.parametrize("seed", [11, 12])
def test_seeded_weak_targets_off_the_ridges_are_kept(seed):
    """Weak targets (-3 to -15 dB) at least 1.5 cells off both of the strong one's axes."""
    _, cells, _ = _listing([PointTarget(position_m=(0.0, 0.0))])
    _check(weak_beside_strong(np.random.default_rng(seed), cells))
