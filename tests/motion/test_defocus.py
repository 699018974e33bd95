"""Movers whose traces look stationary: the cross-range-speed bank and the mover stage.

A mover moving across the line of sight only (no range speed) at (15, -10) m has the
range rate of the stationary point under it: its image lands inside the scene, in the
stationary band ``g(u)`` does not test, and the separation keeps its echo in ``L``.
Its cross-range speed defocuses it by ``edge_phase_rad`` per m/s at the aperture's
edges; the bank focuses it. The search is on by default (``defocus_search``; ``OPTIONS``
names it); the mover has the clutter points' unit amplitude.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.core import Radar, Traces, Trajectory, delay_phase, to_fast_time, to_frequency
from sarmotion.imaging import resolution
from sarmotion.motion import central_sub_aperture, defocus_scan, family_member, point_model
from sarmotion.motion.defocus import (
    EDGE_PHASE_STEP_RAD,
    DefocusCandidate,
    _local_peaks,
    cross_speed_bank,
    echo_peak_power,
    echo_residue,
    edge_phase_rad,
)
from sarmotion.pipeline import AnalysisOptions, analyze
from sarmotion.simulation import PointTarget, add_noise, simulate_phase_history

MOVER_AT = np.array([15.0, -10.0])
OPTIONS = AnalysisOptions(defocus_search=True)
WIDE = AnalysisOptions(defocus_search=True, wide_defocus_search=True)


def _scene(
    seed: int,
    cross_speed_mps: float | None,
    snr_db: float | None = None,
    aperture_deg: float = 1.0,
):
    """Traces of 20 unit stationary points in +-45 m and an optional cross-range mover."""
    rng = np.random.default_rng(seed)
    traj, radar = Trajectory.circular(aperture_deg=aperture_deg), Radar()
    targets = [PointTarget(position_m=p) for p in rng.uniform(-45.0, 45.0, size=(20, 2))]
    mover = None
    if cross_speed_mps is not None:
        mover = PointTarget(
            position_m=MOVER_AT,
            velocity_mps=(0.0, cross_speed_mps),
            label="m",
        )
        targets.append(mover)
    ph = simulate_phase_history(targets, traj, radar, (0.0, 0.0, 0.0))
    if snr_db is not None:
        ph = add_noise(ph, snr_db=snr_db, rng=np.random.default_rng(seed + 1))
    tr = Traces(
        data=to_fast_time(ph).astype(np.complex64),
        trajectory=traj,
        radar=radar,
        reference_point_m=(0.0, 0.0, 0.0),
    )
    return tr, targets[:20], mover


def _central(tr: Traces) -> Traces:
    c = central_sub_aperture(tr, 1.0)
    return tr.select_pulses(c.start, c.stop)


def test_bank_steps_are_a_quarter_turn_of_edge_phase():
    tr, _, _ = _scene(0, None)
    sub = _central(tr)
    bank = cross_speed_bank(sub, 30.0)
    assert bank[bank.size // 2] == 0.0 and np.allclose(bank, -bank[::-1])
    step = bank[1] - bank[0]
    # the edge phase is linear in w over road speeds: one step is pi/2 of it
    assert edge_phase_rad(sub, step) == pytest.approx(EDGE_PHASE_STEP_RAD, rel=0.02)
    assert edge_phase_rad(sub, 10 * step) == pytest.approx(10 * EDGE_PHASE_STEP_RAD, rel=0.05)


@pytest.mark.parametrize("shape", [(5, 7, 9), (1, 4, 6), (3, 1, 2), (2, 5, 1)])
def test_local_peaks_are_the_maxima_of_the_filtered_bank(shape):
    # The screen keeps a cell only where it is the largest of its 3 x 3 x 3 neighbourhood
    # (edges repeated) over the searched columns: evaluated at the cells asked about, the
    # same answer as filtering the whole bank; ties count as peaks.
    from scipy.ndimage import maximum_filter

    rng = np.random.default_rng(sum(shape))
    maps = np.round(rng.random(shape) * 4.0).astype(np.float32)  # many ties
    n_cols = shape[2]
    cols = np.sort(rng.choice(n_cols, size=max(1, n_cols - 1), replace=False))
    local = maximum_filter(maps[:, :, cols], size=3, mode="nearest")
    for k in range(shape[0]):
        rows, js = np.nonzero(np.ones((shape[1], cols.size), bool))
        want = maps[k][:, cols][rows, js] >= local[k][rows, js]
        np.testing.assert_array_equal(_local_peaks(maps, cols, k, rows, js), want)


@pytest.mark.parametrize("n, guard", [(64, 4), (16, 7), (8, 5)])
def test_compiled_guarded_mean_is_the_cumulative_sums_bit_for_bit(n, guard):
    # The screen's cell-averaged interference: the compiled form repeats the reference's
    # float32 running sums and its float64 differences in the same order (windows that
    # wrap around either end, and a guard wider than the row).
    from sarmotion.motion.defocus import _guarded_mean, _guarded_mean_f32

    rng = np.random.default_rng(n + guard)
    power = (rng.exponential(size=(5, n)) * 10.0 ** rng.uniform(-3, 3, (5, n))).astype(np.float32)
    cols = np.array([0, 1, guard, n // 2, n - 2, n - 1])
    out = np.empty((5, cols.size))
    _guarded_mean_f32(power, cols, guard, out)
    np.testing.assert_array_equal(out, _guarded_mean(power, cols, guard))
    if 2 * guard + 1 >= n:
        return  # no cell beyond the guard: the reference's value is not a mean
    # and it is the mean beyond the guard (up to float32's running-sum rounding)
    j = int(cols[3])
    keep = np.abs((np.arange(n) - j + n // 2) % n - n // 2) > guard
    want = power[:, keep].astype(np.float64).sum(axis=1) / max(n - (2 * guard + 1), 1)
    np.testing.assert_allclose(out[:, 3], want, rtol=1e-5)


@pytest.mark.parametrize(("aperture_deg", "offset_m"), [(2.0, 50.0), (2.0, -50.0), (4.0, 45.0)])
def test_each_rows_stationary_points_focus_at_zero(aperture_deg, offset_m):
    # A stationary point off the reference in range curves in range by about x Omega^2
    # s^2 / 2: over two GOTCHA degrees, 50 m away, more than the bank's step. With each
    # row's own curvature removed it focuses at w = 0, as the smear model takes it;
    # about the reference alone (the same transform without the row phases) it would
    # focus at another hypothesis with under half its power at w = 0.
    from sarmotion.core.geometry import look_geometry, range_direction_velocity
    from sarmotion.motion.defocus import _hypothesis_power, hypothesis_delays_s

    traj, radar = Trajectory.circular(aperture_deg=aperture_deg), Radar()
    at = -offset_m * range_direction_velocity(
        1.0, look_geometry(traj, (0.0, 0.0, 0.0))
    )  # range up by offset_m
    ph = simulate_phase_history([PointTarget(position_m=tuple(at))], traj, radar, (0, 0, 0))
    tr = Traces(data=to_fast_time(ph), trajectory=traj, radar=radar, reference_point_m=(0, 0, 0))
    bank = cross_speed_bank(tr, 2.0)
    rows = np.flatnonzero(np.abs(tr.fast_times_s - 2 * offset_m / 3e8) <= 4.0 / radar.bandwidth_hz)
    n_dop = 2 * tr.n_pulses
    spectrum = to_frequency(tr.data)
    with_rows = [
        float(_hypothesis_power(tr, spectrum, hypothesis_delays_s(tr, w), rows, n_dop)[1].max())
        for w in bank
    ]
    about_ref = []
    for w in bank:
        aligned = to_fast_time(
            spectrum * delay_phase(hypothesis_delays_s(tr, w), tr.frequencies_hz)
        )
        about_ref.append(float(np.max(np.abs(np.fft.fft(aligned[:, rows], n=n_dop, axis=0)) ** 2)))
    zero = bank.size // 2
    assert bank[zero] == 0.0
    assert with_rows[zero] == max(with_rows)
    assert about_ref[zero] < 0.5 * max(about_ref)


@pytest.mark.parametrize("at", [(0.0, 45.0), (-35.0, -35.0)])
def test_keystoned_stationary_points_stay_in_their_cell_and_focus_at_zero(at):
    # Over two GOTCHA degrees a stationary point 35-45 m off in cross range walks
    # through several range cells: a fast-time row holds it over part of the aperture
    # only, and the row's bank peaks at another hypothesis (its power at w = 0 under
    # 0.8 of the best). Keystoned, its range no longer walks: w = 0 is its best, and
    # the neighbouring hypotheses read at most the smear of a quarter turn's step.
    from sarmotion.motion.defocus import _Bank, hypothesis_delays_s

    traj, radar = Trajectory.circular(aperture_deg=2.0), Radar()
    ph = simulate_phase_history([PointTarget(position_m=at)], traj, radar, (0, 0, 0))
    tr = Traces(data=to_fast_time(ph), trajectory=traj, radar=radar, reference_point_m=(0, 0, 0))
    bank = cross_speed_bank(tr, 1.0)
    rows = np.arange(tr.n_samples)
    n_dop = 2 * tr.n_pulses
    best = {}
    for keystone in (False, True):
        b = _Bank(tr, rows, n_dop, keystone=keystone)
        out = np.empty((rows.size, n_dop), dtype=np.float32)
        powers = []
        for w in bank:
            b.power(hypothesis_delays_s(tr, w), out=out)
            powers.append(float(out.max()))
        best[keystone] = np.asarray(powers) / max(powers)
    zero = bank.size // 2
    assert best[False][zero] < 0.8
    assert best[True][zero] == 1.0
    assert max(best[True][zero - 1], best[True][zero + 1]) < 0.95


def test_keystone_is_the_scaled_slow_time_of_each_frequency():
    # A tone over slow time at each frequency, sampled at s f_c / f: band-limited
    # interpolation to -50 dB of the tone away from the ends of the aperture.
    from sarmotion.motion.defocus import keystone_spectrum

    s = np.linspace(-0.5, 0.5, 301)
    f_c = 1e10
    f = f_c + np.array([-3e8, 0.0, 2e8])
    nu = 37.0  # Hz, well within the pulse rate's +-150 Hz
    spectrum = np.exp(2j * np.pi * nu * s[:, None] * np.ones(f.size)[None, :])
    got = keystone_spectrum(spectrum, s, f, f_c)
    want = np.exp(2j * np.pi * nu * s[:, None] * (f_c / f)[None, :])
    inner = np.abs(s) <= 0.4
    assert np.max(np.abs(got[inner] - want[inner])) < 10 ** (-50 / 20)
    np.testing.assert_allclose(got[:, 1], spectrum[:, 1], atol=1e-12)  # f = f_c: unchanged


def test_bank_power_is_each_hypothesis_transform():
    # The scan's transforms (spectrum held in FFT order, searched rows only, slow time on
    # the last axis, in place) against the hypothesis' definition: |X|^2 to float32.
    from sarmotion.motion.defocus import _Bank, _hypothesis_power, hypothesis_delays_s

    tr, _, _ = _scene(1, 12.0)
    sub = _central(tr)
    rows = np.flatnonzero(np.abs(sub.fast_times_s) <= 2 * 30.0 / 3e8)
    n_dop = 4 * sub.n_pulses
    bank = _Bank(sub, rows, n_dop)
    spectrum = to_frequency(sub.data)
    for w in (0.0, 4.0, -9.0):
        delays = hypothesis_delays_s(sub, w)
        got = np.empty((rows.size, n_dop), dtype=np.float32)
        bank.power(delays, out=got)
        _, want = _hypothesis_power(sub, spectrum, delays, rows, n_dop)
        np.testing.assert_allclose(got, want.T, rtol=2e-7, atol=2e-7 * float(want.max()))


def test_scan_places_the_mover_in_its_cell():
    tr, _, mover = _scene(1, 12.0)
    sub = _central(tr)
    geom = sub.geometry
    band = geom.speed_mps * (100.0 / np.sqrt(2.0)) / geom.range_m
    scan = defocus_scan(
        sub, max_speed_mps=30.0, band_mps=band, half_span_s=2 * 75.0 / 3e8, false_alarm_rate=0.01
    )
    best = scan.candidates[0]
    # the truth's range history relative to the reference: rate and delay at s = 0
    s, x, ref = sub.slow_times_s, sub.positions_m, sub.reference_point_m
    p, v = np.r_[MOVER_AT, 0.0], np.r_[mover.velocity_mps, 0.0]
    r = np.linalg.norm(x - (p + s[:, None] * v), axis=1) - np.linalg.norm(x - ref, axis=1)
    rate, r0 = np.polyfit(s, r, 1)
    step = scan.speeds_mps[1] - scan.speeds_mps[0]
    doppler_mps = 0.5 * 3e8 / sub.radar.carrier_hz / float(np.ptp(s))  # lambda / (2 T)
    assert abs(best.cross_range_speed_mps - 12.0) <= step
    assert abs(best.range_speed_mps - rate) <= doppler_mps
    assert abs(best.delay_s - 2.0 * r0 / 3e8) <= 1.0 / sub.radar.bandwidth_hz


def test_echo_power_is_the_banks_cell_and_the_true_model_removes_it():
    """The echo's peak is the coherent sum of its pulses; its own model leaves nothing."""
    traj, radar = Trajectory.circular(), Radar()
    mover = PointTarget(position_m=MOVER_AT, velocity_mps=(0.0, 12.0), reflectivity=0.5j)
    ph = simulate_phase_history([mover], traj, radar, (0.0, 0.0, 0.0))
    tr = Traces(data=to_fast_time(ph), trajectory=traj, radar=radar, reference_point_m=(0, 0, 0))
    sub = _central(tr)
    scan = defocus_scan(
        sub, max_speed_mps=30.0, band_mps=1.0, half_span_s=2 * 75.0 / 3e8, false_alarm_rate=0.01
    )
    # the brightest candidate (the list is ranked by power over the local interference,
    # which noise-free side lobes far from the echo also reach)
    powers = [echo_peak_power(sub, c) for c in scan.candidates]
    cand = scan.candidates[int(np.argmax(powers))]
    peak = max(powers)
    # |X|^2 of an aligned point echo of amplitude |a| = 0.5 (its compressed pulse's
    # peak) over n pulses: at most (n |a|)^2 (Cauchy-Schwarz), less the bank's
    # straddle losses (its delay sample, Doppler cell and cross-range-speed step),
    # together under 6 dB
    n = sub.n_pulses
    assert peak <= (n * 0.5) ** 2 * (1 + 1e-9)
    assert peak >= (n * 0.5) ** 2 / 4
    model = point_model(sub, np.r_[MOVER_AT, 0.0], np.array([0.0, 12.0]), 0.5j)
    assert echo_peak_power(sub, cand, np.asarray(sub.data) - model) <= 1e-12 * peak


