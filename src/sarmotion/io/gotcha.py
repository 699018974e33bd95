"""GOTCHA phase-history files (AFRL "Gotcha Volumetric SAR Data Set v1.0", MATLAB format).

File format
-----------
Each file is a MATLAB v5 ``.mat`` file holding one struct ``data`` (one file per degree
of azimuth in the AFRL release). Fields, read by name:

``fp`` : (n_freq, n_pulses) complex64
    Deramped phase history, one column per pulse, referenced to the scene centre (the
    origin): a point reflector at ``rho`` contributes
    ``exp(-1j * 4 pi f / c * (|r(s) - rho| - r0(s)))``.
``freq`` : (n_freq, 1)
    Frequencies (Hz), a uniform increasing grid (X band, 9.288-9.910 GHz, 424 steps).
``x``, ``y``, ``z`` : (1, n_pulses)
    Antenna position (m); scene centre at the origin, ground plane ``z = 0``.
``r0`` : (1, n_pulses)
    Range from the antenna to the scene centre (m).
``th``, ``phi`` : (1, n_pulses)
    Azimuth (from the +x axis) and elevation (from the xy plane) of the antenna (deg).
``af.r_correct``, ``af.ph_correct`` : (1, n_pulses)
    AFRL's autofocus solution (HH and VV only): a range correction of ``r0`` (m) and a
    phase correction (rad).

The AFRL files store every real field as float32 (ranges of ~10 km to ~0.5 mm). The
files carry no pulse times: slow time is derived from the along-track distance and the
platform speed (:meth:`sarmotion.core.geometry.Trajectory.from_positions`).

In sarmotion the phase history becomes :class:`~sarmotion.core.traces.Traces` (pulses along
the first axis) with the conventions of :mod:`sarmotion.core.spectral`; see
the notes below for the plausibility rules and the conventions chosen (phase reference,
autofocus sign), and :func:`write_gotcha` for the reverse direction.

Plausibility rules
------------------
:func:`read_gotcha` refuses a file that breaks one of these rules with a one-line
:class:`~sarmotion.io.errors.DataError` naming the file, the field, the pulse and the
rule (``lenient=True``, ``--lenient`` on the command line, logs a warning instead, for
unusual but genuine data). Each tolerance is set from the float32 rounding of the
files' fields or from what a real platform can do, well above what pass 1 HH and the
built-in scenes written by :func:`write_gotcha` reach (their margins:
``docs/notes/gotcha.md``):

Envelope
    The antenna is above the ground plane (``z > 0``) and 10 m to 1000 km from the scene
    centre.
Track
    The antenna moves by more than 0 and at most 2.5 median pulse spacings per pulse (as
    between files: one missing pulse allowed), and each position lies within 1 % of the
    spacing of the midpoint of its two neighbours (the second difference): ten times the
    float32 rounding of 7 km coordinates (about 1 mm against a 1 m spacing), and a real
    aircraft at 70 m/s and 1 m spacing would need 5 g to bend its track by 1 %.
Continuity
    Consecutive files follow each other as pulses within a file do: the second
    differences of the last two pulses of a file and the first two of the next are at
    most 1 % of the median spacing (a file shifted by 1 m, or a missing pulse, breaks it).
Signal
    ``fp`` is not all zero (refused even leniently: no echo) and not constant (a fill).
Angles
    ``th`` and ``phi`` agree with the azimuth and elevation of ``x, y, z`` to 0.01 deg
    (float32 angles and positions agree to about 1e-5 deg; a mislabelled field is off by
    degrees).
Range reference
    ``r0`` agrees with ``|r(s)|`` to float32 rounding, ``2 eps_32 |r|`` (2.4 mm at
    10 km: half an ulp of ``r0`` plus up to ``sqrt(3)`` half-ulps of the positions).
    Leniently, a file beyond it is re-referenced exactly from
    ``r0`` to ``|r(s)|`` (``metadata["phase_reference"]`` says so).
Dynamic range
    No sample of ``fp`` exceeds 1000 times the median magnitude of the file (60 dB). A
    deramped phase history spreads each reflector over every frequency, so its samples
    are even (a tapered pulse spectrum, as the built-in scenes' Gaussian pulse, raises
    the ratio by its taper only); a corrupted float32 exponent multiplies a sample by
    2**(2**k).

Conventions
-----------
Frequency grid
    ``freq`` is float32 in the files (steps of 1471488 Hz and 1470464 Hz alternate from
    rounding). ``f0`` and ``df`` are fitted by least squares in float64 (deviations up to
    float32's rounding of ~9.6 GHz, a few hundred Hz); the carrier is ``f0 + (n // 2) df``
    and the bandwidth ``n df``.
Phase reference
    ``fp`` is referenced to the file's ``r0``, float32, which differs from ``|r(s)|``
    computed from the float64-converted positions by the float32 rounding of both (a
    fraction of a millimetre, a tenth of a radian at 9.6 GHz). The data are *kept* as they
    are, i.e. taken as referenced to ``|r(s) - 0|`` of the positions: ``fp`` was formed
    with the exact ``r0``, whose float32 rounding is noise, while the rounding of the
    positions cancels between ``|r - rho|`` and ``|r|`` for pixels near the centre. The
    kept reference focuses better (lower entropy, higher reflector peaks;
    ``tests/io/test_io_gotcha.py::test_kept_r0_reference_focuses_better_than_re_referenced``,
    figures in ``docs/notes/gotcha.md``).
Autofocus sign
    AFRL's MATLAB convention: the reference range becomes ``r0 + r_correct`` and the
    phase history is multiplied by ``exp(+1j ph_correct)``; here that is
    ``P *= exp(+1j ph_correct) exp(-1j 4 pi f / c r_correct)``: flipping either sign
    defocuses the reflectors, and this sign focuses best of the four
    (``tests/io/test_io_gotcha.py::test_autofocus_sign``). On pass 1 the correction does
    *not* sharpen the uncorrected image and it moves the image by a fraction of a metre
    (``r_correct`` is a range offset plus a linear phase trend), hence the default False
    (figures in ``docs/notes/gotcha.md``).
"""

