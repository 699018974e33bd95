"""Slow-time resampling of a patch's traces: the ratio's rule, the polyphase sum, the bound."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from scipy.signal import upfirdn

from sarmotion.collection import CollectionOptions, extract_patches, plan_patches
from sarmotion.collection.plan import BAND_GUARD, Patch
from sarmotion.collection.resample import (
    MAX_DENOMINATOR,
    design,
    output_grid,
    phase_errors,
    slow_time_ratio,
)
from sarmotion.core import Radar, Traces, Trajectory, to_fast_time, travel_time
from sarmotion.core.blocks import TracesBlocks
from sarmotion.simulation import PointTarget, radar_with_range_window, simulate_phase_history

REF = np.zeros(3)


@pytest.mark.parametrize("ratio", [1.7, 3.0, 3.89, 1.0 / 0.9, 4.0, 0.8])
def test_ratio_is_the_smallest_fraction_at_or_above_the_target(ratio):
    """``p / q >= R / F`` and no fraction with ``q <= MAX_DENOMINATOR`` lies in between."""
    prf = 313.0
    rate = prf / ratio
    p, q = slow_time_ratio(prf, rate)
    if rate >= prf:
        assert (p, q) == (1, 1)
        return
    assert prf * p / q >= rate * (1 - 1e-12)
    assert q <= MAX_DENOMINATOR
    target = Fraction(rate / prf)
    for d in range(1, MAX_DENOMINATOR + 1):
        for n in range(1, d + 1):
            if Fraction(n, d) >= target:
                assert Fraction(p, q) <= Fraction(n, d)
    # the output rate's excess over R below 1 / q of F / R (module notes)
    assert prf * p / q / rate - 1 < prf / (q * rate)
    if float(ratio).is_integer():  # an integer ratio is the integer decimation
        assert (p, q) == (1, int(ratio))


def _stream(x: np.ndarray, patch: Patch, block: int) -> Traces:
    """``x`` (n_pulses, n_cols) resampled by ``patch`` through PatchBuilder, block by block.

    The patch's centre is the reference point and its window the data's, so the builder's
    re-referencing and fast-time window are the identity: only the slow-time resampling acts.
    """
    n = x.shape[0]
    radar = Radar(n_samples=x.shape[1], frequency_step_hz=Radar().bandwidth_hz / x.shape[1])
    traj = Trajectory.circular(pulses_per_deg=n)
    src = TracesBlocks(
        Traces(data=x.astype(np.complex64), trajectory=traj, radar=radar, reference_point_m=REF)
    )
    (got,) = extract_patches(src, [patch], block_pulses=block)
    return got


def _patch(n_pulses, up, down, taps, n_cols):
    return Patch(
        index=0,
        core_m=(-1.0, -1.0, 1.0, 1.0),
        centre_m=REF.copy(),
        n_samples=n_cols,
        decimation=down,
        interpolation=up,
        passband_hz=1.0,
        taps=taps,
        pulses=output_grid(n_pulses, up, down, taps.size),
    )


@pytest.mark.parametrize(("up", "down", "block"), [(10, 17, 29), (8, 31, 256), (1, 3, 37)])
def test_streamed_polyphase_sum_is_upfirdn(up, down, block):
    """The blocks' polyphase sums equal ``scipy.signal.upfirdn`` on the whole array (at the
    output pulses' places), to single precision."""
    rng = np.random.default_rng(up * 100 + down)
    n, cols = 300, 16
    prf = 1.0
    f_pass = 0.5 * prf * up / down / (2 * (1 + BAND_GUARD))
    taps = design(up, f_pass, prf, 60.0, guard=BAND_GUARD)
    patch = _patch(n, up, down, taps, cols)
    x = rng.standard_normal((n, cols)) + 1j * rng.standard_normal((n, cols))
    got = _stream(x, patch, block)
    ref = upfirdn(taps, x, up=up, down=1, axis=0)[patch.pulses + taps.size // 2]
    scale = np.max(np.abs(ref))
    assert np.max(np.abs(got.data - ref)) <= 1e-5 * scale
    # the output pulses' slow times sit at pulses / up on the input's pulse axis
    s_in = Trajectory.circular(pulses_per_deg=n).slow_times_s
    want = np.interp(patch.pulses / up, np.arange(n), s_in)
    assert np.allclose(got.slow_times_s, want, rtol=0.0, atol=1e-12)


@pytest.mark.parametrize(("ratio", "stopband_db"), [(1.7, 60.0), (3.0, 60.0), (2.3, 80.0)])
def test_resampled_band_limited_signal_within_the_stated_bound(ratio, stopband_db):
    """Tones in the pass band come out as the tones at the output pulses' exact places,
    within ``10^(-A/20)`` of their summed amplitude (in dB: at most ``-A``); tones in the
    stop band leave at most ``10^(-A/20)`` of theirs. Measured through the streaming
    builder, against the band-limited signal itself, not against the filter's design."""
    rng = np.random.default_rng(int(ratio * 10 + stopband_db))
    n, cols, tones = 700, 24, 5
    prf = 1.0
    f_pass = prf / ratio / (2 * (1 + BAND_GUARD))
    f_stop = (1 + 2 * BAND_GUARD) * f_pass
    up, down = slow_time_ratio(prf, 2 * (1 + BAND_GUARD) * f_pass)
    taps = design(up, f_pass, prf, stopband_db, guard=BAND_GUARD)
    patch = _patch(n, up, down, taps, cols)
    j = np.arange(n)
    u = patch.pulses / up  # output places on the pulse axis
    amp = rng.standard_normal((tones, cols)) + 1j * rng.standard_normal((tones, cols))
    bound = 10 ** (-stopband_db / 20)
    # pass band: the signal and its value at the output places
    f = rng.uniform(-f_pass, f_pass, (tones, cols))
    f[0] = f_pass  # the band's edge
    x = np.einsum("tc,tjc->jc", amp, np.exp(2j * np.pi * f[:, None, :] * j[None, :, None] / prf))
    want = np.einsum("tc,tkc->kc", amp, np.exp(2j * np.pi * f[:, None, :] * u[None, :, None] / prf))
    got = _stream(x, patch, 64).data
    err_db = 20 * np.log10(np.max(np.abs(got - want) / np.abs(amp).sum(axis=0)))
    assert err_db <= -stopband_db
    # stop band, folded into [f_stop, F - f_stop] and its negative
    g = rng.uniform(f_stop, prf - f_stop, (tones, cols)) * rng.choice([-1, 1], (tones, cols))
    g[0] = f_stop
    y = np.einsum("tc,tjc->jc", amp, np.exp(2j * np.pi * g[:, None, :] * j[None, :, None] / prf))
    left = _stream(y, patch, 64).data
    assert np.max(np.abs(left) / np.abs(amp).sum(axis=0)) <= bound
    # the design's own account agrees: every phase within the bound
    assert max(phase_errors(taps, up, f_pass, f_stop, prf)) <= bound


def _acquisition(pulses_per_deg):
    radar = radar_with_range_window(200.0, radar=Radar())
    return radar, Trajectory.circular(pulses_per_deg=pulses_per_deg)


def _traces(targets, radar, traj):
    ph = simulate_phase_history(targets, traj, radar, REF)
    return Traces(data=to_fast_time(ph), trajectory=traj, radar=radar, reference_point_m=REF)


def _scene_at(factor, opts, region):
    """Radar and trajectory whose pulse rate is ``factor`` times the patches' need."""
    radar, probe = _acquisition(468.0)
    plan0 = plan_patches(TracesBlocks(_traces([], radar, probe)), opts, region_m=region)
    need = 2 * (1 + BAND_GUARD) * max(p.passband_hz for p in plan0.patches)
    return _acquisition(468.0 * factor * need / (1.0 / probe.pulse_interval_s))


def _patch_error(tgt, patch, radar, traj, stopband_db):
    """Largest difference of a target's patch traces from its traces simulated on the
    patch's (resampled) pulses, and the bound: the filter's plus the window's."""
    from test_collection import _window_bound

    (got,) = extract_patches(TracesBlocks(_traces([tgt], radar, traj)), [patch], block_pulses=50)
    want = to_fast_time(simulate_phase_history([tgt], got.trajectory, got.radar, patch.centre_m))
    rel = travel_time(got.positions_m, tgt.positions_at(got.slow_times_s)) - travel_time(
        got.positions_m, patch.centre_m
    )
    tol = 10 ** (-stopband_db / 20) + _window_bound(radar, got.radar, float(np.max(np.abs(rel))))
    assert tol < 0.02  # the bound is tight enough to mean something
    return float(np.max(np.abs(got.data - want))), tol, got


def _doppler(tgt, patch, radar, traj):
    """The target's instantaneous Doppler relative to the patch's centre, over the band's
    ends and the pulses (Hz), unaliased."""
    s = traj.slow_times_s
    rel = travel_time(traj.positions_m, tgt.positions_at(s)) - travel_time(
        traj.positions_m, patch.centre_m
    )
    d = np.gradient(rel, s)
    f = radar.carrier_hz + np.array([-0.5, 0.5]) * radar.bandwidth_hz
    return f[:, None] * d[None, :]


def test_a_patch_keeps_the_pulses_its_band_needs_and_its_movers_at_the_speed_bound():
    """A pulse rate 2.5 times the patches' need, movers of the speed range unaliased: the
    patch is resampled by ``p / q`` (``p > 1``) to ``R = (1 + guard) 2 f_pass`` or just
    above, where the integer rule gives ``F / 2`` (1.25 R). A point and movers at the speed
    bound whose Doppler centre is the core's come out as their traces simulated on the
    patch's resampled pulses, within the filter's bound plus the fast-time window's
    (``tests/collection/test_collection.py``'s rule), their whole Doppler spread in the
    kept band."""
    speed = 0.5
    opts = CollectionOptions(patch_size_m=40.0, max_speed_mps=speed, stopband_db=60.0)
    region = (-40.0, -40.0, 40.0, 40.0)
    radar, traj = _scene_at(2.5, opts, region)
    plan = plan_patches(TracesBlocks(_traces([], radar, traj)), opts, region_m=region)
    prf = 1.0 / traj.pulse_interval_s
    patch = next(p for p in plan.patches if p.contains((10.0, -20.0)))
    rate = 2 * (1 + BAND_GUARD) * patch.passband_hz
    q_int = int(np.floor(prf / rate))
    assert patch.interpolation > 1 and q_int == 2
    out_rate = prf * patch.interpolation / patch.decimation
    assert rate <= out_rate < rate * (1 + prf / (patch.decimation * rate))
    assert out_rate < prf / q_int
    # fewer pulses than every q_int-th with the same filter's support
    span = patch.taps.size / patch.interpolation
    assert patch.pulses.size < (traj.n_pulses - span) / q_int

    cx, cy = patch.centre_m[:2]
    cases = [
        PointTarget(position_m=(cx + 7.0, cy - 11.0)),
        # at the speed bound, Doppler centre on the core: cross-range motion
        PointTarget(position_m=(cx + 3.0, cy + 2.0), velocity_mps=(0.0, speed)),
        PointTarget(position_m=(cx - 4.0, cy + 5.0), velocity_mps=(0.0, -speed)),
    ]
    for tgt in cases:
        d = _doppler(tgt, patch, radar, traj)
        assert np.max(np.abs(d)) <= patch.passband_hz <= out_rate / (2 * (1 + BAND_GUARD))
        err, tol, got = _patch_error(tgt, patch, radar, traj, opts.stopband_db)
        assert err <= tol
        # the antenna at the output pulses: on the flight circle
        r = np.hypot(*got.positions_m[:, :2].T)
        assert np.allclose(r, np.hypot(*traj.positions_m[0, :2]), rtol=0, atol=1e-6)


def test_a_mover_aliased_in_the_data_keeps_whole_pulses():
    """Movers of 10 m/s alias in the data (Doppler beyond ``F - f_pass``): the plan keeps
    the integer decimation, and a mover at a blind speed (Doppler ``F`` from the core's
    centre, aliased onto it) comes out as its own traces on the kept pulses. Resampled by
    the rational ratio instead, between the data's pulses its traces carry the alias's
    Doppler with its true range migration: far from the mover's (module ``resample``)."""
    import dataclasses

    from sarmotion.collection.resample import aliased_doppler_hz

    opts = CollectionOptions(patch_size_m=40.0, max_speed_mps=10.0, stopband_db=60.0)
    radar, traj = _scene_at(1.7, opts, None)
    src = TracesBlocks(_traces([], radar, traj))
    plan = plan_patches(src, opts)
    prf = 1.0 / traj.pulse_interval_s
    patch = next(p for p in plan.patches if p.contains((25.0, -30.0)))
    rate = 2 * (1 + BAND_GUARD) * patch.passband_hz
    assert patch.interpolation == 1
    assert patch.decimation == max(1, int(np.floor(prf / rate)))
    f = radar.carrier_hz + np.array([-0.5, 0.5]) * radar.bandwidth_hz
    from sarmotion.collection.plan import _velocities

    x0, y0, x1, y1 = plan.region_m
    corners = np.array([[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]])
    assert (
        aliased_doppler_hz(
            traj.positions_m, traj.slow_times_s, patch.centre_m, corners, _velocities(10.0), f
        )
        >= prf - patch.passband_hz
    )
    # blind speed: ground range speed whose Doppler at the carrier is F (x is ground range)
    cx, cy = patch.centre_m[:2]
    unit = PointTarget(position_m=(cx, cy), velocity_mps=(1.0, 0.0))
    v = prf / abs(float(np.mean(_doppler(unit, patch, radar, traj))))
    tgt = PointTarget(position_m=(cx + 2.0, cy + 1.0), velocity_mps=(v, 0.0))
    d = _doppler(tgt, patch, radar, traj)
    assert np.all(np.abs(d) > prf - patch.passband_hz)  # aliased in the data
    assert np.all(np.abs(np.abs(d) - prf) <= patch.passband_hz)  # onto the core's band
    err, tol, _ = _patch_error(tgt, patch, radar, traj, opts.stopband_db)
    assert err <= tol
    up, down = slow_time_ratio(prf, rate)
    assert up > 1
    taps = design(up, patch.passband_hz, prf, opts.stopband_db, guard=BAND_GUARD)
    rational = dataclasses.replace(
        patch,
        interpolation=up,
        decimation=down,
        taps=taps,
        pulses=output_grid(traj.n_pulses, up, down, taps.size),
    )
    err, tol, _ = _patch_error(tgt, rational, radar, traj, opts.stopband_db)
    assert err > 10 * tol
