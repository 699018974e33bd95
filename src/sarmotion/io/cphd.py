"""CPHD files (Compensated Phase History Data, NGA.STND.0068-1, versions 1.0.1 and 1.1.0).

Files are parsed and written with sarkit (``sarkit.cphd.Reader`` and ``Writer``); this
module maps them to and from :class:`~sarmotion.traces.Traces`.

Reading (:func:`read_cphd`)
---------------------------
Signal
    FX domain only (``Global/DomainType = FX``): vector ``j`` is the deramped phase
    history on the frequencies ``SC0_j + k SCSS_j`` (Hz), referenced to the
    stabilisation reference point ``SRPPos_j``: a point reflector at ``p`` contributes
    ``exp(2i pi SGN f (TOA_j(p) - TOA_j(SRP_j)))`` with the bistatic time of arrival
    ``TOA_j(p) = (|TxPos_j - p| + |RcvPos_j - p|) / c``. With ``SGN = -1`` this is the
    GOTCHA convention of :mod:`sarmotion.spectral` and the vectors are the phase history
    as they stand; ``SGN = +1`` vectors are conjugated. ``AmpSF`` scales the vectors
    when present; the sample formats CI2, CI4 and CF8 are read. All selected vectors
    must share one frequency grid (SC0, SCSS); the bandwidth is ``max FX2 - min FX1``.
    TOA-domain, compressed and bistatic files are refused (:class:`DataError`).
Geometry
    PVP positions are Earth-centred (ECF, m). sarmotion works in the scene frame of the
    file: origin at the image area reference point (IARP), axes ``uIAX``, ``uIAY`` and
    ``uIAX x uIAY`` (up) of a planar reference surface, or east, north and up at the
    IARP for an HAE surface; the ground of the scene is ``z = 0``. The antenna position
    of a vector is the mid-point of ``TxPos`` and ``RcvPos`` (one antenna, the
    start-stop model of sarmotion), its slow time ``TxTime``, re-centred so that
    ``s = 0`` is half-way between the first and last selected vectors.
Image area
    ``SceneCoordinates/ImageArea`` (its polygon, else the ``X1Y1``/``X2Y2`` rectangle),
    in the image-area frame (IARP, ``uIAX``, ``uIAY``): the scene frame's ``x``, ``y``
    for a planar surface; for an HAE surface along ``uIAXLL``, ``uIAYLL`` in the east and
    north. It is the declared scene, ``metadata["image_area_m"]`` (``(n, 2)`` ground
    ``x, y``, m; :func:`~sarmotion.core.blocks.declared_area`), which the collection
    analyses by default. A polygon of fewer than 3 distinct vertices, no area, or crossing
    sides is refused. A file written by sarmotion with no area declared (its stored
    parameter ``sarmotion.image_area`` is ``"none"``) declares none.
Reference point
    ``SRPPos``. When it moves between the selected vectors the phase history is
    re-referenced exactly to one point (the SRP of the middle selected vector, or
    ``reference_point_m``) by ``exp(-2i pi f (TOA_j(SRP_j) - TOA_j(rho_o)))``.
Plausibility
    The rules of :mod:`sarmotion.io.plausibility` (a one-line DataError naming the file,
    channel, PVP and vector; ``lenient=True``, ``--lenient``, logs a warning instead):
    the antenna above the ground and 10 m to 1000 km from the reference point, a track
    that moves by more than 0 and at most 2.5 median spacings per vector with second
    differences within 1 % of the spacing, ``TxTime`` increasing by at most 2.5 median
    intervals and, with the positions, a platform speed of 1 mm/s to 10 km/s, an
    ``SRPPos`` track as smooth as the antenna's (second differences within
    1 % of the antenna spacing: a fixed SRP, one moving smoothly, or jumps that hold for
    two vectors or more), the IARP's ECF and LLH within 0.1 m, and a largest
    sample modulus at most 1000 times the median, not all zero (refused even
    leniently) and not constant. The rules on the PVPs are checked before the signal is
    read, and the bytes the read will take (from ``NumVectors``, ``NumSamples`` and the
    sample format, which must fill the file's blocks exactly) before anything is read.
    A corrupted PVP that passes them changes the differential range of the scene by
    less than a quarter cycle (``tests/io/test_fuzz_cphd.py``).
Not modelled
    ``TDTropoSRP`` and ``TDIonoSRP`` (the data are taken as referenced to the geometric
    TOA of the SRP), antenna patterns, noise levels and support arrays.

Writing (:func:`write_cphd`)
----------------------------
CPHD 1.1.0, one monostatic spotlight channel of CF8 samples (complex64), FX domain,
``SGN = -1``: the phase history of the traces as it stands. The scene frame of the
traces is placed on the WGS 84 ellipsoid as east, north, up at ``origin_llh`` (the
IARP; the reference surface is that tangent plane), so :func:`read_cphd` gives the
positions back in the same frame. Per vector: ``TxPos = RcvPos`` = the antenna position
(start-stop), ``TxTime`` = slow time from the first pulse, ``RcvTime`` = ``TxTime`` plus
the two-way travel time to the reference point, velocities by finite differences,
``SRPPos`` = the reference point, ``FX1``/``FX2`` = the pulse band ``carrier +- B/2``
(the sampled span for a Gaussian pulse), ``TOA1``/``TOA2`` = the fast-time window
``+-0.4 / SCSS`` (a 1.25 oversampling), ``aFRR1 = aFRR2 = 0`` (no chirp rate is known),
``SIGNAL = 1``. ``SceneCoordinates/ImageArea``: the declared image area
(``image_area_m``, or the traces' ``metadata["image_area_m"]``; its bounding rectangle as
``X1Y1``/``X2Y2``), else a square about the reference point of the TOA window's range
half-width, marked undeclared. The exact radar parameters, the traces' metadata and
whether an image area is declared go in ``ProductInfo/Parameter`` elements named
``sarmotion.radar``, ``sarmotion.metadata`` and ``sarmotion.image_area`` (JSON), which
:func:`read_cphd` restores. The file passes sarkit's consistency checker
(``cphdcheck FILE --thorough``) without errors or warnings.

Writing in blocks (:func:`write_cphd_blocks`, :class:`CphdWriter`)
-----------------------------------------------------------------
The same file, from the acquisition's axes (trajectory, radar, reference point) and its
data handed over a block of vectors at a time: the XML and PVPs are written through
sarkit first, then each block's phase history in its place in the signal block
(sarkit's ``Writer`` writes a channel's signal whole only). Peak memory is one block.
Both writers stage the file under a temporary name and rename it onto ``path`` only once
complete.
"""

from __future__ import annotations

import datetime as _dt
import json
import logging
import os
import sys
from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import lxml.etree
import numpy as np
import sarkit.cphd as skcphd
import sarkit.wgs84 as skwgs84
from numpy.typing import ArrayLike, NDArray

from .._limits import over_budget, phase_history_bytes
from .._validation import geodetic_origin, integer
from .._version import __version__
from ..core import Acquisition, C, Radar, Traces, Trajectory, as_point, delay_phase
from ..core.blocks import IMAGE_AREA_KEY, PulseBlocks
from ..core.polygon import polygon_area, polygon_problem
from ..core.spectral import to_fast_time, to_frequency
from .errors import DataError
from .native import _to_json
from .plausibility import (
    MAX_BEND,
    as_lenient,
    check_coherent_sum,
    check_envelope,
    check_signal,
    check_speed,
    check_times,
    check_track,
    violation,
)
from .staging import staged_paths

__all__ = [
    "CphdBlocks",
    "CphdWriter",
    "is_cphd_file",
    "open_cphd_blocks",
    "read_cphd",
    "write_cphd",
    "write_cphd_blocks",
]

logger = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]

#: XML namespace of the CPHD version written.
CPHD_NAMESPACE = "http://api.nsgreg.nga.mil/schema/cphd/1.1.0"

#: PVPs the reader needs.
_REQUIRED_PVPS = ("TxTime", "TxPos", "RcvTime", "RcvPos", "SRPPos", "FX1", "FX2", "SC0", "SCSS")

#: Largest spread of ``SC0`` and of ``SCSS`` over the vectors, in steps, taken as one grid.
_GRID_TOL = 1e-3

#: Name prefix of the ProductInfo parameters written by sarmotion.
_PARAMETER_PREFIX = "sarmotion."

#: Fast-time (TOA) window saved, as a fraction of the unaliased window ``1 / SCSS``.
_TOA_FRACTION = 0.8

#: Placeholder collection start for traces without one (they carry relative times only).
_DEFAULT_COLLECTION_START = "2000-01-01T00:00:00Z"

