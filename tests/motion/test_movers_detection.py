"""Movers as a statistical test, their maximum-likelihood fit and its Cramér–Rao bound.

The threshold is set once, from a stated false-alarm rate (1 % per scene) and the null
tail measured on other data (sarmotion.motion.detector notes); nothing here is tuned on
these draws. Seeds 7000+ are used nowhere else. Errors of a fit are taken against the
member of the truth's cross-range family at the fit's cross-range coordinate, where the
bound (cross-range coordinate held) is defined.
"""

import numpy as np
import pytest

from sarmotion.core import C, ground_velocity, range_speed
from sarmotion.imaging import resolution
from sarmotion.io import read_gotcha
from sarmotion.motion import (
    NULL_TAIL,
    MatchedFilter,
    detect_range_speeds,
    fisher_information,
    fit_point_mover,
    local_statistic,
    peak_statistics,
    point_model,
    point_peak_width,
    range_gradients,
    threshold_db,
)
from sarmotion.pipeline import AnalysisOptions, detect, estimate_movers
from sarmotion.pipeline import family_errors as _family_errors
from sarmotion.separation import SeparationOptions
from sarmotion.simulation import PointTarget, inject, random_scene, simulate


def _movers_stages(traces, method, size_m=None):
    """The analysis's separation, detection and estimation stages (default options)."""
    options = AnalysisOptions(
        separation=SeparationOptions(method=method), trajectory=False, image_size_m=size_m
    )
    d = detect(traces, options)
    return d.sub, d.moving_sub, d.candidates, list(estimate_movers(d).movers)


def _white_noise_bound(sub, truth, noise_variance_t):
    """Cramér–Rao standard deviations (x, u, u_perp) of ``truth`` in white noise alone.

    ``noise_variance_t`` is the per-sample variance of the simulated noise in fast time;
    the phase history's is ``n_samples`` times it.
    """
    geom = sub.geometry
    grads = range_gradients(
        sub.positions_m,
        sub.slow_times_s,
        truth.position_m,
        truth.velocity_mps,
        range_direction=resolution(sub).range_direction,
        range_basis_mps=ground_velocity(1, 0, geom),
        cross_basis_mps=ground_velocity(0, 1, geom),
    )
    J = fisher_information(
        grads,
        sub.frequencies_hz,
        sub.radar.spectral_weights(),
        amplitude=abs(truth.reflectivity),
        noise_variance=sub.n_samples * noise_variance_t,
    )
    return np.sqrt(np.diag(np.linalg.inv(J)))[:3]


# ------------------------------------------------------------------ pure functions
def test_fisher_matrix_is_the_closed_form_of_the_model():
    """The phase-eliminated Fisher matrix equals the one of numeric model derivatives."""
    traces = simulate(random_scene(n_stationary=1, rng=0)).traces
    geom = traces.geometry
    e_r = resolution(traces).range_direction
    pos, vel = np.array([3.0, -2.0, 0.0]), ground_velocity(4.0, -6.0, geom)
    amp, var = 0.8, 0.05
    grads = range_gradients(
        traces.positions_m,
        traces.slow_times_s,
        pos,
        vel,
        range_direction=e_r,
        range_basis_mps=ground_velocity(1, 0, geom),
        cross_basis_mps=ground_velocity(0, 1, geom),
    )
    w = traces.radar.spectral_weights()
    J = fisher_information(grads, traces.frequencies_hz, w, amplitude=amp, noise_variance=var)

    def model(q):  # phase history of a * W exp(-i psi(theta)), theta = (x, u_r, u_p, A, phi)
        p = pos + q[0] * np.r_[e_r, 0.0]
        v = ground_velocity(4.0 + q[1], -6.0 + q[2], geom)
        where = p[None] + traces.slow_times_s[:, None] * np.r_[v, 0.0][None]
        r = np.linalg.norm(traces.positions_m - where, axis=1)
        r0 = np.linalg.norm(traces.positions_m - traces.reference_point_m, axis=1)
        cyc = (2 * (r - r0) / C)[:, None] * traces.frequencies_hz[None]
        return (
            (amp + q[3]) * np.exp(1j * q[4]) * w[None] * np.exp(-2j * np.pi * (cyc - np.rint(cyc)))
        )

    h = np.array([1e-5, 1e-6, 1e-4, 1e-6, 1e-6])
    d = [(model(np.eye(5)[i] * h[i]) - model(-np.eye(5)[i] * h[i])) / (2 * h[i]) for i in range(5)]
    F = np.array([[2 / var * np.real(np.vdot(a, b)) for b in d] for a in d])
    schur = F[:4, :4] - np.outer(F[:4, 4], F[4, :4]) / F[4, 4]
    assert np.allclose(J, schur, rtol=2e-3, atol=1e-9 * np.abs(J).max())


