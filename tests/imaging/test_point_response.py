"""The location refinement (a safeguarded Newton ascent of ``|I|^2``) against brute force.

``refine_location`` climbs ``|I(rho)|^2`` with its analytic gradient and Hessian. Its
result must be the maximum of ``|I|`` near the start: no point of a fine grid around it
(0.5 mm spacing, +-5 mm) is higher by more than the grid's own quadratic sampling, and
derivative-free searches started elsewhere in the main lobe end within 1 mm of it.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from sarmotion.imaging import point_response, refine_location
from sarmotion.simulation import random_scene, simulate


@pytest.fixture(scope="module")
def noisy():
    sim = simulate(
        random_scene(n_stationary=8, movers=[([4.0, -3.0], [6.0, 2.0])], rng=21),
        snr_db=15.0,
        rng=21,
    )
    return sim


def _abs_i(traces, xy, z, velocity=None, phase_history=None):
    return abs(
        point_response(
            traces, np.array([xy[0], xy[1], z]), velocity_mps=velocity, phase_history=phase_history
        )[0]
    )


@pytest.mark.parametrize("which", range(4))
def test_refined_location_is_the_local_maximum(noisy, which):
    tr = noisy.traces
    P = tr.phase_history()
    target = np.asarray(noisy.scene.stationary[which].position_m, dtype=float)
    start = target + np.array([0.11, -0.2, 0.0])  # half a pixel, a quarter cross-range cell
    best, value = refine_location(tr, start, phase_history=P)
    assert abs(value) == pytest.approx(_abs_i(tr, best[:2], best[2], phase_history=P), rel=1e-10)
    offsets = np.arange(-5e-3, 5.01e-3, 5e-4)
    grid = [
        _abs_i(tr, best[:2] + [dx, dy], best[2], phase_history=P)
        for dx in offsets
        for dy in offsets
    ]
    assert max(grid) <= abs(value) * (1 + 1e-7)
    ref = minimize(
        lambda q: -_abs_i(tr, q, best[2], phase_history=P),
        start[:2],
        method="Nelder-Mead",
        options={"xatol": 1e-5, "fatol": 1e-12},
    )
    assert np.linalg.norm(ref.x - best[:2]) < 1e-3


def test_refined_moving_location_with_compensation(noisy):
    tr = noisy.traces
    mover = noisy.scene.moving[0]
    truth = np.asarray(mover.position_m, dtype=float)
    vel = np.asarray(mover.velocity_mps, dtype=float)
    best, value = refine_location(tr, truth + [0.1, 0.3, 0.0], velocity_mps=vel)
    ref = minimize(
        lambda q: -_abs_i(tr, q, best[2], velocity=vel),
        truth[:2] + [0.1, 0.3],
        method="Nelder-Mead",
        options={"xatol": 1e-5, "fatol": 1e-12},
    )
    assert np.linalg.norm(ref.x - best[:2]) < 1e-3
    assert abs(value) >= -ref.fun * (1 - 1e-9)


def test_a_lone_point_target_is_found_where_it_is():
    """Alone and noise-free, ``|I|`` peaks exactly at the target (every term in phase)."""
    sim = simulate(random_scene(n_stationary=1, rng=4))
    target = np.asarray(sim.scene.stationary[0].position_m, dtype=float)
    for offset in ([0.1, -0.2, 0.0], [-0.12, 0.4, 0.0], [0.0, 0.0, 0.0]):
        best, value = refine_location(sim.traces, target + offset)
        assert np.linalg.norm(best[:2] - target[:2]) < 1e-4
        assert abs(value) == pytest.approx(sim.traces.n_pulses, rel=1e-6)