_BLOCKS = ("XML", "SUPPORT", "PVP", "SIGNAL")

#: Largest distance between the IARP given in ECF and the IARP given in LLH (m).
_IARP_TOL_M = 0.1


# ----------------------------------------------------------------------------- frames
@dataclass(frozen=True)
class _Frame:
    """A Cartesian scene frame in ECF: ``ecf = origin + local @ axes``."""

    origin_ecf: NDArray[np.float64]  # (3,)
    axes: NDArray[np.float64]  # (3, 3), rows: unit x, y, z in ECF

    def to_ecf(self, local: ArrayLike) -> NDArray[np.float64]:
        return self.origin_ecf + np.asarray(local, dtype=np.float64) @ self.axes

    def to_local(self, ecf: ArrayLike) -> NDArray[np.float64]:
        return (np.asarray(ecf, dtype=np.float64) - self.origin_ecf) @ self.axes.T


def _enu_frame(llh: ArrayLike) -> _Frame:
    """East, north, up at a geodetic point ``(lat_deg, lon_deg, hae_m)``."""
    llh = np.asarray(llh, dtype=np.float64)
    axes = np.stack([skwgs84.east(llh), skwgs84.north(llh), skwgs84.up(llh)])
    return _Frame(origin_ecf=skwgs84.geodetic_to_cartesian(llh), axes=axes)


# ----------------------------------------------------------------------------- reading
def is_cphd_file(path: PathLike) -> bool:
    """Whether ``path`` is a file that starts with a CPHD file type header (``CPHD/``).

    A cheap check for dispatching inputs; :func:`read_cphd` validates the rest.
    """
    p = Path(path)
    if not p.is_file():
        return False
    try:
        with p.open("rb") as fh:
            return fh.read(5) == b"CPHD/"
    except OSError:
        return False


def _open(path: Path, fh: Any) -> Any:
    """A sarkit Reader on ``fh`` after checking the header, version and block sizes."""
    first = fh.readline(64)
    if not first.startswith(b"CPHD/"):
        raise DataError(f"{path}: not a CPHD file (no 'CPHD/' file type header)")
    version = first[5:].decode("ascii", "replace").strip()
    supported = sorted(v["version"] for v in skcphd.VERSION_INFO.values())
    if version not in supported:
        raise DataError(
            f"{path}: CPHD version {version!r} is not supported (supported: {', '.join(supported)})"
        )
    try:
        fh.seek(0)
        _, kvp = skcphd.read_file_header(fh)
        _check_block_sizes(path, kvp)
        fh.seek(0)
        reader = skcphd.Reader(fh)
        _check_arrays(path, reader.metadata.xmltree.getroot(), kvp)
    except RecursionError:
        raise DataError(f"{path}: unreadable CPHD XML (nested too deeply)") from None
    except (ValueError, KeyError, UnicodeDecodeError, lxml.etree.XMLSyntaxError) as exc:
        if isinstance(exc, DataError):
            raise
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(f"{path}: unreadable CPHD header or XML ({msg})") from None
    return reader


def _check_block_sizes(path: Path, kvp: dict[str, str]) -> None:
    """DataError for a block size or offset that is missing or not a count, or past the end.

    Every block but SUPPORT must be declared; the file may not end before a block does.
    """
    size = path.stat().st_size
    for block in _BLOCKS:
        keys = (f"{block}_BLOCK_BYTE_OFFSET", f"{block}_BLOCK_SIZE")
        if block == "SUPPORT" and keys[0] not in kvp:
            continue  # the only optional block
        try:
            offset, length = (int(kvp[k]) for k in keys)
        except (KeyError, ValueError):
            raise DataError(
                f"{path}: file header: {keys[0]} and {keys[1]} must be byte counts, got "
                f"{kvp.get(keys[0])!r} and {kvp.get(keys[1])!r}"
            ) from None
        if offset < 0 or length < 0:
            raise DataError(f"{path}: file header: negative {block.lower()} block offset or size")
        if offset + length > size:
            raise DataError(
                f"{path}: truncated: {size} bytes, but the header puts the end of the "
                f"{block.lower()} block at byte {offset + length}"
            )


#: Bytes per sample of each uncompressed signal array format.
_SAMPLE_BYTES = {"CI2": 2, "CI4": 4, "CF8": 8}


def _count(node: Any, where: str, path: Path, what: str) -> int:
    text = _find(node, where)
    try:
        value = int(text or "")
    except ValueError:
        raise DataError(f"{path}: {what}: {where} must be a whole number, got {text!r}") from None
    if value < 0:
        raise DataError(f"{path}: {what}: {where} must be >= 0, got {value}")
    return value


def _check_arrays(path: Path, xml: Any, kvp: dict[str, str]) -> None:
    """Each channel's signal and PVP arrays lie in their blocks, which they fill exactly.

    For uncompressed signals, channel ``c`` holds ``NumVectors x NumSamples`` samples of
    ``SignalArrayFormat`` from ``SignalArrayByteOffset`` and ``NumVectors x NumBytesPVP``
    bytes of PVPs from ``PVPArrayByteOffset``; the blocks hold the arrays of every
    channel and nothing else (NGA.STND.0068-1, "Data" and the file header). A NumVectors
    or NumSamples that disagrees with the file is refused here, before any read.
    """
    if _find(xml, "Data/SignalCompressionID") is not None:
        return  # refused by _check_collection
    fmt = _find(xml, "Data/SignalArrayFormat")
    if fmt not in _SAMPLE_BYTES:
        raise DataError(f"{path}: Data/SignalArrayFormat {fmt!r} is not CI2, CI4 or CF8")
    per_pvp = _count(xml, "Data/NumBytesPVP", path, "Data")
    sizes = {"SIGNAL": int(kvp["SIGNAL_BLOCK_SIZE"]), "PVP": int(kvp["PVP_BLOCK_SIZE"])}
    used = {"SIGNAL": 0, "PVP": 0}
    for node in xml.findall("./{*}Data/{*}Channel"):
        what = f"channel {_find(node, 'Identifier')!r}"
        n_vectors = _count(node, "NumVectors", path, what)
        n_samples = _count(node, "NumSamples", path, what)
        for block, offset_key, nbytes in (
            ("SIGNAL", "SignalArrayByteOffset", n_vectors * n_samples * _SAMPLE_BYTES[fmt]),
            ("PVP", "PVPArrayByteOffset", n_vectors * per_pvp),
        ):
            offset = _count(node, offset_key, path, what)
            if offset + nbytes > sizes[block]:
                raise DataError(
                    f"{path}: {what}: NumVectors {n_vectors} x NumSamples {n_samples} need "
                    f"{block.lower()} bytes up to {offset + nbytes}, but the {block.lower()} "
                    f"block holds {sizes[block]} (NumVectors or NumSamples disagree with "
                    "the file)"
                )
            used[block] += nbytes
    for block, size in sizes.items():
        if used[block] != size:
            raise DataError(
                f"{path}: the channels' {block.lower()} arrays take {used[block]} bytes but "
                f"the {block.lower()} block holds {size} (NumVectors or NumSamples disagree "
                "with the file)"
            )


def _find(xml: Any, where: str) -> str | None:
    """Stripped text of the element at ``where`` ("A/B/C", any namespace), or None."""
    value = xml.findtext("./" + "/".join("{*}" + part for part in where.split("/")))
    return value.strip() if value is not None else None


def _text(xml: Any, where: str, path: Path) -> str:
    value = _find(xml, where)
    if value is None:
        raise DataError(f"{path}: not a usable CPHD file: no XML element {where}")
    return value


def _number(xml: Any, where: str, path: Path) -> float:
    text = _text(xml, where, path)
    try:
        return float(text)
    except ValueError:
        raise DataError(f"{path}: XML element {where} is not a number ({text!r})") from None


def _check_collection(xml: Any, path: Path) -> None:
    """Refuse what sarmotion does not model: TOA domain, compression, bistatic data."""
    domain = _text(xml, "Global/DomainType", path)
    if domain != "FX":
        raise DataError(
            f"{path}: signal in the {domain} domain (Global/DomainType {domain}); sarmotion "
            "reads FX-domain (deramped phase history) CPHD only"
        )
    if _find(xml, "Data/SignalCompressionID") is not None:
        raise DataError(f"{path}: compressed signal arrays are not supported")
    kind = _find(xml, "CollectionID/CollectType")
    if kind is not None and kind != "MONOSTATIC":
        raise DataError(f"{path}: {kind} collection; sarmotion models one antenna (MONOSTATIC)")


