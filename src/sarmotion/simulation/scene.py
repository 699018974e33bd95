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
file itself at most :data:`MAX_SCENE_FILE_BYTES`, checked before it is parsed. Arrays and
tables nest at most :data:`MAX_NESTING` deep, checked on the text before it is parsed
(Python's TOML parser recurses once per level) and on the parsed tables (dotted keys).

Physical bounds, the readers' own (:mod:`sarmotion.core.constants`), so that a scene
simulates to traces the readers accept: the platform speed within ``SPEED_RANGE_MPS``;
every antenna position above the reference point, within ``RANGE_ENVELOPE_M`` of it and
seeing it at least ``MIN_GRAZING_DEG`` up, moving at least :data:`MIN_STEP_OF_RANGE` of
its range between pulses (``aperture_deg`` and ``centre_azimuth_deg`` within one turn);
the carrier within ``CARRIER_RANGE_HZ``; a target's amplitude within
:data:`AMPLITUDE_RANGE` and its ground speed at most the platform speeds' upper bound.
What the scene's values cannot show (the phase history's dynamic range) the
``simulate`` command checks on the traces before it writes them.

Aliasing (:func:`check_aliasing`): every target, a mover at each of its positions along
its path over the acquisition, lies inside the unambiguous scene of the radar and the
trajectory: its echo within the fast-time window ``1 / df`` (``df`` =
``radar.frequency_step_hz``: ``c / (2 df)`` of slant range, ``c / (2 df cos psi)`` of
ground range at grazing angle ``psi``) and its phase turning by at most half a cycle
between pulses (the alias-free cross-range extent ``lambda R / (2 dx)`` at the aperture
centre, ``dx`` the pulse spacing; ``lambda / (2 cos psi dphi)`` on a circle of angular
pulse spacing ``dphi``). A target beyond it is refused, or with ``lenient`` simulated with
a warning that says where it aliases to.
"""

from __future__ import annotations

import logging
import re
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._limits import over_budget, phase_history_bytes
from ..core import C, Radar, Trajectory, as_point, target_positions
from ..core.constants import (
    CARRIER_RANGE_HZ,
    MIN_GRAZING_DEG,
    RANGE_ENVELOPE_M,
    SPEED_RANGE_MPS,
)
from ..core.geometry import GOTCHA_PULSES_PER_DEG
from ..errors import InputError

__all__ = [
    "AMPLITUDE_RANGE",
    "MAX_NESTING",
    "PointTarget",
    "Scene",
    "SceneError",
    "builtin_scene_names",
    "check_aliasing",
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
#: Deepest nesting of tables and arrays in a scene file, the file's own table counted:
#: twice the schema's deepest (4: the file, ``targets``, a target, its ``position_m``).
MAX_NESTING = 8
#: Least distance the antenna moves between pulses, as a share of its range: float64
#: holds a position to 1e-16 of the range, so steps of 1e-9 of it are uniform to 1e-7, as
#: the readers' track rule needs (a rail SAR 10 m away may step by 10 nm).
MIN_STEP_OF_RANGE = 1e-9
#: A target's amplitude ``|sigma|`` (dimensionless): its power ``|sigma|^2`` stays a
#: normal float32 number, eight decades above the smallest (1.2e-38), so a GOTCHA file
#: (complex64) holds it and the pulse's spectral tails; and the power summed over the
#: most terms of a simulation (:data:`MAX_SIMULATION_TERMS`) stays below float32's
#: largest (3.4e38): ``1e14^2 x 1e10 = 1e38``.
AMPLITUDE_RANGE = (1e-15, 1e14)
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
#: Trajectory keys that must be positive numbers, by kind.
_POSITIVE_KEYS = {
    "circular": ("aperture_deg", "altitude_m", "ground_radius_m", "speed_mps", "pulses_per_deg"),
    "linear": ("speed_mps", "aperture_m", "pulse_spacing_m"),
}

logger = logging.getLogger("sarmotion.simulation")


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
    def from_dict(
        cls, raw: dict[str, Any], *, source: str = "scene", lenient: bool = False
    ) -> Scene:
        """Parse a scene from the dictionary form of the file schema (see module doc).

        The values are checked against the module's bounds and the targets against the
        unambiguous scene (:func:`check_aliasing`); ``lenient`` turns an aliasing target
        into a logged warning. Raises :class:`SceneError` (one line) otherwise.
        """
        if not isinstance(raw, dict):
            raise SceneError(f"{source}: expected a table at top level, got {type(raw).__name__}")
        _check_nesting(raw, source)
        _check_keys(raw, _TOP_KEYS, source, "")
        schema = raw.get("schema", SCHEMA)
        if schema != SCHEMA:
            raise SceneError(f"{source}: schema must be {SCHEMA!r}, got {_short(schema)}")
        name = _text(raw.get("name", Path(source).stem), source, "name")
        ref = _vector(raw.get("reference_point_m", [0.0, 0.0]), source, "reference_point_m", 3)

        traj = _table(raw.get("trajectory", {}), source, "trajectory")
        kind = traj.get("kind", "circular")
        if kind not in ("circular", "linear"):
            raise SceneError(
                f"{source}: trajectory.kind must be 'circular' or 'linear', got {_short(kind)}"
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
        _check_trajectory_values(traj, source)

        radar_raw = _table(raw.get("radar", {}), source, "radar")
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
        lo, hi = CARRIER_RANGE_HZ
        if not lo <= radar.carrier_hz <= hi:
            raise SceneError(
                f"{source}: radar.carrier_hz must be within {lo:g} to {hi:g} Hz (the radio "
                f"spectrum from HF to its upper edge), got {radar.carrier_hz:g}"
            )
        lowest = radar.carrier_hz - (radar.n_samples // 2) * radar.frequency_step_hz
        if not lowest > 0.0:
            raise SceneError(
                f"{source}: radar: the lowest sampled frequency, carrier_hz - (n_samples // 2) "
                f"x frequency_step_hz = {lowest:.6g} Hz, must be positive"
            )

        raw_targets = raw.get("targets", [])
        if not isinstance(raw_targets, list) or not raw_targets:
            raise SceneError(f"{source}: targets must be a non-empty array of tables")
        _check_size(traj, radar, len(raw_targets), source)
        _check_turn(traj, source)
        targets = []
        for i, t in enumerate(raw_targets):
            where = f"targets[{i}]"
            if not isinstance(t, dict):
                raise SceneError(f"{source}: {where} must be a table, got {t!r}")
            _check_keys(t, _TARGET_KEYS, source, f"{where}.")
            if "position_m" not in t:
                raise SceneError(f"{source}: {where}.position_m is missing")
            pos = _vector(t["position_m"], source, f"{where}.position_m", 3)
            reach = RANGE_ENVELOPE_M[1]
            with np.errstate(over="ignore"):
                offset = float(np.max(np.abs(pos[:2] - ref[:2])))
            if not offset <= reach:
                raise SceneError(
                    f"{source}: {where}.position_m must lie within {reach:g} m of the reference "
                    f"point (the readers' range envelope), got {_short(t['position_m'])}"
                )
            vel = _vector(t.get("velocity_mps", [0.0, 0.0]), source, f"{where}.velocity_mps", 2)
            speed = float(np.hypot(vel[0], vel[1]))
            if speed > SPEED_RANGE_MPS[1]:
                raise SceneError(
                    f"{source}: {where}.velocity_mps must be a ground velocity [ux, uy] of at "
                    f"most {SPEED_RANGE_MPS[1]:g} m/s (a satellite in low orbit), got "
                    f"{_short(t.get('velocity_mps'))}"
                )
            amp = _number(t.get("amplitude", 1.0), source, f"{where}.amplitude")
            if amp <= 0:
                raise SceneError(
                    f"{source}: {where}.amplitude must be > 0 (the modulus |sigma|; a sign "
                    f"or phase goes in phase_deg), got {amp:g}"
                )
            lo, hi = AMPLITUDE_RANGE
            if not lo <= amp <= hi:
                raise SceneError(
                    f"{source}: {where}.amplitude must be within {lo:g} to {hi:g} (its power "
                    f"and their sums stay normal float32 numbers), got {amp:g}"
                )
            phase = _number(t.get("phase_deg", 0.0), source, f"{where}.phase_deg")
            targets.append(
                PointTarget(
                    position_m=pos,
                    velocity_mps=vel[:2],
                    reflectivity=amp * np.exp(1j * np.deg2rad(phase)),
                    label=_text(t.get("label", ""), source, f"{where}.label"),
                )
            )
        scene = cls(
            name=name,
            targets=tuple(targets),
            reference_point_m=ref,
            trajectory_spec=traj,
            radar=radar,
            description=_text(raw.get("description", ""), source, "description"),
        )
        try:
            trajectory = scene.trajectory()
        except (TypeError, ValueError) as exc:
            raise SceneError(f"{source}: trajectory: {exc}") from None
        _check_geometry(trajectory, scene.reference_point_m, kind, source)
        check_aliasing(scene, source=source, lenient=lenient, trajectory=trajectory)
        return scene

    @classmethod
    def from_file(cls, path: str | Path, *, lenient: bool = False) -> Scene:
        """Read a scene TOML file (schema in the module docstring).

        ``lenient``: as :meth:`from_dict`. The file's size and nesting are checked before
        it is parsed.
        """
        p = Path(path)
        if not p.is_file():
            raise SceneError(f"scene file not found: {p}")
        if p.stat().st_size > MAX_SCENE_FILE_BYTES:
            raise SceneError(
                f"{p}: {p.stat().st_size} bytes; a scene file holds at most "
                f"{MAX_SCENE_FILE_BYTES} (the work limit of the simulation)"
            )
        try:
            text = p.read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise SceneError(
                f"{p}: not a TOML scene file: not UTF-8 text (byte {exc.start})"
            ) from None
        return cls.from_dict(_parse_toml(text, str(p)), source=str(p), lenient=lenient)

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
    """Pulses the trajectory ``spec`` will hold (the rules of ``Trajectory``), or None.

    None when the count is not a finite positive number (a spacing of 0 or 1e-320).
    """
    with np.errstate(all="ignore"):
        if spec.get("kind", "circular") == "circular":
            if "n_pulses" in spec:
                return int(spec["n_pulses"])
            n = np.float64(spec.get("aperture_deg", 1.0)) * np.float64(
                spec.get("pulses_per_deg", GOTCHA_PULSES_PER_DEG)
            )
        else:
            n = np.float64(spec.get("aperture_m", 400.0)) / np.float64(
                spec.get("pulse_spacing_m", 1.055)
            )
            n += 1.0
    return int(round(float(n))) if np.isfinite(n) and n > 0 else None


def _check_size(spec: dict[str, Any], radar: Radar, n_targets: int, source: str) -> None:
    """The scene's memory and work limits (module notes), before anything is built."""
    n = _pulse_count(spec)
    if n is None:
        keys = (
            "aperture_deg x pulses_per_deg"
            if spec.get("kind", "circular") == "circular"
            else "aperture_m / pulse_spacing_m"
        )
        raise SceneError(f"{source}: trajectory: {keys} is not a finite number of pulses")
    if n < 1:
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


