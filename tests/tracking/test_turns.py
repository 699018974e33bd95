"""A turn as a change of velocity between sub-apertures (sarmotion.tracking.turns).

The test on synthetic detections (velocities drawn with their covariances: the false-alarm
rate is what it states; a 3 deg/s turn is flagged), and on a simulated acquisition
through ``track``: a mover turning at 3 deg/s is flagged, a straight one is not.
"""

import numpy as np
import pytest

from sarmotion.pipeline import AnalysisOptions
from sarmotion.simulation import PointTarget, Scene, TurningTarget, load_scene, simulate
from sarmotion.tracking import TrackingOptions, track, turn_test

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