def test_bound_is_reached_by_the_fit_in_white_noise():
    """One mover in white noise: RMSE of the maximum-likelihood fit within 1.35 bounds.

    Measured on these 30 draws (integrated SNR 20 dB): RMSE / bound = 1.21 (range
    position), 1.09 (range speed), 1.09 (cross-range speed).
    """
    base = simulate(random_scene(n_stationary=1, rng=0)).traces
    geom = base.geometry
    truth = PointTarget(position_m=[3.0, -4.0], velocity_mps=ground_velocity(4.0, 6.0, geom))
    clean = inject(base.with_data(np.zeros(base.shape, complex)), [truth])
    n, k = clean.shape
    var = n / 10**2.0  # sigma_t^2 for A^2 sum w / sigma_P^2 = 100 (rect W = 1)
    sd = _white_noise_bound(clean, truth, var)
    rng = np.random.default_rng(7000)
    errs = []
    for _ in range(30):
        noise = np.sqrt(var / 2) * (
            rng.standard_normal(clean.shape) + 1j * rng.standard_normal(clean.shape)
        )
        fit = fit_point_mover(
            clean.data + noise,
            range_speed(truth.velocity_mps, geom),
            acquisition=clean.acquisition,
            cross_speed_range_mps=(3.0, 9.0),
        )
        errs.append(_family_errors(clean, fit, truth))
    rmse = np.sqrt(np.mean(np.square(errs), axis=0))
    assert np.all(rmse <= 1.35 * sd), (rmse, sd)
    assert np.sum(np.abs(errs) > 3 * sd) <= 1


def test_statistic_threshold_and_peak_width():
    u = np.arange(-30, 30, 0.135)
    rng = np.random.default_rng(7001)
    g = 1.0 + 0.02 * rng.standard_normal(u.size)
    g += 3.0 * np.exp(-0.5 * ((u - 5.0) / 0.2) ** 2)  # a narrow peak 12 dB up
    g += 0.5 * np.exp(-0.5 * ((u + 8.0) / 2.5) ** 2)  # a broad swell
    st = peak_statistics(u, g, 0.27)
    i = int(np.argmin(np.abs(st.speeds_mps - 5.0)))
    assert st.statistic_db[i] == pytest.approx(20 * np.log10(4.0), abs=0.3)
    j = int(np.argmin(np.abs(st.speeds_mps + 8.0)))
    assert st.statistic_db[j] < 2.0 and st.width_resolutions[i] < 3.0
    # the threshold grows with the number of candidates and falls with the rate
    assert threshold_db(0.01, 100) == pytest.approx(
        NULL_TAIL["t0_db"] + NULL_TAIL["scale_db"] * np.log(1000.0)
    )
    assert threshold_db(0.001, 100) > threshold_db(0.01, 100) > threshold_db(0.01, 10)


@pytest.mark.gotcha
def test_point_peak_width_of_gotcha(gotcha_files):
    """Rect spectrum of a GOTCHA degree: a point mover's g peak is 2.1 resolutions wide."""
    assert point_peak_width(read_gotcha(gotcha_files[:1])) == pytest.approx(2.1, abs=0.1)


# ------------------------------------------------------------------ real clutter
@pytest.mark.gotcha
@pytest.mark.slow
@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_no_false_mover_on_a_real_degree(gotcha_files, degree):
    """The parked-car GOTCHA scene has no mover: none declared on any single degree.

    The four together are test_analysis.test_real_stationary_scene_has_no_mover.
    """
    _, _, detection, fits = _movers_stages(read_gotcha(gotcha_files[degree : degree + 1]), "rpca")
    assert fits == [], [f.fit.range_speed_mps for f in fits]
    assert 5.0 < detection.threshold_db < 6.0


