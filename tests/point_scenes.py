"""Point scenes beside a strong point, for the sidelobe tests (listing and collections)."""

from __future__ import annotations

import numpy as np

from sarmotion.core import Radar, Traces, Trajectory, to_fast_time
from sarmotion.simulation import PointTarget, simulate_phase_history


def point_traces(targets) -> Traces:
    """Noise-free traces of ``targets`` over the default circular aperture."""
    traj, radar = Trajectory.circular(), Radar()
    ph = simulate_phase_history(targets, traj, radar, (0.0, 0.0, 0.0))
    return Traces(
        data=to_fast_time(ph), trajectory=traj, radar=radar, reference_point_m=(0.0, 0.0, 0.0)
    )


def cell_offset(cells, a_r: float, a_c: float) -> np.ndarray:
    """Ground point ``a_r`` range cells and ``a_c`` cross-range cells from the origin."""
    e_r = np.asarray(cells.range_direction, float)
    e_c = np.asarray(cells.cross_range_direction, float)
    return a_r * cells.ground_range_m * e_r + a_c * cells.cross_range_m * e_c


def weak_beside_strong(rng: np.random.Generator, cells, n: int = 3) -> list[PointTarget]:
    """A unit point at the origin and ``n`` weak ones (-3 to -15 dB, random phase), each
    1.5 to 6 cells off both of its axes (off its sidelobe ridges)."""
    targets = [PointTarget(position_m=(0.0, 0.0))]
    for _ in range(n):
        a_r, a_c = rng.choice([-1, 1], 2) * rng.uniform(1.5, 6.0, 2)
        level_db = rng.uniform(-15.0, -3.0)
        targets.append(
            PointTarget(
                position_m=cell_offset(cells, a_r, a_c),
                reflectivity=10 ** (level_db / 20) * np.exp(2j * np.pi * rng.random()),
            )
        )
    return targets