#: What opens or closes a level of nesting in TOML text, and what to skip over: strings
#: (multi-line first, escapes in basic strings) and comments; and chains of dotted key
#: segments (bare or quoted), each dot a level of tables (a float or a time has one dot).
#: A bare word is one token (possessive), so that the scan is linear in the text.
_SEGMENT = r"""(?:[A-Za-z0-9_-]++|"(?:[^"\\\n]|\\.)*"|'[^'\n]*')"""
_SEGMENTS = re.compile(_SEGMENT)
_TOKENS = re.compile(
    r'"""(?:[^"\\]|\\.|"(?!""))*"{3,5}'  # multi-line basic string
    r"|'''(?:[^']|'(?!''))*'{3,5}"  # multi-line literal string
    rf"|(?P<chain>{_SEGMENT}(?:[ \t]*\.[ \t]*{_SEGMENT})*)"  # a key, dotted or not, a word
    r'|"(?:[^"\\\n]|\\.)*"'  # basic string
    r"|'[^'\n]*'"  # literal string
    r"|#[^\n]*"  # comment
    r"|[\[\]{}]",
    re.DOTALL,
)


def _parse_toml(text: str, source: str) -> dict[str, Any]:
    """``tomllib.loads(text)`` once its arrays and inline tables nest at most :data:`MAX_NESTING`.

    The nesting is measured on the text (brackets and braces outside strings and
    comments) before the parser, which recurses once per level, sees it.
    """
    depth = deepest = 0
    where = 0
    for match in _TOKENS.finditer(text):
        token = match.group()
        if match.group("chain") is not None:
            # a dotted key of n segments nests n tables (the parser's work grows as n^2)
            segments = len(_SEGMENTS.findall(token))
            if segments + 1 > MAX_NESTING:
                line = text.count("\n", 0, match.start()) + 1
                raise SceneError(
                    f"{source}: line {line}: a dotted key nests {segments} tables, more than "
                    f"{MAX_NESTING} deep (the file's own table counted; a scene file needs at "
                    "most 4)"
                )
        elif token in "[{":
            depth += 1
            if depth > deepest:
                deepest, where = depth, match.start()
        elif token in "]}":
            depth = max(depth - 1, 0)
    if deepest + 1 > MAX_NESTING:
        line = text.count("\n", 0, where) + 1
        raise SceneError(
            f"{source}: line {line}: arrays and tables nest more than {MAX_NESTING} deep (the "
            f"file's own table counted; a scene file needs at most 4)"
        )
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{source}: not a valid TOML scene file ({exc})") from None
    except RecursionError:  # the text's count above makes this unreachable; kept as a guard
        raise SceneError(f"{source}: arrays and tables nest more than {MAX_NESTING} deep") from None


