"""Phase-space (Wigner) motion estimation and trajectory errors (sect:numeric, fig:motEstscatt)."""

import numpy as np
import pytest

from sarmotion.core import C, Trajectory, look_geometry, range_direction_velocity
from sarmotion.motion import (
    estimate_trajectory,
    trajectory_error,
    wigner_ridge,
    wigner_slow_time,
)
from sarmotion.separation import annihilate
from sarmotion.simulation import add_noise, load_scene, simulate

DS = 0.015  # pulse interval of the GOTCHA scenes (s)


def _chirp(f0_hz, rate_hz_per_s, n=117, ds=DS):
    s = (np.arange(n) - (n - 1) / 2) * ds
    return (
        s,
        np.exp(2j * np.pi * (f0_hz * s + 0.5 * rate_hz_per_s * s**2)),
        f0_hz + rate_hz_per_s * s,
    )


def _true_range_rate(traces, mover):
    """Independent oracle: d/ds |r(s) - rho(s)| by central differences of the range."""
    s = traces.slow_times_s
    rho = mover.position_m[None, :] + s[:, None] * mover.velocity3_mps[None, :]
    return np.gradient(np.linalg.norm(traces.positions_m - rho, axis=1), s)


@pytest.fixture(scope="module")
def filter10():
    scene = load_scene("filter10")
    return scene, simulate(scene)


@pytest.fixture(scope="module")
def separated(filter10):
    """The mover's traces separated by the composed filter eq:OP2 at the exact locations.

    N alternated differences reach ceil(N/2) pulses to each side, so the scene is
    simulated on its aperture extended by that many pulses at each end and filtered there,
    and its own pulses are kept: every pulse has a complete stencil, and what is measured
    is the filter, not the end of the aperture.
    """
    out = {}
    scene30 = load_scene("filter30")
    for name, (scene, sim) in {
        "filter10": filter10,
        "filter30": (scene30, simulate(scene30)),
    }.items():
        mover = scene.moving[0]
        pts = [t.position_m for t in scene.stationary]
        n, pad = sim.traces.n_pulses, (len(pts) + 1) // 2 + 1
        wide = simulate(
            scene, trajectory=Trajectory.circular(aperture_deg=1.0, n_pulses=n + 2 * pad)
        )
        filtered = annihilate(wide.traces, pts).data[pad : pad + n]
        traces = sim.traces.with_data(filtered)
        est = estimate_trajectory(traces, mover.position_m)
        err = trajectory_error(est, mover.position_m, mover.velocity_mps)
        out[name] = (scene, traces, est, err)
    return out


# ----------------------------------------------------------------------------- Wigner


def test_wigner_ridge_of_a_chirp_follows_its_instantaneous_frequency():
    # A linear chirp has an exactly quadratic phase: its Wigner transform is concentrated
    # on the instantaneous frequency f0 + a s (here -8.5 .. 12.5 Hz, inside +-1/(4 ds)).
    s, x, inst = _chirp(2.0, 12.0)
    w, f = wigner_slow_time(x, pulse_interval_s=DS, lag_window_pulses=61)
    bin_hz = f[1] - f[0]
    assert w.shape == (s.size, f.size)
    assert np.isclose(bin_hz, 1 / (2 * f.size * DS))
    interior = slice(1, -1)  # the end samples have no lag but 0: a flat row
    grid_ridge = f[np.argmax(w, axis=1)]
    assert np.max(np.abs(grid_ridge - inst)[interior]) <= bin_hz
    # The Newton-refined ridge is not limited by the bin (exact for a quadratic phase).
    ridge = wigner_ridge(x, pulse_interval_s=DS, lag_window_pulses=61)
    assert np.max(np.abs(ridge.doppler_hz - inst)[interior]) < 1e-3 * bin_hz
    assert np.all(ridge.curvature[interior] > 0)


