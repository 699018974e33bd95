"""Fast factorised backprojection at oblique look directions (the rotated path of
:mod:`sarmotion.imaging.ffbp`) against exact backprojection. No timing here (see
benchmarks/bench_backprojection.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarmotion.core import Trajectory
from sarmotion.imaging import ImageGrid, backproject, ffbp
from sarmotion.io import read_gotcha
from sarmotion.simulation import PointTarget, Scene, add_noise, simulate
from turned import turned


def _ser_db(ref: np.ndarray, x: np.ndarray) -> float:
    err = np.linalg.norm(x - ref)
    return math.inf if err == 0 else 20.0 * math.log10(np.linalg.norm(ref) / err)


def _points(centre_azimuth_deg: float):
    """Four points (one moving) seen over 4 degrees of a GOTCHA-like circle, 20 dB SNR."""
    targets = [
        PointTarget(position_m=(7.3, -4.1)),
        PointTarget(position_m=(-20.0, 15.0), reflectivity=0.5j),
        PointTarget(position_m=(30.0, 25.0), reflectivity=-0.7),
        PointTarget(position_m=(0.0, 0.0), velocity_mps=(10.0, 5.0)),
    ]
    trajectory = Trajectory.circular(aperture_deg=4.0, centre_azimuth_deg=centre_azimuth_deg)
    tr = simulate(Scene(name="oblique", targets=targets), trajectory=trajectory).traces
    return tr.with_data(add_noise(tr.data, snr_db=20.0, rng=11))


@pytest.mark.parametrize(
    ("band", "taps", "max_error"), [(0.3125, 10, 2e-3), (0.3125, 8, 1e-2), (0.175, 6, 1e-3)]
)
def test_fractional_filters_interpolate_the_band(band, taps, max_error):
    # The default rotated grid holds the band up to 0.3125 cycles/sample along u (10 taps;
    # 8 for comparison) and 0.175 along v (6 taps). Every tabulated phase, and the linear
    # interpolation half-way between two, reproduces exp(2i pi f x) at its fractional
    # position for |f| <= band: worst error (at the band edges) 1.4e-3, 6.5e-3 and 6.1e-4
    # measured.
    table = ffbp.fractional_filters(band, taps)
    phases = table.shape[0] - 1
    f = np.linspace(-band, band, 401)
    worst = 0.0
    for q in np.arange(0, phases, 0.5):
        p = int(q)
        g = table[p].astype(np.float64)
        if q != p:
            g = 0.5 * (g + table[p + 1])
        offsets = np.arange(taps) - (taps // 2 - 1) - q / phases
        response = np.exp(2j * np.pi * np.outer(f, offsets)) @ g
        worst = max(worst, float(np.max(np.abs(response - 1.0))))
    assert worst < max_error
    # Half a sample past tap T/2 - 1 is the symmetric half-sample filter.
    np.testing.assert_allclose(table[phases // 2], table[phases // 2][::-1], atol=1e-6)


@pytest.mark.parametrize("azimuth_deg", [0.0, 15.0, 30.0, 45.0, 70.0])
def test_ffbp_at_any_look_direction(azimuth_deg):
    # 1024 x 1024 at 0.25 m (256 m): the smallest simulated size where the rotated path is
    # predicted to pay; to the accuracy of FFBP (ffbp.TARGET_DB).
    tr = _points(azimuth_deg)
    grid = ImageGrid.square(size_m=256.0, spacing_m=0.25)
    exact = backproject(tr, grid)
    fast = backproject(tr, grid, method="ffbp")
    assert fast.metadata["kernel_variant"] == "ffbp"
    info = fast.metadata["ffbp"]
    assert info["path"] == ("axis-aligned" if azimuth_deg == 0.0 else "rotated")
    if azimuth_deg:
        # the frame's u axis is the look direction, from the aperture towards the scene
        assert math.cos(math.radians(info["rotation_deg"] - azimuth_deg - 180.0)) > 0.999
    assert _ser_db(exact.values, fast.values) >= ffbp.TARGET_DB
    # The points are where exact backprojection puts them.
    assert fast.peak()[:2] == pytest.approx(exact.peak()[:2], abs=1e-9)


@pytest.fixture(scope="module")
def gotcha(gotcha_files):
    return read_gotcha(gotcha_files)


@pytest.mark.gotcha
@pytest.mark.parametrize("deg", [30.0, 45.0])
def test_ffbp_on_gotcha_turned_to_an_oblique_look(gotcha, deg):
    # The four degrees turned so that the look is 28-32 (or 43-47) degrees from both grid
    # axes; 1024 x 1024 at 0.25 m, to the accuracy of FFBP (ffbp.TARGET_DB), some pixels
    # computed exactly near the ends of the fast-time window.
    tr = turned(gotcha, deg)
    grid = ImageGrid.square(size_m=256.0, spacing_m=0.25)
    fast = backproject(tr, grid, method="ffbp")
    info = fast.metadata["ffbp"]
    assert info["path"] == "rotated" and info["exact_pixels"] > 0
    assert _ser_db(backproject(tr, grid).values, fast.values) >= ffbp.TARGET_DB


@pytest.mark.gotcha
def test_window_ends_are_computed_exactly(gotcha, monkeypatch):
    # GOTCHA's fast-time window covers ~145 m of ground range: at its ends every pulse's
    # contribution steps to 0 along u, which no band-limited interpolation reproduces:
    # resampled there too, the image falls short of the accuracy of FFBP, which the pixels
    # near the ends computed exactly restore.
    tr = turned(gotcha, 45.0)
    grid = ImageGrid.square(size_m=256.0, spacing_m=0.25)
    exact = backproject(tr, grid).values
    with_edges = _ser_db(exact, backproject(tr, grid, method="ffbp").values)
    monkeypatch.setattr(ffbp, "_window_edge_blocks", lambda *a, **k: [])
    fast = backproject(tr, grid, method="ffbp")
    assert fast.metadata["ffbp"]["path"] == "rotated"
    without = _ser_db(exact, fast.values)
    assert without < ffbp.TARGET_DB <= with_edges


def _turned_outline(azimuth_deg: float, centre, depth_m: float, width_m: float) -> np.ndarray:
    """A rectangle ``depth_m`` along the look and ``width_m`` across, about ``centre``."""
    a = math.radians(azimuth_deg)
    e_r, e_c = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    o = np.asarray(centre, float) - 0.5 * depth_m * e_r - 0.5 * width_m * e_c
    return np.array([o, o + depth_m * e_r, o + depth_m * e_r + width_m * e_c, o + width_m * e_c])


@pytest.mark.parametrize("azimuth_deg", [0.0, 30.0])
def test_an_outline_forms_only_its_pixels_with_the_same_values(azimuth_deg):
    # A patch's halo: a rectangle turned to the look, a fraction of the square grid. Every
    # path forms the pixels within it with the values it forms without it (exact: the
    # same sums; FFBP: to its accuracy against exact), and 0 outside; the rotated path
    # factorises a smaller grid.
    from sarmotion.imaging import in_outline

    tr = _points(azimuth_deg)
    grid = ImageGrid.square(size_m=256.0, spacing_m=0.25)
    outline = _turned_outline(azimuth_deg, (5.0, -3.0), 60.0, 170.0)
    xx, yy = np.meshgrid(grid.x_m, grid.y_m)
    inside = in_outline(np.stack([xx, yy], axis=-1), outline)
    assert 0.1 < inside.mean() < 0.25
    exact = backproject(tr, grid)
    cut = backproject(tr, grid, outline_m=outline)
    assert not np.any(cut.values[~inside])
    peak = np.abs(exact.values).max()
    assert np.max(np.abs(cut.values[inside] - exact.values[inside])) <= 1e-6 * peak
    fast = backproject(tr, grid, method="ffbp")
    fast_cut = backproject(tr, grid, method="ffbp", outline_m=outline)
    assert not np.any(fast_cut.values[~inside])
    assert _ser_db(exact.values[inside], fast_cut.values[inside]) >= ffbp.TARGET_DB
    info, whole = fast_cut.metadata["ffbp"], fast.metadata["ffbp"]
    assert info["path"] == whole["path"]
    if azimuth_deg:  # the rotated path: only the outline's box in its frame
        assert np.prod(info["rotated_grid"]) < 0.5 * np.prod(whole["rotated_grid"])
    else:  # the axis-aligned path: only the outline's box on the grid
        assert fast_cut.metadata["outline_m"] == outline.tolist()


def test_an_outline_must_be_a_parallelogram():
    tr = _points(0.0)
    grid = ImageGrid.square(size_m=20.0, spacing_m=0.5)
    with pytest.raises(ValueError, match="parallelogram"):
        backproject(tr, grid, outline_m=[[0, 0], [1, 0], [2, 2], [0, 1]])
    with pytest.raises(ValueError, match=r"\(4, 2\)"):
        backproject(tr, grid, outline_m=[[0, 0], [1, 0], [1, 1]])
