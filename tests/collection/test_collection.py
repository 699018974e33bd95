"""Whole collections: patch traces against the exact physics, the plan's rules, the merge."""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.collection import (
    CollectionOptions,
    MoverRecord,
    RegionError,
    StationaryRecord,
    extract_patches,
    inscribed_box,
    merge_movers,
    merge_stationary,
    plan_patches,
    same_mover,
    unambiguous_scene,
)
from sarmotion.collection.plan import window_transform_length
from sarmotion.core import Radar, Traces, Trajectory, to_fast_time, travel_time
from sarmotion.core.blocks import PulseBlocks, TracesBlocks
from sarmotion.motion import family_member
from sarmotion.simulation import PointTarget, radar_with_range_window, simulate_phase_history

REF = np.zeros(3)


def _acquisition(range_window_m=200.0, pulses_per_deg=4 * 117.0):
    radar = radar_with_range_window(range_window_m, radar=Radar())
    traj = Trajectory.circular(pulses_per_deg=pulses_per_deg)
    return radar, traj


def _traces(targets, radar, traj, ref=REF):
    ph = simulate_phase_history(targets, traj, radar, ref)
    return Traces(data=to_fast_time(ph), trajectory=traj, radar=radar, reference_point_m=ref)


def _pulse(radar: Radar, times_s: np.ndarray) -> np.ndarray:
    """The compressed pulse of ``radar`` at ``times_s`` by its explicit spectral sum."""
    w = radar.spectral_weights()
    df = radar.frequencies_hz - radar.carrier_hz
    return (np.exp(2j * np.pi * np.outer(times_s, df)) @ w) / radar.n_samples