@pytest.mark.gotcha
@pytest.mark.slow
@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_injected_movers_found_when_their_peak_stands_8db(gotcha_files, degree):
    """Movers injected into a real degree at two strengths each.

    Every mover whose g(u) peak after separation stands 8 dB above its local floor is
    found, with a range speed within 0.05 m/s and a cross-range speed within 0.25 m/s of
    the truth (on its family), and nothing else is declared. (The same fit on all traces,
    no separation, was measured more accurate on one of these movers, 0.016 against
    0.119 m/s: RPCA keeps a distorted fraction of a mover in ``S``; the benchmark
    compares the two on every mover.)
    """
    clutter = read_gotcha(gotcha_files[degree : degree + 1])
    geom = clutter.geometry
    ref = float(np.median(np.abs(clutter.data).max(axis=1)))
    rng = np.random.default_rng(7100 + degree)
    strong = 0
    for att in (6.0, 12.0):
        movers = []
        for _ in range(2):
            u = rng.uniform(1.5, 10.0) * rng.choice([-1, 1])
            up = rng.uniform(1.0, 10.0) * rng.choice([-1, 1])
            movers.append(
                PointTarget(
                    position_m=rng.uniform(-20, 20, 2),
                    velocity_mps=ground_velocity(u, up, geom),
                    reflectivity=ref * 10 ** (-att / 20) * np.exp(2j * np.pi * rng.random()),
                )
            )
        data = inject(clutter, movers)
        sub, moving, _, fits = _movers_stages(data, "rpca")
        found = [f.fit for f in fits]
        assert len(found) <= len(movers)
        for m in movers:
            u = range_speed(m.velocity_mps, geom)
            stat = local_statistic(sub.with_data(moving), u)
            near = [f for f in found if abs(f.range_speed_mps - u) < 0.3]
            if stat >= 8.0:
                strong += 1
                assert near, (att, u, stat)
            if near:
                err = _family_errors(sub, near[0], m)
                assert abs(err[1]) <= 0.05 and abs(err[2]) <= 0.25, (att, u, err)
        # every declared mover is one of the injected ones
        for f in found:
            assert any(
                abs(f.range_speed_mps - range_speed(m.velocity_mps, geom)) < 0.3 for m in movers
            )
    assert strong >= 2  # the test is not vacuous


# ------------------------------------------------------------------ point clutter
@pytest.fixture(scope="module")
def clutter_draws():
    """30 seeded scenes of 15 point targets at 20 dB SNR with one mover (50 m image).

    Returns the errors (x m, u and u_perp m/s; on the truth's family member at the fit's
    cross range), the standard errors the analysis reported and the Cramér–Rao bound of
    the truth in the simulated white noise alone (the bound at the data's SNR), shape
    (30, 3) each.
    """
    base = simulate(random_scene(n_stationary=1, rng=0)).traces
    geom = base.geometry
    errs, reported, white = [], [], []
    for seed in range(7200, 7230):
        rng = np.random.default_rng(seed)
        u = rng.uniform(2.0, 8.0) * rng.choice([-1, 1])
        truth = PointTarget(
            position_m=rng.uniform(-15, 15, 2),
            velocity_mps=ground_velocity(u, rng.uniform(-8, 8), geom),
        )
        scene = random_scene(n_stationary=15, rng=rng)
        noisy = simulate(scene, snr_db=20.0, rng=rng).traces
        noise = noisy.data - simulate(scene).traces.data
        traces = inject(noisy, [truth])
        sub, _, _, fits = _movers_stages(traces, "combined", size_m=50.0)
        assert len(fits) == 1, (seed, [f.fit.range_speed_mps for f in fits])
        errs.append(_family_errors(sub, fits[0].fit, truth))
        b = fits[0].bound
        reported.append([b.range_position_m, b.range_speed_mps, b.cross_range_speed_mps])
        white.append(_white_noise_bound(sub, truth, float(np.mean(np.abs(noise) ** 2))))
    return np.array(errs), np.array(reported), np.array(white)


def _rms(a):
    return np.sqrt(np.mean(np.square(a), axis=0))


