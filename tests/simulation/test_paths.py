"""Piecewise-straight movers and long range windows (sarmotion.simulation.paths)."""

import numpy as np
import pytest

from sarmotion.core import C, Trajectory, delay_phase, delta_tau, target_positions, to_fast_time
from sarmotion.simulation import (
    AcceleratingTarget,
    PathTarget,
    PointTarget,
    Scene,
    TurningTarget,
    radar_with_range_window,
    simulate,
    simulate_phase_history,
)


def test_uniform_motion_is_bit_identical_to_the_straight_line_formula():
    """The forward model's phase history of a uniform mover is the eq:MOD9 formula, bit for bit."""
    traj = Trajectory.circular(aperture_deg=1.0)
    from sarmotion.core import Radar

    radar = Radar()
    tgt = PointTarget(position_m=[3.0, -4.0], velocity_mps=[5.0, 2.0], reflectivity=0.7 + 0.2j)
    ref = np.zeros(3)
    got = simulate_phase_history([tgt], traj, radar, ref)
    rho = target_positions(tgt.position_m, tgt.velocity3_mps, traj.slow_times_s)
    dtau = delta_tau(traj.positions_m, rho, ref)
    amp = np.full(traj.n_pulses, tgt.reflectivity, dtype=np.complex128)
    expected = np.zeros((traj.n_pulses, radar.n_samples), dtype=np.complex128)
    expected += amp[:, None] * delay_phase(-dtau, radar.frequencies_hz)
    expected *= radar.spectral_weights()[None, :]
    assert np.array_equal(got, expected)


def test_path_positions_turn_and_stop():
    path = PathTarget(
        times_s=[-4.0, 0.0, 2.0, 6.0],
        waypoints_m=[[-20.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 12.0]],
    )
    s = np.array([-6.0, -4.0, -1.0, 0.0, 1.0, 2.0, 3.0, 8.0])
    p = path.positions_at(s)
    assert p.shape == (8, 3) and np.all(p[:, 2] == 0)
    np.testing.assert_allclose(
        p[:, :2], [[-30, 0], [-20, 0], [-5, 0], [0, 0], [0, 0], [0, 0], [0, 3], [0, 18]]
    )
    v = path.velocities_at(s)
    np.testing.assert_allclose(v, [[5, 0], [5, 0], [5, 0], [0, 0], [0, 0], [0, 3], [0, 3], [0, 3]])
    np.testing.assert_allclose(path.position_m, [0, 0, 0])
    with pytest.raises(ValueError, match="times_s"):
        PathTarget(times_s=[0.0, 0.0], waypoints_m=[[0, 0], [1, 1]])
    with pytest.raises(ValueError, match="waypoints_m"):
        PathTarget(times_s=[0.0, 1.0], waypoints_m=[[0, 0]])


def test_one_leg_path_equals_the_uniform_mover():
    """A path of one leg through the same motion gives the uniform mover's traces (1e-9)."""
    traj = Trajectory.circular(aperture_deg=1.0)
    from sarmotion.core import Radar

    radar = Radar()
    uniform = PointTarget(position_m=[3.0, -4.0], velocity_mps=[5.0, 2.0])
    path = PathTarget(times_s=[-1.0, 1.0], waypoints_m=[[-2.0, -6.0], [8.0, -2.0]])
    a = simulate_phase_history([uniform], traj, radar, np.zeros(3))
    b = simulate_phase_history([path], traj, radar, np.zeros(3))
    assert np.max(np.abs(a - b)) < 1e-9 * np.max(np.abs(a))


def test_radar_with_range_window_keeps_band_and_resolution():
    base_window = 0.5 * C / 1.47130106e6  # GOTCHA, 101.9 m
    radar = radar_with_range_window(300.0)
    assert 0.5 * C / radar.frequency_step_hz >= 300.0
    from sarmotion.core import Radar

    gotcha = Radar()
    assert radar.carrier_hz == gotcha.carrier_hz and radar.bandwidth_hz == gotcha.bandwidth_hz
    assert abs(radar.span_hz - gotcha.span_hz) < 1e-6 * gotcha.span_hz
    assert radar_with_range_window(base_window - 1.0) is not None
    assert radar_with_range_window(50.0) == gotcha
    with pytest.raises(ValueError, match="range_window_m"):
        radar_with_range_window(-1.0)


