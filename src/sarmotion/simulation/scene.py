"""Scenes of point targets and their acquisition, with a documented TOML file format.

Scene file schema (``schema = "sarmotion.scene/1"``), all SI units::

    schema = "sarmotion.scene/1"
    name = "scene1"                      # optional, defaults to the file stem
    description = "..."                  # optional
    reference_point_m = [0.0, 0.0]       # rho_o, [x, y] or [x, y, z] (m); default origin

    [trajectory]                         # optional; defaults to a GOTCHA 1-degree circle
    kind = "circular"                    # "circular" or "linear"
    # circular: aperture_deg, altitude_m, ground_radius_m, speed_mps, pulses_per_deg,
    #           centre_azimuth_deg, n_pulses
    # linear:   centre_m, direction, speed_mps, aperture_m, pulse_spacing_m

    [radar]                              # optional; defaults to GOTCHA X band
    # carrier_hz, bandwidth_hz, n_samples, frequency_step_hz, pulse ("rect"|"gaussian")

    [[targets]]                          # one table per point target
    position_m = [x, y]                  # position at s = 0 (aperture centre), m
    velocity_mps = [ux, uy]              # ground velocity, m/s; default [0, 0]
    amplitude = 1.0                      # |sigma| > 0; default 1
    phase_deg = 0.0                      # arg(sigma) in degrees; default 0
    label = "mover A"                    # optional

Any other key is an error that names the key and the file.

Limits, checked from the file before any array is built: the simulation's memory (the
phase histories of the stationary and of the moving targets, ``n_pulses x n_samples``
complex128 each, with their working copies) within the memory limit of
:mod:`sarmotion._limits` (``--max-memory``), and its work, ``n_pulses x n_samples x
n_targets`` terms of the forward model, at most :data:`MAX_SIMULATION_TERMS`; and the
file itself at most :data:`MAX_SCENE_FILE_BYTES`, checked before it is parsed.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._limits import over_budget, phase_history_bytes
from ..core import Radar, Trajectory, as_point, target_positions
from ..core.geometry import GOTCHA_PULSES_PER_DEG
from ..errors import InputError

__all__ = [
    "PointTarget",
    "Scene",
    "SceneError",
    "builtin_scene_names",
    "load_scene",
    "random_scene",
]

SCHEMA = "sarmotion.scene/1"
#: Most terms (pulse x sample x target) of the forward model a scene may ask for: a
#: full 360-degree GOTCHA circle (42 120 pulses of 424 samples) with 500 targets.
MAX_SIMULATION_TERMS = 10**10
#: Largest scene file (bytes). At GOTCHA sampling (117 pulses of 424 samples, one degree)
#: the work limit admits 2e5 targets, about 6 MB of ``[[targets]]`` tables of 30 bytes.
MAX_SCENE_FILE_BYTES = 16 * 2**20
_TOP_KEYS = {"schema", "name", "description", "reference_point_m", "trajectory", "radar", "targets"}
_TARGET_KEYS = {"position_m", "velocity_mps", "amplitude", "phase_deg", "label"}
_CIRCULAR_KEYS = {
    "kind",
    "aperture_deg",
    "altitude_m",
    "ground_radius_m",
    "speed_mps",
    "pulses_per_deg",
    "centre_azimuth_deg",
    "n_pulses",
}
_LINEAR_KEYS = {"kind", "centre_m", "direction", "speed_mps", "aperture_m", "pulse_spacing_m"}
_RADAR_KEYS = {"carrier_hz", "bandwidth_hz", "n_samples", "frequency_step_hz", "pulse"}


class SceneError(InputError):
    """A scene description is invalid; the message names the key and the value."""


@dataclass(frozen=True, kw_only=True, eq=False)
class PointTarget:
    """A point reflector moving on a straight line over the aperture (``eq:MOD9``).

    Parameters
    ----------
    position_m : (2,) or (3,) array_like
        Position ``rho(0)`` at the aperture centre ``s = 0`` (m).
    velocity_mps : (2,) array_like
        Ground velocity ``(ux, uy)`` (m/s); zero for a stationary target.
    reflectivity : complex
        Complex reflectivity ``sigma`` (dimensionless amplitude).
    label : str
        Optional name.
    """

    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64] = field(default_factory=lambda: np.zeros(2))
    reflectivity: complex = 1.0 + 0.0j
    label: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "position_m", as_point(self.position_m, name="position_m"))
        v = np.asarray(self.velocity_mps, dtype=np.float64)
        if v.shape == (3,) and v[2] == 0.0:
            v = v[:2]
        if v.shape != (2,) or not np.all(np.isfinite(v)):
            raise ValueError(f"velocity_mps must be a finite ground velocity (ux, uy), got {v}")
        object.__setattr__(self, "velocity_mps", v)
        r = complex(self.reflectivity)
        if not np.isfinite(r):
            raise ValueError(f"reflectivity must be finite, got {r}")
        object.__setattr__(self, "reflectivity", r)

    @property
    def is_moving(self) -> bool:
        """True when the ground velocity is non-zero."""
        return bool(np.any(self.velocity_mps != 0.0))

    @property
    def velocity3_mps(self) -> NDArray[np.float64]:
        """Velocity lifted to 3-D ``(ux, uy, 0)`` (m/s)."""
        return np.array([self.velocity_mps[0], self.velocity_mps[1], 0.0])

    def positions_at(self, slow_times_s: ArrayLike) -> NDArray[np.float64]:
        """Positions ``rho(s) = rho(0) + s u`` at the slow times (m), shape (n, 3)."""
        return target_positions(self.position_m, self.velocity3_mps, slow_times_s)


@dataclass(frozen=True, kw_only=True, eq=False)
class Scene:
    """Point targets, reference point and acquisition of a simulated scene.

    Parameters
    ----------
    name : str
        Scene name.
    targets : tuple of PointTarget
        The targets.
    reference_point_m : (3,) array_like
        Range-compression reference point ``rho_o`` (m).
    trajectory_spec : dict
        Keyword arguments of :meth:`Trajectory.circular` or :meth:`Trajectory.linear`,
        with ``kind``.
    radar : Radar
        Radar parameters.
    description : str
        Free text.
    """

    name: str
    targets: tuple[PointTarget, ...]
    reference_point_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    trajectory_spec: dict[str, Any] = field(default_factory=lambda: {"kind": "circular"})
    radar: Radar = field(default_factory=Radar)
    description: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "reference_point_m", as_point(self.reference_point_m, name="reference_point_m")
        )
        object.__setattr__(self, "targets", tuple(self.targets))

    @property
    def stationary(self) -> tuple[PointTarget, ...]:
        """The stationary targets."""
        return tuple(t for t in self.targets if not t.is_moving)

    @property
    def moving(self) -> tuple[PointTarget, ...]:
        """The moving targets."""
        return tuple(t for t in self.targets if t.is_moving)

    def trajectory(self) -> Trajectory:
        """Build the platform trajectory described by :attr:`trajectory_spec`."""
        spec = dict(self.trajectory_spec)
        kind = spec.pop("kind", "circular")
        if kind == "circular":
            return Trajectory.circular(**spec)
        if kind == "linear":
            return Trajectory.linear(**spec)
        raise SceneError(f"trajectory.kind must be 'circular' or 'linear', got {kind!r}")

    # ------------------------------------------------------------- parsing
    @classmethod
    def from_dict(cls, raw: dict[str, Any], *, source: str = "scene") -> Scene:
        """Parse a scene from the dictionary form of the file schema (see module doc)."""
        if not isinstance(raw, dict):
            raise SceneError(f"{source}: expected a table at top level, got {type(raw).__name__}")
        _check_keys(raw, _TOP_KEYS, source, "")
        schema = raw.get("schema", SCHEMA)
        if schema != SCHEMA:
            raise SceneError(f"{source}: schema must be {SCHEMA!r}, got {schema!r}")
        name = str(raw.get("name", Path(source).stem))
        ref = _vector(raw.get("reference_point_m", [0.0, 0.0]), source, "reference_point_m", 3)

        traj = dict(raw.get("trajectory", {}))
        kind = traj.get("kind", "circular")
        if kind not in ("circular", "linear"):
            raise SceneError(
                f"{source}: trajectory.kind must be 'circular' or 'linear', got {kind!r}"
            )
        _check_keys(
            traj, _CIRCULAR_KEYS if kind == "circular" else _LINEAR_KEYS, source, "trajectory."
        )
        traj["kind"] = kind
        for key, value in traj.items():
            if key in ("centre_m", "direction"):
                traj[key] = _vector(value, source, f"trajectory.{key}", 3).tolist()
            elif key == "n_pulses":
                traj[key] = _integer(value, source, f"trajectory.{key}")
            elif key != "kind":
                traj[key] = _number(value, source, f"trajectory.{key}")

        radar_raw = dict(raw.get("radar", {}))
        _check_keys(radar_raw, _RADAR_KEYS, source, "radar.")
        for key, value in radar_raw.items():
            if key == "n_samples":
                radar_raw[key] = _integer(value, source, "radar.n_samples")
            elif key != "pulse":
                radar_raw[key] = _number(value, source, f"radar.{key}")
        try:
            radar = Radar(**radar_raw)
        except ValueError as exc:
            raise SceneError(f"{source}: radar: {exc}") from None

        raw_targets = raw.get("targets", [])
        if not isinstance(raw_targets, list) or not raw_targets:
            raise SceneError(f"{source}: targets must be a non-empty array of tables")
        _check_size(traj, radar, len(raw_targets), source)
        targets = []
        for i, t in enumerate(raw_targets):
            where = f"targets[{i}]"
            if not isinstance(t, dict):
                raise SceneError(f"{source}: {where} must be a table, got {t!r}")
            _check_keys(t, _TARGET_KEYS, source, f"{where}.")
            if "position_m" not in t:
                raise SceneError(f"{source}: {where}.position_m is missing")
            pos = _vector(t["position_m"], source, f"{where}.position_m", 3)
            vel = _vector(t.get("velocity_mps", [0.0, 0.0]), source, f"{where}.velocity_mps", 2)
            amp = _number(t.get("amplitude", 1.0), source, f"{where}.amplitude")
            if amp <= 0:
                raise SceneError(
                    f"{source}: {where}.amplitude must be > 0 (the modulus |sigma|; a sign "
                    f"or phase goes in phase_deg), got {amp:g}"
                )
            phase = _number(t.get("phase_deg", 0.0), source, f"{where}.phase_deg")
            targets.append(
                PointTarget(
                    position_m=pos,
                    velocity_mps=vel[:2],
                    reflectivity=amp * np.exp(1j * np.deg2rad(phase)),
                    label=str(t.get("label", "")),
                )
            )
        scene = cls(
            name=name,
            targets=tuple(targets),
            reference_point_m=ref,
            trajectory_spec=traj,
            radar=radar,
            description=str(raw.get("description", "")),
        )
        try:
            scene.trajectory()
        except (TypeError, ValueError) as exc:
            raise SceneError(f"{source}: trajectory: {exc}") from None
        return scene

    @classmethod
    def from_file(cls, path: str | Path) -> Scene:
        """Read a scene TOML file (schema in the module docstring)."""
        p = Path(path)
        if not p.is_file():
            raise SceneError(f"scene file not found: {p}")
        if p.stat().st_size > MAX_SCENE_FILE_BYTES:
            raise SceneError(
                f"{p}: {p.stat().st_size} bytes; a scene file holds at most "
                f"{MAX_SCENE_FILE_BYTES} (the work limit of the simulation)"
            )
        try:
            raw = tomllib.loads(p.read_text(encoding="utf-8"))
        except UnicodeDecodeError as exc:
            raise SceneError(
                f"{p}: not a TOML scene file: not UTF-8 text (byte {exc.start})"
            ) from None
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(f"{p}: not a valid TOML scene file ({exc})") from None
        return cls.from_dict(raw, source=str(p))

    def to_dict(self) -> dict[str, Any]:
        """Dictionary form of the file schema (inverse of :meth:`from_dict`)."""
        radar = self.radar
        return {
            "schema": SCHEMA,
            "name": self.name,
            "description": self.description,
            "reference_point_m": self.reference_point_m.tolist(),
            "trajectory": dict(self.trajectory_spec),
            "radar": {
                "carrier_hz": radar.carrier_hz,
                "bandwidth_hz": radar.bandwidth_hz,
                "n_samples": radar.n_samples,
                "frequency_step_hz": radar.frequency_step_hz,
                "pulse": radar.pulse,
            },
            "targets": [
                {
                    "position_m": t.position_m.tolist(),
                    "velocity_mps": t.velocity_mps.tolist(),
                    "amplitude": abs(t.reflectivity),
                    "phase_deg": float(np.rad2deg(np.angle(t.reflectivity))),
                    "label": t.label,
                }
                for t in self.targets
            ],
        }


def _pulse_count(spec: dict[str, Any]) -> int | None:
    """Pulses the trajectory ``spec`` will hold (the rules of ``Trajectory``), or None."""
    with np.errstate(all="ignore"):
        if spec.get("kind", "circular") == "circular":
            if "n_pulses" in spec:
                return int(spec["n_pulses"])
            n = float(spec.get("aperture_deg", 1.0)) * float(
                spec.get("pulses_per_deg", GOTCHA_PULSES_PER_DEG)
            )
        else:
            n = float(spec.get("aperture_m", 400.0)) / float(spec.get("pulse_spacing_m", 1.055))
            n += 1.0
    return int(round(n)) if np.isfinite(n) and n > 0 else None


def _check_size(spec: dict[str, Any], radar: Radar, n_targets: int, source: str) -> None:
    """The scene's memory and work limits (module notes), before anything is built."""
    n = _pulse_count(spec)
    if n is None or n < 1:
        return  # Trajectory refuses it with its own message
    m = radar.n_samples
    terms = n * m * n_targets
    if terms > MAX_SIMULATION_TERMS:
        raise SceneError(
            f"{source}: simulating it takes {n} pulses x {m} samples x {n_targets} targets = "
            f"{terms:.3g} terms, over the limit of {MAX_SIMULATION_TERMS:.0e} (a full GOTCHA "
            "circle with 500 targets)"
        )
    nbytes = 2 * phase_history_bytes(n, m) + 4 * 24 * n
    reason = over_budget(nbytes, f"{n} pulses x {m} samples, complex128, with working copies")
    if reason:
        raise SceneError(f"{source}: {reason.replace('reading', 'simulating')}")