def _check_nesting(raw: dict[str, Any], source: str) -> None:
    """Parsed tables and arrays nest at most :data:`MAX_NESTING` deep (dotted keys too).

    Walked without recursion, before any value is printed (``repr`` of a deeper value
    recurses).
    """
    stack: list[tuple[Any, int, str]] = [(raw, 1, "")]
    while stack:
        value, depth, path = stack.pop()
        if depth > MAX_NESTING:
            shown = path if len(path) <= 60 else path[:57] + "..."
            raise SceneError(
                f"{source}: {shown or 'the file'}: tables and arrays nest more than "
                f"{MAX_NESTING} deep (the file's own table counted; a scene file needs at most 4)"
            )
        if isinstance(value, dict):
            for key, item in value.items():
                if isinstance(item, (dict, list)):
                    stack.append((item, depth + 1, f"{path}.{key}" if path else str(key)))
        elif isinstance(value, list):
            for k, item in enumerate(value):
                if isinstance(item, (dict, list)):
                    stack.append((item, depth + 1, f"{path}[{k}]"))


def _short(value: Any, limit: int = 60) -> str:
    """``repr(value)``, cut to ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _text(value: Any, source: str, key: str) -> str:
    if not isinstance(value, str):
        raise SceneError(f"{source}: {key} must be a string, got {_short(value)}")
    return value


def _table(value: Any, source: str, key: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise SceneError(f"{source}: {key} must be a table, got {_short(value)}")
    return dict(value)


def _check_trajectory_values(traj: dict[str, Any], source: str) -> None:
    """Positive sizes and spacings, at least 2 pulses and a platform speed within bounds."""
    kind = traj["kind"]
    for key in _POSITIVE_KEYS[kind]:
        if key in traj and not traj[key] > 0.0:
            raise SceneError(f"{source}: trajectory.{key} must be > 0, got {traj[key]:g}")
    for key in ("aperture_deg", "centre_azimuth_deg"):
        if key in traj and not abs(traj[key]) <= 360.0:
            raise SceneError(
                f"{source}: trajectory.{key} must be within -360 to 360 deg (one turn of the "
                f"circle), got {traj[key]:g}"
            )
    if "n_pulses" in traj and traj["n_pulses"] < 2:
        raise SceneError(f"{source}: trajectory.n_pulses must be >= 2, got {traj['n_pulses']}")
    reach = RANGE_ENVELOPE_M[1]
    sizes = {"altitude_m": reach, "ground_radius_m": reach, "aperture_m": 2.0 * reach}
    for key, most in sizes.items():
        if key in traj and not traj[key] <= most:
            raise SceneError(
                f"{source}: trajectory.{key} must be at most {most:g} m (the readers' range "
                f"envelope: antennas within {reach:g} m of the scene), got {traj[key]:g}"
            )
    if "centre_m" in traj and not max(abs(v) for v in traj["centre_m"]) <= reach:
        raise SceneError(
            f"{source}: trajectory.centre_m must lie within {reach:g} m of the scene (the "
            f"readers' range envelope), got {_short(traj['centre_m'])}"
        )
    if "speed_mps" in traj:
        lo, hi = SPEED_RANGE_MPS
        if not lo <= traj["speed_mps"] <= hi:
            raise SceneError(
                f"{source}: trajectory.speed_mps must be within {lo:g} to {hi:g} m/s (from a "
                f"rail SAR to a satellite in low orbit), got {traj['speed_mps']:g}"
            )


def _check_turn(traj: dict[str, Any], source: str) -> None:
    """A circle's pulses, ``n_pulses`` at ``pulses_per_deg``, span at most one turn."""
    if traj["kind"] == "circular" and "n_pulses" in traj:
        with np.errstate(over="ignore"):
            turn = np.float64(traj["n_pulses"]) / np.float64(
                traj.get("pulses_per_deg", GOTCHA_PULSES_PER_DEG)
            )
        if not turn <= 360.0:
            raise SceneError(
                f"{source}: trajectory: n_pulses / pulses_per_deg = {float(turn):.6g} deg must be "
                "within one turn of the circle (360 deg)"
            )


