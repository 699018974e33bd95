"""SICD files (Sensor Independent Complex Data, NGA.STND.0024, version 1.4.0) of images.

A backprojection image on a ground grid (:class:`~sarmotion.imaging.ImageGrid`: pixel
``(iy, ix)`` at ``(x_m[ix], y_m[iy], 0)`` of the scene frame) is written through sarkit
(``sarkit.sicd.NitfWriter``) with the metadata of the traces it was formed from.

Geodesy
    As :func:`~sarmotion.io.write_cphd`: the scene frame is east, north, up at
    ``origin_llh`` on the WGS 84 ellipsoid (default ``(0, 0, 0)``, for inputs without a
    geodetic position such as GOTCHA), and its ground ``z = 0`` is the tangent plane
    there. The grid is a ground ``PLANE`` grid in that plane.
Orientation
    SICD rows run along ``Grid/Row/UVectECF`` and columns along ``Col/UVectECF`` with
    ``Row x Col`` pointing up; the row direction is the ground axis (``+-x`` or ``+-y``)
    closest to the look direction away from the antenna (so shadows fall down the
    image), and the pixel array is the image transposed and flipped to match; no pixel
    is resampled. Pixel ``(r, c)`` lies at ``SCP + (r - SCPRow) SS_row u_row + (c -
    SCPCol) SS_col u_col``, the SCP being the pixel nearest the grid centre.
Pixels
    SICD stores the image with its spatial-frequency support centred on zero: the value
    written is ``I(rho) exp(-2i pi K_ctr . (rho - SCP))`` (complex64), where
    ``I(rho)`` carries the carrier phase ``exp(i omega_o dtau(rho))`` of
    backprojection (:mod:`sarmotion.imaging.backprojection`) and ``K_ctr = (2 nu_o /
    c) u_los`` (cycles/m) is its local spatial frequency at the SCP, ``u_los`` the unit
    line of sight from the antenna at the aperture centre to the SCP projected on the
    row and column directions (``Grid/Row/KCtr``, ``Col/KCtr``, ``Sgn = -1``).
    :func:`sicd_pixels` is the map; its inverse restores ``I``.
Spectral support
    The support of the data is the band ``[nu_o - B/2, nu_o + B/2]`` times the look
    directions of the aperture: ``K = (2 f / c) u_los(s)`` for all pulses and
    frequencies, projected on row and column. ``ImpRespBW`` is its extent per axis,
    ``DeltaK1``/``DeltaK2`` its bounds about ``KCtr`` widened by the drift of the local
    line of sight across the image (the spherical wavefront), and ``ImpRespWid`` the
    uniform-weighting width ``0.886 / ImpRespBW``. The pixels must sample that support
    (``SS <= 1 / (DeltaK2 - DeltaK1)``): a coarser grid is refused.
Timeline and positions
    ``CollectStart`` as ``collection_start`` (default 2000-01-01T00:00:00Z: the traces
    carry relative times only), times from the first pulse, one IPP set at the mean
    pulse interval ``T`` (pulse ``j`` in ``[j T, (j + 1) T)``, so the collection lasts
    ``n_pulses T``), ``ARPPoly`` the least-squares polynomial of degree 5 (at most
    ``n_pulses - 1``) of the antenna positions (ECF), ``Grid/TimeCOAPoly`` the time of
    the aperture centre (``s = 0``), ``SCPCOA`` computed by sarkit.
Radar collection
    Transmitted band ``nu_o +- B/2`` (the sampled span for a Gaussian pulse), one
    receive channel of unknown polarisation, ``ImageFormAlgo = OTHER``
    (backprojection), ``AzAutofocus = GLOBAL`` after phase-gradient autofocus.

Each file passes sarkit's SICD consistency checker (``sicdcheck``).
"""

from __future__ import annotations

import datetime as _dt
import logging
import os
from pathlib import Path
from typing import Any

import lxml.etree
import numpy as np
import sarkit.sicd as sksicd
import sarkit.wgs84 as skwgs84
from numpy.typing import ArrayLike, NDArray

from .._validation import geodetic_origin
from .._version import __version__
from ..core import C, Traces
from .cphd import _band, _enu_frame, _utc
from .errors import DataError
from .staging import staged_paths

