"""Why a track ends: the data's end, the imaged scene's edge in range, or no detection.

The geometry of :func:`sarmotion.tracking.track_end` on a 60 m image (half-sides 30 m):
a mover whose range takes it past the image has left whatever its place along its
cross-range family; one moving across the look has not, unless its position is fixed;
an oblique look sees the square's half-extent along its range grow to
``30 (|cos| + |sin|)``.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.tracking import TrackEnd, track_end

BOX = (0.0, 0.0, 30.0, 30.0)  # the image's centre and half-sides (m)


def _subs(e_r, times=(-2.0, 0.0, 2.0)):
    return [(k, t, np.asarray(e_r, float), BOX) for k, t in enumerate(times)]


def _end(position, velocity, *, e_r=(1.0, 0.0), last=1, fixed=False) -> TrackEnd:
    return track_end(
        last_time_s=0.0,
        last_index=last,
        position_m=np.asarray(position, float),
        velocity_mps=np.asarray(velocity, float),
        fixed=fixed,
        sub_apertures=_subs(e_r),
    )


def test_a_track_detected_in_the_last_sub_aperture_ends_with_the_data():
    end = _end((0.0, 0.0), (40.0, 0.0), last=2)
    assert end.reason == "data" and end.next_time_s is None
    assert "ends with the data" in end.describe()


def test_a_mover_whose_range_leaves_the_image_has_left_whatever_its_cross_range():
    """At 25 m in range moving out at 5 m/s: 35 m two seconds later, the image reaching
    30 m along the look; its cross range (the family's) does not matter."""
    end = _end((25.0, 0.0), (5.0, 0.0))
    assert end.reason == "left_scene"
    assert end.range_offset_m == pytest.approx(35.0)
    assert end.range_half_extent_m == pytest.approx(30.0)
    assert end.next_time_s == pytest.approx(2.0)
    assert "left the imaged scene" in end.describe() and "--size" in end.describe()
    # moving in: still inside, so not detected
    assert _end((25.0, 0.0), (-5.0, 0.0)).reason == "not_detected"


def test_across_the_look_the_family_does_not_say_unless_the_position_is_fixed():
    """At 25 m in cross range moving out across the look: its range stays 0, so without
    a fixed position it may be anywhere along the family (not detected, said so); with
    its position fixed (a road, the looks) it has left."""
    free = _end((0.0, 25.0), (0.0, 5.0))
    assert free.reason == "not_detected" and "across its family" in free.describe()
    fixed = _end((0.0, 25.0), (0.0, 5.0), fixed=True)
    assert fixed.reason == "left_scene" and fixed.fixed
    assert "predicted at (0.0, 35.0) m" in fixed.describe()


@pytest.mark.parametrize("azimuth_deg", [30.0, 45.0, 120.0])
def test_an_oblique_look_measures_the_square_along_its_range(azimuth_deg):
    """The 60 m square seen along ``e_r`` at an angle: its half-extent along ``e_r`` is
    ``30 (|cos| + |sin|)``; a mover just inside it in range has not left, just beyond
    it has."""
    a = np.deg2rad(azimuth_deg)
    e_r = np.array([np.cos(a), np.sin(a)])
    half = 30.0 * (abs(np.cos(a)) + abs(np.sin(a)))
    inside = _end(0.98 * half * e_r, np.zeros(2), e_r=e_r)
    beyond = _end(1.02 * half * e_r, np.zeros(2), e_r=e_r)
    assert inside.reason == "not_detected" and beyond.reason == "left_scene"
    assert beyond.range_half_extent_m == pytest.approx(half)
