"""Platform trajectories, travel times and the look geometry of the paper.

Everything here is float64 and SI: positions in metres, times in seconds,
speeds in m/s. The imaging plane is the ground ``z = 0``; positions are 3-D
``(x, y, z)`` and ground velocities ``(ux, uy)`` are lifted to ``(ux, uy, 0)``.

Slow time ``s`` is the emission time of a pulse, with ``s = 0`` at the centre
of the aperture (the paper's convention, ``sect:image``).

References to the paper's equations use its LaTeX labels:
``eq:DeltaTau`` (differential travel time), ``eq:Mo`` (look direction
``m_o``), ``eq:rangeu`` / ``eq:crangeu`` (range and cross-range speed),
``eq:ORTHPROJ`` (projector ``P_o``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .constants import C

__all__ = [
    "Trajectory",
    "LookGeometry",
    "look_geometry",
    "as_point",
    "travel_time",
    "delta_tau",
    "target_positions",
    "range_speed",
    "cross_range_speed",
    "ground_velocity",
    "range_direction_velocity",
]

#: GOTCHA circular-SAR defaults (paper, sect:scales).
GOTCHA_ALTITUDE_M = 7300.0
GOTCHA_GROUND_RADIUS_M = 7100.0
GOTCHA_SPEED_MPS = 70.0
GOTCHA_PULSES_PER_DEG = 117


def _readonly(a: NDArray) -> NDArray:
    a = np.array(a, dtype=np.float64, copy=True)
    a.setflags(write=False)
    return a


def as_point(point: ArrayLike, *, name: str = "point") -> NDArray[np.float64]:
    """Return a 3-D point (m) as float64, lifting a ground point ``(x, y)`` to ``z = 0``.

    Parameters
    ----------
    point : (2,) or (3,) array_like
        Position in metres.
    name : str
        Parameter name used in error messages.
    """
    p = np.asarray(point, dtype=np.float64)
    if p.shape == (2,):
        p = np.array([p[0], p[1], 0.0])
    if p.shape != (3,):
        raise ValueError(f"{name} must have shape (2,) or (3,) (m), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be finite, got {p}")
    return p


def _as_velocity(velocity: ArrayLike, *, name: str = "velocity") -> NDArray[np.float64]:
    v = np.asarray(velocity, dtype=np.float64)
    if v.shape == (2,):
        v = np.array([v[0], v[1], 0.0])
    if v.shape != (3,):
        raise ValueError(f"{name} must have shape (2,) or (3,) (m/s), got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {v}")
    return v


@dataclass(frozen=True, kw_only=True, eq=False)
class Trajectory:
    """Antenna positions at the pulse emission times.

    Parameters
    ----------
    positions_m : (n_pulses, 3) array_like
        Antenna phase-centre positions (m), float64.
    slow_times_s : (n_pulses,) array_like
        Emission times (s), increasing, with ``s = 0`` at the aperture centre.
    """

    positions_m: NDArray[np.float64]
    slow_times_s: NDArray[np.float64]
    _centre: NDArray[np.float64] = field(init=False, repr=False)
    _tangent: NDArray[np.float64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        pos = np.asarray(self.positions_m, dtype=np.float64)
        s = np.asarray(self.slow_times_s, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise ValueError(f"positions_m must have shape (n_pulses, 3), got {pos.shape}")
        if s.shape != (pos.shape[0],):
            raise ValueError(
                f"slow_times_s must have shape ({pos.shape[0]},) to match positions_m, "
                f"got {s.shape}"
            )
        if pos.shape[0] < 2:
            raise ValueError(f"a trajectory needs at least 2 pulses, got {pos.shape[0]}")
        if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(s))):
            raise ValueError("positions_m and slow_times_s must be finite")
        if np.any(np.diff(s) <= 0):
            raise ValueError("slow_times_s must be strictly increasing")
        object.__setattr__(self, "positions_m", _readonly(pos))
        object.__setattr__(self, "slow_times_s", _readonly(s))
        # Position and unit tangent at s = 0 by local quadratic fit (exact for
        # linear and, to O(s^3), for circular flight).
        k = min(pos.shape[0], 5)
        idx = np.argsort(np.abs(s))[:k]
        deg = min(2, k - 1)
        coef = np.polynomial.polynomial.polyfit(s[idx], pos[idx], deg)
        centre = coef[0]
        velocity = coef[1]
        object.__setattr__(self, "_centre", _readonly(centre))
        object.__setattr__(self, "_tangent", _readonly(velocity / np.linalg.norm(velocity)))

    # ----------------------------------------------------------------- props
    @property
    def n_pulses(self) -> int:
        """Number of pulses."""
        return int(self.positions_m.shape[0])

    @property
    def pulse_interval_s(self) -> float:
        """Median slow-time sampling interval ``Δs`` (s)."""
        return float(np.median(np.diff(self.slow_times_s)))

    @property
    def centre_m(self) -> NDArray[np.float64]:
        """Antenna position ``r(0)`` at the aperture centre (m), shape (3,)."""
        return self._centre

    @property
    def tangent(self) -> NDArray[np.float64]:
        """Unit tangent ``t`` to the flight path at ``s = 0``, shape (3,)."""
        return self._tangent

    @property
    def aperture_length_m(self) -> float:
        """Along-track length ``a`` of the aperture (m)."""
        return float(np.sum(np.linalg.norm(np.diff(self.positions_m, axis=0), axis=1)))

    @property
    def speed_mps(self) -> float:
        """Mean platform speed ``V`` (m/s)."""
        return self.aperture_length_m / float(self.slow_times_s[-1] - self.slow_times_s[0])

    # ---------------------------------------------------------- constructors
    @classmethod
    def circular(
        cls,
        *,
        altitude_m: float = GOTCHA_ALTITUDE_M,
        ground_radius_m: float = GOTCHA_GROUND_RADIUS_M,
        speed_mps: float = GOTCHA_SPEED_MPS,
        pulses_per_deg: float = GOTCHA_PULSES_PER_DEG,
        aperture_deg: float = 1.0,
        centre_azimuth_deg: float = 0.0,
        n_pulses: int | None = None,
    ) -> Trajectory:
        """Circular flight around the scene origin (GOTCHA geometry by default).

        The platform flies counter-clockwise at constant ``altitude_m`` on a circle of
        radius ``ground_radius_m``; pulses are spaced by ``1/pulses_per_deg`` degrees
        of azimuth, centred on ``centre_azimuth_deg``.

        Parameters
        ----------
        altitude_m, ground_radius_m : float
            Height (m) and ground radius (m) of the circle.
        speed_mps : float
            Platform speed ``V`` (m/s).
        pulses_per_deg : float
            Pulse density (pulses per degree of azimuth).
        aperture_deg : float
            Azimuth extent (degrees); ``n_pulses = round(aperture_deg * pulses_per_deg)``.
        centre_azimuth_deg : float
            Azimuth of the platform at ``s = 0`` (degrees from the x axis).
        n_pulses : int, optional
            Overrides the pulse count derived from ``aperture_deg``.
        """
        for name, value in [
            ("altitude_m", altitude_m),
            ("ground_radius_m", ground_radius_m),
            ("speed_mps", speed_mps),
            ("pulses_per_deg", pulses_per_deg),
            ("aperture_deg", aperture_deg),
        ]:
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        n = int(round(aperture_deg * pulses_per_deg)) if n_pulses is None else int(n_pulses)
        if n < 2:
            raise ValueError(f"the aperture must hold at least 2 pulses, got {n}")
        dphi = np.deg2rad(1.0 / pulses_per_deg)
        j = np.arange(n, dtype=np.float64) - (n - 1) / 2.0
        phi = np.deg2rad(centre_azimuth_deg) + j * dphi
        pos = np.stack(
            [
                ground_radius_m * np.cos(phi),
                ground_radius_m * np.sin(phi),
                np.full(n, float(altitude_m)),
            ],
            axis=1,
        )
        ds = ground_radius_m * dphi / speed_mps
        return cls(positions_m=pos, slow_times_s=j * ds)

    @classmethod
    def linear(
        cls,
        *,
        centre_m: ArrayLike,
        direction: ArrayLike = (0.0, 1.0, 0.0),
        speed_mps: float = GOTCHA_SPEED_MPS,
        aperture_m: float = 400.0,
        pulse_spacing_m: float = 1.055,
    ) -> Trajectory:
        """Straight flight at constant speed through ``centre_m`` at ``s = 0``.

        Parameters
        ----------
        centre_m : (3,) array_like
            Antenna position at the aperture centre (m).
        direction : (3,) array_like
            Flight direction (normalised internally).
        speed_mps : float
            Platform speed (m/s).
        aperture_m : float
            Aperture length ``a`` (m).
        pulse_spacing_m : float
            Distance flown between pulses (m).
        """
        c0 = as_point(centre_m, name="centre_m")
        d = np.asarray(direction, dtype=np.float64)
        if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
            raise ValueError(f"direction must be a non-zero (3,) vector, got {direction!r}")
        d = d / np.linalg.norm(d)
        if not (speed_mps > 0 and aperture_m > 0 and pulse_spacing_m > 0):
            raise ValueError("speed_mps, aperture_m and pulse_spacing_m must be positive")
        n = int(round(aperture_m / pulse_spacing_m)) + 1
        j = np.arange(n, dtype=np.float64) - (n - 1) / 2.0
        along = j * pulse_spacing_m
        return cls(positions_m=c0 + along[:, None] * d, slow_times_s=along / speed_mps)

    @classmethod
    def from_positions(
        cls, positions_m: ArrayLike, *, speed_mps: float = GOTCHA_SPEED_MPS
    ) -> Trajectory:
        """Trajectory from per-pulse positions, slow time from along-track distance.

        Real data sets such as GOTCHA carry no pulse times: ``s`` is the cumulative
        along-track distance divided by ``speed_mps``, shifted so that ``s = 0`` lies
        half-way along the flown path.

        Parameters
        ----------
        positions_m : (n_pulses, 3) array_like
            Antenna positions (m).
        speed_mps : float
            Platform speed ``V`` (m/s).
        """
        pos = np.asarray(positions_m, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise ValueError(f"positions_m must have shape (n_pulses, 3), got {pos.shape}")
        if not (np.isfinite(speed_mps) and speed_mps > 0):
            raise ValueError(f"speed_mps must be positive, got {speed_mps!r}")
        step = np.linalg.norm(np.diff(pos, axis=0), axis=1)
        dist = np.concatenate([[0.0], np.cumsum(step)])
        return cls(positions_m=pos, slow_times_s=(dist - dist[-1] / 2.0) / speed_mps)

    def sub_aperture(self, start: int, stop: int) -> Trajectory:
        """Pulses ``start:stop`` as a trajectory with slow time re-centred on them."""
        pos = self.positions_m[start:stop]
        s = self.slow_times_s[start:stop]
        return Trajectory(positions_m=pos, slow_times_s=s - 0.5 * (s[0] + s[-1]))


@dataclass(frozen=True, kw_only=True, eq=False)
class LookGeometry:
    """Look geometry at the aperture centre (paper, ``eq:Mo`` to ``eq:ORTHPROJ``).

    Attributes
    ----------
    m_o : (3,) ndarray
        Unit vector from the reference point to the antenna at ``s = 0``.
    tangent : (3,) ndarray
        Unit tangent ``t`` to the flight path at ``s = 0``.
    range_m : float
        ``L = |r(0) - rho_o|`` (m).
    speed_mps : float
        Platform speed ``V`` (m/s).
    reference_point_m : (3,) ndarray
        ``rho_o`` (m).
    """

    m_o: NDArray[np.float64]
    tangent: NDArray[np.float64]
    range_m: float
    speed_mps: float
    reference_point_m: NDArray[np.float64]

    @property
    def projector(self) -> NDArray[np.float64]:
        """Orthogonal projector ``P_o = I - m_o m_o^T`` (``eq:ORTHPROJ``), shape (3, 3)."""
        return np.eye(3) - np.outer(self.m_o, self.m_o)

    @property
    def ground_m_o(self) -> NDArray[np.float64]:
        """Ground projection ``b_o`` of ``m_o`` (not normalised), shape (2,)."""
        return self.m_o[:2].copy()

    @property
    def elevation_rad(self) -> float:
        """Elevation angle of the antenna seen from the reference point (rad)."""
        return float(np.arcsin(self.m_o[2]))


def look_geometry(trajectory: Trajectory, reference_point_m: ArrayLike) -> LookGeometry:
    """Look geometry of ``trajectory`` relative to ``reference_point_m``.

    Parameters
    ----------
    trajectory : Trajectory
        Platform trajectory.
    reference_point_m : (2,) or (3,) array_like
        Reference point ``rho_o`` (m).
    """
    rho_o = as_point(reference_point_m, name="reference_point_m")
    d = trajectory.centre_m - rho_o
    L = float(np.linalg.norm(d))
    return LookGeometry(
        m_o=d / L,
        tangent=trajectory.tangent.copy(),
        range_m=L,
        speed_mps=trajectory.speed_mps,
        reference_point_m=rho_o,
    )


def travel_time(positions_m: ArrayLike, points_m: ArrayLike) -> NDArray[np.float64]:
    """Round-trip travel time ``tau(s, rho) = 2 |r(s) - rho| / c`` (s).

    Parameters
    ----------
    positions_m : (n_pulses, 3) array_like
        Antenna positions ``r(s)``.
    points_m : (3,) or (n_pulses, 3) array_like
        A fixed point, or one point per pulse (a moving target).

    Returns
    -------
    (n_pulses,) ndarray
        Travel times (s), float64.
    """
    r = np.asarray(positions_m, dtype=np.float64)
    p = np.asarray(points_m, dtype=np.float64)
    return 2.0 * np.linalg.norm(r - p, axis=-1) / C


def delta_tau(
    positions_m: ArrayLike, points_m: ArrayLike, reference_point_m: ArrayLike
) -> NDArray[np.float64]:
    """Differential travel time ``tau(s, rho) - tau(s, rho_o)`` (``eq:DeltaTau``), in s.

    Parameters
    ----------
    positions_m : (n_pulses, 3) array_like
        Antenna positions.
    points_m : (3,) or (n_pulses, 3) array_like
        Target position(s) ``rho`` (fixed, or one per pulse).
    reference_point_m : (3,) array_like
        Range-compression reference point ``rho_o``.

    Returns
    -------
    (n_pulses,) ndarray
        Differential travel times (s), float64.
    """
    return travel_time(positions_m, points_m) - travel_time(positions_m, reference_point_m)


def target_positions(
    position_m: ArrayLike, velocity_mps: ArrayLike, slow_times_s: ArrayLike
) -> NDArray[np.float64]:
    """Straight-line target positions ``rho(s) = rho(0) + s u`` (``eq:MOD9``), shape (n, 3)."""
    p = as_point(position_m, name="position_m")
    v = _as_velocity(velocity_mps, name="velocity_mps")
    s = np.asarray(slow_times_s, dtype=np.float64)
    return p[None, :] + s[:, None] * v[None, :]


def range_speed(velocity_mps: ArrayLike, geometry: LookGeometry) -> float:
    """Range speed ``u = u_vec . m_o`` (``eq:rangeu``), in m/s."""
    return float(_as_velocity(velocity_mps, name="velocity_mps") @ geometry.m_o)


def cross_range_speed(velocity_mps: ArrayLike, geometry: LookGeometry) -> float:
    """Cross-range speed ``u_perp = t . P_o u_vec`` (``eq:crangeu``), in m/s."""
    v = _as_velocity(velocity_mps, name="velocity_mps")
    return float(geometry.tangent @ (geometry.projector @ v))


def ground_velocity(
    range_speed_mps: float, cross_range_speed_mps: float, geometry: LookGeometry
) -> NDArray[np.float64]:
    """Ground velocity ``(ux, uy)`` with the given range and cross-range speeds.

    Solves ``u . m_o = u_r`` and ``t . P_o u = u_perp`` for a horizontal ``u``
    (the paper's parametrisation after ``eq:OBJ2``).

    Returns
    -------
    (2,) ndarray
        Ground velocity (m/s).
    """
    P = geometry.projector
    a = np.array(
        [[geometry.m_o[0], geometry.m_o[1]], [(geometry.tangent @ P)[0], (geometry.tangent @ P)[1]]]
    )
    return np.linalg.solve(a, np.array([range_speed_mps, cross_range_speed_mps], dtype=float))


def range_direction_velocity(range_speed_mps: float, geometry: LookGeometry) -> NDArray[np.float64]:
    """Ground velocity along the ground projection ``b_o`` of ``m_o`` with range speed ``u``.

    The paper writes the search direction in ``eq:OBJg`` as ``u (b_o, 0)``; at GOTCHA
    elevation ``|b_o| ~ 0.7`` so that vector's range speed is ``0.49 u``, not ``u``.
    This returns ``u b_o / |b_o|^2``, whose range speed is exactly ``u``.

    Returns
    -------
    (2,) ndarray
        Ground velocity (m/s).
    """
    b = geometry.ground_m_o
    return range_speed_mps * b / float(b @ b)
