"""Circular passes at GOTCHA's geometry and looks made from their exact ranges (tracking tests)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from sarmotion.motion.aperture import family_direction
from sarmotion.simulation import Scene, load_scene, simulate
from sarmotion.tracking import Detection
from sarmotion.tracking.sub_apertures import sub_aperture_slices, sub_aperture_time_s
from sarmotion.tracking.wide_aspect import LookMeasurement, antenna_state


@lru_cache(maxsize=8)
def empty_pass(aperture_deg: float):
    """An empty circular pass at GOTCHA's geometry, 30 pulses per degree (the antenna only)."""
    sc = load_scene("scene1")
    scene = Scene(
        name="pass",
        targets=(),
        radar=sc.radar,
        trajectory_spec={"kind": "circular", "aperture_deg": aperture_deg, "pulses_per_deg": 30},
    )
    return simulate(scene).traces


def turn_motion(p0, speed, heading, rate_deg_s, t):
    """Ground position (m) and velocity (m/s) at times ``t`` (s) of a constant-rate turn.

    ``p0`` at ``t = 0``, ``heading`` (rad) there, ``rate_deg_s`` counter-clockwise; 0 is
    uniform motion. Returns two ``(len(t), 2)`` arrays.
    """
    t = np.asarray(t, dtype=np.float64)
    w = np.radians(rate_deg_s)
    th = heading + w * t
    u = speed * np.column_stack([np.cos(th), np.sin(th)])
    if w == 0.0:
        return np.asarray(p0) + np.outer(t, u[0]), u
    p = np.asarray(p0) + speed / w * np.column_stack(
        [np.sin(th) - np.sin(heading), np.cos(heading) - np.cos(th)]
    )
    return p, u


def exact_history(traces, sl, t_c, motion):
    """``(R, R', R'')`` at ``t_c`` from a polynomial fitted to the exact range over ``sl``.

    ``motion(t) -> (positions, velocities)``; independent of any closed form of the
    model's (m, m/s, m/s^2).
    """
    s = traces.slow_times_s[sl]
    p, _ = motion(s)
    r = np.linalg.norm(traces.positions_m[sl] - np.c_[p, np.zeros(len(s))], axis=1)
    h = float(np.max(np.abs(s - t_c)))
    c = np.polyfit((s - t_c) / h, r, 6)[::-1]
    return np.array([c[0], c[1] / h, 2.0 * c[2] / h**2])


def exact_looks(traces, motion, std, rng) -> list[LookMeasurement]:
    """One look per sub-aperture of a degree: the exact range history plus errors of ``std``.

    ``std``: standard deviations of R (m), R' (m/s) and R'' (m/s^2), also the looks'
    covariance; each detection is the true motion at the centre time, with its family.
    """
    std = np.asarray(std, dtype=np.float64)
    out = []
    for k, sl in enumerate(sub_aperture_slices(traces, 1.0, 0.0)):
        t_c = sub_aperture_time_s(traces, sl)
        z = exact_history(traces, sl, t_c, motion)
        p, u = motion(np.array([t_c]))
        a, b = family_direction(traces.select_pulses(sl.start, sl.stop), np.r_[p[0], 0.0], u[0])
        det = Detection(
            position_m=p[0], velocity_mps=u[0], range_speed_mps=0.0, cross_range_speed_mps=0.0,
            family_position_per_m=a, family_velocity_per_m=b, peak_db=0.0, traces=None,
        )  # fmt: skip
        out.append(
            LookMeasurement(
                sub_aperture=k, antenna=antenna_state(traces, sl, t_c),
                z=z + rng.standard_normal(3) * std, covariance=np.diag(std**2), detection=det,
            )
        )  # fmt: skip
    return out
