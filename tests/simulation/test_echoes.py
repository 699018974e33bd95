"""The compiled sum of point echoes against the forward model, target by target."""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.core import Trajectory
from sarmotion.simulation import PointTarget
from sarmotion.simulation.collection import collection_acquisition
from sarmotion.simulation.echoes import point_echoes
from sarmotion.simulation.forward import simulate_phase_history


def _targets(rng: np.random.Generator, n: int, half_m: float) -> list[PointTarget]:
    return [
        PointTarget(
            position_m=rng.uniform(-half_m, half_m, 2),
            velocity_mps=rng.uniform(-12.0, 12.0, 2) * (k % 3 == 0),
            reflectivity=complex(rng.standard_normal(), rng.standard_normal()),
        )
        for k in range(n)
    ]


def test_sum_is_the_forward_model_to_the_rounding_of_the_travel_times() -> None:
    """Every sample agrees with ``simulate_phase_history`` (one target at a time, numpy).

    The two differ only in how the travel times are rounded: ``tau ~ 7e-5`` s in float64
    is exact to ``~1e-20`` s, a phase of ``f tau eps ~ 1e-10`` cycles at 10 GHz; summed
    over the targets' amplitudes, ``|err| <= 1e-8 sum |a_t|`` holds with room.
    """
    acq = collection_acquisition(300.0)
    traj = acq.trajectory
    rng = np.random.default_rng(5)
    targets = _targets(rng, 40, 150.0)
    ref = simulate_phase_history(targets, traj, acq.radar, acq.reference_point_m)
    got = point_echoes(
        traj.positions_m,
        traj.slow_times_s,
        [t.position_m for t in targets],
        [t.velocity3_mps for t in targets],
        [t.reflectivity for t in targets],
        acq.reference_point_m,
        acq.radar.frequencies_hz,
    )
    got *= acq.radar.spectral_weights()[None, :]
    amplitude = sum(abs(t.reflectivity) for t in targets)
    assert got.shape == ref.shape
    assert np.max(np.abs(got - ref)) <= 1e-8 * amplitude
    # and not trivially: the sum is of order its terms' amplitudes
    assert np.max(np.abs(ref)) > 0.1 * amplitude


def test_point_at_the_reference_has_no_phase_and_a_mover_no_fixed_range() -> None:
    """A point at the reference has ``dtau = 0`` exactly (the difference of the ranges is
    formed without cancellation): ``a`` at every sample; a mover's phase slope changes
    pulse to pulse."""
    traj = Trajectory.circular(aperture_deg=1.0, pulses_per_deg=40.0)
    f = np.linspace(9.5e9, 9.7e9, 33)
    a = 0.3 - 0.7j
    got = point_echoes(
        traj.positions_m, traj.slow_times_s, [[0.0, 0.0, 0.0]], [[0.0, 0.0, 0.0]], [a], [0, 0, 0], f
    )
    np.testing.assert_allclose(got, a, rtol=0, atol=1e-15)
    moving = point_echoes(
        traj.positions_m,
        traj.slow_times_s,
        [[0.0, 0.0, 0.0]],
        [[3.0, 4.0, 0.0]],
        [1.0],
        [0, 0, 0],
        f,
    )
    slope = np.angle(moving[:, 1] * np.conj(moving[:, 0]))
    assert np.ptp(slope) > 1e-3  # the range changes over the aperture


def test_no_targets_is_silence_and_mismatched_shapes_are_refused() -> None:
    traj = Trajectory.circular(aperture_deg=0.1, pulses_per_deg=100.0)
    f = np.linspace(9.5e9, 9.7e9, 8)
    out = point_echoes(
        traj.positions_m, traj.slow_times_s, np.zeros((0, 3)), np.zeros((0, 3)), [], [0, 0, 0], f
    )
    assert out.shape == (traj.n_pulses, 8) and not np.any(out)
    with pytest.raises(ValueError, match="one per target"):
        point_echoes(
            traj.positions_m,
            traj.slow_times_s,
            np.zeros((2, 3)),
            np.zeros((1, 3)),
            [1, 1],
            [0] * 3,
            f,
        )
    with pytest.raises(ValueError, match="slow times"):
        point_echoes(traj.positions_m, [0.0], np.zeros((1, 3)), np.zeros((1, 3)), [1], [0] * 3, f)
