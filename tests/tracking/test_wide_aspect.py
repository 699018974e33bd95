"""A mover's position fixed by the turning look (sarmotion.tracking.wide_aspect).

Detections are made from the geometry: over each sub-aperture of a degree of a circular
GOTCHA pass, the member of the mover's cross-range family at the reference cross range
(what the single-degree estimator reports, :mod:`sarmotion.motion.aperture`), moved by
a draw of its bound's errors in ground-range position, range speed and cross-range speed.
The fit must fix the position over 30 degrees, within 4 of its own standard deviations
of the truth, and must not over 4 degrees; detections of one mover cut into pieces are
one track, those of two movers are not. The slow test runs the whole chain on a
simulated pass.
"""

from functools import lru_cache

import numpy as np
import pytest

from circular_passes import empty_pass
from sarmotion.core import ground_velocity
from sarmotion.imaging import ImageGrid, resolution
from sarmotion.motion.aperture import family_direction, family_member
from sarmotion.motion.speed_resolution import (
    cross_range_speed_resolution,
    range_speed_resolution,
)
from sarmotion.pipeline import AnalysisOptions
from sarmotion.simulation import PointTarget, Scene, load_scene, simulate
from sarmotion.tracking import Detection, SubApertureDetections, TrackingOptions, track
from sarmotion.tracking.sub_apertures import sub_aperture_slices, sub_aperture_time_s
from sarmotion.tracking.wide_aspect import (
    PRIOR_SHARE,
    LookMeasurement,
    antenna_state,
    coherence_acceleration_mps2,
    fit_track,
    join_tracks,
    look_measurement,
    range_history,
)

# Standard deviations of a detection's ground-range position (m), range speed and
# cross-range speed (m/s): the order of the errors measured on a simulated 10 degree pass
# at 20 dB (module notes of sarmotion.tracking.wide_aspect).
BOUND_STD = np.array([5e-3, 1e-4, 0.05])
PRIOR_STD_M = 30.0  # half a 60 m scene
GATE = 0.999


@lru_cache(maxsize=8)
def _members(aperture_deg: float, position: tuple, velocity: tuple):
    """Each sub-aperture's member of the family at the reference cross range, noise-free."""
    traces = empty_pass(aperture_deg)
    p0, u = np.array(position), np.array(velocity)
    out = []
    for sl in sub_aperture_slices(traces, 1.0, 0.0):
        sub_traces = traces.select_pulses(sl.start, sl.stop)
        t_c = sub_aperture_time_s(traces, sl)
        cells = resolution(sub_traces)
        p_c = p0 + t_c * u
        offset = -float(p_c @ cells.cross_range_direction)
        p, v, _ = family_member(sub_traces, np.r_[p_c, 0.0], u, offset)
        a, b = family_direction(sub_traces, p, v)
        out.append((sl, t_c, sub_traces, cells, p[:2], v, a, b))
    return out


def _looks(aperture_deg: float, mover: PointTarget, rng, *, index_offset: int = 0, std=BOUND_STD):
    """One detection per sub-aperture of a degree (module notes) as a look measurement.

    ``std``: the standard deviations of its errors and bound (default ``BOUND_STD``).
    """
    traces = empty_pass(aperture_deg)
    members = _members(
        aperture_deg, tuple(np.asarray(mover.position_m)[:2]), tuple(mover.velocity_mps)
    )
    out = []
    for k, (sl, t_c, sub_traces, cells, p, v, a, b) in enumerate(members):
        geom = sub_traces.geometry
        e = rng.standard_normal(3) * std
        b_r, b_p = ground_velocity(1.0, 0.0, geom), ground_velocity(0.0, 1.0, geom)
        p = p + e[0] * cells.range_direction
        v = v + e[1] * b_r + e[2] * b_p
        det = Detection(
            position_m=p,
            velocity_mps=v,
            range_speed_mps=float(v @ geom.m_o[:2]),
            cross_range_speed_mps=float(v @ (geom.tangent @ geom.projector)[:2]),
            family_position_per_m=a,
            family_velocity_per_m=b,
            peak_db=0.0,
            traces=None,
            bound_cov=np.diag(np.asarray(std) ** 2),
        )
        sub = SubApertureDetections(
            index=k + index_offset,
            pulses=sl,
            time_s=t_c,
            look_direction=np.asarray(geom.m_o, dtype=np.float64),
            range_direction=np.asarray(cells.range_direction, dtype=np.float64),
            cross_range_direction=np.asarray(cells.cross_range_direction, dtype=np.float64),
            range_cell_m=float(cells.ground_range_m),
            cross_range_cell_m=float(cells.cross_range_m),
            range_speed_resolution_mps=float(range_speed_resolution(sub_traces)),
            cross_range_speed_resolution_mps=float(cross_range_speed_resolution(sub_traces)),
            cross_range_speed_row=(geom.tangent @ geom.projector)[:2].copy(),
            detections=(det,),
            stationary_db=None,
            grid=ImageGrid(x_m=np.linspace(-30, 30, 3), y_m=np.linspace(-30, 30, 3)),
            seconds=0.0,
        )
        out.append(look_measurement(sub, det, antenna_state(traces, sl, t_c)))
    return out


