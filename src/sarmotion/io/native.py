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
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import __version__
from ..core import Radar, Traces, Trajectory
from .errors import DataError, staged_paths

__all__ = [
    "TRACES_SCHEMA",
    "IMAGE_SCHEMA",
    "save_traces",
    "load_traces",
    "load_extra",
    "save_image",
    "load_image",
    "native_schema",
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
    if isinstance(text, bytes):
        text = text.decode("utf-8")
    try:
        value = json.loads(text)
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
    try:
        fh = h5py.File(p, "r")
    except OSError as exc:
        raise DataError(f"{p}: cannot open as HDF5 ({exc})") from None
    try:
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


def _dataset(group: h5py.Group, name: str, path: Path, *, ndim: int) -> NDArray[Any]:
    where = f"{group.name.rstrip('/')}/{name}"
    obj = group.get(name)
    if not isinstance(obj, h5py.Dataset):
        raise DataError(f"{path}: missing dataset {where}")
    value = obj[()]
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
            g.attrs["metadata"] = meta
            if extras:
                e = fh.create_group("extra")
                for name, value in extras.items():
                    e.create_dataset(name, data=value)
    return target


def load_traces(path: PathLike) -> Traces:
    """Read the traces of a native HDF5 file (schema ``sarmotion.traces/1``).

    Parameters
    ----------
    path : path
        File written by :func:`save_traces`.

    Returns
    -------
    Traces
        Data, trajectory, radar, reference point and metadata as saved.

    Raises
    ------
    DataError
        Missing file, not HDF5, another schema or a newer version, a missing dataset or
        attribute, wrong shapes, NaN/inf values, or inconsistent parameters.
    """
    fh, p = _open(path, TRACES_SCHEMA)
    with fh:
        g = fh.get("traces")
        if not isinstance(g, h5py.Group):
            raise DataError(f"{p}: missing group /traces")
        data = _dataset(g, "data", p, ndim=2)
        pos = _dataset(g, "positions_m", p, ndim=2)
        s = _dataset(g, "slow_times_s", p, ndim=1)
        attrs = {name: _attr(g, name, p) for name in _RADAR_ATTRS}
        ref = np.asarray(_attr(g, "reference_point_m", p), dtype=np.float64)
        meta = _from_json(_attr(g, "metadata", p), p, "/traces metadata")
    n, m = data.shape
    if not np.iscomplexobj(data):
        raise DataError(f"{p}: dataset /traces/data must be complex, got {data.dtype}")
    if pos.shape != (n, 3):
        raise DataError(
            f"{p}: dataset /traces/positions_m has shape {pos.shape}, expected ({n}, 3)"
        )
    if s.shape != (n,):
        raise DataError(f"{p}: dataset /traces/slow_times_s has shape {s.shape}, expected ({n},)")
    if ref.shape != (3,):
        raise DataError(f"{p}: attribute reference_point_m has shape {ref.shape}, expected (3,)")
    try:
        radar = Radar(
            carrier_hz=float(attrs["carrier_hz"]),
            bandwidth_hz=float(attrs["bandwidth_hz"]),
            n_samples=int(attrs["n_samples"]),
            frequency_step_hz=float(attrs["frequency_step_hz"]),
            pulse=str(attrs["pulse"]),  # type: ignore[arg-type]
        )
        trajectory = Trajectory(positions_m=pos, slow_times_s=s)
        return Traces(
            data=data, trajectory=trajectory, radar=radar, reference_point_m=ref, metadata=meta
        )
    except (TypeError, ValueError) as exc:
        raise DataError(f"{p}: inconsistent traces: {exc}") from None


def load_extra(path: PathLike) -> dict[str, NDArray[Any]]:
    """The extra trace sets of a native traces file, ``{name: (n_pulses, n_samples)}``.

    Returns an empty dict when the file has none.
    """
    fh, p = _open(path, TRACES_SCHEMA)
    with fh:
        g = fh.get("traces")
        shape = g["data"].shape if isinstance(g, h5py.Group) and "data" in g else None
        e = fh.get("extra")
        if e is None:
            return {}
        if not isinstance(e, h5py.Group):
            raise DataError(f"{p}: /extra must be a group")
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
    with fh:
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