def _beside(seed: int, cross_speed_mps: float, offset_m: tuple[float, float]):
    """``_scene`` with one more unit stationary point at ``MOVER_AT + offset_m``."""
    tr, stationary, mover = _scene(seed, cross_speed_mps)
    neighbour = PointTarget(position_m=MOVER_AT + np.asarray(offset_m))
    targets = [*stationary, neighbour, mover]
    ph = simulate_phase_history(targets, tr.trajectory, tr.radar, (0.0, 0.0, 0.0))
    return tr.with_data(to_fast_time(ph).astype(np.complex64)), [*stationary, neighbour], mover


def test_echo_residue_is_what_a_model_leaves_of_its_own_echo():
    """Over the model's main lobe: ``(1 - k)^2`` for ``k`` times the truth's model, exactly.

    A slow mover (1.5 m/s across the line of sight) has a unit stationary point 7 m
    away in cross range, a quarter of a range cell nearer: inside the extent of the
    mover's echo (two range-speed resolutions span tens of metres of cross range), and
    nearly focused in the mover's hypothesis. Its echo is no part of the mover's model:
    the peak over the extent keeps it after the model is subtracted (more than
    ``MAX_ECHO_RESIDUE`` of the echo's peak), the model's own cells do not.
    """
    from sarmotion.pipeline.defocused import MAX_ECHO_RESIDUE

    traj, radar = Trajectory.circular(), Radar()
    mover = PointTarget(position_m=MOVER_AT, velocity_mps=(0.0, 1.5), reflectivity=0.5j)
    neighbour = PointTarget(position_m=MOVER_AT + np.array([-0.25, 7.0]), reflectivity=0.5)
    for targets in ([mover], [mover, neighbour]):
        ph = simulate_phase_history(targets, traj, radar, (0.0, 0.0, 0.0))
        tr = Traces(
            data=to_fast_time(ph), trajectory=traj, radar=radar, reference_point_m=(0, 0, 0)
        )
        sub = _central(tr)
        scan = defocus_scan(
            sub, max_speed_mps=30.0, band_mps=1.0, half_span_s=2 * 75.0 / 3e8, false_alarm_rate=0.01
        )
        cand = max(scan.candidates, key=lambda c: c.power)
        assert abs(cand.cross_range_speed_mps - 1.5) <= abs(scan.speeds_mps[1] - scan.speeds_mps[0])
        truth = point_model(sub, np.r_[MOVER_AT, 0.0], np.array([0.0, 1.5]), 0.5j)
        if len(targets) == 1:
            for k in (1.0, 0.5, 0.25, 2.0):
                got = echo_residue(sub, cand, k * truth, 1.0)
                assert got == pytest.approx((1 - k) ** 2, abs=1e-9)
            assert echo_residue(sub, cand, 0.0 * truth, 1.0) == np.inf
        else:
            assert echo_residue(sub, cand, truth, 1.0) < 0.01
            left = echo_peak_power(sub, cand, np.asarray(sub.data) - truth)
            assert left > MAX_ECHO_RESIDUE * echo_peak_power(sub, cand)


