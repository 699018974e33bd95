"""Geometry: trajectories, travel times, look vectors and speed conversions."""

import numpy as np
import pytest

from sarmotion.core import (
    C,
    Trajectory,
    cross_range_speed,
    delta_tau,
    ground_velocity,
    look_geometry,
    range_direction_velocity,
    range_speed,
    target_positions,
    travel_time,
)


def test_gotcha_circular_defaults():
    traj = Trajectory.circular(aperture_deg=1.0)
    assert traj.n_pulses == 117
    r = np.hypot(traj.positions_m[:, 0], traj.positions_m[:, 1])
    np.testing.assert_allclose(r, 7100.0, rtol=1e-12)
    np.testing.assert_allclose(traj.positions_m[:, 2], 7300.0)
    # 117 pulses per degree on a 7.1 km circle: 1.059 m and 15.1 ms between pulses.
    assert traj.pulse_interval_s == pytest.approx(7100 * np.deg2rad(1 / 117) / 70.0, rel=1e-12)
    assert traj.speed_mps == pytest.approx(70.0, rel=1e-6)
    # s = 0 at the aperture centre, platform on the x axis flying towards +y.
    assert traj.slow_times_s[58] == 0.0
    np.testing.assert_allclose(traj.centre_m, [7100.0, 0.0, 7300.0], atol=1e-9)
    np.testing.assert_allclose(traj.tangent, [0.0, 1.0, 0.0], atol=1e-9)


def test_from_positions_recovers_slow_time():
    traj = Trajectory.circular(aperture_deg=2.0)
    again = Trajectory.from_positions(traj.positions_m, speed_mps=70.0)
    # Chord vs arc length differs by (dphi)^2/24 ~ 1e-11 relative.
    np.testing.assert_allclose(again.slow_times_s, traj.slow_times_s, atol=1e-9)


def test_travel_time_and_delta_tau_against_direct_formula():
    traj = Trajectory.circular(aperture_deg=1.0)
    rho = np.array([3.0, -4.0, 0.0])
    tau = travel_time(traj.positions_m, rho)
    direct = 2 * np.sqrt(((traj.positions_m - rho) ** 2).sum(axis=1)) / C
    np.testing.assert_allclose(tau, direct, rtol=1e-15)
    dtau = delta_tau(traj.positions_m, rho, [0.0, 0.0, 0.0])
    # A target 3 m nearer in ground range is ~ 3 m * cos(elev) nearer in slant range.
    geom = look_geometry(traj, [0, 0, 0])
    assert dtau[58] == pytest.approx(-2 * geom.m_o @ rho / C, rel=1e-3)


def test_trace_slope_is_set_by_range_speed():
    # eq:Dtau with rho^e = rho_o: d(dtau)/ds at s = 0 = -2 u . m_o / c for a mover at rho_o.
    traj = Trajectory.circular(aperture_deg=1.0)
    geom = look_geometry(traj, [0, 0, 0])
    u = np.array([6.0, 3.0, 0.0])
    rho = target_positions([0, 0], u, traj.slow_times_s)
    dtau = delta_tau(traj.positions_m, rho, [0, 0, 0])
    slope = np.gradient(dtau, traj.slow_times_s)[58]
    assert slope == pytest.approx(-2 * range_speed(u, geom) / C, rel=1e-3)


def test_velocity_parametrisation_round_trip():
    traj = Trajectory.circular(aperture_deg=1.0, centre_azimuth_deg=37.0)
    geom = look_geometry(traj, [2.0, 1.0, 0.0])
    for u_r, u_p in [(5.0, -3.0), (-13.8, 9.9), (0.0, 1.0)]:
        v = ground_velocity(u_r, u_p, geom)
        assert range_speed(v, geom) == pytest.approx(u_r, abs=1e-12)
        assert cross_range_speed(v, geom) == pytest.approx(u_p, abs=1e-12)


def test_range_direction_velocity_has_exact_range_speed():
    traj = Trajectory.circular(aperture_deg=1.0)
    geom = look_geometry(traj, [0, 0, 0])
    v = range_direction_velocity(10.0, geom)
    assert range_speed(v, geom) == pytest.approx(10.0, abs=1e-12)
    # The paper's literal u (b_o, 0) has range speed |b_o|^2 u: ~0.49 u at GOTCHA elevation.
    b = geom.ground_m_o
    assert range_speed(10.0 * b, geom) == pytest.approx(10.0 * (b @ b))
    assert 0.45 < b @ b < 0.52


def test_trajectory_validation():
    with pytest.raises(ValueError, match=r"positions_m must have shape \(n_pulses, 3\)"):
        Trajectory(positions_m=np.zeros((5, 2)), slow_times_s=np.arange(5.0))
    with pytest.raises(ValueError, match="strictly increasing"):
        Trajectory(positions_m=np.zeros((3, 3)), slow_times_s=np.zeros(3))
    with pytest.raises(ValueError, match="aperture_deg"):
        Trajectory.circular(aperture_deg=-1.0)
