"""Movers on piecewise-straight paths (turns and stops) and long acquisitions.

Over a long acquisition (many degrees of a circular pass) a road vehicle does not move
uniformly: it turns and stops. :class:`PathTarget` is a point reflector whose ground
position is linear between waypoints ``(s_k, p_k)``: constant velocity on each leg,
a turn or a change of speed at each waypoint, a stop where two consecutive waypoints
coincide. Before the first and after the last waypoint it keeps the first and last
legs' velocities. The forward model (:func:`sarmotion.simulation.simulate`,
:func:`~sarmotion.simulation.inject`) asks of a target only its positions at the pulses,
so such paths are simulated exactly (the displacement during the round trip neglected,
as for uniform motion).

A long track also needs a long range window: the fast-time window of the data covers
``c / (2 df)`` of slant range (GOTCHA: ``df`` = 1.47 MHz, 102 m). A mover at 10 m/s
crosses it in 10 s, under six degrees of the GOTCHA pass. :func:`radar_with_range_window`
gives the same band sampled more finely in frequency.

Positions in m, slow times in s (``s = 0`` at the acquisition centre), speeds in m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import C, Radar

__all__ = ["PathTarget", "radar_with_range_window"]


@dataclass(frozen=True, kw_only=True, eq=False)
class PathTarget:
    """A point reflector on a piecewise-straight ground path.

    Parameters
    ----------
    times_s : (n_waypoints,) array_like
        Slow times of the waypoints (s), strictly increasing, ``n_waypoints >= 2``.
    waypoints_m : (n_waypoints, 2) array_like
        Ground positions ``(x, y)`` at those times (m); the reflector moves on the
        ground plane ``z = 0``.
    reflectivity : complex
        Complex reflectivity ``sigma``.
    label : str
        Optional name.
    """

    times_s: NDArray[np.float64]
    waypoints_m: NDArray[np.float64]
    reflectivity: complex = 1.0 + 0.0j
    label: str = ""

    def __post_init__(self) -> None:
        t = np.asarray(self.times_s, dtype=np.float64)
        w = np.asarray(self.waypoints_m, dtype=np.float64)
        if t.ndim != 1 or t.size < 2:
            raise ValueError(f"times_s must have shape (n_waypoints >= 2,), got {t.shape}")
        if not (np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)):
            raise ValueError(f"times_s must be finite and strictly increasing, got {t}")
        if w.shape != (t.size, 2) or not np.all(np.isfinite(w)):
            raise ValueError(
                f"waypoints_m must be finite with shape ({t.size}, 2) to match times_s, "
                f"got {w.shape}"
            )
        r = complex(self.reflectivity)
        if not np.isfinite(r):
            raise ValueError(f"reflectivity must be finite, got {r}")
        object.__setattr__(self, "times_s", t)
        object.__setattr__(self, "waypoints_m", w)
        object.__setattr__(self, "reflectivity", r)

    @property
    def leg_velocities_mps(self) -> NDArray[np.float64]:
        """Ground velocity of each leg (m/s), shape (n_waypoints - 1, 2)."""
        return np.diff(self.waypoints_m, axis=0) / np.diff(self.times_s)[:, None]

    def velocities_at(self, slow_times_s: ArrayLike) -> NDArray[np.float64]:
        """Ground velocity at the slow times (m/s), shape (n, 2).

        At a waypoint itself, the velocity of the leg that starts there.
        """
        s = np.atleast_1d(np.asarray(slow_times_s, dtype=np.float64))
        leg = np.clip(np.searchsorted(self.times_s, s, side="right") - 1, 0, self.times_s.size - 2)
        return self.leg_velocities_mps[leg]

    def positions_at(self, slow_times_s: ArrayLike) -> NDArray[np.float64]:
        """Positions on the path at the slow times (m), shape (n, 3), ``z = 0``."""
        s = np.atleast_1d(np.asarray(slow_times_s, dtype=np.float64))
        leg = np.clip(np.searchsorted(self.times_s, s, side="right") - 1, 0, self.times_s.size - 2)
        start = self.waypoints_m[leg]
        xy = start + (s - self.times_s[leg])[:, None] * self.leg_velocities_mps[leg]
        return np.column_stack([xy, np.zeros(s.size)])

    @property
    def position_m(self) -> NDArray[np.float64]:
        """Position at ``s = 0`` (m), shape (3,)."""
        return self.positions_at([0.0])[0]

    @property
    def velocity_mps(self) -> NDArray[np.float64]:
        """Ground velocity at ``s = 0`` (m/s), shape (2,)."""
        return self.velocities_at([0.0])[0]

    @property
    def velocity3_mps(self) -> NDArray[np.float64]:
        """Velocity at ``s = 0`` lifted to 3-D ``(ux, uy, 0)`` (m/s)."""
        return np.r_[self.velocity_mps, 0.0]

    @property
    def is_moving(self) -> bool:
        """True: a path is a mover (a stop is one of its legs)."""
        return True


def radar_with_range_window(range_window_m: float, *, radar: Radar | None = None) -> Radar:
    """``radar``'s band sampled finely enough for a slant-range window of ``range_window_m``.

    The frequency step becomes ``df = c / (2 W)`` or finer, so that ``n_samples = ceil(
    span / df)`` frequencies cover the original sampled span; carrier and bandwidth
    are unchanged, and so are the resolution and the image of a point.

    Parameters
    ----------
    range_window_m : float
        Slant-range window ``W`` wanted (m, > 0).
    radar : Radar, optional
        The radar to widen; default GOTCHA's (102 m window).

    Returns
    -------
    Radar
        The same radar if its window already covers ``W``.
    """
    base = Radar() if radar is None else radar
    if not (np.isfinite(range_window_m) and range_window_m > 0):
        raise ValueError(f"range_window_m must be a positive number (m), got {range_window_m!r}")
    if 0.5 * C / base.frequency_step_hz >= range_window_m:
        return base
    n = int(np.ceil(base.span_hz * 2.0 * range_window_m / C))
    return Radar(
        carrier_hz=base.carrier_hz,
        bandwidth_hz=base.bandwidth_hz,
        n_samples=n,
        frequency_step_hz=base.span_hz / n,
        pulse=base.pulse,
    )
