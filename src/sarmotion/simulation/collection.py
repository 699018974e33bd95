"""Large simulated collections, computed a block of pulses at a time.

A *collection* is a square scene of side ``L`` seen by a GOTCHA-like circular spotlight
(:meth:`~sarmotion.core.geometry.Trajectory.circular`, one degree by default) sampled for
the whole scene (:func:`collection_acquisition`):

- **fast time**: a slant-range window of ``guard x L cos(el)`` (``el`` the elevation at
  the aperture centre: the ground extent ``guard x L`` seen in slant range), or more to
  reach ``n_samples`` (:func:`~sarmotion.simulation.paths.radar_with_range_window`);
- **slow time**: an angular pulse spacing ``dtheta <= lambda / (2 W)`` for a cross-range
  extent ``W = guard x L``, with ``dtheta = cos(el) dphi`` the line-of-sight rotation per
  pulse for an azimuth step ``dphi`` of the circle, or more pulses to reach ``n_pulses``
  (a higher pulse rate over the same aperture).

:class:`CollectionScene` holds the targets and serves the traces block by block (the
:class:`~sarmotion.core.blocks.PulseBlocks` protocol): each block is the forward model of
:func:`~sarmotion.simulation.forward.simulate_phase_history` on its pulses, plus white
noise, so the whole phase history is never held. Every pulse is computed on its own, so a
block equals the same rows of the whole simulation whatever the block size, noise
included: pulse ``j``'s noise is drawn from its own generator, seeded by ``(seed, j)``.

Noise level
    ``snr_db`` is the signal-to-noise ratio per phase-history sample *of one unit point
    target*: noise of variance ``sigma^2 = mean(W^2) / 10^(snr_db / 10)`` (``W`` the
    compressed-pulse spectrum, :meth:`~sarmotion.core.radar.Radar.spectral_weights`),
    circular complex Gaussian. Unlike :func:`~sarmotion.simulation.forward.add_noise`
    (relative to the mean power of the whole traces) it does not depend on the number of
    targets, so scenes of different sizes at one density have the same per-target SNR.

:func:`random_collection` draws a seeded scene: stationary unit points uniform in the
square at a stated density, and movers of random ground velocity, some placed within a
few metres of given lines and their crossings (the patch borders and corners of a plan,
which the caller computes: this layer imports no analysis).
"""

from __future__ import annotations

import functools
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import (
    Acquisition,
    C,
    Radar,
    Traces,
    Trajectory,
    to_fast_time,
)
from ..core.blocks import check_block_pulses
from .echoes import point_echoes
from .paths import radar_with_range_window
from .scene import PointTarget

__all__ = [
    "DENSITY_PER_M2",
    "CollectionScene",
    "collection_acquisition",
    "random_collection",
]

#: Stationary points per square metre of the constant-density scenes (0.5 per 1000 m^2).
DENSITY_PER_M2 = 0.5e-3

#: Extent sampled around the scene, as a multiple of its side, in range and cross range.
GUARD = 1.3

#: Schema of :meth:`CollectionScene.truth`.
TRUTH_SCHEMA = "sarmotion.collection-truth/1"


def _cos_elevation(trajectory: Trajectory, point_m: NDArray[np.float64]) -> float:
    """Cosine of the elevation of the aperture centre seen from ``point_m``."""
    d = trajectory.centre_m - point_m
    return float(np.hypot(d[0], d[1]) / np.linalg.norm(d))