from __future__ import annotations

import logging
import os
import stat
import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.io
from numpy.typing import ArrayLike, NDArray

from .._limits import format_bytes, memory_limit, over_budget, phase_history_bytes
from .._validation import positive
from ..core import C, Radar, Traces, Trajectory, as_point
from .errors import DataError
from .matv5 import MatInflationError, MatStructureError, MatSummary, check_mat_v5
from .plausibility import (
    MAX_BEND,
    MAX_STEP,
    SPEED_RANGE_MPS,
    as_lenient,
    check_envelope,
    check_signal,
    check_track,
    violation,
)
from .staging import staged_paths

__all__ = [
    "read_gotcha",
    "write_gotcha",
    "is_gotcha_file",
    "AZIMUTH_NAME_PATTERN",
    "DEFAULT_NAME_PATTERN",
]

logger = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]

#: File names of the AFRL release (pass 1, HH); ``index`` counts files from 1.
DEFAULT_NAME_PATTERN = "data_3dsar_pass1_az{index:03d}_HH.mat"

#: The AFRL release's names: file ``azNNN`` holds the azimuths ``[NNN - 1, NNN)`` degrees;
#: ``azimuth`` is that ``NNN`` for a file's first pulse (1 to 360).
AZIMUTH_NAME_PATTERN = "data_3dsar_pass1_az{azimuth:03d}_HH.mat"

#: The shell pattern of the names :data:`AZIMUTH_NAME_PATTERN` gives.
AZIMUTH_NAME_GLOB = "data_3dsar_pass1_az[0-9][0-9][0-9]_HH.mat"

#: The 116-byte descriptive text that opens every MATLAB v5 file :func:`write_gotcha`
#: writes (free text by the format; readers skip it): it marks the file as sarmotion's.
_WRITER_MARK = b"MATLAB 5.0 MAT-file, written by sarmotion.io.write_gotcha"
_WRITER_HEADER = _WRITER_MARK.ljust(116, b" ")


def written_by_sarmotion(path: PathLike) -> bool:
    """Whether ``path`` is a regular file that :func:`write_gotcha` wrote (by its header).

    Used by ``--force`` to tell a previous output from a user's own file of the same
    name pattern; a file that cannot be read is not sarmotion's.
    """
    try:
        with open(path, "rb", buffering=0) as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
                return False
            return fh.read(len(_WRITER_MARK)) == _WRITER_MARK
    except OSError:
        return False


#: Largest deviation of ``freq`` from its least-squares uniform grid, as a fraction of the
#: step: float32 rounds ~9.6 GHz to 512 Hz, 3.5e-4 of GOTCHA's 1.47 MHz step; 1e-2 is 30x that.
_GRID_TOL = 1e-2

#: Largest ``|r0 - |r|| / |r|``: float32 rounding of r0 (half an ulp, eps/2 relative) and
#: of the three coordinates (up to sqrt(3) eps/2), with a factor 2 of margin.
_R0_TOL_REL = 2.0 * float(np.finfo(np.float32).eps)

#: Largest disagreement of ``th``/``phi`` with the positions' azimuth/elevation (deg).
_ANGLE_TOL_DEG = 0.01

_REQUIRED = ("fp", "freq", "x", "y", "z", "r0", "th", "phi")


# --------------------------------------------------------------------------- reading
@dataclass(frozen=True, kw_only=True, eq=False)
class _GotchaFile:
    """Validated content of one file (float64 geometry, pulses first)."""

    path: Path
    phase_history: NDArray[np.complexfloating]  # (n_pulses, n_freq)
    freq_hz: NDArray[np.float64]  # (n_freq,)
    positions_m: NDArray[np.float64]  # (n_pulses, 3)
    r0_m: NDArray[np.float64]  # (n_pulses,)
    th_deg: NDArray[np.float64]
    phi_deg: NDArray[np.float64]
    record: Any  # the MATLAB struct, for the optional ``af`` fields

    @property
    def n_pulses(self) -> int:
        return int(self.positions_m.shape[0])

    @property
    def azimuth_rad(self) -> NDArray[np.float64]:
        """Azimuth of each pulse from the positions, unwrapped within the file (rad)."""
        return np.unwrap(np.arctan2(self.positions_m[:, 1], self.positions_m[:, 0]))


