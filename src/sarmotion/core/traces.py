"""The traces object: range-compressed complex-baseband data with its own axes."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .geometry import LookGeometry, Trajectory, as_point, look_geometry
from .radar import Radar
from .spectral import to_fast_time, to_frequency

__all__ = ["Traces"]


@dataclass(frozen=True, kw_only=True, eq=False)
class Traces:
    """Pulse- and range-compressed traces ``D_r(s, t)`` (paper ``eq:rangecompress``).

    ``data[j, l]`` is the complex-baseband sample at slow time ``s_j`` and fast time
    ``t_l`` *relative to* the reference travel time ``tau(s_j, rho_o)``: a point at
    ``rho`` peaks at ``t = tau(s, rho) - tau(s, rho_o)`` with phase
    ``exp(-i omega_o (tau(s, rho) - tau(s, rho_o)))`` (see :mod:`sarmotion.core.spectral`).

    Parameters
    ----------
    data : (n_pulses, n_samples) array_like
        Complex traces (complex64 or complex128).
    trajectory : Trajectory
        Antenna positions (m) and slow times (s), one per pulse.
    radar : Radar
        Carrier, bandwidth and fast-time sampling; ``radar.n_samples`` must equal
        ``n_samples``.
    reference_point_m : (3,) array_like
        Range-compression reference point ``rho_o`` (m).
    metadata : dict, optional
        Free-form provenance (source files, scene name, ...); JSON-serialisable values.
    """

    data: NDArray[np.complexfloating]
    trajectory: Trajectory
    radar: Radar
    reference_point_m: NDArray[np.float64]
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        d = np.asarray(self.data)
        if d.ndim != 2:
            raise ValueError(f"data must have shape (n_pulses, n_samples), got {d.shape}")
        if not np.iscomplexobj(d):
            d = d.astype(np.complex128)
        if d.shape[0] != self.trajectory.n_pulses:
            raise ValueError(
                f"data has {d.shape[0]} pulses but the trajectory has {self.trajectory.n_pulses}"
            )
        if d.shape[1] != self.radar.n_samples:
            raise ValueError(
                f"data has {d.shape[1]} fast-time samples but radar.n_samples is "
                f"{self.radar.n_samples}"
            )
        if not np.all(np.isfinite(d)):
            raise ValueError("data contains NaN or infinite values")
        object.__setattr__(self, "data", d)
        object.__setattr__(
            self, "reference_point_m", as_point(self.reference_point_m, name="reference_point_m")
        )

    # ----------------------------------------------------------------- axes
    @property
    def shape(self) -> tuple[int, int]:
        """``(n_pulses, n_samples)``."""
        return (int(self.data.shape[0]), int(self.data.shape[1]))

    @property
    def n_pulses(self) -> int:
        """Number of pulses (slow-time samples)."""
        return self.shape[0]

    @property
    def n_samples(self) -> int:
        """Number of fast-time samples."""
        return self.shape[1]

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

    @property
    def geometry(self) -> LookGeometry:
        """Look geometry (``m_o``, ``t``, ``L``, ``V``) relative to the reference point."""
        return look_geometry(self.trajectory, self.reference_point_m)

    # ------------------------------------------------------------ conversions
    def phase_history(self) -> NDArray[np.complex128]:
        """Deramped phase history ``P(s, f_k)``, shape (n_pulses, n_samples)."""
        return to_frequency(self.data)

    @classmethod
    def from_phase_history(
        cls,
        phase_history: ArrayLike,
        *,
        trajectory: Trajectory,
        radar: Radar,
        reference_point_m: ArrayLike,
        metadata: dict[str, Any] | None = None,
    ) -> Traces:
        """Traces from a deramped phase history ``P(s, f_k)`` on ``radar.frequencies_hz``.

        Parameters
        ----------
        phase_history : (n_pulses, n_samples) array_like
            Phase history, one row per pulse, frequencies increasing along the row.
        """
        p = np.asarray(phase_history)
        if p.ndim != 2:
            raise ValueError(f"phase_history must have shape (n_pulses, n_freq), got {p.shape}")
        return cls(
            data=to_fast_time(p),
            trajectory=trajectory,
            radar=radar,
            reference_point_m=reference_point_m,
            metadata=dict(metadata or {}),
        )

    def with_data(self, data: ArrayLike, **metadata: Any) -> Traces:
        """A copy with new ``data`` (same axes), metadata updated with ``metadata``."""
        return dataclasses.replace(
            self, data=np.asarray(data), metadata={**self.metadata, **metadata}
        )

    def select_pulses(self, start: int, stop: int) -> Traces:
        """Pulses ``start:stop`` with slow time re-centred (a sub-aperture)."""
        if not (0 <= start < stop <= self.n_pulses):
            raise ValueError(f"pulse range [{start}, {stop}) outside [0, {self.n_pulses})")
        return dataclasses.replace(
            self,
            data=self.data[start:stop],
            trajectory=self.trajectory.sub_aperture(start, stop),
        )
