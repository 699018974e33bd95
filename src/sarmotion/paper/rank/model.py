"""The trace model of the rank analysis: passband (the paper's ``eq:MOD8``) and baseband traces."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._validation import positive as _positive
from ...core import Radar, Trajectory, as_point, delta_tau, target_positions
from ...simulation import PointTarget

__all__ = ["fast_time_grid", "passband_traces", "baseband_traces"]


#: Default carrier (Hz): the GOTCHA centre frequency of :class:`~sarmotion.core.radar.Radar`.
Model = Literal["passband", "baseband"]

DEFAULT_CARRIER_HZ = Radar().carrier_hz


def _check_model(model: str) -> None:
    if model not in ("passband", "baseband"):
        raise ValueError(f"model must be 'passband' or 'baseband', got {model!r}")


def _as_velocity3(velocity: ArrayLike) -> NDArray[np.float64]:
    v = np.asarray(velocity, dtype=np.float64)
    if v.shape == (2,):
        v = np.array([v[0], v[1], 0.0])
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"velocity must be a finite (2,) or (3,) vector (m/s), got {velocity!r}")
    return v


def _normalise_targets(
    targets: Sequence[Any],
) -> list[tuple[NDArray[np.float64], NDArray[np.float64], complex]]:
    """``[(position (3,), velocity (3,), reflectivity)]`` from the accepted target forms."""
    if isinstance(targets, PointTarget):
        targets = [targets]
    out = []
    for i, item in enumerate(targets):
        if isinstance(item, PointTarget):
            out.append((item.position_m, item.velocity3_mps, item.reflectivity))
            continue
        if isinstance(item, (tuple, list)) and len(item) == 2 and np.ndim(item[0]) == 1:
            pos = as_point(item[0], name=f"targets[{i}] position")
            out.append((pos, _as_velocity3(item[1]), 1.0 + 0.0j))
            continue
        arr = np.asarray(item, dtype=np.float64)
        if arr.ndim == 1:
            out.append((as_point(arr, name=f"targets[{i}]"), np.zeros(3), 1.0 + 0.0j))
            continue
        raise TypeError(
            f"targets[{i}] must be a PointTarget, a (position, velocity) pair or a position, "
            f"got {item!r}"
        )
    if not out:
        raise ValueError("targets must hold at least one target")
    return out


def _delays(
    targets: Sequence[Any], trajectory: Trajectory, reference_point_m: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """Exact differential delays ``dtau_q(s_j)`` (s), shape (n_targets, n_pulses)."""
    rho_o = as_point(reference_point_m, name="reference_point_m")
    tg = _normalise_targets(targets)
    s = trajectory.slow_times_s
    dtau = np.stack(
        [delta_tau(trajectory.positions_m, target_positions(p, v, s), rho_o) for p, v, _ in tg]
    )
    amp = np.array([r for _, _, r in tg], dtype=np.complex128)
    return dtau, amp


# ------------------------------------------------------------------- trace models
def fast_time_grid(
    targets: Sequence[Any],
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    *,
    carrier_hz: float,
    bandwidth_hz: float,
    model: Model = "passband",
    samples_per_cycle: float = 4.0,
    n_widths: float = 6.0,
) -> NDArray[np.float64]:
    """Fast-time grid (s) that resolves the pulses and covers every trace.

    The window is ``[min dtau - n_widths/B, max dtau + n_widths/B]`` (the Gaussian envelope
    is ``exp(-n_widths^2/2)`` at its ends). The step is ``1 / (samples_per_cycle nu_o)``
    for ``"passband"`` (well below the Nyquist step ``1 / (2 nu_o)`` so that the Riemann
    sum ``eq:covar1p`` is the integral to ``~exp(-(pi (samples_per_cycle - 2) nu_o / B)^2)``)
    and ``1 / (2 B)`` for ``"baseband"`` (relative error ``~exp(-4 pi^2)``).

    Parameters
    ----------
    targets : sequence
        Targets as accepted by :func:`passband_traces`.
    trajectory : Trajectory
        Antenna positions and slow times.
    reference_point_m : (3,) array_like
        Reference point ``rho_o`` (m).
    carrier_hz, bandwidth_hz : float
        ``nu_o`` and ``B`` (Hz).
    model : {"passband", "baseband"}
        Which traces the grid is for.
    samples_per_cycle : float
        Passband samples per carrier period; must exceed 2.
    n_widths : float
        Margin in pulse widths ``1/B`` on both sides.

    Returns
    -------
    (n_samples,) ndarray
        Fast times relative to ``tau(s, rho_o)`` (s), uniformly spaced.
    """
    _check_model(model)
    nu = _positive(carrier_hz, "carrier_hz")
    bw = _positive(bandwidth_hz, "bandwidth_hz")
    if not samples_per_cycle > 2.0:
        raise ValueError(f"samples_per_cycle must exceed 2 (Nyquist), got {samples_per_cycle!r}")
    dtau, _ = _delays(targets, trajectory, reference_point_m)
    dt = 1.0 / (samples_per_cycle * nu) if model == "passband" else 0.5 / bw
    lo = float(dtau.min()) - n_widths / bw
    hi = float(dtau.max()) + n_widths / bw
    n = int(np.ceil((hi - lo) / dt)) + 1
    return lo + dt * np.arange(n, dtype=np.float64)


def _check_fast_times(fast_times_s: ArrayLike) -> NDArray[np.float64]:
    t = np.asarray(fast_times_s, dtype=np.float64)
    if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)):
        raise ValueError(f"fast_times_s must be a finite 1-D array of >= 2 times, got {t.shape}")
    return t


def passband_traces(
    targets: Sequence[Any],
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    *,
    carrier_hz: float,
    bandwidth_hz: float,
    fast_times_s: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """The paper's real matrix of traces ``M(s_j, t_l)`` (``eq:MOD8``, ``eq:TWO1``).

    ``M(s, t) = sum_q |sigma_q| cos(w_o (t - dtau_q(s)) + arg sigma_q)
    exp(-B^2 (t - dtau_q(s))^2 / 2)`` with the exact differential delay
    ``dtau_q(s) = tau(s, rho_q(s)) - tau(s, rho_o)`` (``eq:DeltaTau``, float64) and
    ``rho_q(s) = rho_q(0) + s u_q`` (``eq:MOD9``). Targets given as positions or
    ``(position, velocity)`` pairs have ``sigma = 1`` (the paper's equal reflectivities).

    Parameters
    ----------
    targets : sequence
        Each a :class:`~sarmotion.simulation.scene.PointTarget`, a ``(position_m, velocity_mps)``
        pair of (2,) or (3,) vectors (m, m/s), or a position (stationary target).
    trajectory : Trajectory
        Antenna positions (m) and slow times (s).
    reference_point_m : (3,) array_like
        Reference point ``rho_o`` (m).
    carrier_hz : float
        ``nu_o = w_o / (2 pi)`` (Hz).
    bandwidth_hz : float
        ``B`` (Hz) in ``exp(-B^2 t^2 / 2)``.
    fast_times_s : (n_samples,) array_like, optional
        Uniform fast-time grid (s); its step must resolve the carrier (``< 1 / (2 nu_o)``).
        Default: :func:`fast_time_grid` with the same arguments.

    Returns
    -------
    (n_pulses, n_samples) ndarray
        ``M``, float64. ``M M^T`` approximates ``(1/dt) int M(s, t) M(s', t) dt``
        (``eq:covar1p``), so it scales like ``1/dt``; the rank does not.

    Raises
    ------
    ValueError
        If the grid step does not resolve the carrier.
    """
    nu = _positive(carrier_hz, "carrier_hz")
    bw = _positive(bandwidth_hz, "bandwidth_hz")
    if fast_times_s is None:
        fast_times_s = fast_time_grid(
            targets, trajectory, reference_point_m, carrier_hz=nu, bandwidth_hz=bw
        )
    t = _check_fast_times(fast_times_s)
    dt = float(np.max(np.abs(np.diff(t))))
    if dt >= 0.5 / nu:
        raise ValueError(
            f"fast_times_s step {dt:.3g} s does not resolve the carrier: it must be below "
            f"1 / (2 carrier_hz) = {0.5 / nu:.3g} s"
        )
    dtau, amp = _delays(targets, trajectory, reference_point_m)
    w0 = 2.0 * np.pi * nu
    out = np.zeros((trajectory.n_pulses, t.size), dtype=np.float64)
    for d, a in zip(dtau, amp, strict=True):
        x = t[None, :] - d[:, None]
        out += abs(a) * np.cos(w0 * x + np.angle(a)) * np.exp(-0.5 * (bw * x) ** 2)
    return out


def baseband_traces(
    targets: Sequence[Any],
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    *,
    carrier_hz: float,
    bandwidth_hz: float,
    fast_times_s: ArrayLike | None = None,
) -> NDArray[np.complex128]:
    """Complex-baseband traces ``D(s, t) = sum_q sigma_q p(t - dtau_q) exp(-i w_o dtau_q)``.

    The direct fast-time formula of :func:`sarmotion.simulation.simulate` with
    ``Radar(pulse="gaussian")``, ``p(t) = exp(-B^2 t^2 / 2)``, on any grid and without
    the spectral truncation and circular wrap of the simulator.

    Parameters
    ----------
    targets, trajectory, reference_point_m, carrier_hz, bandwidth_hz
        As in :func:`passband_traces`.
    fast_times_s : (n_samples,) array_like, optional
        Fast-time grid (s); ``dt <~ 1/B`` suffices. Default: :func:`fast_time_grid` with
        ``model="baseband"``.

    Returns
    -------
    (n_pulses, n_samples) ndarray
        ``D``, complex128.
    """
    nu = _positive(carrier_hz, "carrier_hz")
    bw = _positive(bandwidth_hz, "bandwidth_hz")
    if fast_times_s is None:
        fast_times_s = fast_time_grid(
            targets,
            trajectory,
            reference_point_m,
            carrier_hz=nu,
            bandwidth_hz=bw,
            model="baseband",
        )
    t = _check_fast_times(fast_times_s)
    dtau, amp = _delays(targets, trajectory, reference_point_m)
    out = np.zeros((trajectory.n_pulses, t.size), dtype=np.complex128)
    for d, a in zip(dtau, amp, strict=True):
        cycles = nu * d
        cycles = cycles - np.round(cycles)
        phase = a * np.exp(-2j * np.pi * cycles)
        out += phase[:, None] * np.exp(-0.5 * (bw * (t[None, :] - d[:, None])) ** 2)
    return out
