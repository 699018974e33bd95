"""A turn as a change of velocity between sub-apertures (sarmotion.tracking.turns).

The test on synthetic detections (velocities drawn with their covariances: the false-alarm
rate is what it states; a 3 deg/s turn is flagged), and on a simulated acquisition
through ``track``: a mover turning at 3 deg/s is flagged, a straight one is not.
"""

from functools import lru_cache

import numpy as np
import pytest

from sarmotion.pipeline import AnalysisOptions
from sarmotion.simulation import PointTarget, Scene, TurningTarget, load_scene, simulate
from sarmotion.tracking import Detection, TrackingOptions, track, turn_test
from sarmotion.tracking.turns import look_turn_test

# Detections of a GOTCHA degree every 1.76 s, sub-apertures not overlapping; velocity
# covariances of the order of a strong mover's bound: range speed 1e-3, cross-range
# speed 0.05 m/s (look along x). Family tangent: cross range y, 0.007 (m/s)/m of range
# speed per metre (the GOTCHA family, tests/tracking/test_track.py).
N, DT = 5, 1.76
COV = np.diag([1e-3**2, 0.05**2])
FAMILY = (np.tile([0.0, 1.0], (N, 1)), np.tile([-0.007, 0.0], (N, 1)))
PULSES = [(117 * k, 117 * (k + 1)) for k in range(N)]


def _detections(velocities, rng):
    """Positions on the uniform track of the first velocity, velocities with their noise."""
    t = DT * np.arange(N)
    v = np.asarray(velocities, dtype=np.float64)
    noisy = v + rng.multivariate_normal(np.zeros(2), COV, size=N)
    positions = np.cumsum(np.vstack([np.zeros(2), v[:-1] * DT]), axis=0)
    return t, positions, noisy


def test_uniform_movers_are_flagged_at_the_stated_rate():
    """2000 seeded uniform tracks at p = 0.05: the flagged fraction within 3 sigma of <= p."""
    rng = np.random.default_rng(52)
    p, trials = 0.05, 2000
    flagged = 0
    for _ in range(trials):
        v = np.tile(rng.uniform(-10.0, 10.0, 2), (N, 1))
        t, pos, vel = _detections(v, rng)
        res = turn_test(t, PULSES, pos, vel, [COV] * N, FAMILY, false_alarm=p)
        flagged += res.flagged
    assert res.n_pairs == N - 1 and res.threshold is not None
    assert flagged / trials <= p + 3.0 * np.sqrt(p * (1 - p) / trials)


def test_a_turn_of_three_degrees_per_second_is_flagged_with_its_rate():
    """Velocities rotating at 3 deg/s (7 m/s): flagged; the rate within 3 standard errors."""
    rng = np.random.default_rng(53)
    w = np.radians(3.0)
    t = DT * np.arange(N)
    v = 7.0 * np.column_stack([np.cos(0.3 + w * t), np.sin(0.3 + w * t)])
    _, pos, vel = _detections(v, rng)
    res = turn_test(t, PULSES, pos, vel, [COV] * N, FAMILY, false_alarm=0.01)
    assert res.flagged and res.statistic > res.threshold
    assert abs(res.apparent_turn_rate_deg_s - 3.0) <= 3.0 * res.apparent_turn_rate_std_deg_s


def test_overlapping_detections_are_not_paired():
    """Sub-apertures of 117 pulses starting every 58: detection 0 pairs with 3, 1 with 4."""
    pulses = [(58 * k, 58 * k + 117) for k in range(N)]
    t = 0.5 * DT * np.arange(N)
    v = np.tile([3.0, 4.0], (N, 1))
    pos = t[:, None] * v
    res = turn_test(t, pulses, pos, v, [COV] * N, FAMILY, false_alarm=0.01)
    assert res.n_pairs == 2 and not res.flagged and res.statistic < 1e-12
    with pytest.raises(ValueError, match="false_alarm"):
        turn_test(t, pulses, pos, v, [COV] * N, FAMILY, false_alarm=0.0)


@pytest.mark.slow
def test_track_flags_a_turning_mover_and_not_a_straight_one():
    """Four GOTCHA degrees (4 sub-apertures of a degree, no overlap), white noise.

    A mover turning at 3 deg/s at 7.2 m/s and a straight one at 5.8 m/s, both within 15 m
    of the scene centre: one track each; the turning one flagged, the straight one not.
    """
    sc = load_scene("scene1")
    turning = TurningTarget(position_m=[-6.0, 8.0], velocity_mps=[6.0, -4.0], turn_rate_deg_s=3.0)
    straight = PointTarget(position_m=[8.0, -10.0], velocity_mps=[-3.0, -5.0])
    scene = Scene(
        name="turn",
        targets=(turning, straight),
        radar=sc.radar,
        trajectory_spec={**sc.trajectory_spec, "aperture_deg": 4.0},
    )
    traces = simulate(scene, snr_db=0.0, rng=54).traces
    options = TrackingOptions(
        overlap=0.0, analysis=AnalysisOptions(trajectory=False, image_size_m=40.0)
    )
    result = track(traces, options, n_workers=0)
    assert len(result.tracks) == 2
    by_speed = sorted(result.tracks, key=lambda trk: trk.states[0].range_speed_mps)
    straight_track, turning_track = by_speed  # range speeds about -3 and +6 m/s
    assert turning_track.turn is not None and turning_track.turn.flagged
    assert straight_track.turn is not None and not straight_track.turn.flagged


# --- through the looks: uniform motion against a constant acceleration (look_turn_test)