def collection_acquisition(
    side_m: float,
    *,
    guard: float = GUARD,
    n_pulses: int | None = None,
    n_samples: int | None = None,
    aperture_deg: float = 1.0,
    radar: Radar | None = None,
) -> Acquisition:
    """A circular spotlight sampled for a square scene of side ``side_m`` (module notes).

    Parameters
    ----------
    side_m : float
        Side ``L`` of the scene (m), centred on the origin, the reference point.
    guard : float
        Extent sampled, as a multiple of ``L`` (>= 1).
    n_pulses, n_samples : int, optional
        Least numbers of pulses and fast-time samples: more than the scene needs means a
        higher pulse rate over the same aperture, a longer range window.
    aperture_deg : float
        Azimuth extent of the circular flight (degrees).
    radar : Radar, optional
        The band (default GOTCHA's); its frequency step is made fine enough.

    Returns
    -------
    Acquisition
        Trajectory, radar and the reference point (the origin).
    """
    if not (np.isfinite(side_m) and side_m > 0):
        raise ValueError(f"side_m must be a positive number (m), got {side_m!r}")
    if not (np.isfinite(guard) and guard >= 1.0):
        raise ValueError(f"guard must be >= 1, got {guard!r}")
    origin = np.zeros(3)
    base = Radar() if radar is None else radar
    probe = Trajectory.circular(aperture_deg=aperture_deg)
    cos_el = _cos_elevation(probe, origin)
    window = guard * side_m * cos_el
    if n_samples is not None:
        window = max(window, int(n_samples) * C / (2.0 * base.span_hz))
    wide = radar_with_range_window(window, radar=base)
    needed = np.deg2rad(aperture_deg) * cos_el * 2.0 * guard * side_m / wide.wavelength_m
    count = max(int(np.ceil(needed)), int(n_pulses or 0), 2)
    trajectory = Trajectory.circular(
        pulses_per_deg=count / aperture_deg, aperture_deg=aperture_deg, n_pulses=count
    )
    return Acquisition(trajectory=trajectory, radar=wide, reference_point_m=origin)


