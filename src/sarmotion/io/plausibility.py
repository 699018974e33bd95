"""Plausibility rules shared by the readers: what a file may hold before it is refused.

Each rule raises a one-line :class:`~sarmotion.io.errors.DataError` naming the file, the
field, the pulse and the rule, or, with ``lenient=True`` (``--lenient`` on the command
line), logs the same line as a warning for unusual but genuine data. The thresholds and
why are documented in :mod:`sarmotion.io.gotcha` (notes), the data's margins in
``docs/notes/gotcha.md``. An
all-zero phase history is refused even leniently.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..core.constants import MIN_GRAZING_DEG, RANGE_ENVELOPE_M, SPEED_RANGE_MPS
from .errors import DataError

__all__ = [
    "MAX_BEND",
    "MAX_DYNAMIC_RANGE",
    "MAX_STEP",
    "MIN_GRAZING_DEG",
    "RANGE_ENVELOPE_M",
    "SPEED_RANGE_MPS",
    "as_lenient",
    "MAX_COHERENT_SUM",
    "check_coherent_sum",
    "check_dynamic_range",
    "check_envelope",
    "check_reference_point",
    "check_signal",
    "check_speed",
    "check_times",
    "check_track",
    "violation",
]

logger = logging.getLogger("sarmotion.io")

#: Largest step between consecutive pulses, in median spacings (one missing pulse allowed).
MAX_STEP = 2.5
#: Largest second difference of the positions, as a fraction of the median spacing.
MAX_BEND = 0.01
#: Largest ``max |P| / median |P|`` of a phase history (60 dB).
MAX_DYNAMIC_RANGE = 1e3
# The acquisition bounds RANGE_ENVELOPE_M, SPEED_RANGE_MPS and MIN_GRAZING_DEG are stated
# once, in sarmotion.core.constants: the scene files meet them too.

#: Largest sum of a data set's sample magnitudes, ``sum |P|``. An image pixel is a sum of
#: the samples with unit-modulus weights, so ``sum |P|`` bounds its modulus, and its power
#: ``(sum |P|)^2`` must be finite in float32, the precision of the separation's and the
#: detectors' maps: ``sqrt(float32 max)``, 1.8e19. Measured phase histories are far
#: below (a 32767-count CI2 sample in each of 1e8 samples sums to 3e12).
MAX_COHERENT_SUM = float(np.sqrt(np.finfo(np.float32).max))
#: Samples of a constant phase history agree to this fraction of their magnitude
#: (4 float32 roundings): the value of a fill, not the echoes of a scene.
_CONSTANT_TOL = 4.0 * float(np.finfo(np.float32).eps)


def as_lenient(value: object, name: str = "lenient") -> bool:
    """A flag such as ``lenient`` as a bool: True or False (numpy bools too), else TypeError."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r:.60}")
    return bool(value)


def violation(message: str, *, lenient: bool) -> None:
    """Raise ``message`` as a DataError, or (``lenient``) log it as a warning."""
    if lenient:
        logger.warning("%s (accepted: --lenient)", message)
        return
    raise DataError(f"{message} (--lenient accepts it)")


def check_envelope(
    path: Path | str, field: str, positions_m: NDArray[np.float64], *, lenient: bool
) -> None:
    """Antenna above the ground plane and 10 m to 1000 km from the scene centre."""
    with np.errstate(over="ignore"):  # a corrupted coordinate near 1e308: inf, refused
        rng = np.linalg.norm(positions_m, axis=1)
    lo, hi = RANGE_ENVELOPE_M
    bad = np.flatnonzero((rng < lo) | (rng > hi) | (positions_m[:, 2] <= 0.0))
    if bad.size:
        j = int(bad[0])
        x, y, z = positions_m[j]
        violation(
            f"{path}: {field}, pulse {j}: antenna at ({x:.6g}, {y:.6g}, {z:.6g}) m is outside "
            f"the plausible envelope (rule: above the ground plane, {lo:g} m to {hi:g} m from "
            "the scene centre)",
            lenient=lenient,
        )