def _unreadable_reason(exc: BaseException) -> str:
    """A short, user-facing reason for an exception of the MATLAB reader."""
    text = str(exc)
    if isinstance(exc, MemoryError) or "reshape" in text or "size" in text:
        return "array sizes in its headers do not match its contents (corrupt or truncated)"
    if isinstance(exc, UnicodeDecodeError):
        return "undecodable text in its headers (corrupt)"
    if isinstance(exc, zlib.error) or "compress" in text:
        return "a compressed block is corrupt"
    if "empty" in text.lower():
        return "empty file"
    if "mat file" in text.lower() and "unknown" in text.lower():
        return "no MATLAB v5 header"
    return "corrupt or truncated MATLAB v5 structure"


def _inspect(path: Path) -> MatSummary:
    """The structure of a MATLAB v5 file checked, its variable ``data`` measured.

    The file is read whole (its size is checked against the memory limit first); only
    the variable ``data`` is inflated, within the memory limit (:mod:`.matv5`).
    """
    if not path.exists():
        raise DataError(f"{path}: file not found")
    if not path.is_file():
        raise DataError(f"{path}: not a file")
    with path.open("rb") as fh:
        header = fh.read(128)
    if header.startswith(b"MATLAB 7.3") or header.startswith(b"\x89HDF"):
        raise DataError(
            f"{path}: MATLAB v7.3 (HDF5) file; GOTCHA files are MATLAB v5 (save -v7 or older)"
        )
    reason = over_budget(path.stat().st_size, "the file, read whole for its structure check")
    if reason:
        raise DataError(f"{path}: {reason}")
    cap = _inflation_cap()
    try:
        return check_mat_v5(path.read_bytes(), variables=("data",), max_inflated=cap)
    except MatInflationError:
        raise DataError(
            f"{path}: reading it would allocate more than {format_bytes(cap)} (the variable "
            f"'data' inflates beyond half the memory limit of {format_bytes(2 * cap)}; "
            "--max-memory sets it)"
        ) from None
    except MatStructureError as exc:
        raise DataError(f"{path}: not a readable MATLAB .mat file: {exc}") from None


def _inflation_cap() -> int:
    """Largest inflated size of ``data``: half the memory limit (grown by copies)."""
    return memory_limit() // 2


def _check_budget(paths: list[Path], summaries: list[MatSummary]) -> None:
    """The arrays of ``data`` of every file plus the working copies fit the memory limit."""
    stored = sum(m.loaded_bytes for m in summaries)
    samples = sum(m.largest_elements for m in summaries)  # data.fp, the largest array
    reason = over_budget(
        stored + phase_history_bytes(samples, 1),
        f"{format_bytes(stored)} of MATLAB arrays and the phase history's working copies",
    )
    if reason:
        names = str(paths[0]) if len(paths) == 1 else f"{paths[0]} .. {paths[-1].name}"
        raise DataError(f"{names}: {reason}")


def _load_record(path: Path, names: list[str]) -> Any:
    """The ``data`` struct of a MATLAB v5 file (checked by :func:`_inspect`), or a DataError."""
    try:
        mat = scipy.io.loadmat(path, appendmat=False, variable_names=["data"])
    except Exception as exc:  # scipy raises ValueError, MatReadError, zlib.error, ...
        logger.debug("scipy.io.loadmat(%s) failed: %r", path, exc)
        raise DataError(
            f"{path}: not a readable MATLAB .mat file: {_unreadable_reason(exc)}"
        ) from None
    if "data" not in mat:
        shown = ", ".join(dict.fromkeys(names)) or "none"
        raise DataError(f"{path}: not a GOTCHA file: no MATLAB struct 'data' (variables: {shown})")
    data = mat["data"]
    if not isinstance(data, np.ndarray) or data.dtype.names is None or data.size != 1:
        got = getattr(data, "dtype", type(data).__name__)
        shape = getattr(data, "shape", ())
        raise DataError(
            f"{path}: not a GOTCHA file: 'data' must be a 1x1 MATLAB struct, "
            f"got {got} of shape {shape}"
        )
    return data.reshape(-1)[0]


def _field(record: Any, name: str, path: Path, where: str = "data") -> NDArray[Any]:
    names = record.dtype.names
    if name not in names:
        raise DataError(
            f"{path}: not a GOTCHA file: struct {where} has no field {name!r} "
            f"(fields: {', '.join(names)})"
        )
    value = np.asarray(record[name])
    if value.dtype.kind not in "biufc":
        raise DataError(f"{path}: {where}.{name} must be numeric, got {value.dtype}")
    return value


