"""Forward model: traces of point targets (paper ``eq:MOD1``, ``eq:Mdef``).

Each target moves on a straight line ``rho_q(s) = rho_q(0) + s u_q`` over the aperture
(``eq:MOD9``), or on a piecewise-straight path with turns and stops
(:class:`~sarmotion.simulation.paths.PathTarget`): the model asks of a target only its
positions ``rho_q(s)`` at the pulses (``positions_at``). Its pulse- and range-compressed
baseband trace is synthesised exactly in the frequency domain::

    P(s, f_k) = sum_q a_q(s) W(f_k) exp(-2i pi f_k dtau_q(s)),
    dtau_q(s) = tau(s, rho_q(s)) - tau(s, rho_o)          (eq:DeltaTau)

with ``W`` the compressed-pulse spectrum (:meth:`Radar.spectral_weights`) and
``a_q = sigma_q`` (the paper's constant-amplitude model ``eq:model``) or, with
``spreading=True``, ``a_q = sigma_q (L / |r(s) - rho_q(s)|)^2`` (the ``1/R^2``
factor of ``eq:MOD1`` normalised at the reference range ``L``). The fast-time traces
are the inverse transform (:func:`sarmotion.core.spectral.to_fast_time`); the displacement
of the target during the round trip is neglected, as in the paper.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import (
    Radar,
    Traces,
    Trajectory,
    as_point,
    delay_phase,
    delta_tau,
    to_fast_time,
)
from .scene import PointTarget, Scene

__all__ = ["Simulation", "simulate", "simulate_phase_history", "add_noise", "inject"]


def simulate_phase_history(
    targets: Sequence[PointTarget],
    trajectory: Trajectory,
    radar: Radar,
    reference_point_m: ArrayLike,
    *,
    spreading: bool = False,
) -> NDArray[np.complex128]:
    """Deramped phase history of point targets, shape (n_pulses, n_samples).

    Parameters
    ----------
    targets : sequence of PointTarget or PathTarget
        Targets (positions at ``s = 0`` in m, velocities in m/s; or paths).
    trajectory : Trajectory
        Antenna positions and slow times.
    radar : Radar
        Frequencies and pulse spectrum.
    reference_point_m : (3,) array_like
        Range-compression reference ``rho_o`` (m).
    spreading : bool
        Include the ``(L / R)^2`` amplitude decay.
    """
    rho_o = as_point(reference_point_m, name="reference_point_m")
    f = radar.frequencies_hz
    w = radar.spectral_weights()
    pos = trajectory.positions_m
    s = trajectory.slow_times_s
    L = float(np.linalg.norm(trajectory.centre_m - rho_o))
    out = np.zeros((trajectory.n_pulses, radar.n_samples), dtype=np.complex128)
    for tgt in targets:
        rho_s = tgt.positions_at(s)
        dtau = delta_tau(pos, rho_s, rho_o)
        amp = np.full(trajectory.n_pulses, tgt.reflectivity, dtype=np.complex128)
        if spreading:
            amp *= (L / np.linalg.norm(pos - rho_s, axis=1)) ** 2
        out += amp[:, None] * delay_phase(-dtau, f)
    out *= w[None, :]
    return out


def add_noise(
    data: ArrayLike, *, snr_db: float, rng: np.random.Generator | int | None = None
) -> NDArray[np.complex128]:
    """Return ``data`` plus circular complex white Gaussian noise.

    The noise variance is ``mean(|data|^2) / 10^(snr_db / 10)``: the SNR is the ratio of
    the mean signal power over the whole trace matrix to the noise power per sample.

    Parameters
    ----------
    data : (n_pulses, n_samples) array_like
        Noise-free traces.
    snr_db : float
        Signal-to-noise ratio (dB).
    rng : numpy.random.Generator or int, optional
        Random generator or seed.
    """
    d = np.asarray(data, dtype=np.complex128)
    if not np.isfinite(snr_db):
        raise ValueError(f"snr_db must be finite, got {snr_db!r}")
    gen = np.random.default_rng(rng)
    power = float(np.mean(np.abs(d) ** 2))
    sigma = np.sqrt(power / 10.0 ** (snr_db / 10.0) / 2.0)
    noise = sigma * (gen.standard_normal(d.shape) + 1j * gen.standard_normal(d.shape))
    return d + noise


@dataclass(frozen=True, kw_only=True, eq=False)
class Simulation:
    """A simulated acquisition with its ground truth.

    Attributes
    ----------
    traces : Traces
        The measured traces (all targets, plus noise if requested).
    stationary : (n_pulses, n_samples) ndarray
        Noise-free traces of the stationary targets alone (the true ``L``).
    moving : (n_pulses, n_samples) ndarray
        Noise-free traces of the moving targets alone (the true ``S``).
    scene : Scene
        The scene simulated.
    """

    traces: Traces
    stationary: NDArray[np.complex128]
    moving: NDArray[np.complex128]
    scene: Scene


def simulate(
    scene: Scene,
    *,
    trajectory: Trajectory | None = None,
    radar: Radar | None = None,
    spreading: bool = False,
    snr_db: float | None = None,
    rng: np.random.Generator | int | None = None,
) -> Simulation:
    """Simulate the traces of ``scene`` (``eq:MOD1``) with the stationary/moving truth.

    Parameters
    ----------
    scene : Scene
        Targets, reference point and default acquisition.
    trajectory, radar : optional
        Override the scene's acquisition.
    spreading : bool
        Include the geometric ``1/R^2`` amplitude decay.
    snr_db : float, optional
        Add white noise at this SNR (see :func:`add_noise`).
    rng : numpy.random.Generator or int, optional
        Random generator or seed for the noise.

    Returns
    -------
    Simulation
    """
    traj = trajectory if trajectory is not None else scene.trajectory()
    rad = radar if radar is not None else scene.radar
    ref = scene.reference_point_m
    stat = to_fast_time(
        simulate_phase_history(scene.stationary, traj, rad, ref, spreading=spreading)
    )
    mov = to_fast_time(simulate_phase_history(scene.moving, traj, rad, ref, spreading=spreading))
    data = stat + mov
    if snr_db is not None:
        data = add_noise(data, snr_db=snr_db, rng=rng)
    meta = {"source": "simulation", "scene": scene.name, "spreading": spreading}
    if snr_db is not None:
        meta["snr_db"] = float(snr_db)
    traces = Traces(data=data, trajectory=traj, radar=rad, reference_point_m=ref, metadata=meta)
    return Simulation(traces=traces, stationary=stat, moving=mov, scene=scene)


def inject(
    traces: Traces,
    targets: Sequence[PointTarget],
    *,
    spreading: bool = False,
) -> Traces:
    """Add simulated point targets (stationary or moving) to existing traces.

    The targets' traces are synthesised on the acquisition of ``traces`` (its antenna
    positions, slow times, frequencies and reference point) with :func:`simulate_phase_history`
    and added to the data: the way detection and estimation are measured on real clutter.

    Parameters
    ----------
    traces : Traces
        Measured (e.g. GOTCHA) traces.
    targets : sequence of PointTarget
        Targets to add; positions at ``s = 0`` (m) and ground velocities (m/s) in the
        data's own frame; reflectivities in the data's amplitude units.
    spreading : bool
        Include the ``(L / R)^2`` amplitude decay.

    Returns
    -------
    Traces
        New traces; ``metadata["injected"]`` lists the injected targets.
    """
    ph = simulate_phase_history(
        targets, traces.trajectory, traces.radar, traces.reference_point_m, spreading=spreading
    )
    added = to_fast_time(ph)
    record = [
        {
            "position_m": t.position_m.tolist(),
            "velocity_mps": t.velocity_mps.tolist(),
            "reflectivity": [t.reflectivity.real, t.reflectivity.imag],
        }
        for t in targets
    ]
    previous = list(traces.metadata.get("injected", []))
    data = traces.data.astype(np.result_type(traces.data.dtype, np.complex128)) + added
    return traces.with_data(data, injected=previous + record)
