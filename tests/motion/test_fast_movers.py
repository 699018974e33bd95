"""Fast movers far from the reference point stay on their main lobe, declared once.

Over a degree the likelihood of a point mover has local maxima a Doppler resolution
(``lambda / (2 T)``, 0.009 m/s on a GOTCHA degree) apart in range speed, each with its
own cross-range speed metres per second away. The global search aligns the traces on
the reference point; off it the line of sight's elevation changes how a ground velocity
projects on range, by ``u_r sin(eps) d eps`` (28 m/s at 40 m of ground range: five
Doppler resolutions), so local fits started at the search's range speed climbed to
another lobe. ``fit_point_mover`` now starts them at the motion on the fit's cross range
with the search point's range history and checks the choice against the profile.

The sweep: one mover 25-48 m from the reference point at range speeds of 10-28 m/s
(either sign) and cross-range speeds within +-10 m/s, 20 dB SNR, 1 and 2 degrees of the
default circular flight; alone (the fit functions on its traces, a 2-degree one
refined on the whole aperture as the pipeline does) or among 10 stationary points
(separation, detection and fit as ``analyze`` runs them; some draws through ``analyze``
itself). Criterion: every mover within 0.5 m/s in cross-range speed of the truth slid
along its family to the estimate's cross range (under the 0.74 m/s cross-range-speed
resolution of a degree, the issue's bound), and exactly one mover found in each scene.
Seeds 1000-1063; the method was developed on seeds 0-19.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.core import cross_range_speed, ground_velocity, range_speed
from sarmotion.motion import (
    central_sub_aperture,
    duplicate_fits,
    family_member,
    fit_point_mover,
    point_model,
    range_speed_resolution,
    refine_on_aperture,
)
from sarmotion.pipeline import AnalysisOptions, analyze, detect, estimate_movers, family_errors
from sarmotion.separation import SeparationOptions
from sarmotion.simulation import random_scene, simulate

CROSS_SPEED_TOL = 0.5  # m/s, under the cross-range-speed resolution of a degree (0.74)

pytestmark = pytest.mark.slow


def fast_mover_scene(seed: int, aperture_deg: float, n_stationary: int):
    """One fast mover 25-48 m from the reference point, 20 dB SNR (module notes)."""
    spec = {"kind": "circular", "aperture_deg": aperture_deg}
    rng = np.random.default_rng(seed)
    geom = simulate(random_scene(n_stationary=0, trajectory_spec=spec)).traces.geometry
    r, angle = rng.uniform(25.0, 48.0), rng.uniform(0.0, 2.0 * np.pi)
    ur = rng.choice([-1.0, 1.0]) * rng.uniform(10.0, 28.0)
    up = rng.uniform(-10.0, 10.0)
    position = r * np.array([np.cos(angle), np.sin(angle)])
    scene = random_scene(
        n_stationary=n_stationary,
        movers=[(position, ground_velocity(ur, up, geom))],
        extent_m=100.0,
        rng=seed,
        trajectory_spec=spec,
    )
    return simulate(scene, snr_db=20.0, rng=seed)


ALONE = [(1000 + k, 1.0) for k in range(24)] + [(1024 + k, 2.0) for k in range(16)]


@pytest.mark.parametrize(("seed", "aperture_deg"), ALONE)
def test_fit_of_a_fast_mover_alone_is_on_its_main_lobe(seed, aperture_deg):
    sim = fast_mover_scene(seed, aperture_deg, 0)
    tr, truth = sim.traces, sim.scene.moving[0]
    central = central_sub_aperture(tr, 1.0)
    sub = tr.select_pulses(central.start, central.stop)
    # the start as the g(u) detector gives it: within half a range-speed resolution
    offset = np.random.default_rng(seed).uniform(-0.5, 0.5) * range_speed_resolution(sub)
    start = range_speed(truth.velocity_mps, sub.geometry) + offset
    fit = fit_point_mover(sub, start)
    err = family_errors(sub, fit, truth)
    assert abs(err[2]) < CROSS_SPEED_TOL, (seed, err)
    assert not fit.ambiguous, (seed, fit.lobe_ratio)
    if central != slice(0, tr.n_pulses):
        whole = refine_on_aperture(tr, fit.position_m, fit.velocity_mps, central=central)
        err = family_errors(tr, whole, truth)
        assert abs(err[2]) < CROSS_SPEED_TOL, (seed, "whole aperture", err)


IN_CLUTTER = [(1040 + k, 1.0) for k in range(8)] + [(1048 + k, 2.0) for k in range(8)]


@pytest.mark.parametrize(("seed", "aperture_deg"), IN_CLUTTER)
def test_fast_mover_in_clutter_is_found_once_on_its_main_lobe(seed, aperture_deg):
    sim = fast_mover_scene(seed, aperture_deg, 10)
    truth = sim.scene.moving[0]
    options = AnalysisOptions(separation=SeparationOptions(method="rpca"), trajectory=False)
    det = detect(sim.traces, options)
    movers = estimate_movers(det).movers
    assert len(movers) == 1, (seed, [m.velocity_mps for m in movers])
    err = family_errors(det.sub, movers[0].fit, truth)
    assert abs(err[2]) < CROSS_SPEED_TOL, (seed, err)
    err = family_errors(det.traces, movers[0], truth)
    assert abs(err[2]) < CROSS_SPEED_TOL, (seed, "final", err)


THROUGH_ANALYZE = [(1056, 1.0, 10), (1057, 1.0, 0), (1058, 2.0, 10), (1059, 2.0, 0)]


@pytest.mark.parametrize(("seed", "aperture_deg", "n_stationary"), THROUGH_ANALYZE)
def test_analyze_declares_a_fast_mover_once_on_its_main_lobe(seed, aperture_deg, n_stationary):
    sim = fast_mover_scene(seed, aperture_deg, n_stationary)
    truth = sim.scene.moving[0]
    result = analyze(sim.traces, AnalysisOptions(trajectory=False))
    assert len(result.movers) == 1, (seed, [m.velocity_mps for m in result.movers])
    err = family_errors(sim.traces, result.movers[0], truth)
    assert abs(err[2]) < CROSS_SPEED_TOL, (seed, err)


def _fit_like(fit, position, velocity, geom, amplitude):
    """``fit`` moved to another motion (for the duplicate test)."""
    from dataclasses import replace

    return replace(
        fit,
        position_m=np.asarray(position, dtype=float),
        velocity_mps=np.asarray(velocity, dtype=float),
        range_speed_mps=range_speed(velocity, geom),
        cross_range_speed_mps=cross_range_speed(velocity, geom),
        amplitude=amplitude,
    )


def test_the_same_range_history_is_one_mover():
    """A family member 21 m away is the same mover; 0.5 m/s of range speed is not.

    Along the family the range history is the same (exact over a straight degree), so
    the weaker copy is dropped. A range-speed difference of 0.5 m/s moves the trace by
    0.44 m over the degree's half-length of 0.88 s, two slant-range cells: a second mover.
    """
    sim = fast_mover_scene(1060, 1.0, 0)
    tr, truth = sim.traces, sim.scene.moving[0]
    geom = tr.geometry
    fit = fit_point_mover(tr, range_speed(truth.velocity_mps, geom))
    p, v, _ = family_member(tr, fit.position_m, fit.velocity_mps, 21.0)
    copy = _fit_like(fit, p, v, geom, 0.3 * fit.amplitude)
    assert duplicate_fits(tr, [copy, fit]) == [0]
    other_v = ground_velocity(fit.range_speed_mps + 0.5, fit.cross_range_speed_mps, geom)
    other = _fit_like(fit, fit.position_m, other_v, geom, fit.amplitude)
    assert duplicate_fits(tr, [fit, other]) == []


def test_a_fit_at_a_strong_movers_range_speed_alias_is_its_echo():
    """Two range-speed periods ``lambda PRF / 2`` away, at the same position.

    The alias's model has the mover's phase at every pulse and parts from its envelope
    by a cell in ``(c / 2B) / (2 lambda PRF / 2)`` of slow time: the mover's echo reads
    a share ``rho`` of its amplitude there (the least-squares projection, computed here
    from the two models). A weaker fit at the alias under twice that is the mover's
    echo and is dropped; one above it, or the same amplitude 0.3 m/s off the alias (its
    phase turning against the mover's), is another mover.
    """
    sim = fast_mover_scene(1060, 1.0, 0)
    tr, truth = sim.traces, sim.scene.moving[0]
    geom = tr.geometry
    fit = fit_point_mover(tr, range_speed(truth.velocity_mps, geom))
    prf = 1.0 / float(np.median(np.diff(tr.slow_times_s)))
    period = 0.5 * tr.radar.wavelength_m * prf
    v_alias = ground_velocity(fit.range_speed_mps + 2 * period, fit.cross_range_speed_mps, geom)
    m = point_model(tr, fit.position_m, fit.velocity_mps, 1.0).ravel()
    m_alias = point_model(tr, fit.position_m, v_alias, 1.0).ravel()
    rho = abs(np.vdot(m_alias, m)) / np.vdot(m_alias, m_alias).real
    assert 0.01 < rho < 0.5  # the envelopes part over the aperture; the phases agree
    a = abs(fit.amplitude)
    weak = _fit_like(fit, fit.position_m, v_alias, geom, 1.5 * rho * a)
    assert duplicate_fits(tr, [fit, weak]) == [1]
    strong = _fit_like(fit, fit.position_m, v_alias, geom, 2.5 * rho * a)
    assert duplicate_fits(tr, [fit, strong]) == []
    v_off = ground_velocity(fit.range_speed_mps + 2 * period + 0.3, fit.cross_range_speed_mps, geom)
    off = _fit_like(fit, fit.position_m, v_off, geom, 1.5 * rho * a)
    assert duplicate_fits(tr, [fit, off]) == []


def test_two_near_equal_lobes_are_reported():
    """Two equal movers on one trace, cross-range speeds 4 m/s apart: the fit says so.

    The same position and range speed, cross-range speeds five resolutions apart: the
    likelihood of one point mover has two maxima of equal height, one at each.
    """
    sim = fast_mover_scene(1061, 1.0, 0)
    tr, truth = sim.traces, sim.scene.moving[0]
    geom = tr.geometry
    ur = range_speed(truth.velocity_mps, geom)
    up = cross_range_speed(truth.velocity_mps, geom)
    single = fit_point_mover(tr, ur)
    assert not single.ambiguous, single.lobe_ratio
    velocities = [truth.velocity_mps, ground_velocity(ur, up + 4.0, geom)]
    pair = random_scene(
        n_stationary=0,
        movers=[(truth.position_m[:2], v) for v in velocities],
        trajectory_spec=sim.scene.trajectory_spec,
    )
    both = simulate(pair, snr_db=20.0, rng=1061)
    fit = fit_point_mover(both.traces, ur)
    assert fit.ambiguous, fit.lobe_ratio
    # each maximum at one mover's cross-range speed (on its family at the fit's cross range)
    truths = sorted(
        fit.cross_range_speed_mps - family_errors(both.traces, fit, m)[2] for m in both.scene.moving
    )
    found = sorted([fit.cross_range_speed_mps, fit.other_cross_range_speed_mps])
    assert np.allclose(found, truths, atol=CROSS_SPEED_TOL), (found, truths)


@pytest.mark.parametrize("seed", [1062, 1063])
def test_the_local_fits_start_within_a_doppler_resolution(seed):
    """The start of the local fits is the truth's range history, to a Doppler resolution.

    The search point at the profile's maximum is a range history aligned on the
    reference point; ``_model_start`` gives the motion on the fit's cross range with
    that range history, whose range speed is the truth's (on its family) to within a
    Doppler resolution ``lambda / (2 T)``: inside the main lobe of the likelihood in
    range speed, from where the ascent stays on it.
    """
    from types import SimpleNamespace

    from sarmotion.core import C
    from sarmotion.motion.likelihood import _global_cross_search, _model_start

    sim = fast_mover_scene(seed, 1.0, 0)
    tr, truth = sim.traces, sim.scene.moving[0]
    geom = tr.geometry
    ur = range_speed(truth.velocity_mps, geom)
    search = _global_cross_search(tr, ur, np.arange(-12.0, 12.0, 0.37))
    i = int(np.argmax(search.values))
    pos, u_r, u_p = _model_start(tr, search.delay_s[i], ur + search.residual_mps[i], search.grid[i])
    start = SimpleNamespace(position_m=pos, velocity_mps=ground_velocity(u_r, u_p, geom))
    doppler = C / (2.0 * tr.radar.carrier_hz * (tr.slow_times_s[-1] - tr.slow_times_s[0]))
    err = family_errors(tr, start, truth)
    assert abs(err[1]) < doppler, (err, doppler)
