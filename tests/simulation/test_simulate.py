"""Forward model: traces of point targets against independent formulas."""

import numpy as np
import pytest

from sarmotion.core import Radar, Trajectory, delta_tau, shift_fast_time, target_positions
from sarmotion.simulation import PointTarget, Scene, add_noise, inject, load_scene, simulate
from sarmotion.simulation.signals import baseband_gaussian_pulse


def _scene(targets, **kw):
    return Scene(name="test", targets=tuple(targets), **kw)


def test_point_target_peaks_at_its_delay_with_carrier_phase():
    rho = np.array([3.3, 7.1, 0.0])
    sim = simulate(_scene([PointTarget(position_m=rho, reflectivity=0.5j)]))
    tr = sim.traces
    dtau = delta_tau(tr.positions_m, rho, tr.reference_point_m)
    # Peak within half a fast-time sample of dtau on every pulse.
    peaks = tr.fast_times_s[np.argmax(np.abs(tr.data), axis=1)]
    assert np.max(np.abs(peaks - dtau)) <= 0.5 * tr.radar.sample_interval_s
    # Shifting by dtau (carrier phase included) leaves sigma exactly at t = 0, every pulse.
    aligned = shift_fast_time(tr.data, dtau, frequencies_hz=tr.frequencies_hz)
    np.testing.assert_allclose(aligned[:, tr.n_samples // 2], 0.5j, atol=1e-12)


def test_gaussian_pulse_matches_closed_form():
    # eq:Mdef with the Gaussian pulse: D = sigma exp(-B^2 (t - dtau)^2 / 2) exp(-i w dtau).
    # 1024 frequencies (1.5 GHz span): the Gaussian spectrum (std B/2pi ~ 99 MHz) is then
    # sampled to +-7.6 std, so truncation is ~exp(-29); on the 424-bin GOTCHA grid it is cut
    # at 3.2 std (~0.7 % of the peak).
    radar = Radar(pulse="gaussian", n_samples=1024)
    u = np.array([10.0, -4.0, 0.0])
    tgt = PointTarget(position_m=[2.0, -6.0], velocity_mps=u[:2])
    sim = simulate(_scene([tgt], radar=radar))
    tr = sim.traces
    rho_s = target_positions(tgt.position_m, u, tr.slow_times_s)
    dtau = delta_tau(tr.positions_m, rho_s, tr.reference_point_m)
    t = tr.fast_times_s[None, :] - dtau[:, None]
    phase = np.exp(-2j * np.pi * radar.carrier_hz * dtau)[:, None]
    want = baseband_gaussian_pulse(t, bandwidth_hz=radar.bandwidth_hz) * phase
    np.testing.assert_allclose(tr.data, want, atol=1e-9)


def test_superposition_and_truth_components():
    sim = simulate(load_scene("scene1"))
    np.testing.assert_allclose(sim.traces.data, sim.stationary + sim.moving, atol=1e-12)
    assert np.linalg.norm(sim.moving) > 0 and np.linalg.norm(sim.stationary) > 0


def test_spreading_amplitude_is_inverse_square_range():
    tgt = PointTarget(position_m=[20.0, 0.0])
    plain = simulate(_scene([tgt])).traces.data
    spread = simulate(_scene([tgt]), spreading=True).traces
    L = np.linalg.norm(spread.trajectory.centre_m)
    R = np.linalg.norm(spread.positions_m - tgt.position_m, axis=1)
    ratio = np.abs(spread.data).max(axis=1) / np.abs(plain).max(axis=1)
    np.testing.assert_allclose(ratio, (L / R) ** 2, rtol=1e-9)


def test_noise_has_requested_snr():
    sim = simulate(load_scene("example1"))
    clean = sim.traces.data
    noisy = add_noise(clean, snr_db=20.0, rng=1)
    measured = 10 * np.log10(np.mean(np.abs(clean) ** 2) / np.mean(np.abs(noisy - clean) ** 2))
    # 117 x 424 samples: the sample noise power is within ~1 % (0.05 dB).
    assert measured == pytest.approx(20.0, abs=0.1)


def test_inject_equals_simulating_the_target():
    base = load_scene("example1")
    mover = PointTarget(position_m=[4.0, -3.0], velocity_mps=[-5.0, 2.0])
    with_mover = _scene([*base.targets, mover], radar=base.radar)
    sim = simulate(base)
    injected = inject(sim.traces, [mover])
    np.testing.assert_allclose(injected.data, simulate(with_mover).traces.data, atol=1e-12)
    assert injected.metadata["injected"][0]["position_m"] == [4.0, -3.0, 0.0]


def test_linear_trajectory_hyperbola_scene():
    sim = simulate(load_scene("hyperbola"))
    assert isinstance(sim.traces.trajectory, Trajectory)
    assert sim.traces.geometry.range_m == pytest.approx(10_000.0, rel=1e-6)
    assert sim.traces.trajectory.aperture_length_m == pytest.approx(400.0, abs=1.1)


# ------------------------------------------------------------ the simulate command
ALIASING = """schema = "sarmotion.scene/1"
[radar]
pulse = "gaussian"
[[targets]]
position_m = [5.0, -3.0]
[[targets]]
position_m = [-12.0, 8.0]
[[targets]]
label = "aliased"
position_m = [-110.0, 0.0]
velocity_mps = [6.0, 8.0]
"""


def _refusal(args, capsys):
    from sarmotion.cli.main import run

    capsys.readouterr()
    assert run(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("sarmotion: error: "), err
    return err


def test_simulate_refuses_a_scene_that_aliases_and_lenient_writes_it(tmp_path, capsys, caplog):
    from sarmotion.cli.main import run
    from sarmotion.io import load_traces

    scene = tmp_path / "wide.toml"
    scene.write_text(ALIASING)
    out = tmp_path / "wide.h5"
    err = _refusal(["simulate", str(scene), "--out", str(out)], capsys)
    assert "targets[2] at (-110, 0) m" in err and "radar.frequency_step_hz <=" in err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["wide.toml"]
    with caplog.at_level("WARNING", logger="sarmotion.simulation"):
        assert run(["simulate", str(scene), "--out", str(out), "--lenient"]) == 0
    assert any("aliases to about" in r.getMessage() for r in caplog.records)
    assert load_traces(out).n_pulses == 117  # what simulate writes, the reader accepts


def test_simulate_refuses_traces_the_readers_would_refuse(tmp_path, capsys):
    # A Gaussian pulse sampled to +-7.6 standard deviations: its spectrum spans more than
    # the readers' dynamic range (1000 x the median magnitude).
    from sarmotion.cli.main import run
    from sarmotion.io import DataError, load_traces

    scene = tmp_path / "tails.toml"
    scene.write_text(
        '[radar]\npulse = "gaussian"\nn_samples = 1024\n[[targets]]\nposition_m = [1.0, 2.0]\n'
    )
    out = tmp_path / "tails.h5"
    err = _refusal(["simulate", str(scene), "--out", str(out)], capsys)
    assert "rule: at most 1000 x the median magnitude" in err and not out.exists()
    assert run(["simulate", str(scene), "--out", str(out), "--lenient"]) == 0
    with pytest.raises(DataError, match="median magnitude"):
        load_traces(out)
    load_traces(out, lenient=True)


@pytest.mark.parametrize(
    "name", ["example1", "example2", "scene1", "filter10", "filter30", "hyperbola", "rotscatt"]
)
def test_every_builtin_scene_simulates_to_a_file_the_reader_accepts(tmp_path, name):
    from sarmotion.cli.main import run
    from sarmotion.io import load_traces

    assert run(["simulate", name, "--out", str(tmp_path / "t.h5")]) == 0
    traces = load_traces(tmp_path / "t.h5")
    np.testing.assert_allclose(traces.data, simulate(load_scene(name)).traces.data, atol=1e-12)


@pytest.mark.parametrize("command", ["simulate", "analyze", "image"])
def test_every_command_refuses_a_scene_that_aliases_before_any_work(tmp_path, capsys, command):
    from sarmotion.cli.main import run

    scene = tmp_path / "wide.toml"
    scene.write_text(ALIASING)
    out = tmp_path / ("o.h5" if command == "simulate" else "o")
    capsys.readouterr()
    assert run([command, str(scene), "--out", str(out)]) == 2
    lines = capsys.readouterr().err.splitlines()
    # the refusal is one line, the last (a command may first say what it reads)
    assert [k for k, line in enumerate(lines) if line.startswith("sarmotion:")] == [
        len(lines) - 1
    ], lines
    err = lines[-1]
    assert err.startswith("sarmotion: error: "), lines
    assert command != "simulate" or len(lines) == 1, lines
    for words in (
        "targets[2] at (-110, 0) m",
        "radar.frequency_step_hz <=",
        "radar.n_samples >=",
        "m of ground range",
        "--lenient",
    ):
        assert words in err, (words, err)
    assert not out.exists()