def test_the_residues_smear_bound_is_the_screens():
    """At a candidate's own cell, the smear bound of the echo test is the screen's.

    The screen keeps a cell brighter than ``SMEAR_MARGIN_DB`` over the largest smear a
    stationary point could put there (``leak_db``); the echo test counts a residual cell
    that no smear explains by the same bound, computed for the cells of the echo.
    """
    from sarmotion.core.constants import C
    from sarmotion.motion.defocus import _echo_extent, _smear_bound

    tr, _, _ = _beside(1, 1.5, (-0.25, 7.0))
    sub = _central(tr)
    band = 1.0
    scan = defocus_scan(
        sub, max_speed_mps=30.0, band_mps=band, half_span_s=2 * 60.0 / 3e8, false_alarm_rate=0.01
    )
    assert len(scan.candidates) >= 3
    for cand in scan.candidates[:3]:
        extent = _echo_extent(sub, cand)
        rows, cols, delays, n_dop = extent
        r = int(np.argmin(np.abs(sub.fast_times_s[rows] - cand.delay_s)))
        prf = 1.0 / float(np.median(np.diff(sub.slow_times_s)))
        u_w = 0.5 * C * float(np.polyfit(sub.slow_times_s, delays, 1)[0])
        speed = u_w - 0.5 * sub.radar.wavelength_m * np.fft.fftfreq(n_dop, d=1.0 / prf)
        c = int(np.argmin(np.abs(speed[cols] - cand.range_speed_mps)))
        spectrum = to_frequency(sub.data)
        bound = _smear_bound(sub, extent, spectrum, band, (np.array([c]), np.array([r])))[0]
        assert 20 * np.log10(np.sqrt(cand.power) / bound) == pytest.approx(cand.leak_db, abs=1e-6)


