"""Separation of stationary and moving traces (sect:algdesc) on the paper's scenes."""

import numpy as np
import pytest

from sarmotion.imaging import ImageGrid, backproject
from sarmotion.separation import (
    annihilate,
    mover_trace_coverage,
    separate_annihilation,
    separate_combined,
    separate_rpca,
    separation_quality,
    stationary_candidates,
)
from sarmotion.simulation import load_scene, simulate


@pytest.fixture(scope="module")
def scene1():
    return simulate(load_scene("scene1"))


def _prelim(traces):
    grid = ImageGrid.square(size_m=60.0, spacing_m=0.25)
    return backproject(traces, grid), grid


def _quality(sep, sim, **kw):
    return separation_quality(sep, true_stationary=sim.stationary, true_moving=sim.moving, **kw)


def test_combined_separates_scene1(scene1):
    # Target: ||S - S_true|| / ||S_true|| <= 0.3 keeping >= 85 % of the movers
    # (measured: 0.13 and 99.8 %).
    img, grid = _prelim(scene1.traces)
    sep = separate_combined(scene1.traces, image_values=img.values, x_m=grid.x_m, y_m=grid.y_m)
    q = _quality(sep, scene1)
    assert q["relative_error_moving"] <= 0.3
    assert q["mover_retained"] >= 0.85
    # The stationary locations it used are the scene's, to a small fraction of a cell.
    truth = np.array([t.position_m for t in scene1.scene.stationary])
    used = sep.stationary_points_m
    nearest = np.min(np.linalg.norm(used[:, None, :] - truth[None], axis=2), axis=1)
    assert np.median(nearest) < 0.05
    # L + S = M exactly (S is what the subtraction left).
    np.testing.assert_allclose(sep.stationary + sep.moving, scene1.traces.data, atol=1e-12)


def test_combined_rejects_mover_streaks(scene1):
    # Candidates on the movers' positions are not taken for stationary targets.
    movers = [m.position_m for m in scene1.scene.moving]
    sep = separate_combined(scene1.traces, points_m=movers, refine=False)
    assert len(sep.stationary_points_m) == 0
    np.testing.assert_allclose(sep.moving, scene1.traces.data)


def test_windowed_rpca_beats_whole_matrix_rpca():
    # sect:RPCA, fig:rpcaEx1 / fig:rpcaEx2b: windowing is what makes RPCA work.
    for name in ("example1", "example2"):
        sim = simulate(load_scene(name))
        whole = _quality(separate_rpca(sim.traces, window=sim.traces.n_samples), sim)
        windowed = _quality(separate_rpca(sim.traces, window=32), sim)
        assert windowed["relative_error_moving"] < 0.6 * whole["relative_error_moving"], name


def test_rpca_keeps_mover_traces_that_annihilation_cuts(scene1):
    # fig:rpca2mov vs fig:annihilScene1: the composed annihilation filter "removes some parts
    # of the traces from the moving targets as well"; RPCA keeps more of them. Measured on
    # the fraction of each mover's trace kept within 6 dB of its median (0.55 vs 0.83 seen).
    img, grid = _prelim(scene1.traces)
    pts = stationary_candidates(img.values, x_m=grid.x_m, y_m=grid.y_m, traces=scene1.traces)
    ann = separate_annihilation(scene1.traces, pts)
    rpca = separate_rpca(scene1.traces, window=32)
    movers = scene1.scene.moving
    cov_ann = mover_trace_coverage(ann.moving, scene1.traces, movers)
    cov_rpca = mover_trace_coverage(rpca.moving, scene1.traces, movers)
    assert cov_rpca > cov_ann + 0.15
    assert mover_trace_coverage(scene1.moving, scene1.traces, movers) == 1.0
    # The annihilation filter is still a strong clutter filter: what is left of the
    # stationary traces is far below what is left of the movers (~32 dB seen).
    op = lambda d: annihilate(scene1.traces.with_data(d), pts).data  # noqa: E731
    assert _quality(ann, scene1, operator=op)["signal_to_clutter_db"] > 20


def test_aligned_constant_part_is_the_windowed_mean_of_the_aligned_traces():
    """``T_-`` of the slow-time mean of ``T_+ D`` over ``|t| <= h``: removes the point at rho.

    Checked against the definition written out on the whole array (aligned traces, the
    window's slow-time mean put back on every pulse, transformed back), and on a scene
    of two stationary points: taking the part of one leaves the other and removes the
    one (its echo at rho drops by more than 40 dB).
    """
    from point_scenes import point_traces
    from sarmotion.core import delay_phase, to_fast_time, to_frequency
    from sarmotion.separation import aligned_constant_part, travel_time_delays
    from sarmotion.simulation import PointTarget

    rho, other = np.array([3.0, -2.0, 0.0]), np.array([-8.0, 6.0, 0.0])
    tr = point_traces([PointTarget(position_m=rho[:2]), PointTarget(position_m=other[:2])])
    spectrum = to_frequency(tr.data)
    h = 5
    part = aligned_constant_part(spectrum, rho, acquisition=tr.acquisition, half_window=h)
    phase = delay_phase(travel_time_delays(tr, rho), tr.frequencies_hz)
    aligned = to_fast_time(spectrum * phase)
    c = tr.n_samples // 2
    low = np.zeros_like(aligned)
    low[:, c - h : c + h + 1] = aligned[:, c - h : c + h + 1].mean(axis=0, keepdims=True)
    expected = to_frequency(low) * np.conj(phase)
    assert np.max(np.abs(part - expected)) <= 1e-12 * np.max(np.abs(expected))

    def at(s, p):  # |sum over pulses and frequencies of T_+^p s| (the point's focus)
        ph = delay_phase(travel_time_delays(tr, p), tr.frequencies_hz)
        return abs(np.sum(s * ph))

    left = spectrum - part
    assert at(left, rho) < 1e-2 * at(spectrum, rho)
    assert at(left, other) > 0.9 * at(spectrum, other)