def check_track(
    path: Path | str, field: str, positions_m: NDArray[np.float64], *, lenient: bool
) -> None:
    """Steps between pulses in ``(0, MAX_STEP]`` spacings; second differences ``<= MAX_BEND``."""
    if positions_m.shape[0] < 2:
        return
    with np.errstate(over="ignore", invalid="ignore"):  # inf or nan steps are refused
        steps = np.linalg.norm(np.diff(positions_m, axis=0), axis=1)
    spacing = _check_steps(path, field, steps, "m", "the track moves", lenient=lenient)
    if spacing is None:
        return
    if positions_m.shape[0] < 3:
        return
    bend = np.linalg.norm(np.diff(positions_m, 2, axis=0), axis=1)
    if float(bend.max()) > MAX_BEND * spacing:
        j = int(np.argmax(bend)) + 1
        violation(
            f"{path}: {field}, pulse {j}: the antenna is {0.5 * bend[j - 1]:.3g} m off the "
            f"midpoint of its neighbours (rule: second differences at most {MAX_BEND:g} x "
            f"the median spacing of {spacing:.4g} m, a smooth track)",
            lenient=lenient,
        )


def check_dynamic_range(
    path: Path | str, field: str, magnitudes: NDArray[np.floating], *, lenient: bool
) -> None:
    """``max <= MAX_DYNAMIC_RANGE x median`` of a ``(n_pulses, n_freq)`` phase-history modulus."""
    median = float(np.median(magnitudes))
    peak = float(magnitudes.max())
    if peak > MAX_DYNAMIC_RANGE * median:
        j, k = np.unravel_index(int(np.argmax(magnitudes)), magnitudes.shape)
        ratio = "more than half the samples are zero" if median == 0 else f"{peak / median:.3g} x"
        violation(
            f"{path}: {field}, pulse {j}, frequency index {k}: magnitude {peak:.4g} against a "
            f"median of {median:.4g} ({ratio}; rule: at most {MAX_DYNAMIC_RANGE:g} x the "
            "median magnitude)",
            lenient=lenient,
        )