def test_the_echos_most_powerful_cell_is_fitted_after_its_strongest():
    from sarmotion.pipeline.defocused import cells_to_fit

    def cell(statistic_db, power):
        return DefocusCandidate(
            range_speed_mps=0.0,
            cross_range_speed_mps=1.0,
            delay_s=0.0,
            statistic_db=statistic_db,
            leak_db=7.0,
            power=power,
        )

    a, b, c = cell(26.1, 2.0), cell(25.7, 3.0), cell(20.0, 1.0)
    assert cells_to_fit([a, b, c]) == [a, b]
    assert cells_to_fit([b, c]) == [b]
    assert cells_to_fit([a]) == [a]


def _assert_found_on_family(tr, result, stationary, mover, also_listed=()):
    """One mover, found by its defocus, on the truth's family; its smear not listed.

    ``also_listed``: positions (m) the analysis lists without the mover (side lobes of
    a stationary point), allowed as well.
    """
    assert len(result.movers) == 1
    m = result.movers[0]
    assert m.evidence.defocus is not None
    sub = _central(tr)
    cells = resolution(sub)
    dy = float((m.position_m[:2] - MOVER_AT) @ cells.cross_range_direction)
    tp, tv, _ = family_member(sub, np.r_[MOVER_AT, 0.0], mover.velocity_mps, dy)
    # on the truth's family: range position within a ground-range cell, speeds within
    # a range-speed resolution and 0.5 m/s of cross-range speed
    assert abs(float((m.position_m[:2] - tp[:2]) @ cells.range_direction)) < cells.ground_range_m
    assert abs(m.cross_range_speed_mps - float(tv @ cells.cross_range_direction)) < 0.5
    # its smear is not listed as stationary points: every listing is near a true point
    true = np.array([t.position_m[:2] for t in stationary] + list(also_listed))
    for t in result.stationary:
        if abs(t.position_m[0] - MOVER_AT[0]) < 1.0:
            assert np.min(np.hypot(*(true - np.asarray(t.position_m)).T)) < 3.0


