"""The traces object: range-compressed complex-baseband data with its own axes."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .acquisition import Acquisition
from .geometry import LookGeometry, Trajectory, delta_tau
from .radar import Radar
from .spectral import shift_fast_time, to_fast_time, to_frequency

__all__ = ["Traces", "as_traces"]


@dataclass(frozen=True, kw_only=True, eq=False, init=False)
class Traces:
    """Pulse- and range-compressed traces ``D_r(s, t)`` (paper ``eq:rangecompress``).

    ``data[j, l]`` is the complex-baseband sample at slow time ``s_j`` and fast time
    ``t_l`` *relative to* the reference travel time ``tau(s_j, rho_o)``: a point at
    ``rho`` peaks at ``t = tau(s, rho) - tau(s, rho_o)`` with phase
    ``exp(-i omega_o (tau(s, rho) - tau(s, rho_o)))`` (see :mod:`sarmotion.core.spectral`).

    A :class:`Traces` is an :class:`~sarmotion.core.Acquisition` (trajectory, radar,
    reference point, with its geometry computed once) and one block of data on it:
    :meth:`with_data` pairs the same acquisition with other data.

    Parameters
    ----------
    data : (n_pulses, n_samples) array_like
        Complex traces (complex64 or complex128).
    acquisition : Acquisition, optional
        The acquisition; or give ``trajectory``, ``radar`` and ``reference_point_m``.
        With both, the parts given replace the acquisition's (a new acquisition).
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
    acquisition: Acquisition
    metadata: dict[str, Any] = field(default_factory=dict)

    def __init__(
        self,
        *,
        data: ArrayLike,
        acquisition: Acquisition | None = None,
        trajectory: Trajectory | None = None,
        radar: Radar | None = None,
        reference_point_m: ArrayLike | None = None,
        metadata: dict[str, Any] | None = None,
    ) -> None:
        parts = (trajectory, radar, reference_point_m)
        if acquisition is None:
            if any(p is None for p in parts):
                raise TypeError("give acquisition, or trajectory, radar and reference_point_m")
            acquisition = Acquisition(
                trajectory=trajectory, radar=radar, reference_point_m=reference_point_m
            )
        elif not isinstance(acquisition, Acquisition):
            raise TypeError(f"acquisition must be an Acquisition, got {type(acquisition).__name__}")
        elif any(p is not None for p in parts):  # e.g. dataclasses.replace(t, trajectory=...)
            acquisition = Acquisition(
                trajectory=acquisition.trajectory if trajectory is None else trajectory,
                radar=acquisition.radar if radar is None else radar,
                reference_point_m=(
                    acquisition.reference_point_m
                    if reference_point_m is None
                    else reference_point_m
                ),
            )
        d = np.asarray(data)
        if d.ndim != 2:
            raise ValueError(f"data must have shape (n_pulses, n_samples), got {d.shape}")
        if not np.iscomplexobj(d):
            d = d.astype(np.complex128)
        if d.shape[0] != acquisition.n_pulses:
            raise ValueError(
                f"data has {d.shape[0]} pulses but the trajectory has {acquisition.n_pulses}"
            )
        if d.shape[1] != acquisition.n_samples:
            raise ValueError(
                f"data has {d.shape[1]} fast-time samples but radar.n_samples is "
                f"{acquisition.n_samples}"
            )
        if not np.all(np.isfinite(d)):
            raise ValueError("data contains NaN or infinite values")
        object.__setattr__(self, "data", d)
        object.__setattr__(self, "acquisition", acquisition)
        object.__setattr__(self, "metadata", dict(metadata or {}))

    # ---------------------------------------------------------- acquisition
    @property
    def trajectory(self) -> Trajectory:
        """Antenna positions and slow times (:attr:`acquisition`'s)."""
        return self.acquisition.trajectory

    @property
    def radar(self) -> Radar:
        """Carrier, bandwidth and fast-time sampling (:attr:`acquisition`'s)."""
        return self.acquisition.radar

    @property
    def reference_point_m(self) -> NDArray[np.float64]:
        """Range-compression reference point ``rho_o`` (m), shape (3,), read-only."""
        return self.acquisition.reference_point_m

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
        return self.acquisition.slow_times_s

    @property
    def fast_times_s(self) -> NDArray[np.float64]:
        """Fast times ``t_l`` relative to ``tau(s, rho_o)`` (s), shape (n_samples,)."""
        return self.acquisition.fast_times_s

    @property
    def positions_m(self) -> NDArray[np.float64]:
        """Antenna positions (m), shape (n_pulses, 3)."""
        return self.acquisition.positions_m

    @property
    def frequencies_hz(self) -> NDArray[np.float64]:
        """Absolute frequencies of the spectrum bins (Hz), shape (n_samples,)."""
        return self.acquisition.frequencies_hz

    @property
    def geometry(self) -> LookGeometry:
        """Look geometry (``m_o``, ``t``, ``L``, ``V``) at the reference point (computed once)."""
        return self.acquisition.geometry

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
        return Traces(
            data=np.asarray(data),
            acquisition=self.acquisition,
            metadata={**self.metadata, **metadata},
        )

    def referenced_to(self, reference_point_m: ArrayLike) -> Traces:
        """The same traces range-compressed on another reference point ``rho_n`` (m).

        ``D_n(s, t) = D(s, t + tau(s, rho_n) - tau(s, rho_o))`` (the carrier phase
        included, :func:`~sarmotion.core.spectral.shift_fast_time`) on
        :meth:`Acquisition.with_reference_point`. The shift is circular over the
        fast-time window: a target whose delay relative to ``rho_n`` leaves the window
        wraps around, so ``rho_n`` should lie well inside the scene the window covers.
        """
        acquisition = self.acquisition.with_reference_point(reference_point_m)
        delays = delta_tau(self.positions_m, acquisition.reference_point_m, self.reference_point_m)
        data = shift_fast_time(self.data, delays, frequencies_hz=self.frequencies_hz)
        return Traces(data=data, acquisition=acquisition, metadata=self.metadata)

    def select_pulses(self, start: int, stop: int) -> Traces:
        """Pulses ``start:stop`` with slow time re-centred (a sub-aperture).

        Their acquisition is :meth:`Acquisition.sub_aperture`: the same pulses of the
        same acquisition share it.
        """
        if not (0 <= start < stop <= self.n_pulses):
            raise ValueError(f"pulse range [{start}, {stop}) outside [0, {self.n_pulses})")
        return Traces(
            data=self.data[start:stop],
            acquisition=self.acquisition.sub_aperture(start, stop),
            metadata=self.metadata,
        )


def as_traces(
    data: Traces | ArrayLike, acquisition: Acquisition | None = None, *, name: str = "data"
) -> Traces:
    """``data`` on its acquisition: the signature rule "data first, the acquisition as a keyword".

    Parameters
    ----------
    data : Traces or (n_pulses, n_samples) array_like
        A :class:`Traces` (its own acquisition), or an array on ``acquisition``.
    acquisition : Acquisition, optional
        Required with an array; with a :class:`Traces` it must be omitted or be the
        traces' own.
    name : str
        Parameter name in error messages.

    Returns
    -------
    Traces
    """
    if isinstance(data, Traces):
        if acquisition is not None and acquisition is not data.acquisition:
            raise ValueError(f"{name} is a Traces on another acquisition than `acquisition`")
        return data
    if acquisition is None:
        raise TypeError(f"{name} is an array: give its acquisition (acquisition=...)")
    if isinstance(acquisition, Traces):
        raise TypeError("acquisition must be an Acquisition (a Traces' .acquisition), not Traces")
    return Traces(data=np.asarray(data), acquisition=acquisition)