MOVER = PointTarget(position_m=[6.0, -9.0], velocity_mps=[0.4, 0.3])


def test_range_history_is_the_range_and_its_derivatives():
    """R, R', R'' against finite differences of the exact range over a sub-aperture."""
    traces = empty_pass(2.0)
    sl = slice(20, 50)
    t_c = sub_aperture_time_s(traces, sl)
    ant = antenna_state(traces, sl, t_c)
    p, u = np.array([6.0, -9.0]), np.array([4.0, 3.0])
    z = range_history(p, u, ant)
    s = traces.slow_times_s[sl] - t_c
    r = np.linalg.norm(traces.positions_m[sl] - np.c_[p + np.outer(s, u), np.zeros(len(s))], axis=1)
    h = float(np.max(np.abs(s)))
    c = np.polyfit(s / h, r, 6)[::-1]  # the exact range's derivatives at s_c
    assert abs(z[0] - c[0]) < 1e-8  # m
    assert abs(z[1] - c[1] / h) < 1e-8  # m/s
    assert abs(z[2] - 2.0 * c[2] / h**2) < 1e-9  # m/s^2: 1e-4 of the bound in BOUND_STD


def test_a_family_member_measures_the_same_range_history():
    """The measurement is a property of the range history, not of the member chosen."""
    traces = empty_pass(3.0)
    looks = _looks(3.0, MOVER, np.random.default_rng(0))
    m = looks[1]
    sl = sub_aperture_slices(traces, 1.0, 0.0)[1]
    det = m.detection
    for offset in (-20.0, 10.0):
        p, v, _ = family_member(
            traces.select_pulses(sl.start, sl.stop), np.r_[det.position_m, 0.0],
            det.velocity_mps, offset,
        )  # fmt: skip
        shifted = range_history(p[:2], v, m.antenna)
        sd = np.sqrt(np.diag(m.covariance))
        assert np.all(np.abs(shifted - m.z) < 0.1 * sd)


@pytest.mark.parametrize("seed", [1, 2])
def test_thirty_degrees_fix_the_position(seed):
    """30 degrees: fixed, and the truth within 4 of the fit's own standard deviations."""
    looks = _looks(30.0, MOVER, np.random.default_rng(seed))
    fit = fit_track(looks, prior_std_m=PRIOR_STD_M)
    x, cov = fit.at(0.0)
    e = x[:2] - MOVER.position_m[:2]
    assert fit.fixed
    assert fit.position_std_at(0.0) <= np.sqrt(PRIOR_SHARE) * PRIOR_STD_M
    assert np.sqrt(e @ np.linalg.solve(cov[:2, :2], e)) <= 4.0
    ev = x[2:] - MOVER.velocity_mps
    assert np.sqrt(ev @ np.linalg.solve(cov[2:, 2:], ev)) <= 4.0


