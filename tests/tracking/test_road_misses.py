"""Why a road is ignored: ``road_misses`` gives each road's reason, consistent with ``road_fix``.

A road gives a detection no member when its family line does not cross it, crosses it
only beyond the offset the data allow, or when the member there would cross the road
instead of moving along it (sarmotion.tracking.roads).
"""

from __future__ import annotations

import numpy as np

from sarmotion.tracking import Road, road_fix, road_misses

P = np.zeros(2)
A = np.array([0.0, 1.0])  # the family runs along y (cross range)
V = np.array([0.0, 5.0])  # the mover moves along y at 5 m/s
LIMITS = {"max_cross_speed_mps": 1.0, "max_offset_m": 10.0}


def _why(road: Road) -> str:
    (reason,) = road_misses(P, A, [road], velocity_mps=V, **LIMITS)
    fix = road_fix(P, A, [road], velocity_mps=V, range_std_m=0.5, **LIMITS)
    assert (fix is None) == bool(reason), (reason, fix)
    return reason


def test_each_reason_is_said():
    parallel = Road(points_m=[[5.0, -10.0], [5.0, 10.0]], name="parallel")
    assert "does not cross" in _why(parallel)
    far = Road(points_m=[[-10.0, 30.0], [10.0, 30.0]], name="far")
    assert "30.0 m from the detection, beyond the 10.0 m" in _why(far)
    across = Road(points_m=[[-10.0, 2.0], [10.0, 2.0]], name="across")
    assert "cross it at 5.0 m/s, more than 1.0 m/s" in _why(across)
    along = Road(points_m=[[-1.0, -10.0], [1.0, 10.0]], name="along")
    assert _why(along) == ""


def test_a_road_is_ignored_exactly_when_a_reason_is_given():
    """Seeded random roads and detections: road_fix finds none iff every road has a reason."""
    rng = np.random.default_rng(20261126)
    for _ in range(300):
        roads = [
            Road(points_m=rng.uniform(-40.0, 40.0, size=(int(rng.integers(2, 5)), 2)))
            for _ in range(int(rng.integers(1, 4)))
        ]
        p = rng.uniform(-20.0, 20.0, 2)
        a = np.array([rng.normal(0.0, 0.1), 1.0])
        v = rng.normal(0.0, 5.0, 2)
        b = rng.normal(0.0, 0.01, 2)
        limits = {
            "max_cross_speed_mps": float(rng.uniform(0.5, 3.0)),
            "max_offset_m": float(rng.uniform(5.0, 40.0)),
        }
        reasons = road_misses(p, a, roads, velocity_mps=v, family_velocity_per_m=b, **limits)
        fix = road_fix(
            p, a, roads, velocity_mps=v, family_velocity_per_m=b, range_std_m=0.5, **limits
        )
        assert len(reasons) == len(roads)
        assert (fix is None) == all(reasons)
        if fix is not None:
            assert reasons[fix.road] == ""