@lru_cache(maxsize=4)
def _antennas(aperture_deg: float, overlap: float):
    """Sub-apertures of a degree of GOTCHA's circle (30 pulses per degree): their antennas."""
    from sarmotion.tracking.sub_apertures import sub_aperture_slices, sub_aperture_time_s
    from sarmotion.tracking.wide_aspect import antenna_state

    sc = load_scene("scene1")
    traces = simulate(
        Scene(
            name="pass",
            targets=(),
            radar=sc.radar,
            trajectory_spec={
                "kind": "circular",
                "aperture_deg": aperture_deg,
                "pulses_per_deg": 30,
            },
        )  # fmt: skip
    ).traces
    slices = sub_aperture_slices(traces, 1.0, overlap)
    return tuple(
        (antenna_state(traces, sl, sub_aperture_time_s(traces, sl)), (sl.start, sl.stop))
        for sl in slices
    )


# Errors of a look's range (m), range rate (m/s) and range acceleration (m/s^2) and the
# bounds the detections give them, 5 times smaller (the clutter residue of real passes:
# the fit's a posteriori factors must find it).
LOOK_STD = np.array([5e-3, 2e-5, 1e-3])
LOOK_BOUND = LOOK_STD / 5.0


def _turn_looks(aperture_deg, overlap, speed, heading, rate_deg_s, rng):
    """Look measurements of a mover at (3, -4) m turning at ``rate_deg_s`` (0: uniform).

    The range histories of the true path about each sub-aperture's centre, errors of
    ``LOOK_STD`` correlated as overlapping windows' are (each window's error the
    normalised sum of the independent errors of the steps it spans), bounds
    ``LOOK_BOUND``; each detection is the true state (a member of its family).
    """
    from sarmotion.tracking.wide_aspect import LookMeasurement, range_history

    antennas = _antennas(aperture_deg, overlap)
    span = max(1, round(1.0 / (1.0 - overlap)))
    steps = rng.standard_normal((len(antennas) + span, 3))
    w = np.radians(rate_deg_s)
    looks, pulses = [], []
    for k, (ant, pul) in enumerate(antennas):
        t = ant.time_s
        th = heading + w * t
        u = speed * np.array([np.cos(th), np.sin(th)])
        if w == 0.0:
            p, acc = np.array([3.0, -4.0]) + t * u, np.zeros(2)
        else:
            p = np.array([3.0, -4.0]) + speed / w * np.array(
                [np.sin(th) - np.sin(heading), np.cos(heading) - np.cos(th)]
            )
            acc = w * speed * np.array([-np.sin(th), np.cos(th)])
        z = range_history(p, u, ant)
        d = np.r_[p, 0.0] - ant.position_m
        z[2] += float(np.r_[acc, 0.0] @ d) / float(np.linalg.norm(d))
        z += steps[k : k + span].sum(axis=0) / np.sqrt(span) * LOOK_STD
        det = Detection(
            position_m=p, velocity_mps=u, range_speed_mps=0.0, cross_range_speed_mps=0.0,
            family_position_per_m=np.array([0.0, 1.0]), family_velocity_per_m=np.zeros(2),
            peak_db=0.0, traces=None,
        )  # fmt: skip
        cov = np.diag(LOOK_BOUND**2) / (1.0 - overlap)
        looks.append(
            LookMeasurement(sub_aperture=k, antenna=ant, z=z, covariance=cov, detection=det)
        )
        pulses.append(pul)
    return looks, pulses


def test_looks_flag_a_three_degree_per_second_turn_and_not_a_uniform_mover():
    """10 degrees, overlapping halves: a 3 deg/s turn at 5 m/s flagged, the same mover
    straight not, with errors 5 times their bounds (the pairs' test flags both)."""
    rng = np.random.default_rng(61)
    for rate, expected in ((0.0, False), (3.0, True)):
        looks, pulses = _turn_looks(10.0, 0.5, 5.0, 0.7, rate, rng)
        res = look_turn_test(looks, pulses, false_alarm=0.01, prior_std_m=30.0)
        assert res is not None and res.model == "looks"
        assert res.n_looks == 10  # every other window: those that share no pulse
        assert res.flagged is expected, (rate, res.statistic, res.threshold)
    with pytest.raises(ValueError, match="false_alarm"):
        look_turn_test(looks, pulses, false_alarm=1.0, prior_std_m=30.0)
    assert look_turn_test(looks[:3], pulses[:3], false_alarm=0.01, prior_std_m=30.0) is None


@pytest.mark.slow
@pytest.mark.parametrize(("aperture_deg", "overlap"), [(4.0, 0.0), (10.0, 0.5), (30.0, 0.5)])
def test_looks_hold_their_false_alarm_rate_on_uniform_movers(aperture_deg, overlap):
    """100 seeded uniform movers (1-8 m/s) at p = 0.05: flagged within 3 sigma of p;
    50 turning at 3 deg/s: at least 90 % flagged at 10 and 30 degrees (p = 0.01)."""
    rng = np.random.default_rng(62 + int(aperture_deg))
    p, trials = 0.05, 100
    flagged = 0
    for _ in range(trials):
        looks, pulses = _turn_looks(
            aperture_deg, overlap, rng.uniform(1.0, 8.0), rng.uniform(0, 2 * np.pi), 0.0, rng
        )
        flagged += look_turn_test(looks, pulses, false_alarm=p, prior_std_m=30.0).flagged
    assert flagged / trials <= p + 3.0 * np.sqrt(p * (1 - p) / trials)
    if aperture_deg >= 10.0:
        turns = 0
        for _ in range(50):
            looks, pulses = _turn_looks(
                aperture_deg, overlap, rng.uniform(1.0, 8.0), rng.uniform(0, 2 * np.pi),
                3.0 * rng.choice([-1.0, 1.0]), rng,
            )  # fmt: skip
            turns += look_turn_test(looks, pulses, false_alarm=0.01, prior_std_m=30.0).flagged
        assert turns >= 45
