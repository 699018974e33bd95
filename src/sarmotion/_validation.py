"""Argument checks shared by every layer: one message style, one exception policy.

Each check returns the value converted (``float``, ``int``, ``ndarray``) so a caller
writes ``tol = positive(tol, "tol")``. A value of the wrong kind raises ``TypeError``
(``"tol must be a real number, got 'a'"``); a value of the right kind outside its domain
raises ``ValueError`` naming the parameter, the rule and what came
(``"tol must be > 0, got -1.0"``). ``name`` is what the caller's user typed: a library
parameter name, or a command-line flag such as ``"--speed"``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "HAE_RANGE_M",
    "finite",
    "geodetic_origin",
    "positive",
    "non_negative",
    "integer",
    "interval",
    "point",
    "shape",
    "one_of",
]

#: Heights above the WGS 84 ellipsoid (m) of a scene's origin on the ground: the Earth's
#: land surface spans 430 m below sea level (the Dead Sea shore) to 8849 m above (Everest),
#: and sea level (the geoid) lies within about 110 m of the ellipsoid; the range holds both
#: with some margin.
HAE_RANGE_M = (-1000.0, 10000.0)


def finite(value: Any, name: str, *, unit: str = "") -> float:
    """A finite real number."""
    if isinstance(value, bool) or isinstance(value, str):
        raise TypeError(f"{name} must be a real number{_unit(unit)}, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number{_unit(unit)}, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite{_unit(unit)}, got {value!r}")
    return v


def positive(value: Any, name: str, *, unit: str = "") -> float:
    """A finite real number ``> 0``."""
    v = finite(value, name, unit=unit)
    if v <= 0:
        raise ValueError(f"{name} must be > 0{_unit(unit)}, got {value!r}")
    return v


def non_negative(value: Any, name: str, *, unit: str = "") -> float:
    """A finite real number ``>= 0``."""
    v = finite(value, name, unit=unit)
    if v < 0:
        raise ValueError(f"{name} must be >= 0{_unit(unit)}, got {value!r}")
    return v


def integer(value: Any, name: str, *, minimum: int | None = None) -> int:
    """An integer (not a bool), optionally ``>= minimum``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    return int(value)


def interval(value: Any, name: str, *, unit: str = "") -> tuple[float, float]:
    """A finite pair ``(low, high)`` with ``low < high``."""
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (low, high){_unit(unit)}, got {value!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"{name} must be finite with low < high{_unit(unit)}, got {value!r}")
    return lo, hi


def point(value: Any, name: str) -> NDArray[np.float64]:
    """A finite ``(x, y)`` or ``(x, y, z)`` position (m), returned as ``(3,)`` with ``z = 0``."""
    p = np.asarray(value, dtype=np.float64).reshape(-1)
    if p.size not in (2, 3) or not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be a finite (x, y) or (x, y, z) point (m), got {value!r}")
    return np.concatenate([p, [0.0]]) if p.size == 2 else p


def geodetic_origin(value: Any, name: str) -> NDArray[np.float64]:
    """A scene origin ``(latitude_deg, longitude_deg, hae_m)`` on the ground, as ``(3,)``.

    Latitude within [-90, 90] deg, longitude within [-180, 360) deg, height above the
    WGS 84 ellipsoid within :data:`HAE_RANGE_M`; all finite.
    """
    try:
        llh = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(
            f"{name} must be three numbers (lat_deg, lon_deg, hae_m), got {value!r}"
        ) from None
    if llh.shape != (3,):
        raise ValueError(f"{name} must be three numbers (lat_deg, lon_deg, hae_m), got {value!r}")
    lat, lon, hae = (float(v) for v in llh)
    lo, hi = HAE_RANGE_M
    if not -90.0 <= lat <= 90.0:
        raise ValueError(f"{name} latitude must be within [-90, 90] deg, got {lat!r}")
    if not -180.0 <= lon < 360.0:
        raise ValueError(f"{name} longitude must be within [-180, 360) deg, got {lon!r}")
    if not lo <= hae <= hi:
        raise ValueError(
            f"{name} height must be within [{lo:g}, {hi:g}] m above the WGS 84 ellipsoid "
            f"(the Earth's land surface), got {hae!r}"
        )
    return llh


def shape(array: Any, name: str, expected: tuple[int | None, ...], *, what: str = "") -> None:
    """Check ``array.shape`` against ``expected`` (``None`` matches any length)."""
    got = np.shape(array)
    wrong = len(got) != len(expected) or any(
        e is not None and g != e for g, e in zip(got, expected, strict=True)
    )
    if wrong:
        want = "(" + ", ".join("n" if e is None else str(e) for e in expected) + ")"
        raise ValueError(f"{name} must have shape {what or want}, got {got}")


def one_of(value: Any, name: str, choices: tuple[str, ...]) -> str:
    """One of a fixed set of names."""
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}, got {value!r}")
    return str(value)


def _unit(unit: str) -> str:
    return f" ({unit})" if unit else ""