@pytest.mark.slow
def test_speeds_within_the_bound_in_point_clutter_at_20db(clutter_draws):
    """Range and cross-range speed: RMSE within 1.5 white-noise bounds, at most 1 in 30
    beyond 3 bounds (a wrong lobe is tens of bounds).

    Measured, with the refit on the data minus the stationary estimate made without the
    mover: RMSE / RMS bound 1.28 (range speed) and 1.30 (cross-range speed), one draw
    beyond 3 bounds in each; the fit on the separated traces alone had range speed at
    2.4 bounds (two draws beyond 3: 8.8 and 3.2). Range position is not bound-limited
    here: 2.06 bounds, six beyond 3.
    """
    errs, _, white = clutter_draws
    for k in (1, 2):
        assert _rms(errs[:, k]) <= 1.5 * _rms(white[:, k]), (k, _rms(errs[:, k]), white[:, k])
        assert np.sum(np.abs(errs[:, k]) > 3 * white[:, k]) <= 1, (k, errs[:, k] / white[:, k])


@pytest.mark.slow
def test_reported_standard_errors_cover_the_errors_in_point_clutter(clutter_draws):
    """The standard errors in results.json are not too small: RMSE within 1.5 of them.

    They use the interference the matched filter sees after the fit (white noise plus
    what is left of the clutter), so they exceed the white-noise bound. Measured: RMSE /
    RMS reported 1.09 (range position), 0.70 (range speed), 0.69 (cross-range speed);
    reported / white-noise bound, median 1.8.
    """
    errs, reported, white = clutter_draws
    assert np.all(_rms(errs) <= 1.5 * _rms(reported)), _rms(errs) / _rms(reported)
    assert np.all(reported >= white * 0.99)  # interference only adds to the noise


def test_matched_filter_and_model_agree():
    """The matched filter of a mover's own model is a n_pulses at its parameters."""
    traces = simulate(random_scene(n_stationary=1, rng=0)).traces
    geom = traces.geometry
    pos, vel, a = np.array([2.0, 1.0, 0.0]), ground_velocity(3.0, 5.0, geom), 0.3 - 0.4j
    data = point_model(traces, pos, vel, a)
    value = MatchedFilter(data, acquisition=traces.acquisition).responses(pos[None], vel[None])[0]
    assert value == pytest.approx(a * traces.n_pulses, rel=1e-9)


def _matched_filter_direct(traces, data, positions, velocities):
    """``I(theta)`` by the direct sum over the array of phasors ``exp(2i pi f dtau)``."""
    w = traces.radar.spectral_weights()
    weighted = traces.with_data(data).phase_history() * w[None, :]
    v3 = np.concatenate([velocities, np.zeros((len(velocities), 1))], axis=1)
    ref = np.linalg.norm(traces.positions_m - traces.reference_point_m, axis=1)
    where = positions[:, None, :] + traces.slow_times_s[None, :, None] * v3[:, None]
    rng = np.linalg.norm(traces.positions_m[None] - where, axis=2)
    cycles = (2.0 * (rng - ref[None]) / C)[:, :, None] * traces.frequencies_hz[None, None]
    cycles -= np.rint(cycles)
    return np.einsum("vjk,jk->v", np.exp(2j * np.pi * cycles), weighted) / np.sum(w**2)


def test_matched_filter_compiled_sums_match_the_direct_sum():
    """The compiled frequency sums give the direct phasor sum to 1e-12 of sum |P W|.

    Data: a mover in noise; 40 seeded parameter sets within 20 m and 10 m/s of it (on
    and off the peak). The rotation is re-seeded exactly every 32 bins, so the error
    stays at rounding level (measured ~1e-15).
    """
    traces = simulate(random_scene(n_stationary=1, rng=0)).traces
    geom = traces.geometry
    gen = np.random.default_rng(41)
    pos0, vel0 = np.array([2.0, 1.0, 0.0]), ground_velocity(3.0, 5.0, geom)
    noise = 0.1 * (gen.standard_normal(traces.shape) + 1j * gen.standard_normal(traces.shape))
    data = point_model(traces, pos0, vel0, 0.3 - 0.4j) + noise
    pos = pos0[None] + np.c_[gen.uniform(-20, 20, (40, 2)), np.zeros(40)]
    vel = vel0[None] + gen.uniform(-10, 10, (40, 2))
    got = MatchedFilter(data, acquisition=traces.acquisition).responses(pos, vel)
    want = _matched_filter_direct(traces, data, pos, vel)
    w = traces.radar.spectral_weights()
    scale = np.abs(traces.with_data(data).phase_history() * w).sum() / np.sum(w**2)
    assert np.max(np.abs(got - want)) <= 1e-12 * scale