@pytest.mark.parametrize(("seed", "speed"), [(1, 12.0), (5, -25.0), (6, 2.5), (4, 20.0)])
def test_analysis_finds_the_mover_on_its_family(seed, speed):
    tr, stationary, mover = _scene(seed, speed)
    _assert_found_on_family(tr, analyze(tr, OPTIONS), stationary, mover)


def test_analysis_finds_a_slow_mover_beside_a_stationary_point():
    """A mover 1.5 m/s across the line of sight with a unit stationary point 7 m away.

    The echo's strongest cell by statistic is a hypothesis whose range bin holds less
    clutter (fitted, the stationary points explain it); its most powerful cell focuses the
    mover, whose fit leaves nothing at its own echo's cells though the neighbour's echo,
    nearly focused in the mover's hypothesis, stays in the echo's extent.
    """
    tr, stationary, mover = _beside(1, 1.5, (-0.25, 7.0))
    ph = simulate_phase_history(stationary, tr.trajectory, tr.radar, (0.0, 0.0, 0.0))
    alone = analyze(tr.with_data(to_fast_time(ph).astype(np.complex64)), OPTIONS)
    assert alone.movers == ()
    # the neighbour's cross-range side lobes are listed with or without the mover
    lobes = [t.position_m for t in alone.stationary]
    _assert_found_on_family(tr, analyze(tr, OPTIONS), stationary, mover, lobes)


