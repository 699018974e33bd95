"""A mover's turn rate in the ground frame through its looks (sarmotion.tracking.turn_rate).

Each look's measurement is made from the exact range of a mover turning at a constant
rate: the derivatives of a polynomial fitted to its range over the sub-aperture's pulses
(independent of the model's closed form, ``circular_passes.exact_looks``), plus white
errors of the stated standard deviations. Over 30 degrees a 3 deg/s turn must be fixed,
its interval covering the truth; over 10 degrees the interval must cover it, fixed or not.
"""

from functools import partial

import numpy as np
import pytest

from circular_passes import empty_pass, exact_history, exact_looks, turn_motion
from sarmotion.tracking.sub_apertures import sub_aperture_slices, sub_aperture_time_s
from sarmotion.tracking.turn_rate import turn_histories, turn_rate
from sarmotion.tracking.wide_aspect import antenna_state, range_history

# Standard deviations of R (m), R' (m/s) and R'' (m/s^2): the order of the analysis's
# errors on a simulated 10 degree pass at 20 dB (sarmotion.tracking.wide_aspect notes).
STD = np.array([5e-3, 2e-5, 1e-3])
PRIOR_STD_M = 30.0


def _looks(aperture_deg, p0, speed, heading, rate_deg_s, rng):
    """One look per sub-aperture of a degree of a constant-rate turn (module notes)."""
    motion = partial(turn_motion, p0, speed, heading, rate_deg_s)
    return exact_looks(empty_pass(aperture_deg), motion, STD, rng)


@pytest.mark.parametrize("rate_deg_s", [-3.0, 0.0, 5.0])
def test_turn_histories_are_the_exact_ranges_derivatives(rate_deg_s):
    """The closed form against the exact range's fitted derivatives; w = 0 is uniform."""
    traces = empty_pass(4.0)
    sl = sub_aperture_slices(traces, 1.0, 0.0)[2]
    t_c = sub_aperture_time_s(traces, sl)
    p0, speed, heading = np.array([6.0, -9.0]), 5.0, 0.7
    t0 = 0.3  # the reference time of the state, s
    p, u = turn_motion(p0, speed, heading, rate_deg_s, np.array([t0]))
    ant = antenna_state(traces, sl, t_c)
    antenna = (ant.position_m[None], ant.velocity_mps[None], ant.acceleration_mps2[None])
    got = turn_histories(np.r_[p[0], u[0]], np.radians(rate_deg_s), np.array([t_c - t0]), antenna)
    want = exact_history(traces, sl, t_c, partial(turn_motion, p0, speed, heading, rate_deg_s))
    for k, tol in enumerate((1e-7, 1e-8, 1e-7)):  # m, m/s, m/s^2
        assert abs(got[0, k] - want[k]) < tol, (k, got[0, k] - want[k])
    if rate_deg_s == 0.0:
        pc, _ = turn_motion(p0, speed, heading, 0.0, np.array([t_c]))
        np.testing.assert_allclose(got[0], range_history(pc[0], u[0], ant), rtol=1e-12)


@pytest.mark.parametrize(("rate_deg_s", "seed"), [(3.0, 0), (-3.0, 1), (0.0, 2)])
def test_thirty_degrees_fix_the_turn_rate(rate_deg_s, seed):
    """30 degrees: the rate fixed, its interval covering the truth and narrower than 0.1."""
    rng = np.random.default_rng(seed)
    heading = rng.uniform(0.0, 2.0 * np.pi)
    looks = _looks(30.0, np.array([4.0, -6.0]), 5.0, heading, rate_deg_s, rng)
    found = turn_rate(looks, prior_std_m=PRIOR_STD_M)
    assert found is not None and found.fixed
    lo, hi = found.interval_deg_s
    assert lo <= rate_deg_s <= hi
    assert hi - lo < 0.1
    assert lo <= found.rate_deg_s <= hi


@pytest.mark.parametrize("seed", [3, 4, 5, 6])
def test_ten_degrees_cover_the_turn_rate_fixed_or_not(seed):
    """10 degrees, 3 deg/s either sense: the interval (a hull when ambiguous) covers it."""
    rng = np.random.default_rng(seed)
    rate = 3.0 * rng.choice([-1.0, 1.0])
    heading = rng.uniform(0.0, 2.0 * np.pi)
    looks = _looks(10.0, np.array([-5.0, 8.0]), rng.uniform(2.0, 7.0), heading, rate, rng)
    found = turn_rate(looks, prior_std_m=PRIOR_STD_M)
    assert found is not None
    lo, hi = found.interval_deg_s
    assert lo <= rate <= hi
    assert not found.fixed or hi - lo < 1.0


def test_too_few_looks_give_no_rate():
    """Two looks leave ``3 n - 5 < 4`` degrees of freedom: no rate."""
    looks = _looks(4.0, np.array([0.0, 0.0]), 5.0, 0.0, 0.0, np.random.default_rng(0))
    assert turn_rate(looks[:2], prior_std_m=PRIOR_STD_M) is None


def test_the_turn_rate_in_the_tracks_document_and_in_words():
    """``turn_rate`` validates against the shipped schema; the words say fixed or not."""
    import jsonschema

    from sarmotion.documents.schema import load_schema
    from sarmotion.documents.tracks import _turn_rate
    from sarmotion.report.tracks import ground_rate_text
    from sarmotion.tracking import TurnRate

    schema = load_schema("sarmotion.tracks/1")["properties"]["tracks"]["items"]
    turn_schema = schema["properties"]["turn"]["properties"]["turn_rate"]
    for fixed in (True, False):
        rate = TurnRate(rate_deg_s=2.9, interval_deg_s=(2.7, 3.1) if fixed else (-1.8, 3.1),
                        fixed=fixed, confidence=0.95, n_looks=10)  # fmt: skip
        entry = _turn_rate(rate)
        jsonschema.validate(entry, turn_schema)
        text = ground_rate_text(entry)
        assert ("turn rate in the ground frame 2.9" in text) is fixed
        assert ("not fixed" in text) is not fixed
    assert _turn_rate(None) is None and ground_rate_text(None) == ""