def _check_geometry(
    trajectory: Trajectory, reference_point_m: NDArray[np.float64], kind: str, source: str
) -> None:
    """The readers' geometric rules on the scene's antenna positions.

    Every antenna position within ``RANGE_ENVELOPE_M`` of the reference point and
    seeing it at least ``MIN_GRAZING_DEG`` up (:mod:`sarmotion.core.constants`).
    """
    keys = (
        "trajectory.altitude_m, ground_radius_m"
        if kind == "circular"
        else "trajectory.centre_m, direction, aperture_m"
    )
    d = trajectory.positions_m - reference_point_m[None, :]
    with np.errstate(over="ignore", invalid="ignore"):
        dist = np.linalg.norm(d, axis=1)
        grazing = np.rad2deg(np.arcsin(d[:, 2] / dist))
    lo, hi = RANGE_ENVELOPE_M
    bad = np.flatnonzero(~((dist >= lo) & (dist <= hi)))
    if bad.size:
        j = int(bad[0])
        raise SceneError(
            f"{source}: the antenna at pulse {j} is {dist[j]:.6g} m from the reference point; "
            f"the readers accept {lo:g} to {hi:g} m ({keys}, reference_point_m)"
        )
    step = np.linalg.norm(np.diff(trajectory.positions_m, axis=0), axis=1)
    least = MIN_STEP_OF_RANGE * float(np.max(dist))
    if not float(np.min(step)) >= least:
        spacing = "pulses_per_deg" if kind == "circular" else "pulse_spacing_m"
        raise SceneError(
            f"{source}: the antenna moves {float(np.min(step)):.3g} m between pulses, less than "
            f"{MIN_STEP_OF_RANGE:g} of its range ({least:.3g} m: positions held to float64 "
            f"could not tell the pulses apart) (trajectory.{spacing})"
        )
    bad = np.flatnonzero(~(grazing >= MIN_GRAZING_DEG))
    if bad.size:
        j = int(bad[0])
        raise SceneError(
            f"{source}: the antenna at pulse {j} sees the reference point at a grazing angle "
            f"of {grazing[j]:.3g} deg; the readers accept at least {MIN_GRAZING_DEG:g} deg "
            f"({keys}, reference_point_m)"
        )


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