def test_detection_needs_no_fixed_db_level():
    """A weak mover in noise is a candidate from 6.7 dB over the local floor; noise is not.

    Reflectivity 0.2 of a unit target in noise of 0.085 per sample (amplitude): its g
    peak stands 6.7 dB over the local floor (a fixed 15 dB threshold over the global
    median missed such movers); the threshold is 5.5 dB.
    """
    base = simulate(random_scene(n_stationary=1, rng=0)).traces
    geom = base.geometry
    rng = np.random.default_rng(7300)
    noise = 0.06 * (rng.standard_normal(base.shape) + 1j * rng.standard_normal(base.shape))
    alone = base.with_data(noise)
    assert detect_range_speeds(alone, min_speed_mps=0.55).range_speeds.n_movers == 0
    mover = PointTarget(
        position_m=[4.0, 0.0], velocity_mps=ground_velocity(6.0, 3.0, geom), reflectivity=0.2
    )
    det = detect_range_speeds(inject(alone, [mover]), min_speed_mps=0.55)
    assert det.range_speeds.n_movers == 1
    assert det.range_speeds.speeds_mps[0] == pytest.approx(6.0, abs=0.2)


def test_two_movers_with_one_range_speed_are_both_found():
    """Two movers with the same range speed, 3 range cells apart, share one ``g`` peak.

    The first is fitted and subtracted; the second then stands out at the same speed and
    is fitted too (a speed tried and accepted stays open). Each is found on its own
    family, within a range cell and 0.3 m/s of range speed, and nothing else is declared.
    """
    base = simulate(random_scene(n_stationary=1, rng=0)).traces
    geom = base.geometry
    cells = resolution(base)
    e_r = np.asarray(cells.range_direction)
    rng = np.random.default_rng(7400)
    noise = 0.01 * (rng.standard_normal(base.shape) + 1j * rng.standard_normal(base.shape))
    truths = [
        PointTarget(position_m=4.0 * e_r, velocity_mps=ground_velocity(5.0, 3.0, geom)),
        PointTarget(
            position_m=(4.0 + 3 * cells.ground_range_m) * e_r,
            velocity_mps=ground_velocity(5.0, -4.0, geom),
            reflectivity=0.8 * np.exp(1j),
        ),
    ]
    traces = inject(base.with_data(base.data + noise), truths)
    sub, _, candidates, movers = _movers_stages(traces, "combined")
    assert candidates.range_speeds.n_movers >= 1
    assert len(movers) == 2
    for truth in truths:
        errs = [np.abs(_family_errors(sub, m.fit, truth)) for m in movers]
        best = min(errs, key=lambda e: e[0] / cells.ground_range_m + e[1] / 0.3)
        assert best[0] <= cells.ground_range_m and best[1] <= 0.3, errs


@pytest.mark.parametrize("method", ["combined", "rpca"])
def test_two_movers_of_one_range_speed_at_two_ranges_are_both_found(method):
    """One ``g`` peak, two traces: the second mover is fitted on its own trace.

    Two movers 0.05 m/s apart in range speed (a fifth of a resolution) at ground ranges
    20 m apart, amplitudes 1 and 0.6, among 20 unit points at 20 dB SNR (seed 7310).
    Once the first is fitted and subtracted, the peak at their speed is on the first's
    remnant; the second stands on another trace at its own statistic over the
    threshold. Both are found within 0.3 m/s and a metre of range, and nothing else.
    """
    rng = np.random.default_rng(7310)
    sim = simulate(random_scene(n_stationary=20, rng=rng), snr_db=20.0, rng=rng)
    geom = sim.traces.geometry
    truth = [
        PointTarget(position_m=[8.0, 12.0], velocity_mps=ground_velocity(6.0, 3.0, geom)),
        PointTarget(
            position_m=[-12.0, -9.0],
            velocity_mps=ground_velocity(6.05, -4.0, geom),
            reflectivity=0.6,
        ),
    ]
    sub, _, _, movers = _movers_stages(inject(sim.traces, truth), method)
    e_r = resolution(sub).range_direction
    ref = sub.reference_point_m[:2]
    assert len(movers) == 2
    for t in truth:
        u = range_speed(t.velocity_mps, geom)
        x = float((t.position_m[:2] - ref) @ e_r)
        assert any(
            abs(m.fit.range_speed_mps - u) < 0.3
            and abs(float((m.fit.position_m[:2] - ref) @ e_r) - x) < 1.0
            for m in movers
        ), (u, x)