__all__ = ["SICD_NAMESPACE", "check_sicd_grid", "read_sicd", "sicd_pixels", "write_sicd"]

logger = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]

SICD_NAMESPACE = "urn:SICD:1.4.0"

#: Uniform-weighting 3 dB width times bandwidth: 2 x with sinc^2(x) = 1/2.
_KAPFAC = 0.8858929413789122

#: Degree of the ARP position polynomial (at most n_pulses - 1).
_ARP_DEGREE = 5


def _orientation(los_ground: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Row and column unit vectors (scene frame) and the array map for the look ``los``.

    Returns ``(u_row, u_col, swap, flip_row, flip_col)``: the SICD array is
    ``values.T`` if ``swap`` (rows along x) else ``values``, flipped along rows and/or
    columns.
    """
    options = [
        (np.array([1.0, 0.0, 0.0]), True),
        (np.array([-1.0, 0.0, 0.0]), True),
        (np.array([0.0, 1.0, 0.0]), False),
        (np.array([0.0, -1.0, 0.0]), False),
    ]
    u_row, swap = max(options, key=lambda o: float(o[0][:2] @ los_ground))
    u_col = np.cross(np.array([0.0, 0.0, 1.0]), u_row)  # up x row: row x col is up
    along_row = u_row[0] + u_row[1]  # +1 when the row axis runs with increasing x or y
    along_col = u_col[0] + u_col[1]
    return u_row, u_col, swap, along_row < 0, along_col < 0


def _array(values: NDArray[Any], swap: bool, flip_row: bool, flip_col: bool) -> NDArray[Any]:
    a = values.T if swap else values
    if flip_row:
        a = a[::-1, :]
    if flip_col:
        a = a[:, ::-1]
    return a


def _inverse_array(a: NDArray[Any], swap: bool, flip_row: bool, flip_col: bool) -> NDArray[Any]:
    if flip_col:
        a = a[:, ::-1]
    if flip_row:
        a = a[::-1, :]
    return a.T if swap else a


def _check_axes(values: ArrayLike, x_m: ArrayLike, y_m: ArrayLike) -> tuple[NDArray, ...]:
    v = np.asarray(values)
    x = np.asarray(x_m, dtype=np.float64)
    y = np.asarray(y_m, dtype=np.float64)
    if v.ndim != 2 or v.shape != (y.size, x.size):
        raise ValueError(f"values must have shape (ny, nx) = ({y.size}, {x.size}), got {v.shape}")
    for name, a in (("x_m", x), ("y_m", y)):
        if a.size < 2 or not np.all(np.isfinite(a)) or np.any(np.diff(a) <= 0):
            raise ValueError(f"{name} must be finite, increasing, with >= 2 samples")
    return v, x, y


class _Geometry:
    """Everything the XML and the pixel map need, in the scene frame and ECF."""

    def __init__(
        self,
        traces: Traces,
        x: NDArray,
        y: NDArray,
        origin_llh: NDArray,
        velocity: NDArray | None = None,
    ) -> None:
        self.frame = _enu_frame(origin_llh)
        ix, iy = x.size // 2, y.size // 2
        self.scp_local = np.array([x[ix], y[iy], 0.0])
        pos = traces.positions_m
        s = traces.slow_times_s
        centre = pos[int(np.argmin(np.abs(s)))]
        los = self.scp_local - centre
        los /= np.linalg.norm(los)
        self.los = los
        g = los[:2] / np.linalg.norm(los[:2])
        self.u_row, self.u_col, self.swap, self.flip_row, self.flip_col = _orientation(g)
        self.dx = float((x[-1] - x[0]) / (x.size - 1))
        self.dy = float((y[-1] - y[0]) / (y.size - 1))
        self.ss_row = self.dx if self.swap else self.dy
        self.ss_col = self.dy if self.swap else self.dx
        n_row, n_col = (x.size, y.size) if self.swap else (y.size, x.size)
        self.shape = (n_row, n_col)
        # SCP pixel in the SICD array.
        r0 = ix if self.swap else iy
        c0 = iy if self.swap else ix
        self.scp_pixel = (
            n_row - 1 - r0 if self.flip_row else r0,
            n_col - 1 - c0 if self.flip_col else c0,
        )
        radar = traces.radar
        self.band = _band(radar)
        # A compensated image sees the scene from r(s) - s u (eq:imagecompu).
        self.positions = pos if velocity is None else pos - s[:, None] * velocity[None, :]
        lo, hi = self._support(self.scp_local)
        self.bw = hi - lo
        self.k_ctr = 0.5 * (lo + hi)
        # The local centre of the support drifts across the image (the directions to
        # the aperture turn with the pixel): a plane fit over a 3 x 3 lattice of pixels
        # gives DeltaKCOAPoly in (xrow, ycol).
        rr = np.linspace(-self.scp_pixel[0], n_row - 1 - self.scp_pixel[0], 3) * self.ss_row
        cc = np.linspace(-self.scp_pixel[1], n_col - 1 - self.scp_pixel[1], 3) * self.ss_col
        xr, yc = (a.ravel() for a in np.meshgrid(rr, cc, indexing="ij"))
        offsets = np.array(
            [
                0.5 * np.add(*self._support(self.scp_local + a * self.u_row + b * self.u_col))
                - self.k_ctr
                for a, b in zip(xr, yc, strict=True)
            ]
        )  # (9, 2)
        design = np.stack([np.ones_like(xr), xr, yc], axis=1)
        coef, *_ = np.linalg.lstsq(design, offsets, rcond=None)  # (3, 2)
        self.dk_poly = [np.array([[coef[0, k], coef[2, k]], [coef[1, k], 0.0]]) for k in (0, 1)]
        rc = np.array([[rr[0], cc[0]], [rr[0], cc[-1]], [rr[-1], cc[-1]], [rr[-1], cc[0]]])
        at_corners = np.stack(
            [np.polynomial.polynomial.polyval2d(rc[:, 0], rc[:, 1], p) for p in self.dk_poly],
            axis=1,
        )
        self.dk1 = at_corners.min(axis=0) - 0.5 * self.bw
        self.dk2 = at_corners.max(axis=0) + 0.5 * self.bw
        self.t0 = float(s[0])
        self.times = s - s[0]

    def _support(self, point: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """Lowest and highest ``(2 f / c) u . (u_row, u_col)`` over pulses and band edges."""
        u = point[None, :] - self.positions
        u /= np.linalg.norm(u, axis=1)[:, None]
        proj = np.stack([u @ self.u_row, u @ self.u_col], axis=1)
        ks = np.concatenate([2.0 * f / C * proj for f in self.band])
        return ks.min(axis=0), ks.max(axis=0)

    def pixel_positions(self) -> NDArray[np.float64]:
        """Scene-frame position of every SICD pixel, shape (n_row, n_col, 3)."""
        r = np.arange(self.shape[0]) - self.scp_pixel[0]
        c = np.arange(self.shape[1]) - self.scp_pixel[1]
        return (
            self.scp_local[None, None, :]
            + (r * self.ss_row)[:, None, None] * self.u_row[None, None, :]
            + (c * self.ss_col)[None, :, None] * self.u_col[None, None, :]
        )

    def demodulation(self) -> NDArray[np.complex128]:
        """``exp(-2i pi K_ctr . (rho - SCP))`` on the SICD array."""
        r = (np.arange(self.shape[0]) - self.scp_pixel[0]) * self.ss_row
        c = (np.arange(self.shape[1]) - self.scp_pixel[1]) * self.ss_col
        cycles = self.k_ctr[0] * r[:, None] + self.k_ctr[1] * c[None, :]
        return np.exp(-2j * np.pi * (cycles - np.round(cycles)))


def sicd_pixels(
    values: ArrayLike,
    *,
    x_m: ArrayLike,
    y_m: ArrayLike,
    traces: Traces,
    inverse: bool = False,
) -> NDArray[np.complex128]:
    """The SICD pixel array of an image (module docstring), or with ``inverse`` the image.

    Parameters
    ----------
    values : (ny, nx) array_like
        Image on the grid (``inverse=False``), or the SICD array (``inverse=True``).
    x_m, y_m : (nx,), (ny,) array_like
        The image grid axes (m).
    traces : Traces
        The traces the image was formed from.
    inverse : bool
        Map a SICD array back to the image ``(ny, nx)``.
    """
    x = np.asarray(x_m, dtype=np.float64)
    y = np.asarray(y_m, dtype=np.float64)
    geo = _Geometry(traces, x, y, np.zeros(3))
    v = np.asarray(values)
    if inverse:
        if v.shape != geo.shape:
            raise ValueError(f"values must have the SICD shape {geo.shape}, got {v.shape}")
        return _inverse_array(v / geo.demodulation(), geo.swap, geo.flip_row, geo.flip_col)
    v, x, y = _check_axes(v, x, y)
    return _array(v, geo.swap, geo.flip_row, geo.flip_col) * geo.demodulation()


def _check_sampling(geo: _Geometry) -> None:
    for k, (name, ss) in enumerate((("row", geo.ss_row), ("column", geo.ss_col))):
        if geo.dk2[k] > 0.5 / ss * (1 + 1e-9) or geo.dk1[k] < -0.5 / ss * (1 + 1e-9):
            need = 1.0 / (2.0 * max(geo.dk2[k], -geo.dk1[k]))
            raise DataError(
                f"the {name} pixel spacing {ss:.4g} m does not sample the image's spectral "
                f"support: SICD needs at most {need:.4g} m"
            )


def check_sicd_grid(
    x_m: ArrayLike, y_m: ArrayLike, traces: Traces, *, velocity_mps: ArrayLike | None = None
) -> None:
    """Raise :class:`DataError` when a grid's pixels cannot carry the image as SICD.

    The spectral support of the image (module docstring), drift included, must lie
    within ``+-1 / (2 SS)`` of ``KCtr`` along each axis.
    """
    x = np.asarray(x_m, dtype=np.float64)
    y = np.asarray(y_m, dtype=np.float64)
    _check_axes(np.zeros((y.size, x.size)), x, y)
    vel = None if velocity_mps is None else np.array([*np.asarray(velocity_mps)[:2], 0.0])
    _check_sampling(_Geometry(traces, x, y, np.zeros(3), vel))


def _poly_fit(t: NDArray, pos_ecf: NDArray) -> NDArray[np.float64]:
    deg = min(_ARP_DEGREE, t.size - 1)
    scale = max(float(t[-1] - t[0]), 1e-9)
    # Fit on normalised time for conditioning, then rescale the coefficients.
    coef = np.polynomial.polynomial.polyfit(t / scale, pos_ecf, deg)  # (deg + 1, 3)
    return coef / scale ** np.arange(deg + 1)[:, None]


def _xml(traces: Traces, geo: _Geometry, header: dict[str, Any]) -> Any:
    E = sksicd.ElementWrapper
    root = E(lxml.etree.Element(f"{{{SICD_NAMESPACE}}}SICD", nsmap={None: SICD_NAMESPACE}))
    frame = geo.frame
    scp_ecf = frame.to_ecf(geo.scp_local)
    scp_llh = skwgs84.cartesian_to_geodetic(scp_ecf)
    n_row, n_col = geo.shape
    positions = geo.pixel_positions()
    corners = positions[[0, 0, -1, -1], [0, -1, -1, 0]]  # FRFC, FRLC, LRLC, LRFC
    corner_llh = skwgs84.cartesian_to_geodetic(frame.to_ecf(corners))
    # sarkit's NITF IGEOLO formatter picks a hemisphere by the sign of each corner
    # coordinate and has none for exactly 0 (a corner on the equator or the meridian of
    # the default origin): such a coordinate is written as the smallest positive float.
    corner_llh[corner_llh == 0.0] = np.nextafter(0.0, 1.0)
    row_ecf = geo.u_row @ frame.axes
    col_ecf = geo.u_col @ frame.axes
    duration = float(geo.times[-1])
    t_coa = -geo.t0  # s = 0, counted from the first pulse
    arp = _poly_fit(geo.times, frame.to_ecf(traces.positions_m))
    pri = duration / (traces.n_pulses - 1)
    root["CollectionInfo"] = {
        "CollectorName": "sarmotion",
        "CoreName": header["core_name"],
        "CollectType": "MONOSTATIC",
        "RadarMode": {"ModeType": "SPOTLIGHT"},
        "Classification": header["classification"],
        "Parameter": [(k, v) for k, v in header["parameters"].items()],
    }
    root["ImageCreation"] = {
        "Application": f"sarmotion {__version__}",
        "DateTime": header["now"],
        "Profile": "sarmotion backprojection",
    }
    root["ImageData"] = {
        "PixelType": "RE32F_IM32F",
        "NumRows": n_row,
        "NumCols": n_col,
        "FirstRow": 0,
        "FirstCol": 0,
        "FullImage": {"NumRows": n_row, "NumCols": n_col},
        "SCPPixel": list(geo.scp_pixel),
    }
    root["GeoData"] = {
        "EarthModel": "WGS_84",
        "SCP": {"ECF": scp_ecf, "LLH": scp_llh},
        "ImageCorners": corner_llh[:, :2],
    }
    axis = {}
    for k, (name, uvect, ss) in enumerate(
        (("Row", row_ecf, geo.ss_row), ("Col", col_ecf, geo.ss_col))
    ):
        axis[name] = {
            "UVectECF": uvect,
            "SS": ss,
            "ImpRespWid": _KAPFAC / geo.bw[k],
            "Sgn": -1,
            "ImpRespBW": geo.bw[k],
            "KCtr": geo.k_ctr[k],
            "DeltaK1": geo.dk1[k],
            "DeltaK2": geo.dk2[k],
            "DeltaKCOAPoly": geo.dk_poly[k],
        }
    root["Grid"] = {
        "ImagePlane": "GROUND",
        "Type": "PLANE",
        "TimeCOAPoly": np.array([[t_coa]]),
        **axis,
    }
    root["Timeline"] = {
        "CollectStart": header["collection_start"],
        "CollectDuration": traces.n_pulses * pri,
        "IPP": {
            "Set": [
                {
                    "TStart": 0.0,
                    "TEnd": traces.n_pulses * pri,
                    "IPPStart": 0,
                    "IPPEnd": traces.n_pulses - 1,
                    "IPPPoly": np.array([0.0, 1.0 / pri]),
                }
            ]
        },
    }
    root["Position"] = {"ARPPoly": arp}
    root["RadarCollection"] = {
        "TxFrequency": {"Min": geo.band[0], "Max": geo.band[1]},
        "TxPolarization": "UNKNOWN",
        "RcvChannels": {"ChanParameters": [{"TxRcvPolarization": "UNKNOWN"}]},
    }
    root["ImageFormation"] = {
        "RcvChanProc": {"NumChanProc": 1, "ChanIndex": [1]},
        "TxRcvPolarizationProc": "UNKNOWN",
        "TStartProc": 0.0,
        "TEndProc": duration,
        "TxFrequencyProc": {"MinProc": geo.band[0], "MaxProc": geo.band[1]},
        "ImageFormAlgo": "OTHER",
        "STBeamComp": "NO",
        "ImageBeamComp": "NO",
        "AzAutofocus": header["autofocus"],
        "RgAutofocus": "NO",
    }
    tree = root.elem.getroottree()
    for parent, child in (
        ("Timeline/{*}IPP", "Set"),
        ("RadarCollection/{*}RcvChannels", "ChanParameters"),
    ):
        node = tree.find(f"./{{*}}{parent}")
        children = node.findall(f"./{{*}}{child}")
        node.set("size", str(len(children)))
        for i, c in enumerate(children, start=1):
            c.set("index", str(i))
    root["SCPCOA"] = sksicd.compute_scp_coa(tree)
    return tree


def write_sicd(
    path: PathLike,
    values: ArrayLike,
    *,
    x_m: ArrayLike,
    y_m: ArrayLike,
    traces: Traces,
    origin_llh: ArrayLike = (0.0, 0.0, 0.0),
    collection_start: _dt.datetime | str | None = None,
    classification: str = "UNCLASSIFIED",
    velocity_mps: ArrayLike | None = None,
    overwrite: bool = True,
) -> Path:
    """Write a ground-grid image as a SICD 1.4.0 NITF file (module docstring).

    Parameters
    ----------
    path : path
        Output file (conventionally ``.nitf`` or ``.ntf``); its directory must exist.
    values : (ny, nx) array_like
        Complex image, pixel ``(iy, ix)`` at ``(x_m[ix], y_m[iy], 0)``.
    x_m, y_m : (nx,), (ny,) array_like
        Uniform, increasing pixel coordinates (m).
    traces : Traces
        The traces the image was formed from (geometry, band, timeline, metadata).
    origin_llh : (3,) array_like
        Geodetic ``(latitude_deg, longitude_deg, hae_m)`` of the scene-frame origin.
    collection_start : datetime or ISO 8601 str, optional
        ``Timeline/CollectStart`` (UTC); default ``2000-01-01T00:00:00Z``.
    classification : str
        ``CollectionInfo/Classification``.
    velocity_mps : (2,) array_like, optional
        The ground velocity a mover's image compensates (``eq:imagecompu``): its
        spectral support is that of the aperture ``r(s) - s u`` seen from the pixels;
        the platform's own track stays in ``Position`` and ``SCPCOA``, and ``u`` goes
        in ``CollectionInfo/Parameter[@name="sarmotion.velocity_mps"]`` (SICD has no
        field for a compensated motion).
    overwrite : bool
        Replace an existing file (default); if False, raise FileExistsError.

    Returns
    -------
    Path

    Raises
    ------
    DataError
        When the pixels do not sample the spectral support (a grid too coarse).
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    v, x, y = _check_axes(values, x_m, y_m)
    llh = geodetic_origin(origin_llh, "origin_llh")
    vel = None
    if velocity_mps is not None:
        u = np.asarray(velocity_mps, dtype=np.float64)
        if u.shape != (2,) or not np.all(np.isfinite(u)):
            raise ValueError(f"velocity_mps must be a finite (ux, uy) pair (m/s), got {u}")
        vel = np.array([u[0], u[1], 0.0])
    geo = _Geometry(traces, x, y, llh, vel)
    _check_sampling(geo)
    target = Path(path)
    meta_files = traces.metadata.get("files")
    if isinstance(traces.metadata.get("scene"), str):
        core = traces.metadata["scene"]
    elif isinstance(meta_files, list) and meta_files:
        core = (
            str(meta_files[0]) if len(meta_files) == 1 else f"{meta_files[0]} .. {meta_files[-1]}"
        )
    else:
        core = target.stem
    header = {
        "core_name": core[:80] or "sarmotion",
        "classification": classification,
        "collection_start": _utc(collection_start),
        "now": _dt.datetime.now(_dt.UTC).replace(microsecond=0),
        "autofocus": "GLOBAL" if traces.metadata.get("autofocus") in ("pga", True) else "NO",
        "parameters": {
            "sarmotion.velocity_mps": "[0, 0]" if vel is None else f"[{vel[0]!r}, {vel[1]!r}]",
        },
    }
    tree = _xml(traces, geo, header)
    sec = sksicd.NitfSecurityFields(clas="U")
    meta = sksicd.NitfMetadata(
        xmltree=tree,
        file_header_part=sksicd.NitfFileHeaderPart(ostaid="sarmotion", security=sec),
        im_subheader_part=sksicd.NitfImSubheaderPart(isorce="sarmotion", security=sec),
        de_subheader_part=sksicd.NitfDeSubheaderPart(security=sec),
    )
    pixels = np.ascontiguousarray(
        (_array(v, geo.swap, geo.flip_row, geo.flip_col) * geo.demodulation()).astype(np.complex64)
    )
    with staged_paths([target], overwrite=overwrite) as (tmp,):
        with tmp.open("xb") as fh, sksicd.NitfWriter(fh, meta) as writer:
            writer.write_image(pixels)
    logger.debug("wrote SICD %s: %d x %d pixels", target, *pixels.shape)
    return target


def read_sicd(path: PathLike) -> tuple[NDArray[np.complex64], Any]:
    """The pixel array and XML tree of a SICD NITF file (sarkit's reader)."""
    p = Path(path)
    if not p.is_file():
        raise DataError(f"SICD file not found: {p}")
    with p.open("rb") as fh, sksicd.NitfReader(fh) as reader:
        pixels = reader.read_image()
        tree = reader.metadata.xmltree
    return pixels, tree