def check_coherent_sum(
    path: Path | str,
    field: str,
    samples: NDArray[np.complexfloating],
    *,
    so_far: float = 0.0,
) -> float:
    """``so_far + sum |samples|`` within :data:`MAX_COHERENT_SUM`; returns that sum.

    Refused even leniently: the images of such data overflow single precision, whatever
    the data's origin. ``so_far`` carries the sum over blocks read one after another.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        total = float(so_far) + float(np.sum(np.abs(samples), dtype=np.float64))
    if not total <= MAX_COHERENT_SUM:
        peak = float(np.max(np.abs(samples))) if samples.size else 0.0
        raise DataError(
            f"{path}: {field}: the sample magnitudes sum to {total:.3g} (largest {peak:.3g}); "
            f"an image adding them in phase would overflow single precision (rule: at most "
            f"{MAX_COHERENT_SUM:.3g}, the square root of float32's largest value; rescale "
            "the data)"
        )
    return total


def check_signal(
    path: Path | str, field: str, phase_history: NDArray[np.complexfloating], *, lenient: bool
) -> None:
    """Not all zero, not constant, within the dynamic range and :data:`MAX_COHERENT_SUM`.

    All-zero data and a sum beyond :data:`MAX_COHERENT_SUM` are refused even leniently;
    the dynamic range is checked first, so that one outlier is refused by its place.

    An all-zero phase history holds no echo (a never-written array, a fill value): every
    image of it is empty. A constant one (every sample equal to float32 rounding) is a
    fill value too, or a single reflector exactly at the reference point with a flat
    spectrum, which ``lenient`` accepts.
    """
    magnitudes = np.abs(phase_history)
    if phase_history.size == 0 or not np.any(magnitudes):
        raise DataError(f"{path}: {field}: every sample is zero (no echo to image or analyse)")
    first = phase_history.reshape(-1)[0]
    with np.errstate(over="ignore", invalid="ignore"):  # data near the float range
        spread = float(np.max(np.abs(phase_history - first)))
    if spread <= _CONSTANT_TOL * float(magnitudes.max()):
        violation(
            f"{path}: {field}: every sample equals {complex(first):.6g} (rule: a phase "
            f"history varies over pulses and frequencies; constant to {_CONSTANT_TOL:.2g} "
            "relative is a fill value)",
            lenient=lenient,
        )
    check_dynamic_range(path, field, magnitudes, lenient=lenient)  # names the sample
    check_coherent_sum(path, field, phase_history)


def check_speed(
    path: Path | str,
    field: str,
    positions_m: NDArray[np.float64],
    times_s: NDArray[np.float64],
    *,
    lenient: bool,
) -> None:
    """The platform speed, path length over time span, is within :data:`SPEED_RANGE_MPS`."""
    if positions_m.shape[0] < 2:
        return
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        length = float(np.sum(np.linalg.norm(np.diff(positions_m, axis=0), axis=1)))
        span = float(times_s[-1] - times_s[0])
        speed = length / span if span > 0 else np.inf
    lo, hi = SPEED_RANGE_MPS
    if not lo <= speed <= hi:
        violation(
            f"{path}: {field}: the antenna covers {length:.6g} m in {span:.6g} s, a platform "
            f"speed of {speed:.3g} m/s (rule: {lo:g} to {hi:g} m/s, from a rail SAR to a "
            "satellite in low orbit)",
            lenient=lenient,
        )


def check_reference_point(
    path: Path | str,
    field: str,
    positions_m: NDArray[np.float64],
    reference_point_m: NDArray[np.float64],
    *,
    lenient: bool,
) -> None:
    """Every antenna position sees the reference point at least :data:`MIN_GRAZING_DEG` up.

    The grazing angle of pulse ``j`` is the elevation of the antenna above the reference
    point, ``asin((z_j - z_o) / |r_j - rho_o|)``: a reference point far outside the scene
    the aperture looks at is seen at a grazing angle near zero.
    """
    d = positions_m - reference_point_m[None, :]
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        grazing = np.rad2deg(np.arcsin(d[:, 2] / np.linalg.norm(d, axis=1)))
    bad = np.flatnonzero(~(grazing >= MIN_GRAZING_DEG))
    if bad.size:
        j = int(bad[0])
        x, y, z = reference_point_m
        violation(
            f"{path}: {field} ({x:.6g}, {y:.6g}, {z:.6g}) m is seen from pulse {j} at a "
            f"grazing angle of {grazing[j]:.3g} deg, far from the scene the aperture looks "
            f"at (rule: at least {MIN_GRAZING_DEG:g} deg at every pulse)",
            lenient=lenient,
        )


def check_times(
    path: Path | str, field: str, times_s: NDArray[np.float64], *, lenient: bool
) -> None:
    """Slow times increase by more than 0 and at most ``MAX_STEP`` median intervals per pulse."""
    if times_s.shape[0] < 2:
        return
    _check_steps(path, field, np.diff(times_s), "s", "times increase", lenient=lenient)


def _check_steps(
    path: Path | str, field: str, steps: NDArray[np.float64], unit: str, what: str, *,
    lenient: bool,
) -> float | None:  # fmt: skip
    """Steps in ``(0, MAX_STEP]`` median steps: the median, or None after a violation."""
    median = float(np.median(steps))
    bad = np.flatnonzero(~(steps > 0.0) | (steps > MAX_STEP * median))
    if not bad.size and median > 0.0:
        return median
    j = int(bad[0]) + 1 if bad.size else 1
    violation(
        f"{path}: {field}, pulse {j}: a step of {steps[j - 1]:.6g} {unit} from pulse {j - 1} "
        f"against a median of {median:.6g} {unit} (rule: {what} by more than 0 and at most "
        f"{MAX_STEP:g} median steps per pulse)",
        lenient=lenient,
    )
    return None