def test_wigner_doppler_band_is_half_the_prf_around_its_centre():
    # The discrete Wigner transform (lags 2 k ds) is unambiguous over 1/(2 ds) only. A chirp
    # at 20 .. 28 Hz (beyond 1/(4 ds) = 16.7 Hz) aliases on a band centred on 0 Hz but is
    # recovered on the band centred on its pulse-pair mean Doppler (the default).
    s, x, inst = _chirp(24.0, 4.5)
    interior = slice(1, -1)
    aliased = wigner_ridge(x, pulse_interval_s=DS, lag_window_pulses=31, centre_hz=0.0)
    centred = wigner_ridge(x, pulse_interval_s=DS, lag_window_pulses=31)
    assert np.allclose(aliased.doppler_hz[interior], inst[interior] - 1 / (2 * DS), atol=1e-6)
    assert np.allclose(centred.doppler_hz[interior], inst[interior], atol=1e-6)
    assert abs(centred.centre_hz - 24.0) < 1.0


def test_wigner_rejects_bad_parameters():
    x = np.ones(32, dtype=complex)
    with pytest.raises(ValueError, match="lag_window_pulses"):
        wigner_slow_time(x, pulse_interval_s=DS, lag_window_pulses=10)
    with pytest.raises(ValueError, match="pulse_interval_s"):
        wigner_slow_time(x, pulse_interval_s=0.0)
    with pytest.raises(ValueError, match="n_freq"):
        wigner_slow_time(x, pulse_interval_s=DS, lag_window_pulses=31, n_freq=16)
    with pytest.raises(ValueError, match="signal"):
        wigner_ridge(np.ones((2, 2, 2)), pulse_interval_s=DS)


# ----------------------------------------------------------------------------- motion


def test_clean_mover_trajectory_is_recovered(filter10):
    scene, sim = filter10
    mover = scene.moving[0]  # 28/sqrt(2) (1, 1) m/s at (0, 0)
    traces = sim.traces.with_data(sim.moving)
    est = estimate_trajectory(traces, mover.position_m)
    err = trajectory_error(est, mover.position_m, mover.velocity_mps)
    s0 = int(np.argmin(np.abs(est.slow_times_s)))
    assert est.slow_times_s[s0] == 0.0 and err[s0] == 0.0  # anchored at the known rho(0)
    # Noise-free, straight, one target: the model is exact; what is left is the stopping
    # rule (tol_mps = 1e-3 m/s over |s| <= 0.88 s, < 1 mm). Seen: 1e-10 m. Range resolution
    # c/2B = 0.24 m, cross-range resolution ~1.3 m.
    assert err.max() < 1e-3
    assert np.allclose(est.velocities_mps, mover.velocity_mps, atol=1e-3)
    assert est.converged.all()
    # The Wigner ridge gives the range rate (eq. (1) of the Notes) against an independent
    # oracle (central differences of |r - rho|, accurate to ~1e-5 m/s here).
    good = est.ridge_weight > 0.1
    assert np.max(np.abs(est.range_rate_mps - _true_range_rate(traces, mover))[good]) < 1e-3
    assert np.all(est.range_offset_m == 0.0)


def test_noisy_mover_trajectory_error_is_below_the_resolution(filter10):
    scene, sim = filter10
    mover = scene.moving[0]
    # -10 dB over the whole trace matrix is ~ +12 dB per sample on the pulse.
    traces = sim.traces.with_data(add_noise(sim.moving, snr_db=-10.0, rng=1))
    est = estimate_trajectory(traces, mover.position_m)
    err = trajectory_error(est, mover.position_m, mover.velocity_mps)
    # Seen 0.03 - 0.08 m over seeds 0-3; 0.24 m is the range resolution c/2B.
    assert err.max() < 0.24