def _window_bound(radar: Radar, patch_radar: Radar, max_delay_s: float) -> float:
    """``max |p_n(t - d) - p_np(t - d)|`` over the patch window and ``|d| <= max_delay_s``.

    The data's pulse (``n`` bins) cut to the window against the pulse of the patch's own
    radar (``n_p`` bins) for a point at differential delay ``d`` (module ``extract``).
    """
    dt = patch_radar.sample_interval_s  # the window's samples (the data's, or finer)
    t = (np.arange(patch_radar.n_samples) - patch_radar.n_samples // 2) * dt
    worst = 0.0
    for d in np.linspace(-max_delay_s, max_delay_s, 401):
        worst = max(worst, float(np.max(np.abs(_pulse(radar, t - d) - _pulse(patch_radar, t - d)))))
    return worst


def test_traces_blocks_is_a_pulse_source():
    radar, traj = _acquisition(pulses_per_deg=117.0)
    tr = _traces([PointTarget(position_m=(3.0, 4.0))], radar, traj)
    src = TracesBlocks(tr)
    assert isinstance(src, PulseBlocks)
    blocks = list(src.blocks(50))
    assert [b[0] for b in blocks] == list(range(0, tr.n_pulses, 50))
    assert np.array_equal(np.concatenate([b[2] for b in blocks]), tr.data)
    with pytest.raises(ValueError, match="block_pulses"):
        list(src.blocks(0))


def _prime_length(radar: Radar) -> Radar:
    """The same band and window on ``2 p`` samples, ``p`` prime: a slow transform length."""
    p = radar.n_samples // 2 + 1
    while any(p % k == 0 for k in range(2, int(p**0.5) + 1)):
        p += 1
    n = 2 * p
    return Radar(
        carrier_hz=radar.carrier_hz,
        bandwidth_hz=radar.bandwidth_hz,
        n_samples=n,
        frequency_step_hz=radar.span_hz / n,
        pulse=radar.pulse,
    )


@pytest.mark.parametrize(("block_pulses", "length"), [(37, "fast"), (1000, "fast"), (64, "prime")])
def test_patch_traces_are_the_data_compressed_to_the_patch_centre(block_pulses, length):
    """A point's patch traces equal its traces simulated with the patch centre as the
    reference point, on the patch's pulses and radar: to the FIR ripple 10^(-A/20) plus
    the difference of the two compressed pulses over the window (module ``extract``).

    Data of ``2 p`` samples (``p`` prime) are cut from the transform padded to a fast
    length: the patch's samples are finer by ``n / n'`` and the same bound holds."""
    radar, traj = _acquisition()
    if length == "prime":
        radar = _prime_length(radar)
    src = TracesBlocks(_traces([], radar, traj))
    opts = CollectionOptions(patch_size_m=40.0, max_speed_mps=10.0, stopband_db=60.0)
    plan = plan_patches(src, opts)
    assert len(plan.patches) > 1
    patch = next(p for p in plan.patches if p.contains((25.0, -30.0)))
    assert patch.decimation > 1 and patch.n_samples < radar.n_samples
    cx, cy = patch.centre_m[:2]
    cases = [
        PointTarget(position_m=(cx + 7.0, cy - 11.0)),
        PointTarget(position_m=(cx - 15.0, cy + 12.0)),
        # a mover whose Doppler centre is the patch's: cross-range motion
        PointTarget(position_m=(cx + 3.0, cy + 2.0), velocity_mps=(0.05, 8.0)),
    ]
    for tgt in cases:
        data = _traces([tgt], radar, traj)
        (got,) = extract_patches(TracesBlocks(data), [patch], block_pulses=block_pulses)
        want = to_fast_time(
            simulate_phase_history([tgt], got.trajectory, got.radar, patch.centre_m)
        )
        rel = travel_time(got.positions_m, tgt.positions_at(got.slow_times_s)) - travel_time(
            got.positions_m, patch.centre_m
        )
        tol = 10 ** (-opts.stopband_db / 20) + _window_bound(
            radar, got.radar, float(np.max(np.abs(rel)))
        )
        assert tol < 0.02  # the bound is tight enough to mean something
        assert np.max(np.abs(got.data - want)) <= tol
        on_axis = np.interp(patch.pulse_positions, np.arange(traj.n_pulses), traj.slow_times_s)
        assert np.allclose(got.slow_times_s, on_axis, rtol=0.0, atol=1e-12)
        assert got.radar.carrier_hz == radar.carrier_hz
        n_t = window_transform_length(radar.n_samples)
        assert n_t > radar.n_samples or length == "fast"
        assert got.radar.sample_interval_s == pytest.approx(
            radar.sample_interval_s * radar.n_samples / n_t, rel=1e-12
        )


def test_a_patch_rejects_stationary_echoes_outside_its_band():
    """A stationary point far outside the patch in cross range (its Doppler in the stop
    band) leaves at most the filter's stop-band level 10^(-A/20) (plus window leakage)."""
    radar, traj = _acquisition()
    src = TracesBlocks(_traces([], radar, traj))
    opts = CollectionOptions(patch_size_m=40.0, max_speed_mps=10.0)
    plan = plan_patches(src, opts)
    patch = next(p for p in plan.patches if p.contains((0.0, 0.0)))
    far = PointTarget(
        position_m=(
            patch.centre_m[0],
            patch.centre_m[1] + 0.45 * np.ptp(unambiguous_scene(src)[:, 1]),
        )
    )
    (got,) = extract_patches(TracesBlocks(_traces([far], radar, traj)), [patch])
    assert np.max(np.abs(got.data)) <= 2 * 10 ** (-opts.stopband_db / 20)


def test_plan_tiles_the_region_and_sizes_the_margins_for_every_mover():
    """Cores tile the region without overlap; a mover of speed <= max_speed_mps starting
    in a core keeps every delay in the patch's window and, when its Doppler centre is the
    core's, every instantaneous Doppler in the pass band (seeded draws)."""
    radar, traj = _acquisition()
    src = TracesBlocks(_traces([], radar, traj))
    opts = CollectionOptions(patch_size_m=40.0, max_speed_mps=12.0)
    plan = plan_patches(src, opts)
    x0, y0, x1, y1 = plan.region_m
    area = sum((p.core_m[2] - p.core_m[0]) * (p.core_m[3] - p.core_m[1]) for p in plan.patches)
    assert area == pytest.approx((x1 - x0) * (y1 - y0), rel=1e-9)
    rng = np.random.default_rng(8)
    for p in rng.uniform([x0, y0], [x1, y1], size=(200, 2)):
        assert sum(q.contains(p) for q in plan.patches) == 1
    pos, s = traj.positions_m, traj.slow_times_s
    f_lo = radar.carrier_hz - radar.bandwidth_hz / 2
    f_hi = radar.carrier_hz + radar.bandwidth_hz / 2
    j0 = int(np.argmin(np.abs(s)))
    dt = radar.sample_interval_s
    checked = 0
    for k in range(60):
        patch = plan.patches[rng.integers(len(plan.patches))]
        a, b, c, d = patch.core_m
        start = rng.uniform([a, b], [c, d])
        speed = rng.uniform(0, opts.max_speed_mps)
        phi = rng.uniform(0, 2 * np.pi)
        # half the movers cross-range: their Doppler centre stays on the core's
        vel = speed * np.array([np.cos(phi), np.sin(phi)]) if k % 2 else (0.0, speed)
        tgt = PointTarget(position_m=start, velocity_mps=vel)
        rel = travel_time(pos, tgt.positions_at(s)) - travel_time(pos, patch.centre_m)
        half = (patch.n_samples // 2) * dt
        assert np.max(np.abs(rel)) < half
        rate = np.gradient(rel, s)
        core = _core_doppler(patch, pos, s, radar)
        if abs(radar.carrier_hz * rate[j0]) <= core:
            assert max(np.max(np.abs(f_lo * rate)), np.max(np.abs(f_hi * rate))) <= (
                patch.passband_hz
            )
            checked += 1
    assert checked >= 10


def _core_doppler(patch, pos, s, radar):
    """Largest centre Doppler |f_o dtau/ds(0)| of the core's stationary points (Hz)."""
    a, b, c, d = patch.core_m
    j0 = int(np.argmin(np.abs(s)))
    out = 0.0
    for x, y in ((a, b), (c, b), (c, d), (a, d)):
        rel = travel_time(pos, (x, y, 0.0)) - travel_time(pos, patch.centre_m)
        out = max(out, abs(radar.carrier_hz * np.gradient(rel, s)[j0]))
    return out


@pytest.mark.parametrize("aperture_deg, azimuth_deg", [(4.0, 30.0), (1.0, -50.0)])
def test_unambiguous_scene_holds_at_every_pulse(aperture_deg, azimuth_deg):
    """Every corner stays in the fast-time window and within half the pulse rate at
    every pulse, by the exact delays (the rule is first order: 1 % of slack); and the
    default region is the whole rectangle, each of its points in one core."""
    radar = radar_with_range_window(150.0, radar=Radar())
    traj = Trajectory.circular(
        pulses_per_deg=117.0, aperture_deg=aperture_deg, centre_azimuth_deg=azimuth_deg
    )
    src = TracesBlocks(_traces([], radar, traj))
    amb = unambiguous_scene(src)
    pos, s = traj.positions_m, traj.slow_times_s
    ref = travel_time(pos, REF)
    for x, y in amb:
        rel = travel_time(pos, (x, y, 0.0)) - ref
        assert np.max(np.abs(rel)) <= 1.01 * 0.5 / radar.frequency_step_hz
        doppler = radar.carrier_hz * np.gradient(rel, s)
        assert np.max(np.abs(doppler)) <= 1.01 * 0.5 / traj.pulse_interval_s
    # the rectangle drawn at the aperture centre alone (each side from that pulse's
    # delay and Doppler rates) wraps in Doppler at a corner, at the aperture's ends
    j0 = int(np.argmin(np.abs(s)))
    e_r = (amb[1] - amb[0]) / np.linalg.norm(amb[1] - amb[0])
    e_c = (amb[3] - amb[0]) / np.linalg.norm(amb[3] - amb[0])

    def rel(point):
        return travel_time(pos, (*point, 0.0)) - ref

    half_r = 0.5 / radar.frequency_step_hz / abs(rel(e_r)[j0])
    half_c = 0.5 / traj.pulse_interval_s / abs(radar.carrier_hz * np.gradient(rel(e_c), s)[j0])
    wraps = [
        np.max(np.abs(radar.carrier_hz * np.gradient(rel(i * half_r * e_r + j * half_c * e_c), s)))
        > 0.5 / traj.pulse_interval_s
        for i, j in ((-1, -1), (1, -1), (1, 1), (-1, 1))
    ]
    assert any(wraps)
    # the default region (nothing declared) is the whole rectangle, every point of it in
    # one core
    plan = plan_patches(src)
    assert np.allclose(plan.region_polygon, amb, rtol=0, atol=1e-9)
    rng = np.random.default_rng(3)
    a, b = rng.uniform(0, 1, size=(2, 500))
    points = amb[0] + a[:, None] * (amb[1] - amb[0]) + b[:, None] * (amb[3] - amb[0])
    held = np.sum([p.inside(points) for p in plan.patches], axis=0)
    assert np.all(held == 1)


@pytest.mark.parametrize("beta_deg", [0.0, 3.0, 20.0, 44.0, 60.0, 90.0])
def test_inscribed_box_touches_the_rectangle(beta_deg):
    """The box lies inside the rectangle; unturned, it is the rectangle; turned a little,
    its corners touch both pairs of sides (nothing larger of its shape fits)."""
    beta = np.deg2rad(beta_deg)
    e1, e2 = np.array([np.cos(beta), np.sin(beta)]), np.array([-np.sin(beta), np.cos(beta)])
    centre, a, b = np.array([5.0, -3.0]), 70.0, 40.0
    rect = np.array(
        [centre + i * a * e1 + j * b * e2 for i, j in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    )
    x0, y0, x1, y1 = inscribed_box(rect)
    corners = np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)]) - centre
    p1, p2 = np.abs(corners @ e1), np.abs(corners @ e2)
    assert np.all(p1 <= a * (1 + 1e-9)) and np.all(p2 <= b * (1 + 1e-9))
    assert np.allclose([(x0 + x1) / 2, (y0 + y1) / 2], centre)
    if beta_deg == 0.0:
        assert np.allclose(
            [x0, y0, x1, y1], [centre[0] - a, centre[1] - b, centre[0] + a, centre[1] + b]
        )
    if beta_deg == 3.0:
        assert np.isclose(p1.max(), a) and np.isclose(p2.max(), b)
    if beta_deg == 90.0:  # turned a quarter: the rectangle again, sides swapped
        assert np.isclose(x1 - x0, 2 * b) and np.isclose(y1 - y0, 2 * a)


