"""The cross-range family of a mover and the whole-aperture refinement (sarmotion.motion.aperture).

Scene 1's geometry (GOTCHA, L = 10.18 km, V = 70 m/s, wavelength 3.1 cm) with its two
movers alone, noise-free, over apertures of 1 to 30 degrees.
"""

import numpy as np
import pytest

from sarmotion.core import range_speed
from sarmotion.imaging import resolution
from sarmotion.motion import estimate_velocity
from sarmotion.motion.aperture import (
    azimuth_span_deg,
    central_sub_aperture,
    family_direction,
    family_member,
    ranges_m,
    refine_on_aperture,
)
from sarmotion.simulation import Scene, load_scene, simulate

WAVELENGTH_M = 299_792_458.0 / 9.6e9


def _mover_alone(label: str, aperture_deg: float):
    scene = load_scene("scene1")
    mover = next(t for t in scene.moving if t.label == label)
    one = Scene(
        name="alone",
        targets=(mover,),
        radar=scene.radar,
        trajectory_spec={**scene.trajectory_spec, "aperture_deg": aperture_deg},
        reference_point_m=scene.reference_point_m,
    )
    return mover, simulate(one).traces


def test_central_sub_aperture():
    _, tr4 = _mover_alone("mover 1", 4.0)
    assert abs(azimuth_span_deg(tr4) - 4.0) < 0.02
    c = central_sub_aperture(tr4, 1.0)
    assert c.stop - c.start == 117 and c.start == (tr4.n_pulses - 117) // 2
    _, tr1 = _mover_alone("mover 1", 1.0)
    assert central_sub_aperture(tr1, 1.0) == slice(0, tr1.n_pulses)
    with pytest.raises(ValueError):
        central_sub_aperture(tr1, 0.0)


@pytest.mark.parametrize(
    ("aperture_deg", "bound_m"),
    [
        (1.0, 2e-6),  # measured 8.9e-7 m
        (4.0, 2e-4),  # measured 1.4e-4 m: 1/220 of a wavelength
        (30.0, None),  # measured 3.2e-2 m: one wavelength
    ],
)
def test_family_is_degenerate_over_a_few_degrees(aperture_deg, bound_m):
    """A 10 m cross-range offset, fitted on the central degree, over the whole aperture.

    The member's range history equals the mover's to a small fraction of a wavelength
    over 1 and 4 degrees of circular flight (no data of that length can place the mover
    in cross range), and departs by a wavelength only over 30 degrees (module notes).
    """
    mover, tr = _mover_alone("mover 2", aperture_deg)
    c = central_sub_aperture(tr, 1.0)
    sub = tr.select_pulses(c.start, c.stop)
    s_c = float(np.mean(tr.slow_times_s[c]))
    start = mover.position_m + s_c * np.r_[mover.velocity_mps, 0.0]
    p, v, rms = family_member(sub, start, mover.velocity_mps, 10.0)
    assert rms < 1e-6  # the family is exact over the fitted degree
    p = p - s_c * np.r_[v, 0.0]
    d = ranges_m(tr, p, v) - ranges_m(tr, mover.position_m, mover.velocity_mps)
    spread = float(np.ptp(d))
    if bound_m is None:
        assert spread > WAVELENGTH_M / 2
    else:
        assert spread < bound_m
    # It is a different motion all the same: 10 m off, and the range speed moved by
    # about -(V - u_t) dy / L.
    geom = tr.geometry
    du = range_speed(v, geom) - range_speed(mover.velocity_mps, geom)
    u_t = float(np.r_[mover.velocity_mps, 0.0] @ geom.tangent)
    assert abs(du - (-(geom.speed_mps - u_t) * 10.0 / geom.range_m)) < 0.1 * abs(du)


def test_family_direction_is_the_range_speed_trade():
    mover, tr = _mover_alone("mover 1", 1.0)
    a, b = family_direction(tr, mover.position_m, mover.velocity_mps)
    geom = tr.geometry
    # The member is placed 1 m over in cross range by construction; its fitted range
    # coordinate barely moves (the range at s = 0 is data).
    assert abs(a @ resolution(tr).range_direction) < 0.01
    du = range_speed(b, geom)
    u_t = float(np.r_[mover.velocity_mps, 0.0] @ geom.tangent)
    # per metre of cross-range offset (sign set by the cross-range axis orientation)
    assert abs(abs(du) - (geom.speed_mps - u_t) / geom.range_m) < 0.05 * abs(du)


@pytest.mark.parametrize("label", ["mover 1", "mover 2"])
def test_refine_on_aperture_focuses_four_degrees(label):
    """A 1-degree estimate perturbed within its accuracy focuses on all 4 degrees.

    Perturbation as the 1-degree estimates err off their family (test_analysis: up to
    1.4 cm of range, 0.8 m/s of cross-range speed, the range rate to ~1e-3 m/s): 1 cm in
    range, 0.002 m/s in range speed, 0.5 m/s in cross-range speed (two thirds of a
    1-degree cross-range-speed resolution). Over 4 degrees the start is defocused; the
    refinement recovers the focus of the truth (n_pulses, unit reflectivity) and the
    truth's range and velocity, the cross-range position held.
    """
    mover, tr = _mover_alone(label, 4.0)
    c = central_sub_aperture(tr, 1.0)
    sub = tr.select_pulses(c.start, c.stop)
    s_c = float(np.mean(tr.slow_times_s[c]))
    cells = resolution(sub)
    e_r, e_c = cells.range_direction, cells.cross_range_direction
    start = mover.position_m + s_c * np.r_[mover.velocity_mps, 0.0] + 0.01 * np.r_[e_r, 0.0]
    vel = mover.velocity_mps + 0.002 * e_r / np.hypot(*sub.geometry.m_o[:2]) + 0.5 * e_c
    fit = refine_on_aperture(tr, start, vel, central=c)
    n = tr.n_pulses
    assert fit.start_focus < 0.9 * n
    assert fit.focus > 0.999 * n, (fit.start_focus / n, fit.focus / n)
    assert np.hypot(*(fit.position_m[:2] - mover.position_m[:2])) < 0.01
    assert np.hypot(*(fit.velocity_mps - mover.velocity_mps)) < 0.01


def test_one_degree_estimate_lies_on_the_family():
    """estimate_velocity on mover 2's degree: the truth is its family member (1 cm, 1 cm/s)."""
    mover, tr = _mover_alone("mover 2", 1.0)
    est = estimate_velocity(tr)
    a, b = family_direction(tr, est.position_m, est.velocity_mps)
    d = mover.position_m[:2] - est.position_m[:2]
    t = float(d @ a) / float(a @ a)
    assert abs(t) > 2.0  # the estimate is off in cross range (measured 4.7 m) ...
    assert np.hypot(*(est.position_m[:2] + t * a - mover.position_m[:2])) < 0.01
    assert np.hypot(*(est.velocity_mps + t * b - mover.velocity_mps)) < 0.01  # ... on it
