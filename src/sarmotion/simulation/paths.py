"""Movers that do not move uniformly (turns, stops, accelerations) and long acquisitions.

Over a long acquisition (many degrees of a circular pass) a road vehicle does not move
uniformly: it turns and stops. :class:`PathTarget` is a point reflector whose ground
position is linear between waypoints ``(s_k, p_k)``: constant velocity on each leg,
a turn or a change of speed at each waypoint, a stop where two consecutive waypoints
coincide. Before the first and after the last waypoint it keeps the first and last
legs' velocities. The forward model (:func:`sarmotion.simulation.simulate`,
:func:`~sarmotion.simulation.inject`) asks of a target only its positions at the pulses,
so such paths are simulated exactly (the displacement during the round trip neglected,
as for uniform motion).

Two smooth motions complete it: :class:`AcceleratingTarget`, a constant ground
acceleration ``rho(s) = rho(0) + s u + s^2 a / 2``, and :class:`TurningTarget`, a
constant speed on a circle (a constant turn rate ``omega``):
its position in closed form (:meth:`TurningTarget.positions_at`).

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

__all__ = ["AcceleratingTarget", "PathTarget", "TurningTarget", "radar_with_range_window"]


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


def _ground_motion(
    position_m: ArrayLike, velocity_mps: ArrayLike, reflectivity: complex
) -> tuple[NDArray[np.float64], NDArray[np.float64], complex]:
    """Validated ``(position (3,), ground velocity (2,), reflectivity)`` of a smooth mover."""
    p = np.asarray(position_m, dtype=np.float64).ravel()
    if p.shape not in ((2,), (3,)) or not np.all(np.isfinite(p)):
        raise ValueError(f"position_m must be a finite (x, y) or (x, y, z) point, got {p}")
    p = np.r_[p[:2], 0.0 if p.size == 2 else p[2]]
    v = np.asarray(velocity_mps, dtype=np.float64).ravel()
    if v.shape != (2,) or not np.all(np.isfinite(v)):
        raise ValueError(f"velocity_mps must be a finite ground velocity (ux, uy), got {v}")
    r = complex(reflectivity)
    if not np.isfinite(r):
        raise ValueError(f"reflectivity must be finite, got {r}")
    return p, v, r


@dataclass(frozen=True, kw_only=True, eq=False)
class AcceleratingTarget:
    """A point reflector with a constant ground acceleration.

    ``rho(s) = rho(0) + s u + s^2 a / 2`` and ``u(s) = u + s a``.

    Parameters
    ----------
    position_m : (2,) or (3,) array_like
        Position ``rho(0)`` at ``s = 0`` (m).
    velocity_mps : (2,) array_like
        Ground velocity ``u`` at ``s = 0`` (m/s).
    acceleration_mps2 : (2,) array_like
        Ground acceleration ``a`` (m/s^2).
    reflectivity : complex
        Complex reflectivity ``sigma``.
    label : str
        Optional name.
    """

    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64]
    acceleration_mps2: NDArray[np.float64]
    reflectivity: complex = 1.0 + 0.0j
    label: str = ""

    def __post_init__(self) -> None:
        p, v, r = _ground_motion(self.position_m, self.velocity_mps, self.reflectivity)
        a = np.asarray(self.acceleration_mps2, dtype=np.float64).ravel()
        if a.shape != (2,) or not np.all(np.isfinite(a)):
            raise ValueError(f"acceleration_mps2 must be a finite ground vector, got {a}")
        object.__setattr__(self, "position_m", p)
        object.__setattr__(self, "velocity_mps", v)
        object.__setattr__(self, "acceleration_mps2", a)
        object.__setattr__(self, "reflectivity", r)

    def positions_at(self, slow_times_s: ArrayLike) -> NDArray[np.float64]:
        """Positions at the slow times (m), shape (n, 3)."""
        s = np.atleast_1d(np.asarray(slow_times_s, dtype=np.float64))[:, None]
        v3, a3 = np.r_[self.velocity_mps, 0.0], np.r_[self.acceleration_mps2, 0.0]
        return self.position_m[None, :] + s * v3[None, :] + 0.5 * s**2 * a3[None, :]

    def velocities_at(self, slow_times_s: ArrayLike) -> NDArray[np.float64]:
        """Ground velocities at the slow times (m/s), shape (n, 2)."""
        s = np.atleast_1d(np.asarray(slow_times_s, dtype=np.float64))[:, None]
        return self.velocity_mps[None, :] + s * self.acceleration_mps2[None, :]

    @property
    def velocity3_mps(self) -> NDArray[np.float64]:
        """Velocity at ``s = 0`` lifted to 3-D ``(ux, uy, 0)`` (m/s)."""
        return np.r_[self.velocity_mps, 0.0]

    @property
    def is_moving(self) -> bool:
        """True: an accelerating reflector is a mover."""
        return True


@dataclass(frozen=True, kw_only=True, eq=False)
class TurningTarget:
    """A point reflector at constant speed turning at a constant rate (a circular arc).

    With ``omega`` the turn rate (rad/s, positive counter-clockwise) and ``Q(x)`` the
    rotation by ``x``: ``u(s) = Q(omega s) u`` and
    ``rho(s) = rho(0) + [sin(omega s) I + (1 - cos(omega s)) J] u / omega``
    (``J`` the rotation by 90 degrees), the straight line ``rho(0) + s u`` at
    ``omega = 0``.

    Parameters
    ----------
    position_m : (2,) or (3,) array_like
        Position ``rho(0)`` at ``s = 0`` (m).
    velocity_mps : (2,) array_like
        Ground velocity ``u`` at ``s = 0`` (m/s).
    turn_rate_deg_s : float
        Turn rate (degrees per second, positive counter-clockwise).
    reflectivity : complex
        Complex reflectivity ``sigma``.
    label : str
        Optional name.
    """

    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64]
    turn_rate_deg_s: float
    reflectivity: complex = 1.0 + 0.0j
    label: str = ""

    def __post_init__(self) -> None:
        p, v, r = _ground_motion(self.position_m, self.velocity_mps, self.reflectivity)
        if not np.isfinite(self.turn_rate_deg_s):
            raise ValueError(f"turn_rate_deg_s must be finite, got {self.turn_rate_deg_s!r}")
        object.__setattr__(self, "position_m", p)
        object.__setattr__(self, "velocity_mps", v)
        object.__setattr__(self, "turn_rate_deg_s", float(self.turn_rate_deg_s))
        object.__setattr__(self, "reflectivity", r)

    def positions_at(self, slow_times_s: ArrayLike) -> NDArray[np.float64]:
        """Positions at the slow times (m), shape (n, 3).

        ``sin(w s) / w = s sinc(w s / pi)`` and ``(1 - cos(w s)) / w = (w s^2 / 2)
        sinc(w s / (2 pi))^2`` (numpy's ``sinc(x) = sin(pi x) / (pi x)``): exact at
        ``w = 0`` and without cancellation for small turn rates.
        """
        s = np.atleast_1d(np.asarray(slow_times_s, dtype=np.float64))
        w = np.radians(self.turn_rate_deg_s)
        along = s * np.sinc(w * s / np.pi)
        across = 0.5 * w * s**2 * np.sinc(w * s / (2.0 * np.pi)) ** 2
        u = self.velocity_mps
        turned = np.array([-u[1], u[0]])
        xy = along[:, None] * u[None, :] + across[:, None] * turned[None, :]
        return self.position_m[None, :] + np.column_stack([xy, np.zeros(s.size)])

    def velocities_at(self, slow_times_s: ArrayLike) -> NDArray[np.float64]:
        """Ground velocities at the slow times (m/s), shape (n, 2)."""
        s = np.atleast_1d(np.asarray(slow_times_s, dtype=np.float64))
        x = np.radians(self.turn_rate_deg_s) * s
        c, sn = np.cos(x), np.sin(x)
        u = self.velocity_mps
        return np.column_stack([c * u[0] - sn * u[1], sn * u[0] + c * u[1]])

    @property
    def velocity3_mps(self) -> NDArray[np.float64]:
        """Velocity at ``s = 0`` lifted to 3-D ``(ux, uy, 0)`` (m/s)."""
        return np.r_[self.velocity_mps, 0.0]

    @property
    def is_moving(self) -> bool:
        """True: a turning reflector is a mover."""
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