def test_bad_region_and_patch_size():
    radar, traj = _acquisition(pulses_per_deg=117.0)
    src = TracesBlocks(_traces([], radar, traj))
    amb = unambiguous_scene(src)
    with pytest.raises(RegionError, match="unambiguous"):
        plan_patches(src, region_m=(amb[:, 0].max() + 1, 0, amb[:, 0].max() + 50, 10))
    with pytest.raises(RegionError, match="resolution cell"):
        plan_patches(src, CollectionOptions(patch_size_m=0.2))
    with pytest.raises(RegionError, match="X0 < X1"):
        plan_patches(src, region_m=(10, 0, 0, 10))


def test_one_patch_when_todays_analysis_covers_the_scene():
    """A GOTCHA-sized acquisition is one patch: the data unchanged."""
    radar, traj = Radar(), Trajectory.circular()
    plan = plan_patches(TracesBlocks(_traces([], radar, traj)))
    assert plan.single and len(plan.patches) == 1
    (p,) = plan.patches
    assert p.decimation == 1 and p.n_samples == radar.n_samples
    assert p.pulses.size == traj.n_pulses
    assert np.array_equal(p.centre_m, REF)


# ------------------------------------------------------------------------ merge
def _record(patch, position, velocity, sigma=1e-3, snr=30.0):
    return MoverRecord(
        patch=patch,
        position_m=np.r_[np.asarray(position, float)[:2], 0.0],
        velocity_mps=np.asarray(velocity, float),
        sigma_range_m=sigma,
        sigma_range_speed_mps=sigma,
        snr_db=snr,
        document={},
    )