@pytest.mark.parametrize("seed", [11, 12])
def test_no_mover_in_stationary_clutter(seed):
    tr, _, _ = _scene(seed, None, snr_db=10.0)
    result = analyze(tr, OPTIONS)
    assert result.movers == ()


def test_a_mover_under_the_central_step_is_found_over_the_wide_span():
    """A mover slower across the line of sight than the central degree's first step.

    Over two degrees, at 0.3 m/s (0.4 of the central bank's step), a degree cannot tell
    its range history from a stationary point's: the analysis of the central degree
    alone finds no mover, nor does the default analysis of both degrees (no wide
    search). Over the wide span (both degrees, about the same middle) its quadratic
    phase is four times as large, and the analysis with the wide search finds it on its
    family.
    """
    from sarmotion.pipeline import detect
    from sarmotion.pipeline.defocused import wide_pulses

    tr, stationary, mover = _scene(2, 0.3, aperture_deg=2.0)
    det = detect(tr, WIDE)
    wide = wide_pulses(det)
    c = det.central
    assert wide is not None and wide.start + wide.stop == c.start + c.stop
    step = float(cross_speed_bank(det.sub, 30.0)[1] - cross_speed_bank(det.sub, 30.0)[0])
    assert 0.3 < 0.5 * step
    assert analyze(tr.select_pulses(c.start, c.stop), OPTIONS).movers == ()
    assert analyze(tr, OPTIONS).movers == ()
    _assert_found_on_family(tr, analyze(tr, WIDE), stationary, mover)


@pytest.mark.parametrize("seed", [13, 14])
def test_no_mover_in_stationary_clutter_over_the_wide_span(seed):
    tr, _, _ = _scene(seed, None, snr_db=10.0, aperture_deg=2.0)
    assert analyze(tr, WIDE).movers == ()