def test_four_degrees_leave_the_family():
    """4 degrees: not fixed; the least-known direction is the detections' family."""
    looks = _looks(4.0, MOVER, np.random.default_rng(3))
    fit = fit_track(looks, prior_std_m=PRIOR_STD_M)
    assert not fit.fixed
    assert fit.position_std_m > np.sqrt(PRIOR_SHARE) * PRIOR_STD_M
    a = looks[len(looks) // 2].detection.family_position_per_m
    cosine = abs(fit.family_position_per_m @ a) / np.linalg.norm(a)
    assert cosine > 0.99


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_range_accelerations_alone_do_not_fix_the_position(seed):
    """4 degrees, cross-range speeds to 5e-4 m/s: a family, its spread the ranges' and rates'.

    Such range accelerations would make the full fit's standard deviation 1.3-2.4 m
    (module notes); the ranges and range rates leave the position on the family. The
    same detections over 30 degrees fix it, within 4 of its standard deviations.
    """
    std = np.array([5e-3, 1e-4, 5e-4])
    mover = PointTarget(position_m=[-8.0, 5.0], velocity_mps=[3.0, -4.0])
    looks = _looks(4.0, mover, np.random.default_rng(seed), std=std)
    fit = fit_track(looks, prior_std_m=PRIOR_STD_M)
    assert not fit.fixed
    assert fit.position_std_m > 0.5 * PRIOR_STD_M  # the prior's, not a point's
    a = looks[len(looks) // 2].detection.family_position_per_m
    assert abs(fit.family_position_per_m @ a) / np.linalg.norm(a) > 0.99
    wide = fit_track(_looks(30.0, mover, np.random.default_rng(seed), std=std),
                     prior_std_m=PRIOR_STD_M)  # fmt: skip
    x, cov = wide.at(0.0)
    e = x[:2] - mover.position_m[:2]
    assert wide.fixed and np.sqrt(e @ np.linalg.solve(cov[:2, :2], e)) <= 4.0


def test_one_mover_cut_in_pieces_is_one_track_two_movers_are_two():
    """20 degrees of one mover in three pieces join; a second mover's piece does not."""
    rng = np.random.default_rng(4)
    looks = _looks(20.0, MOVER, rng)
    pieces = [looks[:7], looks[7:13], looks[13:]]
    assert join_tracks(pieces, prior_std_m=PRIOR_STD_M, gate_probability=GATE) == [[0, 1, 2]]
    other = PointTarget(position_m=[-4.0, 7.0], velocity_mps=[0.3, -0.4])
    others = _looks(20.0, other, rng)[7:13]
    groups = join_tracks(
        [looks[:7], others, looks[13:]], prior_std_m=PRIOR_STD_M, gate_probability=GATE
    )
    assert sorted(groups) == [[0, 2], [1]]


# Errors of the order of the detections' Cramér-Rao bounds at 20 dB (ground range,
# range speed, cross-range speed): the looks alone then claim a point even over 4 degrees.
SMALL_STD = np.array([3e-4, 1e-5, 5e-4])


def _accelerating_looks(aperture_deg, p0, u0, acc, seed, std):
    """Looks of a mover at a constant ground acceleration ``acc`` (m/s^2) through ``s = 0``.

    Each look's ``z`` is the accelerating mover's range history at its centre time (its
    acceleration's range component in ``R''``) plus the error that :func:`_looks` draws.
    """
    p0, u0, acc = (np.asarray(v, dtype=float) for v in (p0, u0, acc))
    mover = PointTarget(position_m=list(p0), velocity_mps=list(u0))
    out = []
    for m in _looks(aperture_deg, mover, np.random.default_rng(seed), std=std):
        t = m.time_s
        error = m.z - range_history(p0 + t * u0, u0, m.antenna)
        p, v = p0 + t * u0 + 0.5 * t**2 * acc, u0 + t * acc
        z = range_history(p, v, m.antenna)
        z[2] += float((np.r_[p, 0.0] - m.antenna.position_m)[:2] @ acc) / z[0]
        out.append(
            LookMeasurement(
                sub_aperture=m.sub_aperture, antenna=m.antenna, z=z + error,
                covariance=m.covariance, detection=m.detection,
            )
        )  # fmt: skip
    return out


def _mahalanobis(fit, truth):
    x, cov = fit.at(0.0)
    e = x[:2] - np.asarray(truth)[:2]
    return float(np.sqrt(e @ np.linalg.solve(cov[:2, :2], e)))


def test_the_coherence_margin_is_an_eighth_of_a_wavelength_over_the_track():
    """``a_c T^2 / 8 = lambda / 8``, ``T`` the span of the looks' centre times; 0 without."""
    looks = _looks(10.0, MOVER, np.random.default_rng(0))
    lam = float(empty_pass(10.0).radar.wavelength_m)
    span = looks[-1].time_s - looks[0].time_s
    a_c = coherence_acceleration_mps2(looks, lam)
    assert a_c * span**2 / 8.0 == pytest.approx(lam / 8.0, rel=1e-12)
    assert coherence_acceleration_mps2(looks, None) == 0.0
    assert coherence_acceleration_mps2(looks[:1], lam) == 0.0
    fit = fit_track(looks, prior_std_m=PRIOR_STD_M, wavelength_m=lam)
    assert fit.acceleration_std_mps2 == pytest.approx(a_c)
    with pytest.raises(ValueError, match="wavelength_m"):
        coherence_acceleration_mps2(looks, -1.0)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_four_degrees_are_a_family_however_small_the_errors(seed):
    """4 degrees, errors at the bounds: with the coherence margin the looks leave a family.

    The mover accelerating by the margin moves the uniform fit's point 11-13 m along
    the family: a point over 4 degrees rests on nothing a vehicle's motion holds to.
    """
    lam = float(empty_pass(4.0).radar.wavelength_m)
    looks = _looks(4.0, PointTarget(position_m=[6.0, -9.0], velocity_mps=[3.0, -4.0]),
                   np.random.default_rng(seed), std=SMALL_STD)  # fmt: skip
    fit = fit_track(looks, prior_std_m=PRIOR_STD_M, wavelength_m=lam)
    assert not fit.fixed
    assert fit.position_std_m > np.sqrt(PRIOR_SHARE) * PRIOR_STD_M
    a = looks[len(looks) // 2].detection.family_position_per_m
    assert abs(fit.family_position_per_m @ a) / np.linalg.norm(a) > 0.99


@pytest.mark.parametrize(("aperture_deg", "speed_scale"), [(10.0, 1.0), (30.0, 0.25)])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_coherence_margin_covers_a_mover_accelerating_by_it(aperture_deg, speed_scale, seed):
    """A mover accelerating by ``a_c``: the uniform fit misses it, the margin covers it.

    The fixed position's error is within 3 of the fit's standard deviations with the
    margin; without it, beyond 4 (measured 4.7-11): the test can fail both ways.
    """
    lam = float(empty_pass(aperture_deg).radar.wavelength_m)
    p0, u0 = np.array([6.0, -9.0]), speed_scale * np.array([3.0, -4.0])
    plain = _looks(aperture_deg, PointTarget(position_m=list(p0), velocity_mps=list(u0)),
                   np.random.default_rng(seed), std=SMALL_STD)  # fmt: skip
    acc = coherence_acceleration_mps2(plain, lam) * np.array([0.6, 0.8])
    looks = _accelerating_looks(aperture_deg, p0, u0, acc, seed, SMALL_STD)
    uniform = fit_track(looks, prior_std_m=PRIOR_STD_M)
    margin = fit_track(looks, prior_std_m=PRIOR_STD_M, wavelength_m=lam)
    assert uniform.fixed and margin.fixed
    assert _mahalanobis(uniform, p0) > 4.0
    assert _mahalanobis(margin, p0) <= 3.0


@pytest.mark.slow
def test_one_mover_one_track_on_a_simulated_pass():
    """10 degrees of GOTCHA's circle, one mover at 2.5 m/s among 6 points, 20 dB: one track.

    Its fit fixes the position at the pass's centre, within 4 of its own standard
    deviations of the truth (measured: 0.8 m off, a standard deviation of 1.5 m, where
    the track's filter is 22 m off along the family); the fixed track also gets its
    turn rate in the ground frame and its focused fit.
    """
    sc = load_scene("scene1")
    rng = np.random.default_rng(3)
    clutter = [PointTarget(position_m=rng.uniform(-25, 25, 2)) for _ in range(6)]
    mover = PointTarget(position_m=[4.0, -6.0], velocity_mps=[1.5, 2.0])
    scene = Scene(
        name="wide",
        targets=(*clutter, mover),
        radar=sc.radar,
        trajectory_spec={**sc.trajectory_spec, "aperture_deg": 10.0},
    )
    traces = simulate(scene, snr_db=20.0, rng=1).traces
    opts = TrackingOptions(
        overlap=0.0, analysis=AnalysisOptions(trajectory=False, image_size_m=60.0)
    )
    result = track(traces, opts, n_workers=0)
    assert len(result.tracks) == 1
    trk = result.tracks[0]
    fit = trk.fit
    assert fit is not None and fit.fixed
    assert fit.acceleration_std_mps2 > 0.0  # the coherence margin
    x, cov = fit.at(0.0)
    e = x[:2] - mover.position_m[:2]
    assert np.sqrt(e @ np.linalg.solve(cov[:2, :2], e)) <= 4.0
    # the position fixed: the ground-frame turn rate (a uniform mover: 0 within its
    # interval) and the track focused over its pulses, within 4 of its deviations
    assert trk.turn is not None and trk.turn.turn_rate is not None
    lo, hi = trk.turn.turn_rate.interval_deg_s
    assert lo <= 0.0 <= hi
    focused = trk.coherent
    assert focused is not None and focused.coherent
    assert np.isfinite(focused.error_factor)
    xc, cov_c = focused.at(0.0)
    ec = xc[:2] - mover.position_m[:2]
    assert np.sqrt(ec @ np.linalg.solve(cov_c[:2, :2], ec)) <= 4.0


@pytest.mark.parametrize(("aperture_deg", "fixed_expected"), [(30.0, True), (4.0, False)])
def test_the_fit_in_the_tracks_document_and_on_the_console(aperture_deg, fixed_expected):
    """The document's ``fit`` validates against the shipped schema and says fixed or family."""
    import jsonschema

    from sarmotion.documents.schema import load_schema
    from sarmotion.documents.tracks import _fit
    from sarmotion.report.tracks import fit_line

    looks = _looks(aperture_deg, MOVER, np.random.default_rng(5))
    fit = fit_track(looks, prior_std_m=PRIOR_STD_M)
    entry = _fit(fit)
    schema = load_schema("sarmotion.tracks/1")["properties"]["tracks"]["items"]["properties"]["fit"]
    jsonschema.validate(entry, schema)
    assert entry["fixed"] is fixed_expected
    np.testing.assert_allclose(entry["position_m"], fit.state[:2])
    line = fit_line(entry)
    assert line.startswith("position fixed by" if fixed_expected else "position not fixed by")
    assert _fit(None) is None