def test_one_mover_seen_at_two_family_members_is_merged_and_distinct_movers_kept():
    radar, traj = Radar(), Trajectory.circular()
    tr = _traces([], radar, traj)
    rho_r = radar.range_resolution_m
    p, v = np.array([10.0, 48.0, 0.0]), np.array([6.0, -3.0])
    q, w, _ = family_member(tr, p, v, 30.0)  # the same range history, 30 m away
    a = _record(0, p, v, sigma=2e-3)
    b = _record(1, q, w, sigma=1e-3)
    assert same_mover(a, b, traj, rho_r)
    kept = merge_movers([a, b], traj, rho_r)
    assert len(kept) == 1 and kept[0][0] is b and sorted(kept[0][1]) == [0, 1]
    # two cells further in range, or a range-speed resolution faster: another mover
    e_r = np.array([1.0, 0.0])
    other = _record(2, p[:2] + 2.5 * rho_r / 0.7 * e_r, v)
    faster = _record(3, p, v + 2.0 * rho_r / (0.5 * np.ptp(traj.slow_times_s)) * e_r / 0.7)
    assert not same_mover(a, other, traj, rho_r)
    assert not same_mover(a, faster, traj, rho_r)
    assert len(merge_movers([a, b, other, faster], traj, rho_r)) == 3