def test_annihilated_traces_filter10_beats_filter30(separated):
    # The paper's finding (fig:motEstscatt): with the exact stationary locations, the
    # separated trace of filter10 gives a better trajectory than that of filter30, where
    # thirty slow-time differences have accumulated errors; filter10 stays below 1 m.
    # Seen (complete stencils): filter10 max 0.015 / rms 0.008 m, filter30 max 0.023 /
    # rms 0.013 m.
    e10, e30 = separated["filter10"][3], separated["filter30"][3]
    assert e10.max() < 1.0
    assert e10.max() < e30.max()
    assert np.sqrt(np.mean(e10**2)) < np.sqrt(np.mean(e30**2))
    for name in ("filter10", "filter30"):
        est, err = separated[name][2], separated[name][3]
        assert err[np.argmin(np.abs(est.slow_times_s))] == 0.0


@pytest.mark.parametrize("name, n_filters", [("filter10", 10), ("filter30", 30)])
def test_alternated_annihilation_does_not_shift_the_mover(separated, name, n_filters):
    # A forward difference shows the mover half a pulse later, a backward one half a pulse
    # earlier; alternated, an even number of filters leaves it where it is, where forward
    # differences alone would move it N ds R'(0) / 2 in range (> 3 samples here; module
    # Notes). The offset is read on the fast-time grid: one sample (c dt / 2 = 0.24 m) is
    # the tolerance.
    scene, traces, est, _ = separated[name]
    mover = scene.moving[0]
    rate0 = _true_range_rate(traces, mover)[np.argmin(np.abs(traces.slow_times_s))]
    forward_only = n_filters * traces.trajectory.pulse_interval_s * rate0 / 2
    sample_m = 0.5 * C * traces.radar.sample_interval_s
    assert abs(forward_only) > 3 * sample_m
    assert np.all(np.abs(est.range_offset_m) <= sample_m)


def test_doppler_ambiguity_is_a_range_speed_of_lambda_over_two_ds(filter10):
    # A first guess whose range speed is off by lambda/(2 ds) (one Doppler period) locks on
    # the alias, exactly that far off, and its range walk drifts out of the hypothesised
    # travel time (range_offset_m); one off by less than lambda/(4 ds) converges.
    scene, sim = filter10
    mover = scene.moving[0]
    traces = sim.traces.with_data(sim.moving)
    geo = look_geometry(traces.trajectory, mover.position_m)
    ambiguity = C / traces.radar.carrier_hz / (2 * traces.trajectory.pulse_interval_s)
    aliased = estimate_trajectory(
        traces,
        mover.position_m,
        velocity_guess_mps=mover.velocity_mps + range_direction_velocity(ambiguity, geo),
    )
    range_speed_error = (aliased.velocities_mps - mover.velocity_mps) @ geo.m_o[:2]
    assert np.allclose(range_speed_error, ambiguity, atol=0.01)
    assert np.ptp(aliased.range_offset_m) > 0.3
    close = estimate_trajectory(
        traces,
        mover.position_m,
        velocity_guess_mps=mover.velocity_mps + range_direction_velocity(0.4 * ambiguity, geo),
    )
    assert trajectory_error(close, mover.position_m, mover.velocity_mps).max() < 1e-3


def test_estimate_trajectory_rejects_bad_parameters(filter10):
    scene, sim = filter10
    rho = scene.moving[0].position_m
    with pytest.raises(TypeError, match="traces"):
        estimate_trajectory(sim.moving, rho)
    with pytest.raises(ValueError, match="sub_aperture_pulses"):
        estimate_trajectory(sim.traces, rho, sub_aperture_pulses=3)
    with pytest.raises(ValueError, match="lag_window_pulses"):
        estimate_trajectory(sim.traces, rho, lag_window_pulses=20)
    with pytest.raises(ValueError, match="velocity_guess_mps"):
        estimate_trajectory(sim.traces, rho, velocity_guess_mps=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="fast_time_search"):
        estimate_trajectory(sim.traces, rho, fast_time_search=1000)
    with pytest.raises(ValueError, match="true_velocity_mps"):
        est = estimate_trajectory(sim.traces.with_data(sim.moving), rho)
        trajectory_error(est, rho, [1.0])