def test_turning_mover_trace_follows_its_range_in_a_wide_window():
    """A long turning track (about 150 m of slant range) over 10 degrees with a 300 m window.

    The compressed trace of each pulse peaks at the mover's differential range ``c dtau / 2``
    (within half a fast-time sample): in the GOTCHA window (102 m) the far end would wrap.
    """
    path = PathTarget(
        times_s=[-9.0, 0.0, 9.0], waypoints_m=[[-110.0, -10.0], [0.0, 0.0], [90.0, -40.0]]
    )
    radar = radar_with_range_window(300.0)
    scene = Scene(
        name="turn",
        targets=(path,),
        radar=radar,
        trajectory_spec={"kind": "circular", "aperture_deg": 10.0},
    )
    sim = simulate(scene)
    tr = sim.traces
    dtau = delta_tau(tr.positions_m, path.positions_at(tr.slow_times_s), tr.reference_point_m)
    assert np.ptp(0.5 * C * dtau) > 100.0  # longer than GOTCHA's window
    t = tr.fast_times_s
    dt = t[1] - t[0]
    peaks = t[np.argmax(np.abs(tr.data), axis=1)]
    window = 1.0 / radar.frequency_step_hz
    err = (peaks - dtau + 0.5 * window) % window - 0.5 * window
    assert np.max(np.abs(err)) <= 0.5 * dt + 1e-12
    # the same traces through to_fast_time of the phase history (the model is linear)
    assert np.allclose(
        tr.data, to_fast_time(simulate_phase_history([path], tr.trajectory, radar, np.zeros(3)))
    )


def test_accelerating_target_is_the_constant_acceleration_formula():
    """rho(s) = rho + s u + s^2 a / 2, u(s) = u + s a; zero acceleration is the uniform mover."""
    m = AcceleratingTarget(
        position_m=[1.0, 2.0], velocity_mps=[3.0, -1.0], acceleration_mps2=[0.5, 0.2]
    )
    s = np.array([-2.0, 0.0, 3.0])
    expected = (
        np.array([1.0, 2.0])[None] + s[:, None] * [3.0, -1.0] + 0.5 * s[:, None] ** 2 * [0.5, 0.2]
    )
    np.testing.assert_allclose(m.positions_at(s)[:, :2], expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m.velocities_at(s), [3.0, -1.0] + s[:, None] * [0.5, 0.2])
    flat = AcceleratingTarget(
        position_m=[1.0, 2.0], velocity_mps=[3.0, -1.0], acceleration_mps2=[0, 0]
    )
    uniform = PointTarget(position_m=[1.0, 2.0], velocity_mps=[3.0, -1.0])
    np.testing.assert_array_equal(flat.positions_at(s), uniform.positions_at(s))
    with pytest.raises(ValueError, match="acceleration_mps2"):
        AcceleratingTarget(position_m=[0, 0], velocity_mps=[1, 0], acceleration_mps2=[1.0])


def test_turning_target_keeps_its_speed_and_turns_at_its_rate():
    """Constant speed, heading rate omega, positions the integral of the velocity."""
    m = TurningTarget(position_m=[0.0, 0.0], velocity_mps=[6.0, -4.0], turn_rate_deg_s=3.0)
    s = np.linspace(-5.0, 5.0, 201)
    v = m.velocities_at(s)
    np.testing.assert_allclose(np.hypot(*v.T), np.hypot(6.0, -4.0), rtol=1e-12)
    heading = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    np.testing.assert_allclose(np.degrees(np.diff(heading) / np.diff(s)), 3.0, rtol=1e-9)
    p = m.positions_at(s)[:, :2]
    # central differences of the closed form are the velocity to O(h^2 omega^2 |u|)
    np.testing.assert_allclose(np.gradient(p, s, axis=0)[1:-1], v[1:-1], atol=1e-4)
    straight = TurningTarget(position_m=[1.0, 2.0], velocity_mps=[3.0, -1.0], turn_rate_deg_s=0.0)
    uniform = PointTarget(position_m=[1.0, 2.0], velocity_mps=[3.0, -1.0])
    np.testing.assert_allclose(straight.positions_at(s), uniform.positions_at(s), atol=1e-12)