#: Most pulses at which :func:`check_aliasing` evaluates the echoes (evenly spread, both
#: ends included), and most targets it holds in memory at once.
_ALIAS_PULSES = 257
_ALIAS_CHUNK = 2048


def _range_offsets(antennas: NDArray[np.float64], points: NDArray[np.float64], rho_o: Any) -> Any:
    """``|a - p| - |a - rho_o|`` (m) for antennas ``(n, 3)`` and points ``(k, n, 3)``.

    As ``(|a - p|^2 - |a - rho_o|^2) / (|a - p| + |a - rho_o|)``: no cancellation of two
    ranges of kilometres.
    """
    dp = antennas[None, :, :] - points
    dr = antennas - rho_o[None, :]
    rp = np.linalg.norm(dp, axis=2)
    rr = np.linalg.norm(dr, axis=1)[None, :]
    return (np.sum(dp * dp, axis=2) - rr**2) / (rp + rr)


def _six_digits(value: float, *, up: bool) -> float:
    """``value`` rounded to six significant digits, up or down (a bound a message states)."""
    if not (np.isfinite(value) and value > 0):
        return value
    scale = 10.0 ** (np.floor(np.log10(value)) - 5)
    return float((np.ceil if up else np.floor)(value / scale) * scale)


def check_aliasing(
    scene: Scene,
    *,
    source: str = "scene",
    lenient: bool = False,
    trajectory: Trajectory | None = None,
) -> None:
    """Refuse (or, ``lenient``, warn about) targets beyond the unambiguous scene.

    A target, a mover at each of its positions ``rho(s_j)`` along its path, is
    unambiguous when at every pulse ``j``

    - its echo lies within the fast-time window: ``|R_j(rho) - R_j(rho_o)| <= c / (4 df)``
      (one-way ranges ``R_j`` from the antenna, ``df`` = ``radar.frequency_step_hz``:
      half the window's ``c / (2 df)`` of slant range);
    - its phase relative to the reference point's turns by at most half a cycle to the
      next pulse: ``|d_j(rho) - d_j(rho_o)| <= lambda / 4`` with ``d_j = R_{j+1} - R_j``
      (``lambda`` at the carrier).

    At the aperture centre these are the ground-range window ``c / (2 df cos psi)``
    (grazing angle ``psi``) and the cross-range extent ``lambda / (2 |du . e_c|)``, ``du``
    the line of sight's turn per pulse (``lambda R / (2 dx)`` on a straight path of pulse
    spacing ``dx``, ``lambda / (2 cos psi dphi)`` on a circle of angular spacing
    ``dphi``); over a turning aperture the exact rule is the stricter. The rules are
    evaluated at up to 257 pulses spread evenly over the aperture, ends included.

    Parameters
    ----------
    scene : Scene
        The scene.
    source : str
        The file or name the messages start with.
    lenient : bool
        Log the finding as a warning (what aliases, and where to) instead of refusing.
    trajectory : Trajectory, optional
        ``scene.trajectory()``, when already built.

    Raises
    ------
    SceneError
        A target beyond the unambiguous scene (one line: the extent, the target, the
        keys that would fit it), unless ``lenient``.
    """
    traj = scene.trajectory() if trajectory is None else trajectory
    radar = scene.radar
    pos = traj.positions_m
    s = traj.slow_times_s
    n = pos.shape[0]
    rho_o = scene.reference_point_m
    half_range = C / (4.0 * radar.frequency_step_hz)  # m, one way
    quarter_wave = radar.wavelength_m / 4.0  # m, one way
    # geometry at the aperture centre: ground range and cross-range directions
    jc = int(np.argmin(np.abs(s)))
    d = pos[jc] - rho_o
    ground = float(np.hypot(d[0], d[1]))
    if not ground > 0.0:
        raise SceneError(
            f"{source}: the antenna at the aperture centre (pulse {jc}) is straight above the "
            "reference point: the look has no ground range (trajectory, reference_point_m)"
        )
    cos_psi = ground / float(np.linalg.norm(d))
    e_r = np.array([d[0], d[1], 0.0]) / ground
    e_c = np.array([-e_r[1], e_r[0], 0.0])
    u = (pos - rho_o) / np.linalg.norm(pos - rho_o, axis=1)[:, None]
    j0, j1 = max(jc - 1, 0), min(jc + 1, n - 1)
    turn = abs(float((u[j1] - u[j0]) @ e_c)) / (j1 - j0)  # line-of-sight turn per pulse
    window_ground = 2.0 * half_range / cos_psi
    extent_cross = radar.wavelength_m / (2.0 * turn) if turn > 0 else np.inf
    # the pulses evaluated, and the next pulse of each (for the phase step)
    idx = np.unique(np.linspace(0, n - 1, min(n, _ALIAS_PULSES)).round().astype(int))
    nxt = np.minimum(idx + 1, n - 1)
    nxt[nxt == idx] = np.maximum(idx[nxt == idx] - 1, 0)
    worst = {"range": (0.0, -1, 0), "cross": (0.0, -1, 0)}  # (ratio, target, pulse)
    targets = scene.targets
    for start in range(0, len(targets), _ALIAS_CHUNK):
        chunk = targets[start : start + _ALIAS_CHUNK]
        p0 = np.array([t.position_m for t in chunk])
        v = np.array([t.velocity3_mps for t in chunk])
        with np.errstate(over="ignore", invalid="ignore"):
            points = p0[:, None, :] + s[idx][None, :, None] * v[:, None, :]  # (k, m, 3)
            here = _range_offsets(pos[idx], points, rho_o)
            there = _range_offsets(pos[nxt], points, rho_o)
            ratio_r = np.abs(here) / half_range
            ratio_c = np.abs(there - here) / np.abs(nxt - idx)[None, :] / quarter_wave
        for kind, ratio in (("range", ratio_r), ("cross", ratio_c)):
            ratio = np.where(np.isnan(ratio), np.inf, ratio)
            k, m = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
            if ratio[k, m] > worst[kind][0]:
                worst[kind] = (float(ratio[k, m]), start + int(k), int(idx[m]))
    found = {kind: w for kind, w in worst.items() if w[0] > 1.0}
    spec = scene.trajectory_spec
    for kind, (ratio, i, j) in found.items():
        t = targets[i]
        p = t.positions_at(np.array([s[j]]))[0]
        dp = p - rho_o
        r, c = float(dp @ e_r), float(dp @ e_c)
        where = f"targets[{i}] at ({t.position_m[0]:.6g}, {t.position_m[1]:.6g}) m"
        if t.is_moving:
            where += f", moving, at ({p[0]:.6g}, {p[1]:.6g}) m at s = {s[j]:.4g} s"
        r0, c0 = float((t.position_m - rho_o) @ e_r), float((t.position_m - rho_o) @ e_c)
        if kind == "range":
            # where the analysis would put it: its position at s = 0 when that is outside
            if abs(r0) > 0.5 * window_ground:
                r = r0
            alias = r - window_ground * np.round(r / window_ground) if np.isfinite(r) else r
            fit_df = _six_digits(radar.frequency_step_hz / ratio, up=False)
            fit_n = int(np.ceil(radar.n_samples * radar.frequency_step_hz / fit_df))
            text = (
                f"{where}: {ratio * half_range:.6g} m of slant range from the reference point "
                f"at pulse {j}, beyond {half_range:.6g} m, half the unambiguous range window of "
                f"{2 * half_range:.6g} m (c / (2 radar.frequency_step_hz); {window_ground:.6g} m "
                f"of ground range at "
                f"{np.rad2deg(np.arccos(cos_psi)):.3g} deg grazing): its echo aliases to about "
                f"{alias:.4g} m of ground range; radar.frequency_step_hz <= {fit_df:.6g} Hz "
                f"fits it, with radar.n_samples >= {fit_n} for the same band"
            )
        else:
            if abs(c0) > 0.5 * extent_cross:
                c = c0
            alias = c - extent_cross * np.round(c / extent_cross) if np.isfinite(c) else c
            what = (
                "lambda / (2 cos psi dphi), dphi the angular pulse spacing"
                if spec.get("kind", "circular") == "circular"
                else "lambda R / (2 dx), dx the pulse spacing"
            )
            if spec.get("kind", "circular") == "circular":
                ppd = _six_digits(
                    float(spec.get("pulses_per_deg", GOTCHA_PULSES_PER_DEG)) * ratio, up=True
                )
                fit = f"trajectory.pulses_per_deg >= {ppd:.6g}"
                if "n_pulses" in spec:
                    fit += f" with trajectory.n_pulses >= {int(np.ceil(n * ratio))}"
            else:
                dx = _six_digits(float(spec.get("pulse_spacing_m", 1.055)) / ratio, up=False)
                fit = f"trajectory.pulse_spacing_m <= {dx:.6g}"
            text = (
                f"{where}: {c:.6g} m of cross range from the reference point, its phase "
                f"turning {ratio / 2:.3g} cycle between pulses {j} and the next (rule: at most "
                f"1/2), beyond the alias-free cross-range extent of {extent_cross:.6g} m at "
                f"the aperture centre ({what}): it aliases to about {alias:.4g} m of cross "
                f"range; {fit} fits it"
            )
        if lenient:
            logger.warning("%s: %s (simulated aliased: --lenient)", source, text)
        else:
            raise SceneError(f"{source}: {text} (--lenient simulates it aliased)")


def builtin_scene_names() -> list[str]:
    """Names of the scenes shipped with the package (the paper's examples)."""
    files = resources.files("sarmotion.simulation").joinpath("scenes")
    return sorted(p.name.removesuffix(".toml") for p in files.iterdir() if p.name.endswith(".toml"))


def load_scene(name_or_path: str | Path, *, lenient: bool = False) -> Scene:
    """Load a built-in scene by name (e.g. ``"scene1"``) or a scene TOML file by path.

    ``lenient``: simulate targets beyond the unambiguous scene, with a warning
    (:func:`check_aliasing`), instead of refusing the file.
    """
    text = str(name_or_path)
    if text in builtin_scene_names():
        res = resources.files("sarmotion.simulation").joinpath("scenes", f"{text}.toml")
        source = f"built-in scene {text!r}"
        raw = _parse_toml(res.read_text(encoding="utf-8"), source)
        return Scene.from_dict(raw, source=source, lenient=lenient)
    p = Path(text)
    if p.suffix.lower() != ".toml" and not p.exists():
        raise SceneError(
            f"unknown scene {text!r}: not a built-in scene ({', '.join(builtin_scene_names())}) "
            "and not a file"
        )
    return Scene.from_file(p, lenient=lenient)


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
