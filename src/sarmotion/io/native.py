"""sarmotion's own HDF5 files for traces and images (documented, versioned schemas).

Every file carries its kind and version in the root attribute ``schema``; a reader
refuses another kind, and a version newer than it knows, with a :class:`DataError`.
All values are SI; arrays are stored exactly as given (no compression, no casting).

Traces, ``schema = "sarmotion.traces/1"``::

    /                       attrs: schema, sarmotion_version
    /traces/data            (n_pulses, n_samples) complex64 or complex128 -- D_r(s, t)
    /traces/positions_m     (n_pulses, 3) float64 -- antenna positions (m)
    /traces/slow_times_s    (n_pulses,) float64   -- slow times (s), 0 at aperture centre
    /traces                 attrs: carrier_hz, bandwidth_hz, frequency_step_hz (float, Hz),
                                   n_samples (int), pulse ("rect" | "gaussian"),
                                   reference_point_m (3,) float64 (m),
                                   geometry_sha256 (hex string, optional:
                                   :func:`geometry_digest` of the positions, slow
                                   times, reference point and radar; a file whose
                                   geometry no longer matches it is refused, a file
                                   without it is read as before),
                                   metadata (JSON string)
    /extra/<name>           (n_pulses, n_samples) arrays, optional: further trace sets on
                            the same axes (e.g. separated "L" and "S", simulated truth)

The conventions of ``data`` (fast time relative to the reference travel time, ``t = 0``
at sample ``n_samples // 2``) are those of :class:`sarmotion.core.traces.Traces`.

Images, ``schema = "sarmotion.image/1"``::

    /                       attrs: schema, sarmotion_version, metadata (JSON string),
                                   velocity_mps (2,) float64 (m/s), present only when the
                                   image was focused for a ground velocity (ux, uy)
    /values                 (ny, nx) complex (or real) -- pixel values
    /x_m                    (nx,) float64 -- pixel x coordinates (m), strictly monotonic
    /y_m                    (ny,) float64 -- pixel y coordinates (m), strictly monotonic

Files are written to a temporary file in the target directory and renamed onto the
target when complete (``os.replace``): a failed write leaves no file, or the previous one.

Reading is confined to the file and to the memory limit:

* external links, virtual datasets and datasets with external raw storage would make
  the HDF5 library read other files: a file holding one is refused, wherever it is; a
  soft link must resolve inside the file (a loop of soft links is refused);
* the bytes a read allocates are computed from the dataset headers and checked against
  the memory limit (:mod:`sarmotion._limits`) before any array is read; the positions
  and slow times are read and checked before the trace data.

Plausibility rules of a traces file, beyond those of :mod:`sarmotion.io.plausibility`
shared with the other readers: the slow times increase, and with the positions imply
a platform speed of 1 mm/s to 10 km/s; the reference point is seen from every antenna
position at a grazing angle of at least 5 deg (a reference point far from the scene the
aperture looks at, e.g. displaced by 100 km, is at a few degrees).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import subprocess
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._limits import format_bytes, memory_limit, over_budget, phase_history_bytes
from .._validation import integer
from .._version import __version__
from ..core import Radar, Traces, Trajectory
from .errors import DataError
from .plausibility import (
    as_lenient,
    check_coherent_sum,
    check_envelope,
    check_reference_point,
    check_signal,
    check_speed,
    check_times,
    check_track,
    violation,
)
from .staging import staged_paths

__all__ = [
    "TRACES_SCHEMA",
    "IMAGE_SCHEMA",
    "save_traces",
    "load_traces",
    "load_extra",
    "save_image",
    "load_image",
    "native_schema",
    "check_hdf5_terminates",
    "open_native_blocks",
    "NativeBlocks",
]

PathLike = str | os.PathLike[str]

#: Schema of trace files written by this version.
TRACES_SCHEMA = "sarmotion.traces/1"
#: Schema of image files written by this version.
IMAGE_SCHEMA = "sarmotion.image/1"

_SCHEMA_RE = re.compile(r"^sarmotion\.(?P<kind>[a-z]+)/(?P<version>[0-9]+)$")
_RADAR_ATTRS = ("carrier_hz", "bandwidth_hz", "frequency_step_hz", "n_samples", "pulse")


# ----------------------------------------------------------------------------- helpers
def _to_json(metadata: Mapping[str, Any] | None, what: str) -> str:
    def default(obj: Any) -> Any:
        if isinstance(obj, np.generic):
            return obj.item()
        if isinstance(obj, np.ndarray):
            return obj.tolist()
        if isinstance(obj, Path):
            return str(obj)
        raise TypeError(f"{type(obj).__name__} is not JSON-serialisable")

    try:
        return json.dumps(dict(metadata or {}), default=default, allow_nan=True)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{what} metadata must be JSON-serialisable: {exc}") from None


def _from_json(text: Any, path: Path, where: str) -> dict[str, Any]:
    try:
        if isinstance(text, bytes):
            text = text.decode("utf-8")
        value = json.loads(text)
    except RecursionError:
        raise DataError(f"{path}: attribute {where} nests JSON too deeply (corrupt)") from None
    except UnicodeDecodeError:
        raise DataError(f"{path}: attribute {where} is not UTF-8 text (corrupt)") from None
    except (TypeError, ValueError) as exc:
        raise DataError(f"{path}: attribute {where} is not valid JSON ({exc})") from None
    if not isinstance(value, dict):
        raise DataError(f"{path}: attribute {where} must hold a JSON object")
    return value


def _check_finite(values: NDArray[Any], path: Path | str, name: str) -> None:
    bad = ~np.isfinite(values)
    if np.any(bad):
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        raise DataError(
            f"{path}: {name} contains {int(bad.sum())} NaN/inf value(s) (first at {first})"
        )


_WALK = """
import os, sys, h5py
limit, seen = int(sys.argv[2]), set()
limit = min(limit, 64 * os.path.getsize(sys.argv[1]) + (1 << 24))
def visit(obj):
    if hash(obj.id) in seen:
        return
    seen.add(hash(obj.id))
    for name in obj.attrs:
        obj.attrs[name]
    if isinstance(obj, h5py.Group):
        for name in obj:
            if isinstance(obj.get(name, getlink=True), h5py.HardLink):
                visit(obj[name])
    elif obj.is_virtual or obj.external or obj.size * obj.dtype.itemsize > limit:
        return
    elif obj.ndim == 0 or obj.size == 0:
        obj[()]
    else:
        step = max(1, (1 << 24) // max(1, obj.size // obj.shape[0] * obj.dtype.itemsize))
        for i in range(0, obj.shape[0], step):
            obj[i : i + step]
try:
    with h5py.File(sys.argv[1], "r") as fh:
        visit(fh)
except Exception:
    sys.exit(3)
"""


#: Files the child process read to the end: (path, inode, size, mtime, limit, walk) -> True.
_TERMINATES: dict[tuple[Any, ...], bool] = {}


def check_hdf5_terminates(path: PathLike, *, timeout_s: float | None = None) -> None:
    """Read every attribute and dataset of an HDF5 file in a child process, with a time limit.

    Some corruptions of an HDF5 file make the HDF5 library loop forever or crash inside
    a single call (byte-flipped copies of a traces file do, reading a root attribute:
    ``tests/io/test_fuzz_native.py``, counts in ``docs/notes/readers.md``), which no Python
    code of the reading process can interrupt. The child process reads the whole file, through hard
    links only and 16 MB at a time, skipping datasets stored outside the file (which the
    reader refuses) and those beyond the memory limit or 64 times the file's size (fill
    values of chunks never written, for which no structure of the file is read); a child
    that does not finish within ``timeout_s`` (default 20 s plus 1 s per 20 MB) is killed
    and the file refused. Errors the child meets are left to the real reader to report.
    A file that passed is remembered (by path, inode, size and modification time) and not
    read again.

    Raises
    ------
    DataError
        The HDF5 library did not finish reading the file, or crashed on it.
    """
    p = Path(path)
    st = p.stat()
    key = (str(p.resolve()), st.st_ino, st.st_size, st.st_mtime_ns, memory_limit(), _WALK)
    if key in _TERMINATES:
        return
    if timeout_s is None:
        timeout_s = 20.0 + st.st_size / 20e6
    try:
        done = subprocess.run(
            [sys.executable, "-c", _WALK, str(p), str(memory_limit())],
            timeout=timeout_s,
            capture_output=True,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise DataError(
            f"{p}: not a readable HDF5 file: reading it did not finish within "
            f"{timeout_s:.0f} s (corrupt HDF5 structure)"
        ) from None
    if done.returncode < 0:
        raise DataError(f"{p}: not a readable HDF5 file: the HDF5 library crashed on it (corrupt)")
    _TERMINATES[key] = True
    while len(_TERMINATES) > 64:
        _TERMINATES.pop(next(iter(_TERMINATES)))


def native_schema(path: PathLike) -> str | None:
    """The ``schema`` attribute of a native HDF5 file, or None for any other file."""
    p = Path(path)
    if not p.is_file() or not h5py.is_hdf5(p):
        return None
    try:
        with h5py.File(p, "r") as fh:
            schema = fh.attrs.get("schema")
    except OSError:
        return None
    if isinstance(schema, bytes):
        schema = schema.decode("utf-8", "replace")
    return schema if isinstance(schema, str) else None


def _open(path: PathLike, expected: str) -> tuple[h5py.File, Path]:
    """Open a native file for reading after checking its schema kind and version."""
    p = Path(path)
    if not p.exists():
        raise DataError(f"{p}: file not found")
    if not p.is_file():
        raise DataError(f"{p}: not a file")
    if not h5py.is_hdf5(p):
        raise DataError(f"{p}: not an HDF5 file (expected a {expected} file)")
    check_hdf5_terminates(p)
    try:
        fh = h5py.File(p, "r")
    except OSError as exc:
        reason = "truncated" if "truncated" in str(exc) else "corrupt HDF5 structure"
        raise DataError(f"{p}: not a readable HDF5 file: {reason}") from None
    try:
        with _hdf5_errors(p):
            _check_confined(fh, p)
            schema = fh.attrs.get("schema")
        if isinstance(schema, bytes):
            schema = schema.decode("utf-8", "replace")
        if schema is None:
            raise DataError(f"{p}: not a sarmotion file: no root attribute 'schema'")
        m = _SCHEMA_RE.match(str(schema))
        want = _SCHEMA_RE.match(expected)
        assert want is not None
        if m is None or m["kind"] != want["kind"]:
            raise DataError(f"{p}: schema is {schema!r}, expected {expected!r}")
        if int(m["version"]) > int(want["version"]):
            raise DataError(
                f"{p}: schema {schema!r} is newer than this sarmotion reads ({expected!r})"
            )
    except BaseException:
        fh.close()
        raise
    return fh, p


@contextlib.contextmanager
def _hdf5_errors(path: Path) -> Iterator[None]:
    """The HDF5 library's errors on a corrupt file (RuntimeError, OSError, ...) as DataError."""
    try:
        yield
    except (RuntimeError, OSError, KeyError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(
            f"{path}: not a readable HDF5 file: corrupt HDF5 structure ({msg})"
        ) from None


def _check_confined(fh: h5py.File, path: Path) -> None:
    """DataError for a link or dataset that reaches outside the file, or a soft-link loop.

    Walks every object reachable through hard links (each once: hard links may form
    cycles) and every link of every group.
    """
    seen: set[int] = set()
    stack: list[h5py.Group] = [fh]
    while stack:
        group = stack.pop()
        for name in group:
            where = f"{group.name.rstrip('/')}/{name}"
            try:
                link = group.get(name, getlink=True)
            except (KeyError, RuntimeError, OSError, ValueError):
                raise DataError(f"{path}: unreadable link {where} (corrupt)") from None
            if isinstance(link, h5py.ExternalLink):
                raise DataError(
                    f"{path}: {where} is an external link to {link.filename}:{link.path}; "
                    "sarmotion reads no file but the one given"
                )
            if isinstance(link, h5py.SoftLink):
                try:
                    group.get(name)
                except (KeyError, RuntimeError, OSError, ValueError):
                    raise DataError(
                        f"{path}: soft link {where} -> {link.path} does not resolve (a loop of "
                        "soft links, or a missing target)"
                    ) from None
                continue
            if not isinstance(link, h5py.HardLink):
                raise DataError(f"{path}: {where} is a user-defined link (not supported)")
            obj = group.get(name)
            if obj is None:
                raise DataError(f"{path}: object {where} cannot be opened (corrupt)")
            key = hash(obj.id)
            if key in seen:
                continue
            seen.add(key)
            if isinstance(obj, h5py.Group):
                stack.append(obj)
            elif isinstance(obj, h5py.Dataset):
                if obj.is_virtual:
                    raise DataError(
                        f"{path}: dataset {where} is virtual (its data are in other files); "
                        "sarmotion reads no file but the one given"
                    )
                if obj.external:
                    raise DataError(
                        f"{path}: dataset {where} has external raw storage in "
                        f"{obj.external[0][0]!s}; sarmotion reads no file but the one given"
                    )


def _declared_bytes(group: h5py.Group, name: str) -> int:
    """Bytes of the dataset ``name`` of ``group`` as declared by its header (0 if absent)."""
    obj = group.get(name)
    if not isinstance(obj, h5py.Dataset):
        return 0
    return int(obj.size) * int(obj.dtype.itemsize)


def _check_budget(path: Path, nbytes: int, what: str) -> None:
    reason = over_budget(nbytes, what)
    if reason:
        raise DataError(f"{path}: {reason}")


def _dataset(
    group: h5py.Group, name: str, path: Path, *, ndim: int, rows: slice | None = None
) -> NDArray[Any]:
    where = f"{group.name.rstrip('/')}/{name}"
    obj = group.get(name)
    if not isinstance(obj, h5py.Dataset):
        raise DataError(f"{path}: missing dataset {where}")
    if obj.ndim != ndim:
        raise DataError(f"{path}: dataset {where} must be {ndim}-D, got shape {obj.shape}")
    if obj.dtype.kind not in "biufc":
        raise DataError(f"{path}: dataset {where} must be a numeric array")
    nbytes = int(obj.size) * int(obj.dtype.itemsize)
    if rows is not None:
        nbytes = len(range(*rows.indices(obj.shape[0]))) * nbytes // max(1, obj.shape[0])
    _check_budget(path, nbytes, f"dataset {where} of shape {obj.shape}, {obj.dtype}")
    value = obj[()] if rows is None else obj[rows]
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "biufc":
        raise DataError(f"{path}: dataset {where} must be a numeric array")
    if value.ndim != ndim:
        raise DataError(f"{path}: dataset {where} must be {ndim}-D, got shape {value.shape}")
    _check_finite(value, path, f"dataset {where}")
    return value


def _attr(obj: h5py.HLObject, name: str, path: Path) -> Any:
    if name not in obj.attrs:
        raise DataError(f"{path}: missing attribute {name!r} of {obj.name}")
    value = obj.attrs[name]
    return value.decode("utf-8") if isinstance(value, bytes) else value


def _trace_array(value: ArrayLike, shape: tuple[int, int], what: str) -> NDArray[Any]:
    a = np.asarray(value)
    if a.dtype.kind not in "biufc":
        raise DataError(f"{what} must be a numeric array, got dtype {a.dtype}")
    if a.shape != shape:
        raise DataError(f"{what} must have shape {shape} (n_pulses, n_samples), got {a.shape}")
    _check_finite(a, "save_traces", what)
    return a


# ------------------------------------------------------------------------------ traces
def save_traces(
    path: PathLike,
    traces: Traces,
    *,
    extra: Mapping[str, ArrayLike] | None = None,
    overwrite: bool = True,
) -> Path:
    """Write traces (and optional further trace sets) to a native HDF5 file.

    Parameters
    ----------
    path : path
        Output file (conventionally ``.h5``); its directory must exist.
    traces : Traces
        The traces; stored exactly (dtype kept), metadata as JSON.
    extra : mapping of str to (n_pulses, n_samples) array_like, optional
        Further trace sets on the same axes (e.g. ``{"L": ..., "S": ...}``), stored as
        ``/extra/<name>``; names are non-empty and contain no ``/``.
    overwrite : bool
        Replace an existing file (default); if False, raise FileExistsError.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    DataError
        An extra array of the wrong shape or with NaN/inf, a bad name, or metadata that
        is not JSON-serialisable.
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    extras: dict[str, NDArray[Any]] = {}
    for name, value in (extra or {}).items():
        if not isinstance(name, str) or not name or "/" in name or name in (".", ".."):
            raise DataError(f"extra names must be non-empty strings without '/', got {name!r}")
        extras[name] = _trace_array(value, traces.shape, f"extra[{name!r}]")
    meta = _to_json(traces.metadata, "traces")
    radar = traces.radar
    target = Path(path)
    with staged_paths([target], overwrite=overwrite) as (tmp,):
        with h5py.File(tmp, "w-") as fh:
            fh.attrs["schema"] = TRACES_SCHEMA
            fh.attrs["sarmotion_version"] = __version__
            g = fh.create_group("traces")
            g.create_dataset("data", data=traces.data)
            g.create_dataset("positions_m", data=traces.positions_m)
            g.create_dataset("slow_times_s", data=traces.slow_times_s)
            g.attrs["carrier_hz"] = float(radar.carrier_hz)
            g.attrs["bandwidth_hz"] = float(radar.bandwidth_hz)
            g.attrs["frequency_step_hz"] = float(radar.frequency_step_hz)
            g.attrs["n_samples"] = int(radar.n_samples)
            g.attrs["pulse"] = str(radar.pulse)
            g.attrs["reference_point_m"] = np.asarray(traces.reference_point_m, np.float64)
            g.attrs["geometry_sha256"] = geometry_digest(
                traces.positions_m, traces.slow_times_s, traces.reference_point_m, radar
            )
            g.attrs["metadata"] = meta
            if extras:
                e = fh.create_group("extra")
                for name, value in extras.items():
                    e.create_dataset(name, data=value)
    return target


def _traces_header(
    fh: h5py.File, p: Path, *, lenient: bool, block_rows: int | None = None
) -> dict[str, Any]:
    """Everything of a traces file but the data, checked: radar, trajectory, reference.

    The memory the data will take is checked against the limit from the header of
    ``/traces/data`` (of ``block_rows`` pulses of it when given); the positions and slow
    times are read and checked against the plausibility rules before any trace is read.
    """
    g = fh.get("traces")
    if not isinstance(g, h5py.Group):
        raise DataError(f"{p}: missing group /traces")
    d = g.get("data")
    if not isinstance(d, h5py.Dataset):
        raise DataError(f"{p}: missing dataset /traces/data")
    if d.ndim != 2:
        raise DataError(f"{p}: dataset /traces/data must be 2-D, got shape {d.shape}")
    n, m = (int(k) for k in d.shape)
    if d.dtype.kind != "c":
        raise DataError(f"{p}: dataset /traces/data must be complex, got {d.dtype}")
    for name, shape in (("positions_m", (n, 3)), ("slow_times_s", (n,))):
        obj = g.get(name)
        if isinstance(obj, h5py.Dataset) and obj.shape != shape:
            raise DataError(f"{p}: dataset /traces/{name} has shape {obj.shape}, expected {shape}")
    rows = n if block_rows is None else min(block_rows, n)
    stored = sum(_declared_bytes(g, k) for k in ("positions_m", "slow_times_s"))
    stored += _declared_bytes(g, "data") // max(n, 1) * rows
    _check_budget(
        p,
        stored + phase_history_bytes(rows, m),
        f"{format_bytes(stored)} of datasets and the working copies of {rows} x {m} traces",
    )
    pos = _dataset(g, "positions_m", p, ndim=2)
    s = _dataset(g, "slow_times_s", p, ndim=1)
    attrs = {name: _attr(g, name, p) for name in _RADAR_ATTRS}
    ref = np.asarray(_attr(g, "reference_point_m", p), dtype=np.float64)
    meta = _from_json(_attr(g, "metadata", p), p, "/traces metadata")
    if pos.shape != (n, 3):
        raise DataError(
            f"{p}: dataset /traces/positions_m has shape {pos.shape}, expected ({n}, 3)"
        )
    if s.shape != (n,):
        raise DataError(f"{p}: dataset /traces/slow_times_s has shape {s.shape}, expected ({n},)")
    if ref.shape != (3,):
        raise DataError(f"{p}: attribute reference_point_m has shape {ref.shape}, expected (3,)")
    _check_finite(ref, p, "attribute reference_point_m")
    pos = pos.astype(np.float64)
    s = s.astype(np.float64)
    field = "/traces/positions_m"
    check_envelope(p, field, pos - ref, lenient=lenient)
    check_track(p, field, pos, lenient=lenient)
    check_times(p, "/traces/slow_times_s", s, lenient=lenient)
    check_speed(p, "/traces/positions_m and slow_times_s", pos, s, lenient=lenient)
    check_reference_point(p, "/traces reference_point_m", pos, ref, lenient=lenient)
    try:
        radar = Radar(
            carrier_hz=float(attrs["carrier_hz"]),
            bandwidth_hz=float(attrs["bandwidth_hz"]),
            n_samples=int(attrs["n_samples"]),
            frequency_step_hz=float(attrs["frequency_step_hz"]),
            pulse=str(attrs["pulse"]),  # type: ignore[arg-type]
        )
        trajectory = Trajectory(positions_m=pos, slow_times_s=s)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{p}: inconsistent traces: {exc}") from None
    if radar.n_samples != m:
        raise DataError(
            f"{p}: inconsistent traces: /traces/data has {m} samples per pulse, the radar "
            f"{radar.n_samples}"
        )
    _check_digest(g, p, pos, s, ref, radar, lenient=lenient)
    return {"radar": radar, "trajectory": trajectory, "reference_point_m": ref, "metadata": meta}


def geometry_digest(
    positions_m: ArrayLike, slow_times_s: ArrayLike, reference_point_m: ArrayLike, radar: Radar
) -> str:
    """SHA-256 (hex) of the geometry a traces file's phases rest on.

    Over the antenna positions (m), slow times (s), reference point (m) as little-endian
    float64 and the radar's carrier, bandwidth and frequency step (Hz). A reference point
    moved by metres, or a position or time edited within the plausibility rules, changes
    the travel times every phase is referred to while leaving the file plausible: only a
    digest written with them tells that the file was altered after it was written.
    """
    h = hashlib.sha256()
    for value in (
        positions_m,
        slow_times_s,
        reference_point_m,
        [radar.carrier_hz, radar.bandwidth_hz, radar.frequency_step_hz],
    ):
        h.update(np.ascontiguousarray(value, dtype="<f8").tobytes())
    return h.hexdigest()


def _check_digest(
    g: h5py.Group,
    p: Path,
    pos: NDArray[np.float64],
    s: NDArray[np.float64],
    ref: NDArray[np.float64],
    radar: Radar,
    *,
    lenient: bool,
) -> None:
    """The file's geometry against the digest written with it (files without one pass)."""
    stored = g.attrs.get("geometry_sha256")
    if stored is None:
        return
    if isinstance(stored, bytes):
        stored = stored.decode("ascii", "replace")
    if str(stored) != geometry_digest(pos, s, ref, radar):
        violation(
            f"{p}: the antenna positions, slow times, reference point or radar do not match "
            "the digest written with them (/traces geometry_sha256): the file was altered "
            "after it was written",
            lenient=lenient,
        )


def load_traces(path: PathLike, *, lenient: bool = False) -> Traces:
    """Read the traces of a native HDF5 file (schema ``sarmotion.traces/1``).

    Parameters
    ----------
    path : path
        File written by :func:`save_traces`.
    lenient : bool
        Log a broken plausibility rule as a warning instead of refusing the file.

    Returns
    -------
    Traces
        Data, trajectory, radar, reference point and metadata as saved.

    Raises
    ------
    DataError
        Missing file, not HDF5, another schema or a newer version, a missing dataset or
        attribute, wrong shapes, NaN/inf values, inconsistent parameters, or a broken
        plausibility rule of :mod:`sarmotion.io.plausibility` (antenna envelope relative
        to the reference point, a smooth track, increasing slow times, the platform
        speed, the grazing angle of the reference point, a phase history not zero nor
        constant and within the dynamic range); a file that reaches other files or
        loops; the bytes it would take beyond the memory limit.
    """
    lenient = as_lenient(lenient)
    fh, p = _open(path, TRACES_SCHEMA)
    with fh, _hdf5_errors(p):
        header = _traces_header(fh, p, lenient=lenient)
        data = _dataset(fh["traces"], "data", p, ndim=2)
    try:
        traces = Traces(data=data, **header)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{p}: inconsistent traces: {exc}") from None
    check_signal(p, "/traces/data (as phase history)", traces.phase_history(), lenient=lenient)
    return traces


def load_extra(path: PathLike) -> dict[str, NDArray[Any]]:
    """The extra trace sets of a native traces file, ``{name: (n_pulses, n_samples)}``.

    Returns an empty dict when the file has none.
    """
    fh, p = _open(path, TRACES_SCHEMA)
    with fh, _hdf5_errors(p):
        g = fh.get("traces")
        shape = g["data"].shape if isinstance(g, h5py.Group) and "data" in g else None
        e = fh.get("extra")
        if e is None:
            return {}
        if not isinstance(e, h5py.Group):
            raise DataError(f"{p}: /extra must be a group")
        total = sum(_declared_bytes(e, name) for name in e)
        _check_budget(p, total, f"{len(e)} dataset(s) in /extra")
        out = {}
        for name in e:
            value = _dataset(e, name, p, ndim=2)
            if shape is not None and value.shape != shape:
                raise DataError(
                    f"{p}: dataset /extra/{name} has shape {value.shape}, expected {shape} "
                    "like /traces/data"
                )
            out[name] = value
    return out


# ------------------------------------------------------------------------------ images
def _image_axis(values: ArrayLike, n: int, name: str) -> NDArray[np.float64]:
    a = np.asarray(values, dtype=np.float64)
    if a.shape != (n,):
        raise DataError(f"{name} must have shape ({n},) to match the image, got {a.shape}")
    _check_finite(a, "save_image", name)
    d = np.diff(a)
    if n > 1 and not (np.all(d > 0) or np.all(d < 0)):
        raise DataError(f"{name} must be strictly monotonic (pixel coordinates in m)")
    return a


def save_image(
    path: PathLike,
    values: ArrayLike,
    *,
    x_m: ArrayLike,
    y_m: ArrayLike,
    velocity_mps: ArrayLike | None = None,
    metadata: Mapping[str, Any] | None = None,
    overwrite: bool = True,
) -> Path:
    """Write an image with its axes to a native HDF5 file (schema ``sarmotion.image/1``).

    Parameters
    ----------
    path : path
        Output file (conventionally ``.h5``); its directory must exist.
    values : (ny, nx) array_like
        Pixel values, complex (or real); stored with their dtype.
    x_m : (nx,) array_like
        Pixel x coordinates (m), strictly monotonic.
    y_m : (ny,) array_like
        Pixel y coordinates (m), strictly monotonic.
    velocity_mps : (2,) array_like, optional
        Ground velocity ``(ux, uy)`` (m/s) the image was focused for; None for a
        stationary-scene image.
    metadata : mapping, optional
        JSON-serialisable provenance.
    overwrite : bool
        Replace an existing file (default); if False, raise FileExistsError.

    Returns
    -------
    Path
        ``path``.
    """
    v = np.asarray(values)
    if v.ndim != 2 or v.dtype.kind not in "biufc":
        raise DataError(f"values must be a numeric (ny, nx) array, got {v.dtype} {v.shape}")
    _check_finite(v, "save_image", "values")
    x = _image_axis(x_m, v.shape[1], "x_m")
    y = _image_axis(y_m, v.shape[0], "y_m")
    vel = None
    if velocity_mps is not None:
        vel = np.asarray(velocity_mps, dtype=np.float64)
        if vel.shape != (2,) or not np.all(np.isfinite(vel)):
            raise DataError(
                f"velocity_mps must be a finite ground velocity (ux, uy) in m/s, got {vel}"
            )
    meta = _to_json(metadata, "image")
    target = Path(path)
    with staged_paths([target], overwrite=overwrite) as (tmp,):
        with h5py.File(tmp, "w-") as fh:
            fh.attrs["schema"] = IMAGE_SCHEMA
            fh.attrs["sarmotion_version"] = __version__
            fh.create_dataset("values", data=v)
            fh.create_dataset("x_m", data=x)
            fh.create_dataset("y_m", data=y)
            if vel is not None:
                fh.attrs["velocity_mps"] = vel
            fh.attrs["metadata"] = meta
    return target


def load_image(path: PathLike) -> dict[str, Any]:
    """Read a native image file (schema ``sarmotion.image/1``).

    Returns
    -------
    dict
        ``values`` (ny, nx) array, ``x_m`` (nx,) and ``y_m`` (ny,) float64 (m),
        ``velocity_mps`` (2,) float64 (m/s) or None, ``metadata`` dict, ``schema`` str.

    Raises
    ------
    DataError
        Missing file, not HDF5, another schema or a newer version, a missing dataset,
        wrong shapes or NaN/inf values.
    """
    fh, p = _open(path, IMAGE_SCHEMA)
    with fh, _hdf5_errors(p):
        values = _dataset(fh, "values", p, ndim=2)
        x = _dataset(fh, "x_m", p, ndim=1)
        y = _dataset(fh, "y_m", p, ndim=1)
        vel = fh.attrs.get("velocity_mps")
        meta = _from_json(_attr(fh, "metadata", p), p, "metadata")
        schema = str(_attr(fh, "schema", p))
    ny, nx = values.shape
    if x.shape != (nx,) or y.shape != (ny,):
        raise DataError(
            f"{p}: axes x_m {x.shape} and y_m {y.shape} do not match values {values.shape}, "
            f"expected ({nx},) and ({ny},)"
        )
    if vel is not None:
        vel = np.asarray(vel, dtype=np.float64)
        if vel.shape != (2,) or not np.all(np.isfinite(vel)):
            raise DataError(f"{p}: attribute velocity_mps must be 2 finite numbers, got {vel}")
    return {
        "values": values,
        "x_m": x.astype(np.float64),
        "y_m": y.astype(np.float64),
        "velocity_mps": vel,
        "metadata": meta,
        "schema": schema,
    }


# ------------------------------------------------------------------------ block reading
class NativeBlocks:
    """A native traces file opened for reading its traces block by block.

    Made by :func:`open_native_blocks`. The positions, slow times, radar and reference
    point are read and checked on opening; :meth:`blocks` reads the pulses of one block
    at a time.

    Attributes
    ----------
    radar : Radar
        The radar of the file.
    reference_point_m : (3,) ndarray
        Reference point ``rho_o`` (m, float64).
    trajectory : Trajectory
        Antenna positions and slow times of every pulse.
    n_pulses : int
        Number of pulses.
    metadata : dict
        The file's metadata.
    """

    def __init__(self, path: Path, header: dict[str, Any]) -> None:
        self.path = path
        self.radar: Radar = header["radar"]
        self.reference_point_m: NDArray[np.float64] = header["reference_point_m"]
        self.trajectory: Trajectory = header["trajectory"]
        self.n_pulses: int = self.trajectory.n_pulses
        self.metadata: dict[str, Any] = header["metadata"]

    def blocks(self, block_pulses: int) -> Iterator[tuple[int, int, NDArray[np.complexfloating]]]:
        """``(start, stop, data[start:stop])`` for consecutive blocks of ``block_pulses``.

        ``data`` is ``load_traces(path).data`` (fast time, the dtype stored); only the
        pulses of one block are read from the file at a time.

        Raises
        ------
        DataError
            A block beyond the memory limit, NaN/inf samples, or a file that changed.
        """
        rows = integer(block_pulses, "block_pulses", minimum=1)
        m = self.radar.n_samples
        reason = over_budget(
            rows * m * 16 + phase_history_bytes(rows, m),
            f"a block of {rows} x {m} traces and its working copies",
        )
        if reason:
            raise DataError(f"{self.path}: {reason}")
        return self._blocks(rows)

    def _blocks(self, rows: int) -> Iterator[tuple[int, int, NDArray[np.complexfloating]]]:
        fh, p = _open(self.path, TRACES_SCHEMA)
        with fh, _hdf5_errors(p):
            g = fh.get("traces")
            d = g.get("data") if isinstance(g, h5py.Group) else None
            if not isinstance(d, h5py.Dataset) or d.shape != (self.n_pulses, self.radar.n_samples):
                raise DataError(f"{p}: /traces/data changed since the file was opened")
            coherent = 0.0
            for a in range(0, self.n_pulses, rows):
                b = min(a + rows, self.n_pulses)
                block = _dataset(g, "data", p, ndim=2, rows=slice(a, b))
                coherent = check_coherent_sum(p, "/traces/data", block, so_far=coherent)
                yield a, b, block


def open_native_blocks(path: PathLike, *, lenient: bool = False) -> NativeBlocks:
    """Open a native traces file to read its traces block by block.

    The file's confinement (no external links, virtual or external datasets), the
    memory budget of its positions, and the plausibility rules that need only the
    positions, times and reference point are checked here; the signal rules (zero,
    constant, dynamic range) need every trace and are not.

    Returns
    -------
    NativeBlocks
        ``radar``, ``reference_point_m``, ``trajectory``, ``n_pulses``, ``metadata`` and
        ``blocks(block_pulses)``.
    """
    lenient = as_lenient(lenient)
    fh, p = _open(path, TRACES_SCHEMA)
    with fh, _hdf5_errors(p):
        header = _traces_header(fh, p, lenient=lenient, block_rows=1)
    return NativeBlocks(p, header)
