"""A lone mover where a collection's patches meet is found once, whatever its range rate.

``g(u)`` leaves untested the range speeds of the image's stationary points (relative to
its reference point). A patch of a collection knows them: those of its core. Its
neighbour's reference sits two such bands away, and its pass band reaches beyond, so a
mover whose range rate mimics a stationary point of one core (a slow radial speed, most
of its speed across the beam) is tested and estimated by the next patch. Taking the
image's generic stationary band instead (two range-speed resolutions, wider than a core's
band and than what a neighbour's pass band reaches) left such movers to no patch.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.collection import CollectionOptions, analyze_collection, plan_patches
from sarmotion.core import Radar, Traces, Trajectory, range_speed, to_fast_time
from sarmotion.core.blocks import TracesBlocks
from sarmotion.imaging import resolution
from sarmotion.motion import family_member, range_speed_resolution
from sarmotion.pipeline import AnalysisOptions
from sarmotion.simulation import PointTarget, simulate_phase_history

#: Two patches in range by three in cross range: nearly the whole unambiguous cross
#: range (+-74.4 m over a GOTCHA-like degree); the cores meet at y = +-24 m.
REGION = (-60.0, -72.0, 60.0, 72.0)
OPTIONS = CollectionOptions(
    analysis=AnalysisOptions(trajectory=False), patch_size_m=60.0, max_speed_mps=15.0
)
SEEDS = (11, 12, 13)


def _mover(seed: int, traj: Trajectory, radar: Radar) -> PointTarget:
    """A mover within 2 m of a point where four cores meet, speed in 5-15 m/s.

    Its radial ground speed is drawn within two range-speed resolutions of zero (the
    generic stationary band of ``g(u)``): its range rate relative to the nearby patch
    centres is then that of a stationary point of their cores or just beyond.
    """
    rng = np.random.default_rng(seed)
    meet = REGION[3] / 3.0  # cores meet at x = 0, y = +-meet
    corner = np.array([0.0, rng.choice([-meet, meet])])
    position = corner + rng.uniform(-2.0, 2.0, 2)
    probe = Traces(
        data=np.zeros((traj.positions_m.shape[0], radar.n_samples), np.complex64),
        trajectory=traj,
        radar=radar,
        reference_point_m=(0.0, 0.0, 0.0),
    )
    u_r = rng.uniform(-2.0, 2.0) * range_speed_resolution(probe)
    speed = rng.uniform(5.0, 15.0)
    u_c = rng.choice([-1.0, 1.0]) * np.sqrt(speed**2 - u_r**2)
    return PointTarget(
        position_m=tuple(position), velocity_mps=(u_r, u_c), reflectivity=np.exp(2j * rng.random())
    )


def _family_error(traces: Traces, position, velocity, truth: PointTarget):
    """(range position (m), range speed (m/s)) error with the truth slid along its family."""
    cells = resolution(traces)
    dy = float((np.asarray(position)[:2] - truth.position_m[:2]) @ cells.cross_range_direction)
    p, v, _ = family_member(traces, truth.position_m, truth.velocity_mps, dy)
    geom = traces.geometry
    return (
        float((np.asarray(position)[:2] - p[:2]) @ cells.range_direction),
        range_speed(velocity, geom) - range_speed(v, geom),
    )


@pytest.mark.parametrize("seed", SEEDS)
def test_lone_mover_where_patches_meet_is_found_once(seed):
    traj, radar = Trajectory.circular(), Radar()
    mover = _mover(seed, traj, radar)
    ph = simulate_phase_history([mover], traj, radar, (0.0, 0.0, 0.0))
    scene = Traces(
        data=to_fast_time(ph), trajectory=traj, radar=radar, reference_point_m=(0.0, 0.0, 0.0)
    )
    plan = plan_patches(TracesBlocks(scene), OPTIONS, region_m=REGION)
    assert len(plan.patches) == 6
    res = analyze_collection(scene, OPTIONS, plan=plan, n_workers=0)
    assert len(res.movers) == 1, (mover, [(m.position_m, m.velocity_mps) for m, _ in res.movers])
    m = res.movers[0][0]
    dx, du = _family_error(scene, m.position_m, m.velocity_mps, mover)
    cells = resolution(scene)
    # the family rule's accuracy: a ground-range cell, half a range-speed resolution
    assert abs(dx) <= cells.ground_range_m, (mover, dx)
    assert abs(du) <= 0.5 * range_speed_resolution(scene), (mover, du)