def test_without_the_search_the_mover_is_missed():
    """Without the search ``g(u)`` leaves the band untested and sees no mover."""
    tr, _, _ = _scene(1, 12.0)
    result = analyze(tr, AnalysisOptions(defocus_search=False))
    assert result.movers == ()


def test_unresolved_stationary_points_explain_a_moving_signature():
    """Three unit points on one range line, two of them 0.9 cross-range cells apart.

    Their Doppler tones lie along the sweep of a point moving at about -2 m/s across the
    line of sight, which fits them with more than a unit amplitude; the stationary image
    shows the close pair as one broad peak. Sought one at a time on what the points
    found leave, all three are found (each within a quarter of a cross-range cell) and,
    fitted jointly with the moving signature, leave it under ``JOINT_RATIO`` of its
    amplitude: the stationary scene explains it.
    """
    from sarmotion.motion import fit_point_mover, stationary_explanation
    from sarmotion.pipeline.defocused import JOINT_RATIO, joint_amplitude, stationary_near

    traj, radar = Trajectory.circular(), Radar()
    points = np.array([[-15.35, -19.05], [-15.29, -21.04], [-15.40, -22.21]])
    ph = simulate_phase_history(
        [PointTarget(position_m=p) for p in points], traj, radar, (0.0, 0.0, 0.0)
    )
    tr = Traces(
        data=to_fast_time(ph), trajectory=traj, radar=radar, reference_point_m=(0.0, 0.0, 0.0)
    )
    sub = _central(tr)
    cells = resolution(sub)
    assert 0.5 * cells.cross_range_m < abs(points[1, 1] - points[2, 1]) < cells.cross_range_m
    fit = fit_point_mover(sub, 0.0, cross_speed_range_mps=(-4.0, -1.0))
    assert abs(fit.amplitude) > 1.0  # the signature matches the three better than one point
    value = fit.amplitude * sub.n_pulses
    why = stationary_explanation(sub, fit.position_m, fit.velocity_mps, value)
    near = stationary_near(sub, fit, why.cross_offset_m)
    for p in points:
        assert np.min(np.hypot(*(near[:, :2] - p).T)) < 0.25 * cells.cross_range_m
    assert abs(joint_amplitude(sub, fit, near)) < JOINT_RATIO * abs(fit.amplitude)


def test_skipping_the_joint_fit_keeps_every_verdict():
    # The analysis runs the joint fit with the nearby stationary points only when the
    # other tests have not refused a candidate: on the echoes of a lowered screen (clutter
    # candidates, and the mover of the first scene) every verdict is the one of the full
    # evaluation, and a skipped joint fit is always a refusal.
    from sarmotion.pipeline import detect
    from sarmotion.pipeline.defocused import (
        distinct_echoes,
        scan_detection,
        search_data,
        test_candidate,
    )

    gain = OPTIONS.min_focus_gain_db
    tested = skipped = accepted_any = 0
    for seed, speed in [(1, 12.0), (2, None), (3, None)]:
        tr, _, _ = _scene(seed, speed)
        det = detect(tr, OPTIONS)
        data = det.sub.with_data(search_data(det))
        scan = scan_detection(det, data, threshold_db=6.0)
        step = float(np.min(np.abs(scan.speeds_mps[scan.speeds_mps != 0.0])))
        for echo in distinct_echoes(scan, data)[:6]:
            band = float(det.candidates.min_speed_mps)
            full = test_candidate(data, echo[0], step, band_mps=band)
            lazy = test_candidate(data, echo[0], step, gain, band_mps=band)
            accepted = not full.stationary(gain) and full.cancels
            assert (not lazy.stationary(gain) and lazy.cancels) == accepted
            np.testing.assert_array_equal(  # NaN: a coherence not measured, in both
                [lazy.residue, lazy.coherence], [full.residue, full.coherence]
            )
            tested += 1
            accepted_any += accepted
            if np.isnan(lazy.joint_ratio):
                skipped += 1
                assert not accepted
            else:
                assert lazy.joint_ratio == full.joint_ratio
    assert tested >= 4 and skipped >= 1 and accepted_any >= 1