@dataclass(frozen=True, kw_only=True, eq=False)
class CollectionScene:
    """Point targets seen by an acquisition, served block by block with noise.

    Implements :class:`~sarmotion.core.blocks.PulseBlocks`.

    Attributes
    ----------
    acquisition : Acquisition
        Trajectory, radar, reference point.
    stationary : tuple of PointTarget
        The stationary targets.
    movers : tuple of PointTarget
        The moving targets (positions at ``s = 0``, the aperture centre).
    snr_db : float or None
        Per-sample SNR of a unit point target (dB, module notes); ``None``: no noise.
    seed : int
        Seed of the noise (pulse ``j`` draws from ``default_rng((seed, j))``).
    metadata : dict
        Provenance (JSON-serialisable), carried by the traces and files.
    """

    acquisition: Acquisition
    stationary: tuple[PointTarget, ...]
    movers: tuple[PointTarget, ...]
    snr_db: float | None = None
    seed: int = 0
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.acquisition, Acquisition):
            raise TypeError(
                f"acquisition must be an Acquisition, got {type(self.acquisition).__name__}"
            )
        object.__setattr__(self, "stationary", tuple(self.stationary))
        object.__setattr__(self, "movers", tuple(self.movers))
        for t in (*self.stationary, *self.movers):
            if not isinstance(t, PointTarget):
                raise TypeError(f"targets must be PointTarget, got {type(t).__name__}")
        if self.snr_db is not None and not np.isfinite(self.snr_db):
            raise ValueError(f"snr_db must be finite or None, got {self.snr_db!r}")

    @functools.cached_property
    def _target_arrays(
        self,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.complex128]]:
        """All targets' positions at ``s = 0`` (n, 3), velocities (n, 3), reflectivities (n,)."""
        targets = (*self.stationary, *self.movers)
        if not targets:
            return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, dtype=np.complex128)
        return (
            np.array([t.position_m for t in targets], dtype=np.float64),
            np.array([t.velocity3_mps for t in targets], dtype=np.float64),
            np.array([t.reflectivity for t in targets], dtype=np.complex128),
        )

    # ------------------------------------------------------------ PulseBlocks
    @property
    def radar(self) -> Radar:
        """The radar."""
        return self.acquisition.radar

    @property
    def trajectory(self) -> Trajectory:
        """The antenna positions and slow times of every pulse."""
        return self.acquisition.trajectory

    @property
    def reference_point_m(self) -> NDArray[np.float64]:
        """The range-compression reference point ``rho_o`` (m)."""
        return self.acquisition.reference_point_m

    @property
    def n_pulses(self) -> int:
        """Number of pulses."""
        return self.acquisition.n_pulses

    @property
    def noise_sigma(self) -> float:
        """Standard deviation of the noise per phase-history sample (complex), 0 without."""
        if self.snr_db is None:
            return 0.0
        power = float(np.mean(self.radar.spectral_weights() ** 2))
        return float(np.sqrt(power / 10.0 ** (self.snr_db / 10.0)))

    def phase_history(self, start: int, stop: int) -> NDArray[np.complex128]:
        """Deramped phase history of pulses ``start:stop``, shape (stop - start, n_samples).

        The rows of :func:`~sarmotion.simulation.forward.simulate_phase_history` for all
        targets (no spreading; summed by the compiled
        :func:`~sarmotion.simulation.echoes.point_echoes`), plus each pulse's noise.
        """
        if not 0 <= start < stop <= self.n_pulses:
            raise ValueError(f"pulses {start}:{stop} are not within 0:{self.n_pulses}")
        radar = self.radar
        f = radar.frequencies_hz
        pos = self.trajectory.positions_m[start:stop]
        s = self.trajectory.slow_times_s[start:stop]
        positions, velocities, reflectivities = self._target_arrays
        out = point_echoes(pos, s, positions, velocities, reflectivities, self.reference_point_m, f)
        out *= radar.spectral_weights()[None, :]
        sigma = self.noise_sigma
        if sigma > 0:
            scale = sigma / np.sqrt(2.0)
            for j in range(start, stop):
                gen = np.random.default_rng((self.seed, j))
                noise = gen.standard_normal((2, radar.n_samples))
                out[j - start] += scale * (noise[0] + 1j * noise[1])
        return out

    def blocks(self, block_pulses: int) -> Iterator[tuple[int, int, NDArray[np.complex128]]]:
        """Yield ``(start, stop, traces[start:stop])`` in the Traces convention (fast time)."""
        step = check_block_pulses(block_pulses)
        for start in range(0, self.n_pulses, step):
            stop = min(start + step, self.n_pulses)
            yield start, stop, to_fast_time(self.phase_history(start, stop))

    # -------------------------------------------------------------- in memory
    def traces(self) -> Traces:
        """The whole acquisition in memory (for scenes that fit)."""
        return Traces(
            data=to_fast_time(self.phase_history(0, self.n_pulses)),
            acquisition=self.acquisition,
            metadata=dict(self.metadata),
        )

    def truth(self) -> dict[str, Any]:
        """JSON-ready ground truth: the targets at ``s = 0`` and the acquisition."""
        radar, traj = self.radar, self.trajectory

        def mover(t: PointTarget) -> dict[str, Any]:
            return {
                "label": t.label,
                "position_m": [float(v) for v in t.position_m[:2]],
                "velocity_mps": [float(v) for v in t.velocity_mps],
                "reflectivity": [float(t.reflectivity.real), float(t.reflectivity.imag)],
            }

        return {
            "schema": TRUTH_SCHEMA,
            "time_reference": "positions at slow time s = 0, the aperture centre",
            "metadata": dict(self.metadata),
            "acquisition": {
                "n_pulses": int(traj.n_pulses),
                "n_samples": int(radar.n_samples),
                "carrier_hz": radar.carrier_hz,
                "bandwidth_hz": radar.bandwidth_hz,
                "frequency_step_hz": radar.frequency_step_hz,
                "pulse_interval_s": traj.pulse_interval_s,
                "reference_point_m": [float(v) for v in self.reference_point_m],
            },
            "snr_db": self.snr_db,
            "snr_definition": "per phase-history sample, of one unit point target",
            "noise_sigma": self.noise_sigma,
            "noise_seed": int(self.seed),
            "stationary": [
                {
                    "position_m": [float(v) for v in t.position_m[:2]],
                    "reflectivity": [float(t.reflectivity.real), float(t.reflectivity.imag)],
                }
                for t in self.stationary
            ],
            "movers": [mover(t) for t in self.movers],
        }


def _near(
    rng: np.random.Generator,
    lines: tuple[NDArray[np.float64], NDArray[np.float64]],
    kind: str,
    inner: float,
    offset_m: float,
) -> NDArray[np.float64]:
    """A point within ``offset_m`` of a crossing (``"corner"``) or a line (``"border"``)."""
    xs, ys = lines
    jitter = rng.uniform(-offset_m, offset_m, 2)
    if kind == "corner":
        return np.array([rng.choice(xs), rng.choice(ys)]) + jitter
    on_x = xs.size > 0 and (ys.size == 0 or rng.random() < 0.5)
    if on_x:
        return np.array([rng.choice(xs) + jitter[0], rng.uniform(-inner, inner)])
    return np.array([rng.uniform(-inner, inner), rng.choice(ys) + jitter[1]])