def _select_channel(xml: Any, channel: str | int | None, path: Path) -> tuple[str, int, int]:
    """``(identifier, n_vectors, n_samples)`` of the requested channel."""
    nodes = xml.findall("./{*}Data/{*}Channel")
    ids = [_find(n, "Identifier") or "" for n in nodes]
    if not ids:
        raise DataError(f"{path}: not a usable CPHD file: no Data/Channel")
    if channel is None:
        ref = _find(xml, "Channel/RefChId")
        index = ids.index(ref) if ref in ids else 0
    elif isinstance(channel, (int, np.integer)) and not isinstance(channel, bool):
        if not 0 <= channel < len(ids):
            raise DataError(f"{path}: channel index {channel} outside 0..{len(ids) - 1}")
        index = int(channel)
    elif str(channel) in ids:
        index = ids.index(str(channel))
    else:
        raise DataError(f"{path}: no channel {channel!r} (channels: {', '.join(ids)})")
    if "'" in ids[index] or '"' in ids[index]:
        raise DataError(
            f"{path}: channel identifier {ids[index]!r} contains a quote, which the CPHD "
            "library cannot look up"
        )
    try:
        n_vectors = int(_find(nodes[index], "NumVectors") or "")
        n_samples = int(_find(nodes[index], "NumSamples") or "")
    except ValueError:
        raise DataError(f"{path}: channel {ids[index]}: bad NumVectors or NumSamples") from None
    return ids[index], n_vectors, n_samples


def _vector_range(vectors: tuple[int, int] | None, n: int, path: Path) -> tuple[int, int]:
    start, stop = (0, n) if vectors is None else (int(vectors[0]), int(vectors[1]))
    if not 0 <= start < stop <= n:
        raise DataError(f"{path}: vectors [{start}, {stop}) outside the channel's [0, {n})")
    if stop - start < 2:
        raise DataError(f"{path}: vectors [{start}, {stop}): at least 2 vectors are needed")
    return start, stop