def _row(record: Any, name: str, n: int, path: Path, where: str = "data") -> NDArray[np.float64]:
    """A per-pulse row vector as (n,) float64."""
    v = _field(record, name, path, where)
    if v.size != n or v.ndim > 2 or (v.ndim == 2 and 1 not in v.shape):
        raise DataError(
            f"{path}: {where}.{name} has shape {v.shape}, expected (1, {n}) "
            "(one value per pulse of data.fp)"
        )
    if np.iscomplexobj(v):
        raise DataError(f"{path}: {where}.{name} must be real, got {v.dtype}")
    values = v.reshape(-1).astype(np.float64)
    _check_finite(values, path, f"{where}.{name}", ("pulse", ""))
    return values


def _check_finite(values: NDArray[Any], path: Path, name: str, axes: tuple[str, str]) -> None:
    bad = ~np.isfinite(values)
    if np.any(bad):
        first = np.argwhere(bad)[0]
        where = ", ".join(f"{a} {i}" for a, i in zip(axes, first, strict=False))
        raise DataError(
            f"{path}: {name} contains {int(bad.sum())} NaN/inf value(s) (first at {where})"
        )


def _read_file(path: Path, names: list[str], *, lenient: bool = False) -> _GotchaFile:
    """One file's fields, checked for shape, finiteness and plausibility."""
    rec = _load_record(path, names)
    for name in _REQUIRED:
        _field(rec, name, path)
    fp = _field(rec, "fp", path)
    freq = _field(rec, "freq", path)
    if freq.ndim > 2 or (freq.ndim == 2 and 1 not in freq.shape) or freq.size < 2:
        raise DataError(f"{path}: data.freq has shape {freq.shape}, expected (n_freq, 1)")
    n_freq = freq.size
    if fp.ndim != 2 or fp.shape[0] != n_freq or fp.shape[1] < 1:
        raise DataError(
            f"{path}: data.fp has shape {fp.shape}, expected ({n_freq}, n_pulses) "
            f"to match data.freq ({n_freq} frequencies)"
        )
    if not np.iscomplexobj(fp):
        raise DataError(f"{path}: data.fp must be complex (a phase history), got {fp.dtype}")
    freq_hz = freq.reshape(-1).astype(np.float64)
    _check_finite(freq_hz, path, "data.freq", ("index", ""))
    _check_finite(fp, path, "data.fp", ("frequency index", "pulse"))
    n = fp.shape[1]
    positions = np.stack([_row(rec, k, n, path) for k in ("x", "y", "z")], axis=1)
    f = _GotchaFile(
        path=path,
        phase_history=fp.T,
        freq_hz=freq_hz,
        positions_m=positions,
        r0_m=_row(rec, "r0", n, path),
        th_deg=_row(rec, "th", n, path),
        phi_deg=_row(rec, "phi", n, path),
        record=rec,
    )
    _check_plausible(f, lenient=lenient)
    return f


# ------------------------------------------------------------------- plausibility rules
def _check_plausible(f: _GotchaFile, *, lenient: bool) -> None:
    """Envelope, track, angle, r0 and dynamic-range rules of one file (module notes)."""
    check_envelope(f.path, "data.x/y/z", f.positions_m, lenient=lenient)
    check_track(f.path, "data.x/y/z", f.positions_m, lenient=lenient)
    _check_angles(f, lenient=lenient)
    rng = np.linalg.norm(f.positions_m, axis=1)
    mismatch = np.abs(f.r0_m - rng)
    tol = _R0_TOL_REL * rng
    if np.any(mismatch > tol):
        j = int(np.argmax(mismatch - tol))
        violation(
            f"{f.path}: data.r0, pulse {j}: {f.r0_m[j]:.6g} m but the antenna is "
            f"{rng[j]:.6g} m from the scene centre (rule: agree to {_R0_TOL_REL:.2g} x "
            f"range = {tol[j] * 1e3:.2g} mm, float32 rounding)",
            lenient=lenient,
        )
    check_signal(f.path, "data.fp", f.phase_history, lenient=lenient)


def _check_angles(f: _GotchaFile, *, lenient: bool) -> None:
    """``th`` and ``phi`` agree with the azimuth and elevation of the positions."""
    x, y, z = f.positions_m.T
    expected = {
        "th": np.rad2deg(np.arctan2(y, x)),
        "phi": np.rad2deg(np.arctan2(z, np.hypot(x, y))),
    }
    for name, values in (("th", f.th_deg), ("phi", f.phi_deg)):
        diff = np.abs((values - expected[name] + 180.0) % 360.0 - 180.0)
        if float(diff.max()) > _ANGLE_TOL_DEG:
            j = int(np.argmax(diff))
            violation(
                f"{f.path}: data.{name}, pulse {j}: {values[j]:.6g} deg but the antenna "
                f"position gives {expected[name][j]:.6g} deg (rule: agree to "
                f"{_ANGLE_TOL_DEG:g} deg)",
                lenient=lenient,
            )