def random_collection(
    acquisition: Acquisition,
    side_m: float,
    *,
    seed: int,
    density_per_m2: float = DENSITY_PER_M2,
    n_movers: int = 8,
    speed_range_mps: tuple[float, float] = (5.0, 15.0),
    lines_m: tuple[Sequence[float], Sequence[float]] | None = None,
    n_corner: int = 0,
    n_border: int = 0,
    offset_m: float = 2.0,
    min_separation_m: float = 30.0,
    snr_db: float | None = None,
) -> CollectionScene:
    """A seeded constant-density scene of side ``side_m`` (module notes).

    Parameters
    ----------
    acquisition : Acquisition
        The acquisition (:func:`collection_acquisition`).
    side_m : float
        Side of the square scene, centred on the origin (m).
    seed : int
        Seed of the draw and of the noise.
    density_per_m2 : float
        Stationary unit points per m^2 (``round(density L^2)`` points, uniform).
    n_movers : int
        Number of movers: unit amplitude, random phase, ground speed uniform in
        ``speed_range_mps``, direction uniform.
    lines_m : (xs, ys), optional
        Lines ``x = xs[i]`` and ``y = ys[j]`` (m), such as a patch plan's inner borders.
    n_corner, n_border : int
        Movers placed within ``offset_m`` (m, in x and y) of a crossing of the lines,
        and of a line at a uniform position along it; the others are uniform.
    min_separation_m : float
        Least distance between two movers at ``s = 0`` (m).
    snr_db : float, optional
        Per-sample SNR of a unit point target (dB); ``None``: no noise.

    Returns
    -------
    CollectionScene
        Movers labelled ``"mover k (corner|border|interior)"``; metadata names the draw.
    """
    if n_corner + n_border > n_movers:
        raise ValueError(f"n_corner + n_border ({n_corner + n_border}) exceeds n_movers")
    xs, ys = (np.asarray(v, dtype=np.float64) for v in (lines_m or ((), ())))
    if (n_corner and (not xs.size or not ys.size)) or (n_border and not (xs.size or ys.size)):
        raise ValueError("movers near lines need lines_m")
    rng = np.random.default_rng(seed)
    half = 0.5 * side_m
    n_stat = int(round(density_per_m2 * side_m**2))
    stationary = tuple(PointTarget(position_m=p) for p in rng.uniform(-half, half, (n_stat, 2)))
    s = acquisition.slow_times_s
    # a mover stays inside the scene over the aperture, 10 m from its edge
    inner = half - (speed_range_mps[1] * float(np.max(np.abs(s))) + 10.0)
    if inner <= 0:
        raise ValueError(f"a {side_m:g} m scene cannot hold movers of {speed_range_mps[1]} m/s")
    kinds = ["corner"] * n_corner + ["border"] * n_border
    kinds += ["interior"] * (n_movers - len(kinds))
    movers: list[PointTarget] = []
    for k, kind in enumerate(kinds):
        for _ in range(10_000):
            if kind == "interior":
                p = rng.uniform(-inner, inner, 2)
            else:
                p = _near(rng, (xs, ys), kind, inner, offset_m)
            inside = bool(np.all(np.abs(p) <= inner))
            apart = all(np.hypot(*(p - m.position_m[:2])) >= min_separation_m for m in movers)
            if inside and apart:
                break
        else:
            raise ValueError(f"no place for mover {k + 1} ({kind}) in a {side_m:g} m scene")
        speed = rng.uniform(*speed_range_mps)
        phi = rng.uniform(0.0, 2.0 * np.pi)
        movers.append(
            PointTarget(
                position_m=p,
                velocity_mps=speed * np.array([np.cos(phi), np.sin(phi)]),
                reflectivity=np.exp(2j * np.pi * rng.random()),
                label=f"mover {k + 1} ({kind})",
            )
        )
    metadata = {
        "source": "simulation",
        "scene": f"collection-{side_m:g}m-seed{seed}",
        "side_m": float(side_m),
        "density_per_m2": float(density_per_m2),
        "seed": int(seed),
    }
    return CollectionScene(
        acquisition=acquisition,
        stationary=stationary,
        movers=tuple(movers),
        snr_db=snr_db,
        seed=seed,
        metadata=metadata,
    )