def _read_pvps(reader: Any, ch: str, start: int, stop: int, path: Path) -> NDArray[Any]:
    """The PVPs of vectors ``start:stop`` after checking the required fields are there."""
    try:
        dtype = skcphd.get_pvp_dtype(reader.metadata.xmltree)
    except (AttributeError, TypeError, ValueError, KeyError) as exc:
        raise DataError(f"{path}: unreadable PVP layout ({exc})") from None
    names = dtype.names or ()
    missing = [name for name in _REQUIRED_PVPS if name not in names]
    if missing:
        raise DataError(
            f"{path}: not a usable CPHD file: no PVP {', '.join(missing)} "
            f"(needs {', '.join(_REQUIRED_PVPS)})"
        )
    try:
        pvps = reader.read_pvps(ch, start_vector=start, stop_vector=stop)
    except (RuntimeError, OSError, ValueError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(f"{path}: channel {ch}: PVPs cannot be read (truncated? {msg})") from None
    for name in _REQUIRED_PVPS + (("AmpSF",) if "AmpSF" in names else ()):
        bad = ~np.isfinite(np.asarray(pvps[name], dtype=np.float64))
        if np.any(bad):
            first = int(np.argwhere(bad)[0][0]) + start
            raise DataError(
                f"{path}: channel {ch}: PVP {name} is NaN/inf at {int(bad.sum())} value(s) "
                f"(first at vector {first})"
            )
    return pvps


def _scene_frame(xml: Any, path: Path) -> tuple[_Frame, str]:
    """The scene frame of the file (origin IARP) and its description."""
    origin = np.array([_number(xml, f"SceneCoordinates/IARP/ECF/{k}", path) for k in "XYZ"])
    llh = [_number(xml, f"SceneCoordinates/IARP/LLH/{k}", path) for k in ("Lat", "Lon", "HAE")]
    gap = float(np.linalg.norm(skwgs84.geodetic_to_cartesian(llh) - origin))
    if not gap <= _IARP_TOL_M:
        raise DataError(
            f"{path}: SceneCoordinates/IARP: ECF and LLH are {gap:.4g} m apart (at most "
            f"{_IARP_TOL_M:g} m: the scene origin is ambiguous)"
        )
    planar = xml.find("./{*}SceneCoordinates/{*}ReferenceSurface/{*}Planar")
    if planar is None:
        return _Frame(origin_ecf=origin, axes=_enu_frame(llh).axes), "east, north, up at the IARP"
    ux = np.array([_number(planar, f"uIAX/{k}", path) for k in "XYZ"])
    uy = np.array([_number(planar, f"uIAY/{k}", path) for k in "XYZ"])
    units = np.linalg.norm([ux, uy], axis=1)
    if np.any(np.abs(units - 1) > 1e-6) or abs(ux @ uy) > 1e-6:
        raise DataError(f"{path}: ReferenceSurface/Planar uIAX, uIAY are not orthonormal")
    axes = np.stack([ux, uy, np.cross(ux, uy)])
    return _Frame(origin_ecf=origin, axes=axes), "IARP, uIAX, uIAY, up"


def _stored_parameters(xml: Any, path: Path) -> dict[str, Any]:
    """The ``sarmotion.*`` ProductInfo parameters, JSON-decoded."""
    out: dict[str, Any] = {}
    for node in xml.findall("./{*}ProductInfo/{*}Parameter"):
        name = node.get("name", "")
        if name.startswith(_PARAMETER_PREFIX):
            try:
                out[name[len(_PARAMETER_PREFIX) :]] = json.loads(node.text or "")
            except (ValueError, RecursionError):
                raise DataError(f"{path}: ProductInfo parameter {name} is not valid JSON") from None
    return out


def _stored_radar(stored: Any, n_samples: int, carrier: float, df: float) -> Radar | None:
    """The radar written by :func:`write_cphd`, if it is that of the frequency grid."""
    if not isinstance(stored, dict):
        return None
    try:
        radar = Radar(**stored)
    except (TypeError, ValueError):
        return None
    same = (
        radar.n_samples == n_samples
        and abs(radar.frequency_step_hz - df) * n_samples <= _GRID_TOL * df
        and abs(radar.carrier_hz - carrier) <= _GRID_TOL * df
    )
    return radar if same else None


def _radar(pvps: NDArray[Any], n_samples: int, stored: Any, path: Path, ch: str) -> Radar:
    """One frequency grid for all vectors, as a Radar (the stored one when it agrees)."""
    sc0 = np.asarray(pvps["SC0"], dtype=np.float64)
    scss = np.asarray(pvps["SCSS"], dtype=np.float64)
    df = float(np.median(scss))
    if not df > 0 or not np.all(sc0 > 0):
        raise DataError(f"{path}: channel {ch}: SC0 and SCSS must be positive frequencies (Hz)")
    if np.ptp(sc0) > _GRID_TOL * df or np.ptp(scss) * n_samples > _GRID_TOL * df:
        raise DataError(
            f"{path}: channel {ch}: the frequency grid varies between vectors (SC0 spans "
            f"{np.ptp(sc0):.6g} Hz, SCSS {np.ptp(scss):.6g} Hz); sarmotion needs one grid"
        )
    carrier = float(np.median(sc0)) + (n_samples // 2) * df
    radar = _stored_radar(stored, n_samples, carrier, df)
    if radar is not None:
        return radar
    band = float(np.max(pvps["FX2"]) - np.min(pvps["FX1"]))
    try:
        return Radar(
            carrier_hz=carrier,
            bandwidth_hz=min(band, n_samples * df),
            n_samples=n_samples,
            frequency_step_hz=df,
            pulse="rect",
        )
    except ValueError as exc:
        raise DataError(f"{path}: channel {ch}: unusable frequency band: {exc}") from None


def _sgn(xml: Any, path: Path) -> str:
    sgn = _text(xml, "Global/SGN", path).lstrip("+")
    if sgn not in ("1", "-1"):
        raise DataError(f"{path}: Global/SGN must be +1 or -1, got {sgn!r}")
    return sgn


def _signal(
    reader: Any, ch: str, start: int, stop: int, pvps: NDArray[Any], path: Path
) -> NDArray[np.complex128]:
    """Vectors ``start:stop`` as complex128 ``(n_vectors, n_samples)``, AmpSF applied, SGN -1.

    ``pvps`` are those of the same vectors.
    """
    sgn = _sgn(reader.metadata.xmltree.getroot(), path)
    try:
        raw = reader.read_signal(ch, start_vector=start, stop_vector=stop)
    except (RuntimeError, OSError, ValueError) as exc:  # the file shrank since it was opened
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(
            f"{path}: channel {ch}: vectors {start}:{stop} cannot be read (truncated? {msg})"
        ) from None
    if raw.dtype.names:  # CI2 / CI4: integer real and imaginary parts
        data = raw["real"].astype(np.float64) + 1j * raw["imag"].astype(np.float64)
    else:
        data = raw.astype(np.complex128)
    if "AmpSF" in (pvps.dtype.names or ()):
        data *= np.asarray(pvps["AmpSF"], dtype=np.float64)[:, None]
    bad = ~np.isfinite(data)
    if np.any(bad):
        first = np.argwhere(bad)[0]
        raise DataError(
            f"{path}: channel {ch}: signal has {int(bad.sum())} NaN/inf sample(s) (first at "
            f"vector {int(first[0]) + start}, sample {int(first[1])})"
        )
    return np.conj(data) if sgn == "1" else data


def _toa(tx: NDArray[np.float64], rx: NDArray[np.float64], p: NDArray[np.float64]) -> Any:
    """Bistatic time of arrival ``(|tx - p| + |rx - p|) / c`` per vector (s)."""
    return (np.linalg.norm(tx - p, axis=-1) + np.linalg.norm(rx - p, axis=-1)) / C


def read_cphd(
    path: PathLike,
    *,
    channel: str | int | None = None,
    vectors: tuple[int, int] | None = None,
    reference_point_m: ArrayLike | None = None,
    lenient: bool = False,
) -> Traces:
    """Read one channel of a CPHD 1.x file (FX domain) as traces.

    Parameters
    ----------
    path : path
        CPHD file (see the module docstring for what is read and how).
    channel : str or int, optional
        Channel identifier (``Data/Channel/Identifier``) or 0-based index; default the
        reference channel ``Channel/RefChId``.
    vectors : (int, int), optional
        Vectors ``start:stop`` (0-based, ``stop`` excluded) to read, at least 2; default
        all of the channel.
    reference_point_m : (2,) or (3,) array_like, optional
        Reference point ``rho_o`` (m, scene frame) of the returned traces; the phase
        history is re-referenced to it exactly. Default: the SRP (of the middle selected
        vector when the SRP moves).
    lenient : bool
        Log a broken plausibility rule (module notes) as a warning instead of refusing
        the file.

    Returns
    -------
    Traces
        ``(n_vectors, NumSamples)`` complex128 traces in the scene frame of the file
        (origin at the IARP, ``z`` up); ``Radar(pulse="rect")`` on the common frequency
        grid, or the radar stored by :func:`write_cphd`. Metadata: the stored metadata
        of a file written by sarmotion (else ``source="cphd"``), and ``"cphd"``: file,
        channel, vector range, collector, core name, collection start, SGN, frame.

    Raises
    ------
    DataError
        Missing or truncated file, not a CPHD file, an unsupported version, TOA-domain,
        compressed or bistatic data, an unknown channel, a bad vector range, missing or
        NaN PVPs, NaN samples, frequency grids that differ between vectors, or a broken
        plausibility rule (module notes; unless ``lenient``); NumVectors or NumSamples
        that disagree with the blocks of the file; the bytes the read would take beyond
        the memory limit (checked from the XML before the PVPs are read; the PVP rules
        are checked before the signal is read).
    """
    lenient = as_lenient(lenient)
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{p}: file not found" if not p.exists() else f"{p}: not a file")
    with p.open("rb") as fh:
        opened = _prepare(p, fh, channel, vectors, reference_point_m, None, lenient=lenient)
        phase_history = _signal(opened.reader, opened.channel, *opened.span, opened.pvps, p)
    check_signal(f"{p}: channel {opened.channel}", "signal", phase_history, lenient=lenient)
    if opened.delays_s is not None:
        phase_history *= delay_phase(opened.delays_s, opened.radar.frequencies_hz)
    logger.debug("read CPHD %s channel %s vectors %d:%d", p, opened.channel, *opened.span)
    return Traces.from_phase_history(
        phase_history,
        trajectory=opened.trajectory,
        radar=opened.radar,
        reference_point_m=opened.reference_point_m,
        metadata=opened.metadata,
    )


def _image_area(xml: Any, path: Path) -> NDArray[np.float64]:
    """``SceneCoordinates/ImageArea`` on the ground of the scene frame, ``(n, 2)`` (m).

    The polygon (its vertices in ``index`` order) where given, else the rectangle of
    ``X1Y1`` and ``X2Y2``. Image-area coordinates are along ``uIAX``, ``uIAY`` from the
    IARP: for a planar reference surface the scene frame's own ``x``, ``y``; for an HAE
    surface the directions of ``uIAXLL``, ``uIAYLL`` (latitude and longitude increments)
    in the east and north of the scene frame. A polygon of fewer than 3 distinct
    vertices, of no area or whose sides cross, is refused (:class:`DataError`).
    """
    area = xml.find("./{*}SceneCoordinates/{*}ImageArea")
    where = "SceneCoordinates/ImageArea"
    if area is None:
        raise DataError(f"{path}: not a usable CPHD file: no XML element {where}")
    vertices = area.findall("./{*}Polygon/{*}Vertex")
    if vertices:
        order = []
        for k, v in enumerate(vertices):
            try:
                index = int(v.get("index", k + 1))
            except ValueError:
                raise DataError(
                    f"{path}: {where}/Polygon: a vertex index is not an integer"
                ) from None
            order.append((index, _number(v, "X", path), _number(v, "Y", path)))
        xy = np.array([(x, y) for _, x, y in sorted(order)], dtype=np.float64)
    else:
        x1, y1 = _number(area, "X1Y1/X", path), _number(area, "X1Y1/Y", path)
        x2, y2 = _number(area, "X2Y2/X", path), _number(area, "X2Y2/Y", path)
        xy = np.array([[x1, y1], [x2, y1], [x2, y2], [x1, y2]], dtype=np.float64)
    hae = xml.find("./{*}SceneCoordinates/{*}ReferenceSurface/{*}HAE")
    if hae is not None:
        lat = np.deg2rad(_number(xml, "SceneCoordinates/IARP/LLH/Lat", path))
        axes = []
        for name in ("uIAXLL", "uIAYLL"):
            east = _number(hae, f"{name}/Lon", path) * np.cos(lat)
            north = _number(hae, f"{name}/Lat", path)
            norm = float(np.hypot(east, north))
            if not norm > 0.0:
                raise DataError(f"{path}: SceneCoordinates/ReferenceSurface/HAE/{name} is zero")
            axes.append([east / norm, north / norm])
        xy = xy @ np.array(axes)
    problem = polygon_problem(xy)
    if problem is not None:
        raise DataError(f"{path}: {where}: {problem}")
    return xy


@dataclass(frozen=True, kw_only=True, eq=False)
class _Prepared:
    """A CPHD channel opened and checked, all but its signal read."""

    reader: Any
    channel: str
    span: tuple[int, int]  # vectors start:stop of the channel
    pvps: NDArray[Any]
    radar: Radar
    trajectory: Trajectory
    reference_point_m: NDArray[np.float64]
    delays_s: NDArray[np.float64] | None  # re-referencing delay per vector, or None
    metadata: dict[str, Any]


def _prepare(
    p: Path,
    fh: Any,
    channel: str | int | None,
    vectors: tuple[int, int] | None,
    reference_point_m: ArrayLike | None,
    block_vectors: int | None,
    *,
    lenient: bool,
) -> _Prepared:
    """Header, memory budget, PVPs and geometry rules of a channel, before its signal.

    The budget counts the PVPs and the signal of ``block_vectors`` vectors (all
    selected vectors when None), as stored and in its working copies.
    """
    reader = _open(p, fh)
    xml = reader.metadata.xmltree.getroot()
    _check_collection(xml, p)
    ch, n_vectors, n_samples = _select_channel(xml, channel, p)
    start, stop = _vector_range(vectors, n_vectors, p)
    rows = stop - start if block_vectors is None else min(block_vectors, stop - start)
    fmt = _find(xml, "Data/SignalArrayFormat") or "CF8"
    pvp_bytes = (stop - start) * (_count(xml, "Data/NumBytesPVP", p, "Data") + 8 * 24)
    signal_bytes = rows * n_samples * _SAMPLE_BYTES.get(fmt, 8)
    reason = over_budget(
        pvp_bytes + signal_bytes + phase_history_bytes(rows, n_samples),
        f"channel {ch}: {rows} x {n_samples} samples of {fmt}, their working copies and "
        f"the PVPs of {stop - start} vectors",
    )
    if reason:
        raise DataError(f"{p}: {reason}")
    pvps = _read_pvps(reader, ch, start, stop, p)
    frame, frame_name = _scene_frame(xml, p)
    _check_geometry(p, ch, pvps, frame, lenient=lenient)
    _sgn(xml, p)
    stored = _stored_parameters(xml, p)
    radar = _radar(pvps, n_samples, stored.get("radar"), p, ch)
    trajectory, rho_o, delays = _geometry(pvps, frame, reference_point_m, f"{p}: channel {ch}")
    metadata = dict(stored.get("metadata") or {"source": "cphd"})
    metadata["cphd"] = _provenance(xml, p, ch, (start, stop), n_vectors, frame_name, pvps)
    if stored.get("image_area") == "none":  # written by sarmotion with no area declared
        metadata.pop(IMAGE_AREA_KEY, None)
    else:
        metadata[IMAGE_AREA_KEY] = _image_area(xml, p).tolist()
    return _Prepared(
        reader=reader,
        channel=ch,
        span=(start, stop),
        pvps=pvps,
        radar=radar,
        trajectory=trajectory,
        reference_point_m=rho_o,
        delays_s=delays,
        metadata=metadata,
    )


def _check_geometry(
    path: Path, ch: str, pvps: NDArray[Any], frame: _Frame, *, lenient: bool
) -> None:
    """The geometry rules of the module notes (vector indices within the selection)."""
    where = f"{path}: channel {ch}"
    antenna = frame.to_local(0.5 * (np.asarray(pvps["TxPos"]) + np.asarray(pvps["RcvPos"])))
    srp = frame.to_local(np.asarray(pvps["SRPPos"], dtype=np.float64))
    field = "PVP TxPos/RcvPos (mid-point)"
    check_envelope(where, field, antenna - srp[srp.shape[0] // 2], lenient=lenient)
    check_track(where, field, antenna, lenient=lenient)
    times = np.asarray(pvps["TxTime"], dtype=np.float64)
    check_times(where, "PVP TxTime", times, lenient=lenient)
    check_speed(where, f"{field} and PVP TxTime", antenna, times, lenient=lenient)
    spacing = float(np.median(np.linalg.norm(np.diff(antenna, axis=0), axis=1)))
    j = _isolated_srp(srp, MAX_BEND * spacing)
    if j is not None:
        violation(
            f"{where}: PVP SRPPos, vector {j}: the SRP of this vector alone is away from the "
            f"line of its neighbours (rule: a fixed SRP, one moving smoothly, or jumps that "
            f"hold for at least two vectors, to {MAX_BEND:g} x the antenna's median spacing "
            f"of {spacing:.4g} m)",
            lenient=lenient,
        )


def _isolated_srp(srp: NDArray[np.float64], tol_m: float) -> int | None:
    """First vector whose SRP alone leaves the line of its neighbours by more than ``tol_m``.

    A vector ``j`` inside is isolated when its SRP is more than ``tol_m`` from the
    midpoint of its neighbours' and further from it than they are from each other (a
    jump that holds, ``A A B B``, is not: ``B`` is half as far from the midpoint as ``A``
    from ``B``); an end vector when it is more than ``tol_m`` from the line through the
    next two and further from it than they are apart.
    """
    n = srp.shape[0]
    if n < 3:
        return None
    dev = np.linalg.norm(srp[1:-1] - 0.5 * (srp[:-2] + srp[2:]), axis=1)
    apart = np.linalg.norm(srp[2:] - srp[:-2], axis=1)
    inside = np.flatnonzero((dev > tol_m) & (dev > apart)) + 1
    ends = []
    for j, a, b in ((0, 1, 2), (n - 1, n - 2, n - 3)):
        d = float(np.linalg.norm(srp[j] - (2.0 * srp[a] - srp[b])))
        if d > tol_m and d > float(np.linalg.norm(srp[a] - srp[b])):
            ends.append(j)
    bad = sorted(ends + inside.tolist())
    return int(bad[0]) if bad else None


def _geometry(
    pvps: NDArray[Any], frame: _Frame, reference_point_m: ArrayLike | None, where: str
) -> tuple[Trajectory, NDArray[np.float64], NDArray[np.float64] | None]:
    """Trajectory and reference point (scene frame), and the re-referencing delays if any.

    The antenna is the mid-point of TxPos and RcvPos; the delays ``(n_vectors,)`` (s)
    move the reference of every vector from its SRP to one point ``rho_o``: the phase
    history is multiplied by ``delay_phase(delays, f)``.
    """
    tx = np.asarray(pvps["TxPos"], dtype=np.float64)
    rx = np.asarray(pvps["RcvPos"], dtype=np.float64)
    srp = np.asarray(pvps["SRPPos"], dtype=np.float64)
    if reference_point_m is not None:
        rho_o = frame.to_ecf(as_point(reference_point_m, name="reference_point_m"))
    else:
        rho_o = srp[srp.shape[0] // 2]
    delays = None
    if np.any(srp != rho_o):
        delays = _toa(tx, rx, rho_o) - _toa(tx, rx, srp)
    t = np.asarray(pvps["TxTime"], dtype=np.float64)
    try:
        trajectory = Trajectory(
            positions_m=frame.to_local(0.5 * (tx + rx)), slow_times_s=t - 0.5 * (t[0] + t[-1])
        )
    except ValueError as exc:
        raise DataError(f"{where}: unusable antenna positions or times: {exc}") from None
    return trajectory, frame.to_local(rho_o), delays


def _provenance(
    xml: Any, path: Path, ch: str, span: tuple[int, int], n: int, frame: str, pvps: Any
) -> dict[str, Any]:
    """The ``metadata["cphd"]`` record of a read: where the traces come from."""
    version = skcphd.VERSION_INFO.get(lxml.etree.QName(xml).namespace, {}).get("version")
    signal = pvps["SIGNAL"] if "SIGNAL" in (pvps.dtype.names or ()) else None
    return {
        "file": path.name,
        "path": str(path),
        "version": version,
        "channel": ch,
        "vectors": [int(span[0]), int(span[1])],
        "n_vectors_in_channel": int(n),
        "collector": _find(xml, "CollectionID/CollectorName"),
        "core_name": _find(xml, "CollectionID/CoreName"),
        "collection_start": _find(xml, "Global/Timeline/CollectionStart"),
        "sgn": _find(xml, "Global/SGN"),
        "frame": frame,
        "vectors_without_signal": 0 if signal is None else int(np.count_nonzero(signal == 0)),
    }


# ----------------------------------------------------------------------------- writing
#: PVPs written, in layout order: (name, size in 8-byte words, binary format).
_PVP_LAYOUT = (
    ("TxTime", 1, "F8"),
    ("TxPos", 3, "X=F8;Y=F8;Z=F8;"),
    ("TxVel", 3, "X=F8;Y=F8;Z=F8;"),
    ("RcvTime", 1, "F8"),
    ("RcvPos", 3, "X=F8;Y=F8;Z=F8;"),
    ("RcvVel", 3, "X=F8;Y=F8;Z=F8;"),
    ("SRPPos", 3, "X=F8;Y=F8;Z=F8;"),
    ("aFDOP", 1, "F8"),
    ("aFRR1", 1, "F8"),
    ("aFRR2", 1, "F8"),
    ("FX1", 1, "F8"),
    ("FX2", 1, "F8"),
    ("TOA1", 1, "F8"),
    ("TOA2", 1, "F8"),
    ("TDTropoSRP", 1, "F8"),
    ("SC0", 1, "F8"),
    ("SCSS", 1, "F8"),
    ("SIGNAL", 1, "I8"),
)

_CHANNEL_ID = "1"

#: Signal samples as written: CF8, big-endian (NGA.STND.0068-1 binary data).
_SIGNAL_DTYPE = np.dtype(">c8")


@dataclass(frozen=True, kw_only=True, eq=False)
class _Layout:
    """Geometry and sampling of a file being written (ECF m, Hz, s)."""

    frame: _Frame
    origin_llh: NDArray[np.float64]  # (lat_deg, lon_deg, hae_m) of the IARP
    srp_local: NDArray[np.float64]  # (3,) scene frame
    image_area_m: NDArray[np.float64] | None  # (n, 2) declared image area, or None
    pvps: NDArray[Any]
    band_hz: tuple[float, float]  # FX1, FX2
    toa_s: tuple[float, float]  # TOA1, TOA2
    resolution_m: float  # c / (2 B)


def _band(radar: Radar) -> tuple[float, float]:
    """``(FX1, FX2)``: the pulse band (rect) or the sampled span (Gaussian), Hz."""
    if radar.pulse == "rect":
        half = 0.5 * radar.bandwidth_hz
        return radar.carrier_hz - half, radar.carrier_hz + half
    f, df = radar.frequencies_hz, radar.frequency_step_hz
    return float(f[0] - 0.5 * df), float(f[-1] + 0.5 * df)


def _pvp_dtype() -> np.dtype[Any]:
    return np.dtype(
        [
            (name, "i8" if fmt == "I8" else ("3f8" if size == 3 else "f8"))
            for name, size, fmt in _PVP_LAYOUT
        ]
    )


def _layout(
    traces: Traces, origin_llh: NDArray[np.float64], image_area_m: ArrayLike | None = None
) -> _Layout:
    """PVPs of the traces: start-stop antenna, fixed SRP, one frequency grid."""
    radar = traces.radar
    frame = _enu_frame(origin_llh)
    pos = frame.to_ecf(traces.positions_m)
    srp = frame.to_ecf(traces.reference_point_m)
    t = traces.slow_times_s - traces.slow_times_s[0]
    vel = np.gradient(pos, t, axis=0, edge_order=2 if t.size > 2 else 1)
    r = np.linalg.norm(pos - srp, axis=1)
    band = _band(radar)
    if band[0] <= 0:
        raise DataError(f"the band starts at {band[0]:.6g} Hz: CPHD needs positive frequencies")
    half = 0.5 * _TOA_FRACTION / radar.frequency_step_hz
    pvps = np.zeros(traces.n_pulses, dtype=_pvp_dtype())
    pvps["TxTime"] = t
    pvps["TxPos"] = pvps["RcvPos"] = pos
    pvps["TxVel"] = pvps["RcvVel"] = vel
    pvps["RcvTime"] = t + 2.0 * r / C
    pvps["SRPPos"] = srp
    pvps["aFDOP"] = -2.0 / C * np.sum(vel * (pos - srp), axis=1) / r
    pvps["FX1"], pvps["FX2"] = band
    pvps["TOA1"], pvps["TOA2"] = -half, half
    pvps["SC0"] = radar.frequencies_hz[0]
    pvps["SCSS"] = radar.frequency_step_hz
    pvps["SIGNAL"] = 1
    return _Layout(
        frame=frame,
        origin_llh=origin_llh,
        srp_local=traces.reference_point_m,
        image_area_m=_area_to_write(image_area_m),
        pvps=pvps,
        band_hz=band,
        toa_s=(-half, half),
        resolution_m=C / (2.0 * radar.bandwidth_hz),
    )


def _area_to_write(image_area_m: ArrayLike | None) -> NDArray[np.float64] | None:
    """A declared image area ``(n, 2)`` checked, clockwise seen from above (CPHD's order)."""
    if image_area_m is None:
        return None
    problem = polygon_problem(image_area_m)
    if problem is not None:
        raise DataError(f"image_area_m: {problem}")
    xy = np.asarray(image_area_m, dtype=np.float64)
    return xy[::-1].copy() if polygon_area(xy) > 0 else xy.copy()


def _mark_area(header: dict[str, Any], lay: _Layout) -> None:
    """Store whether the image area is declared (``sarmotion.image_area``).

    A file written with none declared holds the square of the TOA window, which is not
    the scene's.
    """
    header["parameters"]["image_area"] = json.dumps(
        "declared" if lay.image_area_m is not None else "none"
    )


def _declared(image_area_m: ArrayLike | None, metadata: Any) -> ArrayLike | None:
    """The image area to write: the one given, else the metadata's (``image_area_m``)."""
    if image_area_m is not None:
        return image_area_m
    meta = metadata if isinstance(metadata, dict) else {}
    return meta.get(IMAGE_AREA_KEY)


def _scene_coordinates(lay: _Layout) -> dict[str, Any]:
    """IARP at the frame origin, the tangent plane, the image area.

    The declared image area where one is given (its bounding rectangle as ``X1Y1``,
    ``X2Y2`` and the corner points), else a square around the SRP of the saved TOA
    window's range half-width.
    """
    if lay.image_area_m is not None:
        corners = lay.image_area_m
        x1, y1 = corners.min(axis=0)
        x2, y2 = corners.max(axis=0)
    else:
        half = 0.5 * C * lay.toa_s[1]  # range half-width of the saved TOA window (m)
        x1, y1 = lay.srp_local[:2] - half
        x2, y2 = lay.srp_local[:2] + half
        corners = np.array([[x1, y1], [x1, y2], [x2, y2], [x2, y1]])  # clockwise from above
    box = np.array([[x1, y1], [x1, y2], [x2, y2], [x2, y1]])
    ground = np.column_stack([box, np.zeros(4)])
    iacp = skwgs84.cartesian_to_geodetic(lay.frame.to_ecf(ground))[:, :2]
    spacing = 0.5 * lay.resolution_m
    n = max(1, int(np.ceil((x2 - x1) / spacing)))
    n_y = max(1, int(np.ceil((y2 - y1) / spacing)))
    extent = {"FirstLine": 0, "NumLines": n, "LineSpacing": spacing}
    return {
        "EarthModel": "WGS_84",
        "IARP": {"ECF": lay.frame.origin_ecf, "LLH": lay.origin_llh},
        "ReferenceSurface": {"Planar": {"uIAX": lay.frame.axes[0], "uIAY": lay.frame.axes[1]}},
        "ImageArea": {"X1Y1": [x1, y1], "X2Y2": [x2, y2], "Polygon": corners},
        "ImageAreaCornerPoints": iacp,
        "ImageGrid": {
            "IARPLocation": [-x1 / spacing - 0.5, -y1 / spacing - 0.5],  # (line, sample)
            "IAXExtent": extent,
            "IAYExtent": {"SampleSpacing": spacing, "FirstSample": 0, "NumSamples": n_y},
        },
    }


def _channel_parameters(lay: _Layout) -> dict[str, Any]:
    fx1, fx2 = lay.band_hz
    return {
        "RefChId": _CHANNEL_ID,
        "FXFixedCPHD": True,
        "TOAFixedCPHD": True,
        "SRPFixedCPHD": True,
        "Parameters": [
            {
                "Identifier": _CHANNEL_ID,
                "RefVectorIndex": lay.pvps.size // 2,
                "FXFixed": True,
                "TOAFixed": True,
                "SRPFixed": True,
                "SignalNormal": True,
                "Polarization": {"TxPol": "UNSPECIFIED", "RcvPol": "UNSPECIFIED"},
                "FxC": 0.5 * (fx1 + fx2),
                "FxBW": fx2 - fx1,
                "TOASaved": lay.toa_s[1] - lay.toa_s[0],
                "DwellTimes": {"CODId": "1", "DwellId": "1"},
            }
        ],
    }


def _dwell(lay: _Layout) -> dict[str, Any]:
    """Constant centre-of-dwell and dwell times spanning the reference times of the SRP."""
    ends = lay.pvps[[0, -1]]
    # Reference time of the SRP echo; TxPos = RcvPos: half-way between TxTime and RcvTime.
    t_ref = 0.5 * (ends["TxTime"] + ends["RcvTime"])
    return {
        "NumCODTimes": 1,
        "CODTime": [{"Identifier": "1", "CODTimePoly": np.array([[0.5 * (t_ref[0] + t_ref[1])]])}],
        "NumDwellTimes": 1,
        "DwellTime": [{"Identifier": "1", "DwellTimePoly": np.array([[t_ref[1] - t_ref[0]]])}],
    }


def _xml(traces: Traces, lay: _Layout, header: dict[str, Any]) -> Any:
    """The CPHD 1.1.0 XML tree of the traces, ReferenceGeometry computed by sarkit."""
    root = skcphd.ElementWrapper(
        lxml.etree.Element(f"{{{CPHD_NAMESPACE}}}CPHD", nsmap={None: CPHD_NAMESPACE})
    )
    root["CollectionID"] = {
        "CollectorName": "sarmotion",
        "CoreName": header["core_name"],
        "CollectType": "MONOSTATIC",
        "RadarMode": {"ModeType": "SPOTLIGHT"},
        "Classification": header["classification"],
        "ReleaseInfo": header["release_info"],
    }
    root["Global"] = {
        "DomainType": "FX",
        "SGN": -1,
        "Timeline": {
            "CollectionStart": header["collection_start"],
            "TxTime1": float(lay.pvps["TxTime"][0]),
            "TxTime2": float(lay.pvps["TxTime"][-1]),
        },
        "FxBand": {"FxMin": lay.band_hz[0], "FxMax": lay.band_hz[1]},
        "TOASwath": {"TOAMin": lay.toa_s[0], "TOAMax": lay.toa_s[1]},
    }
    root["SceneCoordinates"] = _scene_coordinates(lay)
    root["Data"] = {
        "SignalArrayFormat": "CF8",
        "NumBytesPVP": 8 * sum(size for _, size, _ in _PVP_LAYOUT),
        "NumCPHDChannels": 1,
        "Channel": [
            {
                "Identifier": _CHANNEL_ID,
                "NumVectors": traces.n_pulses,
                "NumSamples": traces.n_samples,
                "SignalArrayByteOffset": 0,
                "PVPArrayByteOffset": 0,
            }
        ],
        "NumSupportArrays": 0,
    }
    root["Channel"] = _channel_parameters(lay)
    offsets = np.cumsum([0] + [size for _, size, _ in _PVP_LAYOUT])
    root["PVP"] = {
        name: {"Offset": int(off), "Size": size, "dtype": skcphd.binary_format_string_to_dtype(fmt)}
        for (name, size, fmt), off in zip(_PVP_LAYOUT, offsets, strict=False)
    }
    root["Dwell"] = _dwell(lay)
    root["ProductInfo"] = {
        "CreationInfo": [{"Application": f"sarmotion {__version__}", "DateTime": header["now"]}],
        "Parameter": [(_PARAMETER_PREFIX + k, v) for k, v in header["parameters"].items()],
    }
    tree = root.elem.getroottree()
    root["ReferenceGeometry"] = skcphd.compute_reference_geometry(tree, lay.pvps)
    return tree


def _utc(value: _dt.datetime | str | None) -> _dt.datetime:
    if value is None:
        value = _DEFAULT_COLLECTION_START
    if isinstance(value, str):
        try:
            value = _dt.datetime.fromisoformat(value.replace("Z", "+00:00"))
        except ValueError:
            raise ValueError(f"collection_start must be an ISO 8601 time, got {value!r}") from None
    if value.tzinfo is None:
        value = value.replace(tzinfo=_dt.UTC)
    return value.astimezone(_dt.UTC)


def _core_name(meta: dict[str, Any], path: Path) -> str:
    if isinstance(meta.get("scene"), str):
        return meta["scene"]
    files = meta.get("files")
    if isinstance(files, list) and files:
        return str(files[0]) if len(files) == 1 else f"{files[0]} .. {files[-1]}"
    return path.stem


def _origin(origin_llh: ArrayLike) -> NDArray[np.float64]:
    """``origin_llh`` checked, its longitude wrapped to [-180, 180) degrees.

    The check is :func:`~sarmotion._validation.geodetic_origin`'s.
    """
    llh = geodetic_origin(origin_llh, "origin_llh").copy()
    llh[1] = (llh[1] + 180.0) % 360.0 - 180.0
    return llh


def _header(
    radar: Radar,
    metadata: dict[str, Any],
    target: Path,
    collection_start: _dt.datetime | str | None,
    classification: str,
    release_info: str,
) -> dict[str, Any]:
    """What the XML needs besides the geometry: names, times, the stored parameters."""
    radar_json = {
        "carrier_hz": radar.carrier_hz,
        "bandwidth_hz": radar.bandwidth_hz,
        "n_samples": radar.n_samples,
        "frequency_step_hz": radar.frequency_step_hz,
        "pulse": radar.pulse,
    }
    return {
        "core_name": _core_name(metadata, target),
        "classification": classification,
        "release_info": release_info,
        "collection_start": _utc(collection_start),
        "now": _dt.datetime.now(_dt.UTC).replace(microsecond=0),
        "parameters": {
            "radar": json.dumps(radar_json),
            "metadata": _to_json(metadata, "traces"),
        },
    }


def write_cphd(
    path: PathLike,
    traces: Traces,
    *,
    origin_llh: ArrayLike = (0.0, 0.0, 0.0),
    collection_start: _dt.datetime | str | None = None,
    classification: str = "UNCLASSIFIED",
    release_info: str = "UNRESTRICTED",
    overwrite: bool = True,
    image_area_m: ArrayLike | None = None,
) -> Path:
    """Write traces as a CPHD 1.1.0 file (one FX-domain channel, CF8 samples).

    Parameters
    ----------
    path : path
        Output file (conventionally ``.cphd``); its directory must exist.
    traces : Traces
        The traces; their phase history is written as complex64, positions in float64.
    origin_llh : (3,) array_like
        Geodetic position ``(latitude_deg, longitude_deg, hae_m)`` of the origin of the
        scene frame: the frame becomes east, north, up there (WGS 84), and the origin is
        the IARP. The traces carry no geodetic position; the default is (0, 0, 0).
    collection_start : datetime or ISO 8601 str, optional
        ``Global/Timeline/CollectionStart`` (UTC); the traces carry relative times only,
        default ``2000-01-01T00:00:00Z``. ``TxTime`` counts from the first pulse.
    classification, release_info : str
        ``CollectionID/Classification`` and ``ReleaseInfo`` (also in the file header).
    overwrite : bool
        Replace an existing file (default); if False, raise FileExistsError.
    image_area_m : (n, 2) array_like, optional
        The image area the file declares (``SceneCoordinates/ImageArea``): a simple
        polygon on the ground of the scene frame (m). Default the traces'
        ``metadata["image_area_m"]`` where present, else a square about the reference
        point of the saved fast-time window's range half-width.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    DataError
        Metadata that is not JSON-serialisable, or a band reaching 0 Hz.

    Notes
    -----
    The module docstring lists what each PVP holds. :func:`read_cphd` gives back the
    traces: the data to complex64 rounding, positions and the reference point to
    float64 rounding of the ECF transform (nm), slow times re-centred, the radar and the
    metadata as stored. The file is written to a temporary file and renamed onto
    ``path`` when complete.
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    llh = _origin(origin_llh)
    target = Path(path)
    header = _header(
        traces.radar, traces.metadata, target, collection_start, classification, release_info
    )
    lay = _layout(traces, llh, _declared(image_area_m, traces.metadata))
    _mark_area(header, lay)
    meta = skcphd.Metadata(xmltree=_xml(traces, lay, header))
    signal = np.ascontiguousarray(traces.phase_history().astype(np.complex64))
    with staged_paths([target], overwrite=overwrite) as (tmp,):
        with tmp.open("xb") as fh, skcphd.Writer(fh, meta) as writer:
            writer.write_signal(_CHANNEL_ID, signal)
            writer.write_pvp(_CHANNEL_ID, lay.pvps)
    logger.debug("wrote CPHD %s: %d vectors of %d samples", target, *traces.shape)
    return target


# ------------------------------------------------------------------------ block writing
class CphdWriter:
    """A CPHD file written a block of vectors at a time (the file of :func:`write_cphd`).

    The XML and the PVPs (which need only the acquisition's axes) are written through
    ``sarkit.cphd.Writer`` on entering; :meth:`write` then puts each block of vectors in
    its place in the signal block, converting it from the traces' fast time to the phase
    history (complex64, big-endian CF8, as ``sarkit`` writes). Only one block is held at
    a time. The file is written under a temporary name beside ``path`` and renamed onto
    it when the ``with`` block ends with every vector written; if the block raises, or
    ends before the last vector, the temporary file is removed and ``path`` is left as
    it was (absent, or its previous content).

    Parameters
    ----------
    path : path
        Output file; its directory must exist.
    acquisition : Acquisition or PulseBlocks
        Anything with ``trajectory``, ``radar`` and ``reference_point_m``: the axes of
        every vector to be written.
    metadata : dict, optional
        Provenance stored with the file (JSON-serialisable), as ``Traces.metadata``.
    origin_llh, collection_start, classification, release_info, overwrite, image_area_m
        As for :func:`write_cphd` (``image_area_m`` defaults to ``metadata``'s).

    Examples
    --------
    >>> with CphdWriter("big.cphd", source) as out:  # doctest: +SKIP
    ...     for start, stop, data in source.blocks(256):
    ...         out.write(start, data)
    """

    def __init__(
        self,
        path: PathLike,
        acquisition: Any,
        *,
        metadata: dict[str, Any] | None = None,
        origin_llh: ArrayLike = (0.0, 0.0, 0.0),
        collection_start: _dt.datetime | str | None = None,
        classification: str = "UNCLASSIFIED",
        release_info: str = "UNRESTRICTED",
        overwrite: bool = True,
        image_area_m: ArrayLike | None = None,
    ) -> None:
        self.path = Path(path)
        self.acquisition = Acquisition(
            trajectory=acquisition.trajectory,
            radar=acquisition.radar,
            reference_point_m=acquisition.reference_point_m,
        )
        if metadata is None:
            metadata = dict(getattr(acquisition, "metadata", {}) or {})
        header = _header(
            self.acquisition.radar,
            metadata,
            self.path,
            collection_start,
            classification,
            release_info,
        )
        self._lay = _layout(
            self.acquisition, _origin(origin_llh), _declared(image_area_m, metadata)
        )
        _mark_area(header, self._lay)
        self._meta = skcphd.Metadata(xmltree=_xml(self.acquisition, self._lay, header))
        self._overwrite = bool(overwrite)
        self._stack: ExitStack | None = None
        self._fh: Any = None
        self._signal_offset = 0
        self.n_written = 0

    @property
    def n_pulses(self) -> int:
        """Vectors the file holds when complete."""
        return self.acquisition.n_pulses

    def __enter__(self) -> CphdWriter:
        if self._stack is not None:
            raise RuntimeError(f"{self.path}: the writer is already open")
        stack = ExitStack()
        try:
            (tmp,) = stack.enter_context(staged_paths([self.path], overwrite=self._overwrite))
            fh = stack.enter_context(tmp.open("x+b"))
            writer = skcphd.Writer(fh, self._meta)  # the file header and the XML
            writer.write_pvp(_CHANNEL_ID, self._lay.pvps)
            fh.flush()
            fh.seek(0)
            _, kvp = skcphd.read_file_header(fh)
            self._signal_offset = int(kvp["SIGNAL_BLOCK_BYTE_OFFSET"])
        except BaseException:
            stack.close()
            raise
        self._stack, self._fh = stack, fh
        return self

    def write(self, start: int, data: ArrayLike) -> None:
        """Write the vectors ``start:start + len(data)``; blocks come in order from 0.

        Parameters
        ----------
        start : int
            First vector of the block: the number of vectors written so far.
        data : (n, n_samples) array_like
            The block in the :class:`~sarmotion.core.traces.Traces` convention (complex
            baseband in fast time, ``t = 0`` at sample ``n_samples // 2``).
        """
        if self._fh is None:
            raise RuntimeError(f"{self.path}: write() outside the writer's with block")
        if start != self.n_written:
            raise ValueError(
                f"blocks must come in order: vector {self.n_written} is next, got {start}"
            )
        block = np.asarray(data)
        n_samples = self.acquisition.n_samples
        if block.ndim != 2 or block.shape[1] != n_samples or block.shape[0] < 1:
            raise ValueError(f"a block must be (n >= 1, {n_samples}), got {block.shape}")
        if start + block.shape[0] > self.n_pulses:
            raise ValueError(
                f"vectors {start}:{start + block.shape[0]} are beyond the {self.n_pulses} "
                "of the acquisition"
            )
        if not np.all(np.isfinite(block)):
            raise ValueError(f"the block at vector {start} has NaN or infinite samples")
        signal = to_frequency(block).astype(_SIGNAL_DTYPE)
        self._fh.seek(self._signal_offset + start * n_samples * _SIGNAL_DTYPE.itemsize)
        self._fh.write(signal.tobytes())
        self.n_written += block.shape[0]

    def __exit__(self, kind: Any, value: Any, traceback: Any) -> None:
        stack, self._stack, self._fh = self._stack, None, None
        if stack is None:
            return
        # unwinding the stack closes the file, then renames it onto path, or removes it
        # when it unwinds with an exception
        if kind is None and self.n_written != self.n_pulses:
            try:
                raise ValueError(
                    f"{self.path}: {self.n_written} of {self.n_pulses} vectors written; "
                    "nothing written"
                )
            except ValueError:
                stack.__exit__(*sys.exc_info())
                raise
        stack.__exit__(kind, value, traceback)
        if kind is None:
            logger.debug("wrote CPHD %s: %d x %d vectors", self.path, *self.acquisition.shape)


def write_cphd_blocks(
    path: PathLike,
    source: PulseBlocks,
    *,
    block_pulses: int = 256,
    **options: Any,
) -> Path:
    """Write a :class:`~sarmotion.core.blocks.PulseBlocks` source as CPHD, block by block.

    The file is that of :func:`write_cphd` for the traces the source's blocks make up,
    written with :class:`CphdWriter`: peak memory is one block (``block_pulses`` x
    ``n_samples``) and its phase history, not the file.

    Parameters
    ----------
    path : path
        Output file; its directory must exist.
    source : PulseBlocks
        The acquisition (``trajectory``, ``radar``, ``reference_point_m``,
        ``metadata``) and its data by blocks.
    block_pulses : int
        Vectors per block (>= 1).
    **options
        ``origin_llh``, ``collection_start``, ``classification``, ``release_info``,
        ``overwrite``: as for :func:`write_cphd`.

    Returns
    -------
    Path
        ``path``.
    """
    rows = integer(block_pulses, "block_pulses", minimum=1)
    with CphdWriter(path, source, **options) as out:
        for start, _stop, data in source.blocks(rows):
            out.write(start, data)
    return Path(path)


# ------------------------------------------------------------------------ block reading
class CphdBlocks:
    """A CPHD channel opened for reading its vectors block by block.

    Made by :func:`open_cphd_blocks`. The PVPs of every selected vector are read and
    checked on opening (the geometry rules of the module notes); the signal is read by
    :meth:`blocks`, only the vectors of one block at a time.

    Attributes
    ----------
    radar : Radar
        The frequency grid, as :func:`read_cphd` gives it.
    reference_point_m : (3,) ndarray
        Reference point ``rho_o`` of the blocks (m, float64, scene frame).
    trajectory : Trajectory
        Antenna positions and slow times of every selected vector.
    n_pulses : int
        Number of selected vectors.
    metadata : dict
        As :func:`read_cphd` gives it.
    """

    def __init__(self, path: Path, prepared: _Prepared) -> None:
        self.path = path
        self._prepared = prepared
        self.radar: Radar = prepared.radar
        self.reference_point_m: NDArray[np.float64] = np.asarray(
            prepared.reference_point_m, dtype=np.float64
        )
        self.trajectory: Trajectory = prepared.trajectory
        self.n_pulses: int = prepared.span[1] - prepared.span[0]
        self.metadata: dict[str, Any] = prepared.metadata

    def blocks(self, block_pulses: int) -> Iterator[tuple[int, int, NDArray[np.complex128]]]:
        """``(start, stop, data[start:stop])`` for consecutive blocks of ``block_pulses``.

        ``data`` is what :func:`read_cphd` returns as ``Traces.data`` (fast time,
        complex128, re-referenced to :attr:`reference_point_m`), for pulses
        ``start:stop`` counted from the first selected vector. Only the vectors of one
        block are read from the file at a time.

        Raises
        ------
        DataError
            A block beyond the memory limit, or a file that no longer reads (truncated,
            NaN samples).
        """
        rows = integer(block_pulses, "block_pulses", minimum=1)
        n_samples = self.radar.n_samples
        reason = over_budget(
            rows * n_samples * 8 + phase_history_bytes(rows, n_samples),
            f"a block of {rows} x {n_samples} samples and its working copies",
        )
        if reason:
            raise DataError(f"{self.path}: {reason}")
        return self._blocks(rows)

    def _blocks(self, rows: int) -> Iterator[tuple[int, int, NDArray[np.complex128]]]:
        prep = self._prepared
        first = prep.span[0]
        frequencies = self.radar.frequencies_hz
        coherent = 0.0
        with self.path.open("rb") as fh:
            reader = _open(self.path, fh)
            for a in range(0, self.n_pulses, rows):
                b = min(a + rows, self.n_pulses)
                pvps = prep.pvps[a:b]
                block = _signal(reader, prep.channel, first + a, first + b, pvps, self.path)
                coherent = check_coherent_sum(
                    f"{self.path}: channel {prep.channel}", "signal", block, so_far=coherent
                )
                if prep.delays_s is not None:
                    block *= delay_phase(prep.delays_s[a:b], frequencies)
                yield a, b, to_fast_time(block)


def open_cphd_blocks(
    path: PathLike,
    channel: str | int | None = None,
    *,
    vectors: tuple[int, int] | None = None,
    reference_point_m: ArrayLike | None = None,
    lenient: bool = False,
) -> CphdBlocks:
    """Open one channel of a CPHD file to read its signal block by block.

    Parameters are those of :func:`read_cphd`. The header, the memory budget of the
    PVPs, and the plausibility rules that need only the PVPs (envelope, track, times,
    speed, SRP) are checked here; the signal rules (zero, constant, dynamic range) need
    the whole signal and are not.

    Returns
    -------
    CphdBlocks
        ``radar``, ``reference_point_m``, ``trajectory``, ``n_pulses``, ``metadata`` and
        ``blocks(block_pulses)``.
    """
    lenient = as_lenient(lenient)
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{p}: file not found" if not p.exists() else f"{p}: not a file")
    with p.open("rb") as fh:
        prepared = _prepare(p, fh, channel, vectors, reference_point_m, 1, lenient=lenient)
    return CphdBlocks(p, prepared)