# ------------------------------------------------------------------ several files
def _frequency_grid(freq_hz: NDArray[np.float64], path: Path) -> tuple[float, float]:
    """Least-squares ``f_k = f0 + k df`` (float64) of a float32-rounded grid, checked."""
    k = np.arange(freq_hz.size, dtype=np.float64)
    kc = k - k.mean()
    df = float(np.sum(kc * (freq_hz - freq_hz.mean())) / np.sum(kc * kc))
    f0 = float(freq_hz.mean() - df * k.mean())
    if not df > 0 or not f0 > 0:
        raise DataError(
            f"{path}: data.freq must be positive and increase, got f0 {f0:.6g} Hz, step {df:.6g} Hz"
        )
    dev = float(np.max(np.abs(freq_hz - (f0 + k * df))))
    if dev > _GRID_TOL * df:
        raise DataError(
            f"{path}: data.freq is not a uniform grid: deviates by up to {dev:.4g} Hz from "
            f"the best-fit step {df:.7g} Hz (tolerance {_GRID_TOL * df:.4g} Hz)"
        )
    return f0, df


def _common_radar(files: list[_GotchaFile]) -> Radar:
    """The radar of the shared frequency grid; files with other frequencies are refused."""
    first = files[0]
    f0, df = _frequency_grid(first.freq_hz, first.path)
    for f in files[1:]:
        if f.freq_hz.size != first.freq_hz.size:
            raise DataError(
                f"{f.path}: {f.freq_hz.size} frequencies, but {first.path.name} has "
                f"{first.freq_hz.size}"
            )
        diff = float(np.max(np.abs(f.freq_hz - first.freq_hz)))
        if diff > _GRID_TOL * df:
            raise DataError(
                f"{f.path}: frequencies differ from those of {first.path.name} by up to "
                f"{diff:.4g} Hz"
            )
    n_freq = first.freq_hz.size
    return Radar(
        carrier_hz=f0 + (n_freq // 2) * df,
        bandwidth_hz=n_freq * df,
        n_samples=n_freq,
        frequency_step_hz=df,
        pulse="rect",
    )


def _flight_order(files: list[_GotchaFile]) -> list[_GotchaFile]:
    """Files in flight order: sorted by azimuth, starting after the largest azimuth gap."""
    if len(files) == 1:
        return files
    centre = np.array([np.angle(np.mean(np.exp(1j * f.azimuth_rad))) % (2 * np.pi) for f in files])
    order = list(np.argsort(centre, kind="stable"))
    keys = centre[order]
    gaps = np.diff(np.concatenate([keys, [keys[0] + 2 * np.pi]]))
    start = (int(np.argmax(gaps)) + 1) % len(files)
    order = order[start:] + order[:start]
    trends = [np.sign(f.azimuth_rad[-1] - f.azimuth_rad[0]) for f in files if f.n_pulses > 1]
    if trends and np.median(trends) < 0:  # azimuth decreasing in flight: clockwise pass
        order = order[::-1]
    return [files[i] for i in order]


def _check_duplicates(files: list[_GotchaFile]) -> None:
    """Two files holding the same pulses (one file under two names, or a copy)."""
    for i, a in enumerate(files):
        for b in files[i + 1 :]:
            same = a.positions_m.shape == b.positions_m.shape and np.array_equal(
                a.positions_m, b.positions_m
            )
            if same:
                raise DataError(
                    f"{b.path}: duplicate of {a.path.name}: the two files hold the same "
                    f"{a.n_pulses} pulses (antenna positions identical)"
                )


def _check_consecutive(files: list[_GotchaFile]) -> None:
    steps = np.concatenate([np.linalg.norm(np.diff(f.positions_m, axis=0), axis=1) for f in files])
    if steps.size == 0:
        return
    step = float(np.median(steps))
    for a, b in zip(files[:-1], files[1:], strict=True):
        jump = b.positions_m[0] - a.positions_m[-1]
        gap = float(np.linalg.norm(jump))
        heading = (
            a.positions_m[-1] - a.positions_m[-2]
            if a.n_pulses > 1
            else b.positions_m[min(1, b.n_pulses - 1)] - b.positions_m[0]
        )
        forward = float(jump @ heading) > 0 or a.n_pulses == b.n_pulses == 1
        if gap > MAX_STEP * step or gap == 0.0 or not forward:
            raise DataError(
                f"{b.path}: does not follow {a.path.name}: {gap:.4g} m ({gap / step:.3g} "
                f"pulse spacings) from its last pulse (azimuth {a.th_deg[-1]:.4f} deg) to "
                f"the first pulse here ({b.th_deg[0]:.4f} deg); the files must be "
                "consecutive, without gaps or repeats"
            )


def _check_continuity(files: list[_GotchaFile], *, lenient: bool) -> None:
    """The track rule of a file holds across files: second differences at the junctions.

    At the junction of consecutive files ``a`` and ``b``, the second differences of the
    last two pulses of ``a`` and the first two of ``b`` are at most ``MAX_BEND`` times
    the median pulse spacing of all the files, as within one file: a file shifted by a
    fraction of a spacing, or a missing pulse, breaks it.
    """
    steps = np.concatenate([np.linalg.norm(np.diff(f.positions_m, axis=0), axis=1) for f in files])
    if steps.size == 0:
        return
    spacing = float(np.median(steps))
    for a, b in zip(files[:-1], files[1:], strict=True):
        window = np.concatenate([a.positions_m[-2:], b.positions_m[:2]])
        if window.shape[0] < 3:
            continue
        bend = np.linalg.norm(np.diff(window, 2, axis=0), axis=1)
        if float(bend.max()) > MAX_BEND * spacing:
            violation(
                f"{b.path}: data.x/y/z, pulse 0: the track does not continue that of "
                f"{a.path.name}: an antenna position at the junction is "
                f"{0.5 * float(bend.max()):.3g} m off the midpoint of its neighbours (rule: "
                f"second differences at most {MAX_BEND:g} x the median spacing of "
                f"{spacing:.4g} m across files as within one)",
                lenient=lenient,
            )


def _carrier_phase(frequencies_hz: NDArray[np.float64], ranges_m: NDArray[np.float64]) -> Any:
    """``exp(-1j 4 pi f / c * dR)`` for ranges ``dR`` (n_pulses,), shape (n_pulses, n_freq).

    The phase is reduced modulo one cycle in float64 before the exponential.
    """
    cycles = np.multiply.outer(2.0 * ranges_m / C, frequencies_hz)
    cycles -= np.round(cycles)
    return np.exp(-2j * np.pi * cycles)


def _as_path(p: Any) -> Path:
    if not isinstance(p, (str, os.PathLike)):
        raise TypeError(
            f"paths must be a path (str or os.PathLike) or a sequence of paths, got "
            f"{type(p).__name__} {p!r:.60}"
        )
    path = Path(p)  # a PathLike of bytes raises TypeError here
    return path


def _as_paths(paths: PathLike | Sequence[PathLike]) -> list[Path]:
    if isinstance(paths, (str, os.PathLike, bytes, bytearray)) or not isinstance(paths, Sequence):
        return [_as_path(paths)]
    out = [_as_path(p) for p in paths]
    if not out:
        raise DataError("no GOTCHA file given")
    seen: dict[Path, Path] = {}
    for p in out:
        key = p.resolve()
        if key in seen:
            first = seen[key]
            also = "" if first == p else f" (also as {first})"
            raise DataError(f"{p}: given twice{also}")
        seen[key] = p
    return out


def _phase_history(
    files: list[_GotchaFile], freqs: NDArray[np.float64], positions: NDArray[np.float64]
) -> tuple[NDArray[np.complex128], str]:
    """Concatenated phase history referenced to ``|r(s)|``, and how it was referenced.

    The plausibility rules have already refused (or, leniently, warned about) an ``r0``
    beyond float32 rounding of ``|r(s)|``; such a file is re-referenced exactly.
    """
    ph = np.concatenate([f.phase_history for f in files]).astype(np.complex128)
    r0 = np.concatenate([f.r0_m for f in files])
    ranges = np.linalg.norm(positions, axis=1)
    mismatch = float(np.max(np.abs(r0 - ranges)))
    if np.all(np.abs(r0 - ranges) <= _R0_TOL_REL * ranges):
        return ph, "data.r0 as stored (= |r(s)| to float32 rounding)"
    logger.warning("r0 departs from |r(s)| by up to %.4g m: re-referencing to |r(s)|", mismatch)
    ph *= _carrier_phase(freqs, r0 - ranges)
    return ph, f"re-referenced from data.r0 (max |r0 - |r(s)|| = {mismatch:.4g} m)"


def _trajectory(
    files: list[_GotchaFile], positions: NDArray[np.float64], speed: float
) -> Trajectory:
    """The antenna track with slow time from the along-track distance at ``speed``."""
    try:
        return Trajectory.from_positions(positions, speed_mps=speed)
    except (ValueError, np.linalg.LinAlgError) as exc:
        names = ", ".join(f.path.name for f in files)
        logger.debug("Trajectory.from_positions failed: %r", exc)
        raise DataError(
            f"{names}: unusable antenna positions: no smooth track fits them at "
            f"--speed {speed:g} m/s"
        ) from None


def _autofocus_factor(files: list[_GotchaFile], freqs: NDArray[np.float64]) -> Any:
    """AFRL's correction ``exp(+1j ph_correct) exp(-1j 4 pi f / c r_correct)`` per pulse."""
    rc, pc = [], []
    for f in files:
        af = f.record["af"] if "af" in f.record.dtype.names else None
        if not (isinstance(af, np.ndarray) and af.dtype.names and af.size == 1):
            raise DataError(
                f"{f.path}: autofocus requested but the file has no struct data.af "
                "(AFRL provides it for HH and VV only)"
            )
        af_rec = af.reshape(-1)[0]
        rc.append(_row(af_rec, "r_correct", f.n_pulses, f.path, "data.af"))
        pc.append(_row(af_rec, "ph_correct", f.n_pulses, f.path, "data.af"))
    return np.exp(1j * np.concatenate(pc))[:, None] * _carrier_phase(freqs, np.concatenate(rc))


def _metadata(files: list[_GotchaFile], **extra: Any) -> dict[str, Any]:
    th = np.concatenate([f.th_deg for f in files])
    return {
        "source": "gotcha",
        "files": [f.path.name for f in files],
        "paths": [str(f.path) for f in files],
        "pulses_per_file": [f.n_pulses for f in files],
        "azimuth_deg": [float(np.min(th)), float(np.max(th))],
        "elevation_deg": float(np.mean(np.concatenate([f.phi_deg for f in files]))),
        **extra,
    }


def read_gotcha(
    paths: PathLike | Sequence[PathLike],
    *,
    speed_mps: float = 70.0,
    reference_point_m: ArrayLike = (0.0, 0.0, 0.0),
    autofocus: bool = False,
    lenient: bool = False,
) -> Traces:
    """Read one or several consecutive GOTCHA files as one aperture.

    The files are checked (shapes, finite values, the plausibility rules of the module
    notes), put in flight (azimuth) order whatever the order given, checked to share one
    frequency grid and to follow each other without gaps or repeats, and concatenated
    along slow time. The conventions chosen (phase reference, autofocus sign) are in the
    module notes.

    Parameters
    ----------
    paths : path or sequence of paths
        GOTCHA ``.mat`` files (see the module docstring for the format).
    speed_mps : float
        Platform speed ``V`` (m/s, > 0): slow time is the along-track distance over
        ``V``, with ``s = 0`` half-way along the path.
    reference_point_m : (2,) or (3,) array_like
        Range-compression reference ``rho_o`` (m) of the returned traces; another point
        than the scene centre re-references the data exactly, by the phase factor
        ``exp(-1j 4 pi f / c (|r| - |r - rho_o|))``. Echoes must stay within about
        +-51 m of differential range from ``rho_o`` (circular fast-time window).
    autofocus : bool
        Apply AFRL's autofocus solution ``af.r_correct``, ``af.ph_correct`` (HH and VV
        only; a file without it is an error when this is True).
    lenient : bool
        Turn a broken plausibility rule into a logged warning (unusual but genuine data).

    Returns
    -------
    Traces
        ``(n_pulses, n_freq)`` complex128 traces, float64 positions (m) in the GOTCHA
        frame, ``Radar(pulse="rect")`` on the fitted grid; metadata: ``source="gotcha"``,
        files, azimuth range and mean elevation (deg), autofocus, phase reference, speed.

    Raises
    ------
    DataError
        One line naming the file, field, pulse and rule (unreadable or inconsistent
        files, a broken plausibility rule, duplicate or non-consecutive files), or the
        bytes the files would take beyond the memory limit (:mod:`sarmotion._limits`;
        only the variable ``data`` of each file is inflated and read).
    TypeError
        ``paths`` is not a path or a sequence of paths (bytes are refused).
    """
    speed = positive(speed_mps, "speed_mps", unit="m/s")
    lo, hi = SPEED_RANGE_MPS
    if not lo <= speed <= hi:
        raise ValueError(f"speed_mps must be within [{lo:g}, {hi:g}] m/s, got {speed_mps!r}")
    lenient = as_lenient(lenient)
    autofocus = as_lenient(autofocus, "autofocus")
    rho_o = as_point(reference_point_m, name="reference_point_m")
    given = _as_paths(paths)
    summaries = [_inspect(p) for p in given]
    _check_budget(given, summaries)
    files = [_read_file(p, m.names, lenient=lenient) for p, m in zip(given, summaries, strict=True)]
    radar = _common_radar(files)
    _check_duplicates(files)
    files = _flight_order(files)
    _check_consecutive(files)
    _check_continuity(files, lenient=lenient)
    positions = np.concatenate([f.positions_m for f in files])
    trajectory = _trajectory(files, positions, speed)
    freqs = radar.frequencies_hz
    ph, phase_reference = _phase_history(files, freqs, positions)
    if autofocus:
        ph *= _autofocus_factor(files, freqs)
    if np.any(rho_o != 0.0):
        ranges = np.linalg.norm(positions, axis=1)
        ph *= _carrier_phase(freqs, ranges - np.linalg.norm(positions - rho_o, axis=1))
    metadata = _metadata(
        files, autofocus=bool(autofocus), phase_reference=phase_reference, speed_mps=speed
    )
    logger.debug("read %d GOTCHA file(s): %d pulses", len(files), ph.shape[0])
    return Traces.from_phase_history(
        ph, trajectory=trajectory, radar=radar, reference_point_m=rho_o, metadata=metadata
    )


def is_gotcha_file(path: PathLike) -> bool:
    """Whether ``path`` is a MATLAB v5 file holding a struct named ``data``.

    A cheap check (it reads the variable headers only), meant for dispatching inputs; it
    does not validate the fields, which :func:`read_gotcha` does.
    """
    p = Path(path)
    if not p.is_file():
        return False
    try:
        if over_budget(p.stat().st_size, "the file"):
            return False
        check_mat_v5(p.read_bytes(), variables=("data",), max_inflated=_inflation_cap())
        variables = scipy.io.whosmat(p, appendmat=False)
    except Exception:  # not a MATLAB v5 file: scipy raises ValueError, MatReadError, ...
        return False
    return any(name == "data" and kind == "struct" for name, _, kind in variables)


# --------------------------------------------------------------------------- writing
def write_gotcha(
    traces: Traces,
    directory: PathLike,
    *,
    pulses_per_file: int | None = None,
    name_pattern: str = DEFAULT_NAME_PATTERN,
    overwrite: bool = True,
) -> list[Path]:
    """Write traces as GOTCHA ``.mat`` files that any GOTCHA tool reads.

    Each file holds the struct ``data`` of the AFRL release (module docstring): ``fp``
    (n_freq, n) complex64, ``freq`` (n_freq, 1) and ``x``, ``y``, ``z``, ``r0``, ``th``,
    ``phi`` (1, n) float32 as in the originals, and ``af`` with zero corrections.
    Coordinates are written relative to ``traces.reference_point_m`` (GOTCHA's scene
    centre is the origin), so that ``r0 = |r(s) - rho_o|`` is the phase reference of
    the data as they stand: the phase history is written unchanged. Reading the files
    back gives the scene in that translated frame.

    Parameters
    ----------
    traces : Traces
        Traces to write.
    directory : path
        Output directory (created if missing).
    pulses_per_file : int, optional
        Pulses per file (the last file takes the remainder); default: all in one file.
        The AFRL release has one file per degree (117 or 118 pulses).
    name_pattern : str
        File-name pattern, formatted with ``index`` = 1, 2, ... in flight order and
        ``azimuth``, the AFRL release's file number of the file's first pulse:
        ``1 + floor(th)`` for its azimuth ``th`` in [0, 360) degrees seen from the
        reference point (:data:`AZIMUTH_NAME_PATTERN`).
    overwrite : bool
        Replace existing files (default); if False, raise FileExistsError first.

    Returns
    -------
    list of Path
        The files written, in flight order.

    Notes
    -----
    Every file is written to a temporary file in ``directory`` and renamed onto its
    name only when all files are complete: on error nothing half-written remains.

    float32 positions: a write and read moves the positions by at most half a float32
    step (0.24 mm at 7 km), yet backprojected point targets keep their peak position and
    value (``tests/io/test_io_gotcha.py::test_round_trip_simulated_scene``): the rounding is
    common to ``|r - rho|`` and ``|r|`` and cancels in the differential range. float32
    positions are thus kept, as in the originals, for compatibility with GOTCHA tools.
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    out_dir = Path(directory)
    n = traces.n_pulses
    per = n if pulses_per_file is None else pulses_per_file
    if isinstance(per, bool) or not isinstance(per, (int, np.integer)) or per < 1:
        raise ValueError(f"pulses_per_file must be a positive integer, got {pulses_per_file!r}")
    bounds = [(a, min(a + int(per), n)) for a in range(0, n, int(per))]
    pos = traces.positions_m - traces.reference_point_m[None, :]
    th = np.unwrap(np.arctan2(pos[:, 1], pos[:, 0]))
    th = np.rad2deg(th - 2 * np.pi * np.floor(th[0] / (2 * np.pi)))
    azimuths = [1 + int(np.floor(th[a] % 360.0)) for a, _ in bounds]
    try:
        names = [name_pattern.format(index=i + 1, azimuth=azimuths[i]) for i in range(len(bounds))]
    except (KeyError, IndexError, ValueError) as exc:
        raise ValueError(
            f"name_pattern must be a format string with the field {{index}}, got "
            f"{name_pattern!r} ({exc})"
        ) from None
    if len(set(names)) != len(names):
        raise ValueError(
            f"name_pattern {name_pattern!r} gives the same name to several files; include {{index}}"
        )
    if any(Path(nm).name != nm or nm in ("", ".", "..") for nm in names):
        raise ValueError(f"name_pattern must give plain file names, got {names[0]!r}")

    r0 = np.linalg.norm(pos, axis=1)
    phi = np.rad2deg(np.arctan2(pos[:, 2], np.hypot(pos[:, 0], pos[:, 1])))
    fp = traces.phase_history().T.astype(np.complex64)
    freq = traces.frequencies_hz.astype(np.float32)[:, None]

    def row(v: NDArray[Any]) -> NDArray[np.float32]:
        return np.asarray(v, dtype=np.float32)[None, :]

    out_dir.mkdir(parents=True, exist_ok=True)
    targets = [out_dir / nm for nm in names]
    with staged_paths(targets, overwrite=overwrite) as temps:
        for tmp, (a, b) in zip(temps, bounds, strict=True):
            struct = {
                "fp": np.ascontiguousarray(fp[:, a:b]),
                "freq": freq,
                "x": row(pos[a:b, 0]),
                "y": row(pos[a:b, 1]),
                "z": row(pos[a:b, 2]),
                "r0": row(r0[a:b]),
                "th": row(th[a:b]),
                "phi": row(phi[a:b]),
                "af": {"r_correct": row(np.zeros(b - a)), "ph_correct": row(np.zeros(b - a))},
            }
            with tmp.open("xb") as fh:
                scipy.io.savemat(fh, {"data": struct}, format="5", oned_as="row")
                fh.seek(0)
                fh.write(_WRITER_HEADER)
    logger.debug("wrote %d GOTCHA file(s) to %s", len(targets), out_dir)
    return targets