def _check_keys(table: dict[str, Any], allowed: set[str], source: str, prefix: str) -> None:
    for key in table:
        if key not in allowed:
            raise SceneError(
                f"{source}: unknown key '{prefix}{key}' (expected one of: "
                f"{', '.join(sorted(allowed))})"
            )


def _number(value: Any, source: str, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise SceneError(f"{source}: {key} must be a finite number, got {value!r}")
    return float(value)


def _integer(value: Any, source: str, key: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise SceneError(f"{source}: {key} must be an integer, got {value!r}")
    return int(value)


def _vector(value: Any, source: str, key: str, max_len: int) -> NDArray[np.float64]:
    ok = isinstance(value, (list, tuple)) and 2 <= len(value) <= max_len
    if ok:
        try:
            arr = np.array([_number(v, source, key) for v in value], dtype=np.float64)
        except SceneError:
            ok = False
    if not ok:
        shape = "[x, y]" if max_len == 2 else "[x, y] or [x, y, z]"
        raise SceneError(f"{source}: {key} must be {shape} numbers, got {value!r}")
    return arr


def builtin_scene_names() -> list[str]:
    """Names of the scenes shipped with the package (the paper's examples)."""
    files = resources.files("sarmotion.simulation").joinpath("scenes")
    return sorted(p.name.removesuffix(".toml") for p in files.iterdir() if p.name.endswith(".toml"))


def load_scene(name_or_path: str | Path) -> Scene:
    """Load a built-in scene by name (e.g. ``"scene1"``) or a scene TOML file by path."""
    text = str(name_or_path)
    if text in builtin_scene_names():
        res = resources.files("sarmotion.simulation").joinpath("scenes", f"{text}.toml")
        raw = tomllib.loads(res.read_text(encoding="utf-8"))
        return Scene.from_dict(raw, source=f"built-in scene {text!r}")
    p = Path(text)
    if p.suffix.lower() != ".toml" and not p.exists():
        raise SceneError(
            f"unknown scene {text!r}: not a built-in scene ({', '.join(builtin_scene_names())}) "
            "and not a file"
        )
    return Scene.from_file(p)


def random_scene(
    *,
    n_stationary: int,
    movers: list[tuple[ArrayLike, ArrayLike]] | None = None,
    extent_m: float = 50.0,
    rng: np.random.Generator | int | None = None,
    name: str = "random",
    trajectory_spec: dict[str, Any] | None = None,
    radar: Radar | None = None,
) -> Scene:
    """Stationary targets drawn uniformly in a square of side ``extent_m`` plus given movers.

    Parameters
    ----------
    n_stationary : int
        Number of stationary unit-reflectivity targets.
    movers : list of (position_m, velocity_mps), optional
        Moving targets (positions at ``s = 0``, m; ground velocities, m/s).
    extent_m : float
        Side of the square region centred on the origin (m).
    rng : numpy.random.Generator or int, optional
        Random generator or seed.
    """
    gen = np.random.default_rng(rng)
    half = 0.5 * extent_m
    pos = gen.uniform(-half, half, size=(n_stationary, 2))
    targets = [PointTarget(position_m=p) for p in pos]
    for k, (p, v) in enumerate(movers or []):
        targets.append(PointTarget(position_m=p, velocity_mps=v, label=f"mover {k + 1}"))
    return Scene(
        name=name,
        targets=tuple(targets),
        trajectory_spec=dict(trajectory_spec or {"kind": "circular"}),
        radar=radar or Radar(),
    )
