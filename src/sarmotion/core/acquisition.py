"""The acquisition: trajectory, radar and reference point, apart from any data.

An :class:`Acquisition` is what many data blocks share: the traces ``M`` of a scene,
its separated parts ``L`` and ``S``, each mover's own traces, the patches of a large
scene. Its look geometry (``eq:Mo`` to ``eq:ORTHPROJ``) and the resolution at its
reference point are computed once, on first use, and its sub-apertures are kept, so
that every block of data on the same pulses shares them. :class:`~sarmotion.core.Traces`
is an acquisition and one block of data.

Positions in m, times in s, frequencies in Hz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .geometry import LookGeometry, Trajectory, as_point, look_geometry
from .radar import Radar

__all__ = ["Acquisition", "Resolution", "stationary_resolution"]


def _readonly(a: ArrayLike) -> NDArray[np.float64]:
    out = np.array(a, dtype=np.float64)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, kw_only=True, eq=False)
class Resolution:
    """Theoretical resolution of a stationary point (paper ``sect:scales``).

    Attributes
    ----------
    slant_range_m : float
        ``c / (2 B)`` (m).
    ground_range_m : float
        ``c / (2 B) / cos(elevation)`` (m), along :attr:`range_direction`.
    cross_range_m : float
        ``lambda_o L / (2 a)`` (m), along :attr:`cross_range_direction`.
    range_direction : (2,) ndarray
        Unit ground vector: the ground projection of ``m_o``, normalised.
    cross_range_direction : (2,) ndarray
        Unit ground vector perpendicular to :attr:`range_direction` (rotated +90 deg).
    elevation_rad : float
        Elevation of the antenna at ``s = 0`` seen from the point (rad).
    range_m : float
        ``L = |r(0) - rho|`` (m).
    aperture_m : float
        Aperture length ``a`` (m): the path flown from the first to the last pulse.
    wavelength_m : float
        ``lambda_o`` (m).
    """

    slant_range_m: float
    ground_range_m: float
    cross_range_m: float
    range_direction: NDArray[np.float64]
    cross_range_direction: NDArray[np.float64]
    elevation_rad: float
    range_m: float
    aperture_m: float
    wavelength_m: float


def stationary_resolution(trajectory: Trajectory, radar: Radar, point_m: ArrayLike) -> Resolution:
    """Slant-range, ground-range and cross-range resolution of a stationary point.

    Parameters
    ----------
    trajectory : Trajectory
        Antenna positions and slow times.
    radar : Radar
        Bandwidth and carrier.
    point_m : (2,) or (3,) array_like
        The point ``rho`` (m).

    Returns
    -------
    Resolution
    """
    geo = look_geometry(trajectory, as_point(point_m, name="point_m"))
    b = geo.ground_m_o
    nb = float(np.linalg.norm(b))
    if nb < 1e-9:
        raise ValueError("the antenna is above the point (zenith look): ground range undefined")
    rng_dir = b / nb
    slant = float(radar.range_resolution_m)
    a = trajectory.aperture_length_m
    lam = float(radar.wavelength_m)
    return Resolution(
        slant_range_m=slant,
        ground_range_m=slant / math.cos(geo.elevation_rad),
        cross_range_m=lam * geo.range_m / (2.0 * a),
        range_direction=rng_dir,
        cross_range_direction=np.array([-rng_dir[1], rng_dir[0]]),
        elevation_rad=geo.elevation_rad,
        range_m=geo.range_m,
        aperture_m=a,
        wavelength_m=lam,
    )


@dataclass(frozen=True, kw_only=True, eq=False)
class Acquisition:
    """Trajectory, radar and range-compression reference point of a set of traces.

    Parameters
    ----------
    trajectory : Trajectory
        Antenna positions (m) and slow times (s), one per pulse.
    radar : Radar
        Carrier, bandwidth and fast-time sampling.
    reference_point_m : (2,) or (3,) array_like
        Range-compression reference point ``rho_o`` (m); a ground point is lifted to
        ``z = 0``.

    Notes
    -----
    Frozen and compared by identity. :attr:`geometry` and :attr:`resolution` are
    computed on first use and kept (read-only arrays); :meth:`sub_aperture` returns the
    same object for the same pulses.
    """

    trajectory: Trajectory
    radar: Radar
    reference_point_m: NDArray[np.float64]
    _sub_apertures: dict[tuple[int, int], Acquisition] = field(
        init=False, repr=False, default_factory=dict
    )

    def __post_init__(self) -> None:
        if not isinstance(self.trajectory, Trajectory):
            raise TypeError(
                f"trajectory must be a Trajectory, got {type(self.trajectory).__name__}"
            )
        if not isinstance(self.radar, Radar):
            raise TypeError(f"radar must be a Radar, got {type(self.radar).__name__}")
        ref = as_point(self.reference_point_m, name="reference_point_m")
        object.__setattr__(self, "reference_point_m", _readonly(ref))

    # ----------------------------------------------------------------- axes
    @property
    def shape(self) -> tuple[int, int]:
        """``(n_pulses, n_samples)`` of the data it is shared by."""
        return (self.n_pulses, self.n_samples)

    @property
    def n_pulses(self) -> int:
        """Number of pulses (slow-time samples)."""
        return self.trajectory.n_pulses

    @property
    def n_samples(self) -> int:
        """Number of fast-time samples."""
        return int(self.radar.n_samples)

    @property
    def slow_times_s(self) -> NDArray[np.float64]:
        """Slow times ``s_j`` (s), shape (n_pulses,)."""
        return self.trajectory.slow_times_s

    @property
    def fast_times_s(self) -> NDArray[np.float64]:
        """Fast times ``t_l`` relative to ``tau(s, rho_o)`` (s), shape (n_samples,)."""
        return self.radar.fast_times_s

    @property
    def positions_m(self) -> NDArray[np.float64]:
        """Antenna positions (m), shape (n_pulses, 3)."""
        return self.trajectory.positions_m

    @property
    def frequencies_hz(self) -> NDArray[np.float64]:
        """Absolute frequencies of the spectrum bins (Hz), shape (n_samples,)."""
        return self.radar.frequencies_hz

    # ------------------------------------------------------------- geometry
    @cached_property
    def geometry(self) -> LookGeometry:
        """Look geometry (``m_o``, ``t``, ``L``, ``V``) at the reference point (computed once)."""
        g = look_geometry(self.trajectory, self.reference_point_m)
        return LookGeometry(
            m_o=_readonly(g.m_o),
            tangent=_readonly(g.tangent),
            range_m=g.range_m,
            speed_mps=g.speed_mps,
            reference_point_m=_readonly(g.reference_point_m),
        )

    @cached_property
    def resolution(self) -> Resolution:
        """Resolution of a stationary point at the reference point (computed once)."""
        r = stationary_resolution(self.trajectory, self.radar, self.reference_point_m)
        return Resolution(
            **{
                **r.__dict__,
                "range_direction": _readonly(r.range_direction),
                "cross_range_direction": _readonly(r.cross_range_direction),
            }
        )

    def resolution_at(self, point_m: ArrayLike) -> Resolution:
        """Resolution of a stationary point at ``point_m`` (m), computed on each call."""
        return stationary_resolution(self.trajectory, self.radar, point_m)

    # -------------------------------------------------------- constructors
    def sub_aperture(self, start: int, stop: int) -> Acquisition:
        """Pulses ``start:stop`` with slow time re-centred on them (``s = 0`` at their middle).

        The same pulses give the same object, with its geometry computed once.
        """
        start, stop = int(start), int(stop)
        if not (0 <= start < stop <= self.n_pulses):
            raise ValueError(f"pulse range [{start}, {stop}) outside [0, {self.n_pulses})")
        if (start, stop) == (0, self.n_pulses) and float(self.slow_times_s[0]) == -float(
            self.slow_times_s[-1]
        ):
            return self
        key = (start, stop)
        if key not in self._sub_apertures:
            self._sub_apertures[key] = Acquisition(
                trajectory=self.trajectory.sub_aperture(start, stop),
                radar=self.radar,
                reference_point_m=self.reference_point_m,
            )
        return self._sub_apertures[key]

    def with_reference_point(self, reference_point_m: ArrayLike) -> Acquisition:
        """The same pulses and radar with another reference point ``rho_o`` (m).

        Only the acquisition: data referenced to ``tau(s, rho_o)`` must be re-referenced
        to the new point (a fast-time delay of ``tau(s, rho_o) - tau(s, rho_new)`` per
        pulse, :func:`~sarmotion.core.delta_tau`) before it is paired with the result.
        """
        return Acquisition(
            trajectory=self.trajectory, radar=self.radar, reference_point_m=reference_point_m
        )