def test_stationary_duplicates_across_a_border_merge():
    t = [
        StationaryRecord(patch=0, position_m=(49.9, 3.0), level=1.0),
        StationaryRecord(patch=1, position_m=(50.1, 3.1), level=0.9),
        StationaryRecord(patch=1, position_m=(50.1, 9.0), level=0.5),
    ]
    kept = merge_stationary(
        t, range_direction=np.array([1.0, 0.0]), range_cell_m=0.33, cross_cell_m=1.3
    )
    assert [k.position_m for k in kept] == [(49.9, 3.0), (50.1, 9.0)]


@pytest.mark.parametrize("velocity", [(0.0, 0.0), (5.0, -3.0), (-13.0, 8.0)])
def test_echo_offsets_give_the_aliased_doppler_of_the_traces(velocity):
    """A mover's echo, re-referenced to ``c``, advances in phase by the aliased Doppler.

    At the compressed pulse's peak the phase of a point is ``-omega_o (tau - tau_c)``;
    from one pulse to the next it turns by ``-2 pi (2 f_o / c) dR dt`` modulo ``2 pi``,
    which is what :func:`echo_offsets` predicts from ``R'(0) - R_c'(0)`` taken modulo
    ``lambda_o PRF / 2``. Its range offset is where the peak sits in fast time.
    """
    from sarmotion.collection.merge import echo_offsets
    from sarmotion.core.constants import C

    radar, traj = _acquisition(range_window_m=100.0, pulses_per_deg=117.0)
    centre = np.array([10.0, -20.0, 0.0])
    mover = PointTarget(position_m=(18.0, 3.0), velocity_mps=velocity)
    tr = _traces([mover], radar, traj, ref=centre)
    j0 = int(np.argmin(np.abs(traj.slow_times_s)))
    dt = traj.slow_times_s[j0 + 1] - traj.slow_times_s[j0]
    period = 0.5 * radar.wavelength_m / traj.pulse_interval_s
    dr, rate = echo_offsets(
        traj, np.asarray(mover.position_m, float), np.asarray(velocity, float), centre, period
    )
    assert -0.5 * period <= rate < 0.5 * period
    # range: the peak of pulse j0 sits at 2 dR / c (within a sample)
    k = int(np.argmax(np.abs(tr.data[j0])))
    t_peak = radar.fast_times_s[k]
    assert abs(t_peak - 2.0 * dr / C) <= radar.sample_interval_s
    # Doppler: the phase step at the peak between pulses j0 and j0 + 1
    k1 = int(np.argmax(np.abs(tr.data[j0 + 1])))
    step = np.angle(tr.data[j0 + 1, k1] * np.conj(tr.data[j0, k]))
    predicted = -2.0 * np.pi * (2.0 * radar.carrier_hz / C) * rate * dt
    # the rate changes over one pulse (the mover's acceleration in range), by far
    # less than a tenth of a turn here
    assert abs(np.angle(np.exp(1j * (step - predicted)))) < 0.2 * np.pi


def test_a_coarsened_patch_image_pastes_as_the_fine_one():
    """Block maxima at the task, pasted into the mosaic, equal the fine image pasted."""
    from sarmotion.collection.merge import PatchImage, coarsen, mosaic_grid, paste

    rng = np.random.default_rng(3)
    fine = PatchImage(
        x_m=-3.1 + 0.25 * np.arange(37),
        y_m=7.3 + 0.25 * np.arange(29),
        magnitude=rng.random((29, 37)).astype(np.float32),
    )
    region = (-10.0, 0.0, 10.0, 20.0)
    for spacing in (0.25, 0.6, 1.7):
        a, _ = mosaic_grid(region, spacing)
        b, _ = mosaic_grid(region, spacing)
        paste(a, fine, region[:2], spacing)
        coarse = coarsen(fine, region[:2], spacing)
        paste(b, coarse, region[:2], spacing)
        np.testing.assert_array_equal(a, b)
        assert coarse.magnitude.size <= fine.magnitude.size
