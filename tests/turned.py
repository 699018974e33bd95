"""An acquisition turned about its reference point, for imaging at other look angles."""

from __future__ import annotations

import dataclasses
import math

from sarmotion.core import Trajectory


def turned(traces, deg: float):
    """The acquisition turned by ``deg`` about the reference point (ranges unchanged)."""
    t = math.radians(deg)
    c, s = math.cos(t), math.sin(t)
    o = traces.reference_point_m
    p = traces.trajectory.positions_m.copy()
    d = p[:, :2] - o[:2]
    p[:, 0] = o[0] + c * d[:, 0] - s * d[:, 1]
    p[:, 1] = o[1] + s * d[:, 0] + c * d[:, 1]
    trajectory = Trajectory(positions_m=p, slow_times_s=traces.trajectory.slow_times_s)
    return dataclasses.replace(traces, trajectory=trajectory)
