"""One analysis lists the stationary image's targets, not a bright target's sidelobes.

With a separation other than the combined one (measured data default to RPCA) the
listing is the local maxima of the stationary image; the sidelobe rule
(:func:`sarmotion.imaging.sidelobes.sidelobe_peaks`, the point-spread function's envelope)
must drop the strong target's sidelobes and keep every true target, weak ones beside the
strong one included, on scenes the rule was not tuned on (seeded positions and levels).
"""

from __future__ import annotations

import numpy as np
import pytest

from point_scenes import cell_offset, point_traces, weak_beside_strong
from sarmotion.imaging import ImageGrid, backproject, resolution
from sarmotion.imaging.sidelobes import envelope, sidelobe_peaks
from sarmotion.pipeline import AnalysisOptions
from sarmotion.pipeline.stages import stationary_targets
from sarmotion.separation import Separation
from sarmotion.simulation import PointTarget


def test_envelope_bounds_the_sinc_outside_the_main_lobe():
    a = np.linspace(-40.0, 40.0, 160001)
    assert np.all(np.abs(np.sinc(a)) <= envelope(a) + 1e-15)
    assert np.all(envelope(a)[np.abs(a) < 1.0] == 1.0)
    np.testing.assert_allclose(envelope(a, gaussian=True), np.exp(-0.5 * a * a))


def test_sidelobe_peaks_keeps_the_input_order_and_the_brightest():
    # Two peaks one cross-range cell and a half apart along the look direction's normal:
    # the weaker at -20 dB lies under the envelope 1 / (1.5 pi) = -13.5 dB and goes; at
    # -10 dB it stands above it and stays; listed weaker first, the flags follow the input.
    antenna = np.array([1.0e4, 0.0, 5.0e3])  # looking along -x: cross range is y
    common = dict(antenna_m=antenna, range_cell_m=0.3, cross_cell_m=0.3, pixel_m=0.01)
    pos = [(0.0, 0.45), (0.0, 0.0)]
    np.testing.assert_array_equal(sidelobe_peaks(pos, [0.1, 1.0], **common), [True, False])
    np.testing.assert_array_equal(sidelobe_peaks(pos, [0.316, 1.0], **common), [False, False])
    assert sidelobe_peaks(np.zeros((0, 2)), [], **common).shape == (0,)
    with pytest.raises(ValueError, match="positions"):
        sidelobe_peaks(pos, [1.0], **common)


def _traces(seed: int):
    """A strong point and three weak ones (-3 to -15 dB) >= 1.5 cells off its axes."""
    cells = resolution(point_traces([PointTarget(position_m=(0.0, 0.0))]))
    targets = weak_beside_strong(np.random.default_rng(seed), cells)
    return point_traces(targets), targets


@pytest.mark.parametrize("seed", [21, 22, 23])
def test_stationary_listing_drops_sidelobes_keeps_weak_targets(seed):
    # The stage on a stationary image whose separation is not the combined one (RPCA:
    # the listing is the image's local maxima, as on measured data).
    traces, targets = _traces(seed)
    image = backproject(traces, ImageGrid.square(centre_m=(0.0, 0.0), size_m=24.0,
                                                 spacing_m=0.25))  # fmt: skip
    sep = Separation(moving=np.zeros_like(traces.data), stationary=traces.data, method="rpca")
    listed, dropped = stationary_targets(
        image, sep, AnalysisOptions(), acquisition=traces.acquisition
    )
    cells = resolution(traces)
    cell = max(cells.ground_range_m, cells.cross_range_m)
    truth = np.array([t.position_m[:2] for t in targets])
    found = np.array([t.position_m for t in listed])
    for p in truth:  # every true target is listed ...
        assert np.min(np.hypot(*(found - p).T)) <= cell, p
    for q in found:  # ... and nothing else: the strong target's sidelobes went
        assert np.min(np.hypot(*(truth - q).T)) <= cell, q
    assert dropped > 0  # they were local maxima above the listing threshold
    levels = [t.level_db for t in listed]
    assert levels == sorted(levels, reverse=True) and levels[0] == 0.0


def test_a_capped_listing_reaches_past_the_sidelobes():
    # A unit point and one at -19 dB, 2.5 range and 3.5 cross-range cells off its axes:
    # the strong point's first and second sidelobes (-13 and -18 dB) outshine the weak
    # one. With max_stationary = 2 (listing down to -25 dB) the listing is both points:
    # maxima are taken brightest first until two are not sidelobes, not a fixed number
    # of them (twice the cap, 4 maxima, would stop short of the weak point).
    probe = point_traces([PointTarget(position_m=(0.0, 0.0))])
    cells = resolution(probe)
    weak = PointTarget(position_m=cell_offset(cells, 2.5, 3.5), reflectivity=10 ** (-19 / 20))
    traces = point_traces([PointTarget(position_m=(0.0, 0.0)), weak])
    image = backproject(traces, ImageGrid.square(centre_m=(0.0, 0.0), size_m=24.0,
                                                 spacing_m=0.25))  # fmt: skip
    sep = Separation(moving=np.zeros_like(traces.data), stationary=traces.data, method="rpca")
    listed, dropped = stationary_targets(
        image,
        sep,
        AnalysisOptions(max_stationary=2, stationary_threshold_db=-25.0),
        acquisition=traces.acquisition,
    )
    cell = max(cells.ground_range_m, cells.cross_range_m)
    assert len(listed) == 2 and dropped >= 3
    assert np.hypot(*listed[0].position_m) <= cell
    assert np.hypot(*(np.asarray(listed[1].position_m) - weak.position_m[:2])) <= cell
