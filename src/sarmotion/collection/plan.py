"""The patch plan: which patches cut a scene, and what data each one holds.

A *patch* is a square core of the ground plus the data a mover whose echo centre lies
in the core needs: its traces are the data re-referenced to the core's centre
``rho_p`` (``eq:rangecompress`` with ``rho_p`` for ``rho_o``), windowed in fast time and
low-pass filtered and decimated in slow time (:mod:`sarmotion.collection.extract`).
Everything is derived from the data (:func:`plan_patches`):

- **Core side** ``P``. Range compression to ``rho_p`` leaves a stationary point at
  cross-range offset ``y`` a residual migration of about ``y dtheta`` over the analysed
  aperture ``dtheta``; robust PCA needs those traces "almost vertical" (``sect:RPCA``).
  ``P = 2 k rho_r / m_1`` with ``m_1`` the residual migration per metre of cross-range
  offset (computed from the trajectory) and ``k = 4`` range-resolution cells ``rho_r``:
  the migration at the edge of the 100 m image the analysis was built and validated on
  (a GOTCHA degree: 50 m x 0.0175 rad = 0.87 m = 3.8 cells). For a GOTCHA degree
  ``P`` is 107 m.
- **Fast-time window.** The core's stationary delays ``tau(s, x) - tau(s, rho_p)`` over
  every pulse and core point, widened on each side by the largest range migration
  ``max_s |tau(s, rho_p + s u) - tau(s, rho_p)|`` of a mover of ground speed
  ``|u| <= max_speed_mps`` and by ``8 / B`` (eight compressed-pulse lengths: the sinc's
  sidelobes are below -28 dB there).
- **Slow-time band.** After re-referencing, the core's stationary echoes have
  instantaneous Doppler ``f d/ds [tau(s, x) - tau(s, rho_p)]`` within ``+- b_core``
  (``f`` over the band, ``s`` over the aperture). A mover's Doppler spreads about its
  centre by its range migration across the band and its acceleration relative to the
  platform: ``b_mover = max |f tau_x'(s) - f_o tau_x'(0)|``, ``tau_x(s) = tau(s, x + s u)
  - tau(s, x)``, over ground speeds ``<= max_speed_mps``, ``x`` the region's corners.
  The passband is ``+- (b_core + b_mover)``: a mover whose Doppler centre (aliased by
  the data's own pulse rate, where its image lands in cross range) falls on the core
  keeps its whole spectrum. The traces are resampled to ``(1 + guard) 2 f_pass`` pulses
  per second or just above (``guard = 0.3``, the sampling margin of the collections the
  analysis was validated on): a rational ratio ``p / q`` of the data's pulse rate
  (:mod:`~sarmotion.collection.resample`, its rule and error bound) where no mover of the
  speed range is aliased in the data, else the integer decimation ``q = floor(PRF /
  ((1 + guard) 2 f_pass))``, exact for aliased movers too; the filter's stop
  band starts at ``(1 + 2 guard) f_pass``, and there is no filter when the ratio is 1 and
  that is above the Nyquist rate (the band is the data's).

The patches' *extents* (core plus those margins) overlap by twice the margins, which
exceed the largest displacement in range and the largest Doppler spread of a mover in
the speed range: every mover lies wholly inside at least one patch. The cores tile the
region without overlap.

The default region is the data's unambiguous scene (:func:`unambiguous_scene`: the
fast-time window ``1 / df`` in range and the pulse rate in cross range, mapped to the
ground at every pulse, so that the look's turn over the aperture does not wrap the
scene's corners), or rather the largest box along the scene axes inside it
(:func:`inscribed_box`): patches are squares along ``x`` and ``y``. A region whose
extent today's single analysis covers (0.6 of it, the rule of
:func:`~sarmotion.imaging.default_scene_size_m`, within ``P``) is one patch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import integer, positive
from ..core.blocks import PulseBlocks
from ..core.constants import C
from ..core.geometry import look_geometry, travel_time
from ..pipeline import AnalysisOptions
from .resample import aliased_doppler_hz, design, output_grid, slow_time_ratio

__all__ = ["CollectionOptions", "Patch", "PatchPlan", "plan_patches", "RegionError"]

#: Residual migration at a core's edge, in range-resolution cells (module notes).
MIGRATION_CELLS = 1.3
#: Fast-time guard either side of a patch's window, in compressed-pulse lengths 1/B.
PULSE_GUARD = 8.0
#: Fraction of the pulse rate kept free above a patch's band (module notes).
BAND_GUARD = 0.3
#: Share of the unambiguous window today's single analysis images (``default_scene_size_m``).
TRUSTED_SHARE = 0.6
#: Ground-velocity directions sampled for the movers' margins.
_N_DIRECTIONS = 16


class RegionError(ValueError):
    """A region or patch size the data cannot serve (outside the extent, below a cell)."""


@dataclass(frozen=True, kw_only=True)
class CollectionOptions:
    """Choices of the analysis of a whole collection (:func:`~sarmotion.collection.run`).

    Attributes
    ----------
    analysis : AnalysisOptions
        Options of each patch's analysis (:func:`~sarmotion.pipeline.analyze`).
        ``image_size_m`` is set per patch to its core; ``max_stationary`` is per patch.
    patch_size_m : float or None
        Core side ``P`` (m); ``None``: from the data (module notes).
    max_speed_mps : float
        Largest ground speed of a mover (m/s) the patches' margins are sized for.
        Default 15 m/s (54 km/h, town traffic): a margin is the mover's Doppler spread, which
        grows with its range speed; at 30 m/s (the analysis's default search bound) a
        GOTCHA-like patch's band would need most of the pulse rate, leaving no room for the
        slow-time filter that keeps the other patches' echoes out. A faster mover is still
        found in the patch where its Doppler centre falls, its spectrum cut by the filter.
    stopband_db : float
        Attenuation of the slow-time filter outside a patch's band (dB, > 0). Default
        60 dB; its pass-band ripple is the same ``10^(-A/20)``.
    block_pulses : int
        Pulses read per block (>= 1). Default 256.
    """

    analysis: AnalysisOptions = field(default_factory=AnalysisOptions)
    patch_size_m: float | None = None
    max_speed_mps: float = 15.0
    stopband_db: float = 60.0
    block_pulses: int = 256

    def __post_init__(self) -> None:
        if not isinstance(self.analysis, AnalysisOptions):
            raise TypeError(
                f"analysis must be an AnalysisOptions, got {type(self.analysis).__name__}"
            )
        if self.patch_size_m is not None:
            positive(self.patch_size_m, "patch_size_m", unit="m")
        positive(self.max_speed_mps, "max_speed_mps", unit="m/s")
        positive(self.stopband_db, "stopband_db", unit="dB")
        integer(self.block_pulses, "block_pulses", minimum=1)

    @property
    def speed_mps(self) -> float:
        """The movers' largest ground speed (m/s)."""
        return float(self.max_speed_mps)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict of the options."""
        return {
            "patch_size_m": self.patch_size_m,
            "max_speed_mps": self.speed_mps,
            "stopband_db": self.stopband_db,
            "block_pulses": self.block_pulses,
        }


@dataclass(frozen=True, kw_only=True)
class Patch:
    """One patch: its core, reference point, and how its traces are cut from the data.

    Attributes
    ----------
    index : int
        Position in the plan.
    core_m : (float, float, float, float)
        Core ``(x0, y0, x1, y1)`` (m).
    centre_m : (3,) ndarray
        Reference point ``rho_p`` (m): the core's centre at the data reference's height.
    n_samples : int
        Fast-time samples of its traces (centred on ``t = 0``).
    decimation : int
        Slow-time down factor ``q`` (1: none).
    interpolation : int
        Slow-time up factor ``p``: the traces' pulse rate is ``p / q`` of the data's
        (:mod:`~sarmotion.collection.resample`).
    passband_hz : float
        Half-width ``f_pass`` of its slow-time band (Hz).
    taps : (n_taps,) ndarray
        Slow-time FIR filter on the grid of ``1 / p`` input pulses (odd length, linear
        phase, gain ``p`` at 0 Hz; ``[1]`` when the patch's band is the data's).
    pulses : (n_out,) ndarray of int
        Where its output pulses sit, on that grid (input pulse ``j`` at ``j p``; the input
        pulses themselves when ``p = 1``), each with the filter's full support.
    """

    index: int
    core_m: tuple[float, float, float, float]
    centre_m: NDArray[np.float64]
    n_samples: int
    decimation: int
    interpolation: int = 1
    passband_hz: float
    taps: NDArray[np.float64]
    pulses: NDArray[np.int64]

    @property
    def pulse_positions(self) -> NDArray[np.float64]:
        """Output pulses' positions on the data's pulse axis, ``pulses / p`` (pulses)."""
        return self.pulses / float(self.interpolation)

    @property
    def size_m(self) -> float:
        """Larger side of the core (m)."""
        x0, y0, x1, y1 = self.core_m
        return float(max(x1 - x0, y1 - y0))

    def contains(self, point_m: ArrayLike) -> bool:
        """Whether the ground point ``(x, y)`` lies in the core (lower edges included)."""
        x, y = np.asarray(point_m, dtype=float)[:2]
        x0, y0, x1, y1 = self.core_m
        return bool(x0 <= x < x1 and y0 <= y < y1)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the patch table of ``results.json``)."""
        return {
            "index": self.index,
            "core_m": [float(v) for v in self.core_m],
            "centre_m": [float(v) for v in self.centre_m[:2]],
            "n_pulses": int(self.pulses.size),
            "n_samples": int(self.n_samples),
            "decimation": int(self.decimation),
            "interpolation": int(self.interpolation),
            "passband_hz": float(self.passband_hz),
            "n_taps": int(self.taps.size),
        }


@dataclass(frozen=True, kw_only=True)
class PatchPlan:
    """The patches of a region.

    Attributes
    ----------
    patches : tuple of Patch
        The patches, row by row (``y``, then ``x``).
    region_m : (float, float, float, float)
        The region ``(x0, y0, x1, y1)`` the cores tile (m).
    patch_size_m : float
        Core side ``P`` used (m).
    unambiguous_m : (4, 2) ndarray
        Corners of the data's unambiguous scene on the ground (m).
    range_margin_m, doppler_margin_hz : float
        A mover's largest range migration (m) and Doppler spread (Hz) in the speed range.
    single : bool
        The region is today's single analysis (no re-referencing needed).
    """

    patches: tuple[Patch, ...]
    region_m: tuple[float, float, float, float]
    patch_size_m: float
    unambiguous_m: NDArray[np.float64]
    range_margin_m: float
    doppler_margin_hz: float
    single: bool

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary of the plan and its patch table."""
        return {
            "region_m": [float(v) for v in self.region_m],
            "patch_size_m": float(self.patch_size_m),
            "unambiguous_scene_m": self.unambiguous_m.tolist(),
            "range_margin_m": float(self.range_margin_m),
            "doppler_margin_hz": float(self.doppler_margin_hz),
            "patches": [p.to_dict() for p in self.patches],
        }


# --------------------------------------------------------------------- geometry
def _frame(source: PulseBlocks) -> tuple[NDArray, NDArray, float]:
    """Ground range and cross-range unit vectors at the reference point, and its height."""
    geom = look_geometry(source.trajectory, source.reference_point_m)
    b = geom.ground_m_o
    nb = float(np.linalg.norm(b))
    if nb < 1e-9:
        raise RegionError("the antenna is above the reference point: no ground range")
    e_r = b / nb
    return e_r, np.array([-e_r[1], e_r[0]]), float(source.reference_point_m[2])


def _lift(points: NDArray, z: float) -> NDArray:
    p = np.atleast_2d(np.asarray(points, dtype=np.float64))
    return np.concatenate([p[:, :2], np.full((p.shape[0], 1), z)], axis=1)


def _delays(positions: NDArray, points: NDArray) -> NDArray:
    """``tau(s_j, x_i)`` for fixed points, shape (n_points, n_pulses) (s)."""
    return np.stack([travel_time(positions, p) for p in points])


def _moving_delays(positions: NDArray, s: NDArray, point: NDArray, velocities: NDArray) -> NDArray:
    """``tau(s_j, x + s_j u_i)`` for each ground velocity ``u_i``, shape (n_vel, n_pulses)."""
    out = []
    for u in velocities:
        where = point[None, :] + s[:, None] * np.r_[u, 0.0][None, :]
        out.append(travel_time(positions, where))
    return np.stack(out)


def _velocities(speed: float) -> NDArray:
    phi = 2 * np.pi * np.arange(_N_DIRECTIONS) / _N_DIRECTIONS
    return speed * np.stack([np.cos(phi), np.sin(phi)], axis=1)


def _square_points(core: tuple[float, float, float, float], z: float) -> NDArray:
    """Corners, edge midpoints and centre of a rectangle, lifted to height ``z``."""
    x0, y0, x1, y1 = core
    xs, ys = np.meshgrid([x0, 0.5 * (x0 + x1), x1], [y0, 0.5 * (y0 + y1), y1])
    return _lift(np.stack([xs.ravel(), ys.ravel()], axis=1), z)


def unambiguous_scene(source: PulseBlocks) -> NDArray[np.float64]:
    """Ground corners of the data's unambiguous scene, shape (4, 2) (m).

    A rectangle about the reference point, sides along the aperture centre's ground
    range ``e_r`` and cross range ``e_c``, every point of which stays unambiguous at
    *every* pulse ``j``: its delay offset from the reference within half the fast-time
    window ``1 / (2 df)`` (s), and its Doppler offset within half the pulse rate. With
    the offsets linear in the ground offset ``d = a e_r + b e_c`` (delay gradient
    ``k_j``, Doppler gradient ``f_c dk_j/ds``), the corners ``|a| = A``, ``|b| = B``
    bound both: ``A |k_j . e_r| + B |k_j . e_c| <= 1 / (2 df)`` and the same for the
    Doppler with ``prf / 2``. ``A_0``, ``B_0`` are each side's bound alone (the look
    turned from ``e_r`` at other pulses couples them); ``A`` and ``B`` are then what
    each bound leaves after the other side at ``B_0``, ``A_0``, so both hold. Over a
    turning aperture the look direction moves, and a rectangle drawn at the aperture
    centre alone reaches, at its far corners, points whose echoes wrap in Doppler at
    the aperture's ends: ghosts of the scene's far side, which fit movers.
    """
    e_r, e_c, z = _frame(source)
    rho = source.reference_point_m
    pos = source.trajectory.positions_m
    s = source.trajectory.slow_times_s
    if s.size < 2:
        raise RegionError("one pulse has no Doppler: no unambiguous cross range")
    step = 1.0
    pts = _lift(np.stack([rho[:2], rho[:2] + step * e_r, rho[:2] + step * e_c]), z)
    tau = _delays(pos, pts)
    k = np.abs(np.stack([tau[1] - tau[0], tau[2] - tau[0]])) / step  # s per m, (2, n)
    f = np.abs(np.gradient(tau[1:] - tau[0], s, axis=1)) * source.radar.carrier_hz / step
    half_t = 0.5 / source.radar.frequency_step_hz  # s
    half_f = 0.5 / source.trajectory.pulse_interval_s  # Hz
    a0 = float(np.min(half_t / np.maximum(k[0], 1e-300)))
    b0 = float(np.min(half_f / np.maximum(f[1], 1e-300)))
    half_r = float(np.min((half_t - b0 * k[1]) / np.maximum(k[0], 1e-300)))
    half_c = float(np.min((half_f - a0 * f[0]) / np.maximum(f[1], 1e-300)))
    if not (half_r > 0.0 and half_c > 0.0):
        raise RegionError("the look turns too far over the aperture: no unambiguous scene")
    c = rho[:2]
    return np.array(
        [c + a * half_r * e_r + b * half_c * e_c for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    )


def inscribed_box(corners_m: ArrayLike) -> tuple[float, float, float, float]:
    """The largest box along the scene axes inside a rectangle, ``(x0, y0, x1, y1)`` (m).

    ``corners_m`` (4, 2) is a rectangle (:func:`unambiguous_scene`): half sides ``A``,
    ``B`` along unit vectors ``e_1``, ``e_2`` turned by ``beta`` from ``x``. A box of
    half sides ``X``, ``Y`` about its centre lies inside when its corners' projections
    do: ``X |cos beta| + Y |sin beta| <= A`` and ``X |sin beta| + Y |cos beta| <= B``.
    Both held with equality give the box touching all four sides; when that has no
    positive solution (a long rectangle turned far), the square
    ``X = Y = min(A, B) / (|cos beta| + |sin beta|)``.
    """
    q = np.asarray(corners_m, dtype=np.float64)
    centre = q.mean(axis=0)
    u, v = q[1] - q[0], q[3] - q[0]
    a, b = 0.5 * float(np.hypot(*u)), 0.5 * float(np.hypot(*v))
    co, si = abs(u[0]) / (2.0 * a), abs(u[1]) / (2.0 * a)
    det = co * co - si * si
    x = (a * co - b * si) / det if abs(det) > 1e-12 else -1.0
    y = (b * co - a * si) / det if abs(det) > 1e-12 else -1.0
    if not (x > 0.0 and y > 0.0):
        x = y = min(a, b) / (co + si)
    return (centre[0] - x, centre[1] - y, centre[0] + x, centre[1] + y)


def _migration_per_m(source: PulseBlocks, e_c: NDArray, z: float, pulses: slice) -> float:
    """Residual slant-range migration per metre of cross-range offset over ``pulses`` (m/m)."""
    rho = source.reference_point_m
    pos = source.trajectory.positions_m[pulses]
    s = source.trajectory.slow_times_s[pulses]
    pts = _lift(np.stack([rho[:2], rho[:2] + e_c]), z)
    d = _delays(pos, pts)
    dd = d[1] - d[0]
    j0 = int(np.argmin(np.abs(s)))
    return float(0.5 * C * np.max(np.abs(dd - dd[j0])))


def _analysed_pulses(source: PulseBlocks, sub_aperture_deg: float) -> slice:
    """The central pulses the movers are estimated on (``central_sub_aperture``'s rule)."""
    pos = source.trajectory.positions_m
    ends = pos[[0, -1], :2] - source.reference_point_m[:2]
    cos_span = np.dot(ends[0], ends[1]) / np.prod(np.linalg.norm(ends, axis=1))
    span = float(np.degrees(np.arccos(np.clip(cos_span, -1.0, 1.0))))
    n = source.n_pulses
    if span <= 1.5 * sub_aperture_deg:
        return slice(0, n)
    m = max(2, int(round(n * sub_aperture_deg / span)))
    return slice((n - m) // 2, (n - m) // 2 + m)


# ------------------------------------------------------------------------- plan
def plan_patches(
    source: PulseBlocks,
    options: CollectionOptions | None = None,
    *,
    region_m: ArrayLike | None = None,
) -> PatchPlan:
    """Cut ``region_m`` (default: the data's unambiguous scene) into patches.

    Parameters
    ----------
    source : PulseBlocks
        The data's axes (radar, reference point, trajectory).
    options : CollectionOptions, optional
        Core side, movers' speed, filter attenuation.
    region_m : (4,) array_like, optional
        ``(x0, y0, x1, y1)`` in scene metres, ``x0 < x1``, ``y0 < y1``; it must lie in
        the data's unambiguous scene. Default: the largest such box
        (:func:`inscribed_box` of :func:`unambiguous_scene`).

    Returns
    -------
    PatchPlan

    Raises
    ------
    RegionError
        The region leaves the unambiguous scene, or the core side is below a
        resolution cell.
    """
    opts = options or CollectionOptions()
    radar = source.radar
    traj = source.trajectory
    pos, s = traj.positions_m, traj.slow_times_s
    e_r, e_c, z = _frame(source)
    amb = unambiguous_scene(source)
    u_r = np.stack([amb @ e_r, amb @ e_c], axis=1)  # corners in (range, cross) coordinates
    lo_rc, hi_rc = u_r.min(axis=0), u_r.max(axis=0)
    tol = 1e-6
    # resolution cells: slant range c / 2B on the ground, cross range lambda L / 2a
    geom = look_geometry(traj, source.reference_point_m)
    cell_r = radar.range_resolution_m / math.cos(geom.elevation_rad)
    cell_c = radar.wavelength_m * geom.range_m / (2.0 * traj.aperture_length_m)
    cell = max(cell_r, cell_c)

    analysed = _analysed_pulses(source, opts.analysis.sub_aperture_deg)
    if opts.patch_size_m is not None:
        size = float(opts.patch_size_m)
    else:
        m1 = _migration_per_m(source, e_c, z, analysed)
        size = 2.0 * MIGRATION_CELLS * radar.range_resolution_m / max(m1, 1e-12)
    if size < cell:
        raise RegionError(f"patch size {size:g} m is smaller than a resolution cell ({cell:.3g} m)")

    default_region = region_m is None
    if default_region:
        x0, y0, x1, y1 = inscribed_box(amb)
    else:
        r = np.asarray(region_m, dtype=np.float64).reshape(-1)
        if r.shape != (4,) or not np.all(np.isfinite(r)):
            raise RegionError(f"region must be 4 finite numbers X0 Y0 X1 Y1 (m), got {region_m}")
        x0, y0, x1, y1 = (float(v) for v in r)
        if not (x1 > x0 and y1 > y0):
            raise RegionError(f"region must have X0 < X1 and Y0 < Y1, got {tuple(r)}")
        corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        rc = np.stack([corners @ e_r, corners @ e_c], axis=1)
        if np.any(rc < lo_rc - tol) or np.any(rc > hi_rc + tol):
            raise RegionError(
                f"region ({x0:g}, {y0:g}, {x1:g}, {y1:g}) m leaves the data's unambiguous "
                f"scene, a rectangle turned to the look direction with corners "
                + ", ".join(f"({a:.1f}, {b:.1f})" for a, b in amb)
                + " m"
            )
    width, height = x1 - x0, y1 - y0
    single = default_region and TRUSTED_SHARE * max(width, height) <= size
    if single:
        n_x = n_y = 1
    else:
        n_x, n_y = max(1, math.ceil(width / size - 1e-9)), max(1, math.ceil(height / size - 1e-9))

    # movers' margins, common to all patches (module notes)
    vel = _velocities(opts.speed_mps)
    f_lo = radar.carrier_hz - 0.5 * radar.bandwidth_hz
    f_hi = radar.carrier_hz + 0.5 * radar.bandwidth_hz
    j0 = int(np.argmin(np.abs(s)))
    margin_t = 0.0
    margin_d = 0.0
    for x in _lift(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]), z):
        still = travel_time(pos, x)
        moving = _moving_delays(pos, s, x, vel) - still[None, :]
        margin_t = max(margin_t, float(np.max(np.abs(moving))))
        rate = np.gradient(moving, s, axis=1)
        centre = radar.carrier_hz * rate[:, j0 : j0 + 1]
        spread = np.maximum(np.abs(f_lo * rate - centre), np.abs(f_hi * rate - centre))
        margin_d = max(margin_d, float(np.max(spread)))
    guard_t = PULSE_GUARD / radar.bandwidth_hz
    prf = 1.0 / traj.pulse_interval_s
    dt = radar.sample_interval_s

    patches = []
    xs = np.linspace(x0, x1, n_x + 1)
    ys = np.linspace(y0, y1, n_y + 1)
    for iy in range(n_y):
        for ix in range(n_x):
            core = (float(xs[ix]), float(ys[iy]), float(xs[ix + 1]), float(ys[iy + 1]))
            pts = _square_points(core, z)
            rc = np.stack([pts[:, :2] @ e_r, pts[:, :2] @ e_c], axis=1)
            if default_region and (
                np.all(rc[:, 0] < lo_rc[0] - tol)
                or np.all(rc[:, 0] > hi_rc[0] + tol)
                or np.all(rc[:, 1] < lo_rc[1] - tol)
                or np.all(rc[:, 1] > hi_rc[1] + tol)
            ):
                continue  # a corner of the bounding box outside the unambiguous scene
            centre = pts[4].copy()
            rel = _delays(pos, pts) - travel_time(pos, centre)[None, :]
            half_t = float(np.max(np.abs(rel))) + margin_t + guard_t
            n_samples = _window_samples(half_t, dt, radar.n_samples)
            rate = np.gradient(rel, s, axis=1)
            core_band = float(max(np.max(np.abs(f_lo * rate)), np.max(np.abs(f_hi * rate))))
            passband = core_band + margin_d
            need = (1.0 + BAND_GUARD) * 2.0 * passband
            up, q = slow_time_ratio(prf, need)
            corners = _lift(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]), z)
            if up > 1 and aliased_doppler_hz(
                pos, s, centre, corners, vel, (f_lo, f_hi)
            ) >= prf - passband:
                # a mover of the speed range is aliased in the data: whole pulses only
                up, q = 1, max(1, int(math.floor(prf / need)))
            if single:
                up, q, n_samples = 1, 1, radar.n_samples
            taps = _design(passband, prf, opts.stopband_db, up=up)
            pulses = _output_pulses(source.n_pulses, q, taps.size, up=up)
            if pulses.size < 2:
                raise RegionError(
                    f"patch {len(patches)} keeps {pulses.size} pulse(s) after its "
                    f"{taps.size}-tap slow-time filter: the aperture is too short"
                )
            patches.append(
                Patch(
                    index=len(patches),
                    core_m=core,
                    centre_m=centre if not single else source.reference_point_m.copy(),
                    n_samples=n_samples,
                    decimation=q,
                    interpolation=up,
                    passband_hz=passband,
                    taps=taps,
                    pulses=pulses,
                )
            )
    return PatchPlan(
        patches=tuple(patches),
        region_m=(float(x0), float(y0), float(x1), float(y1)),
        patch_size_m=float(size),
        unambiguous_m=amb,
        range_margin_m=0.5 * C * margin_t,
        doppler_margin_hz=margin_d,
        single=bool(single),
    )


def _window_samples(half_s: float, dt: float, n_max: int) -> int:
    """Even fast-time window length covering ``+- half_s`` (s), FFT-friendly, <= ``n_max``."""
    from scipy.fft import next_fast_len

    n = 2 * int(math.ceil(half_s / dt)) + 2
    n = next_fast_len(n)
    n += n % 2
    return int(min(n, n_max))


def _design(
    passband_hz: float, prf_hz: float, stopband_db: float, *, up: int = 1
) -> NDArray[np.float64]:
    """Kaiser-window low-pass FIR of pass band ``|f| <= f_pass``, stop band ``|f| >= f_stop``.

    ``f_stop = (1 + 2 guard) f_pass``: for a ratio ``p / q`` the plan has ``prf p / q >=
    2 (1 + guard) f_pass``, so what lies between the bands aliases outside the pass band;
    with ``p = q = 1`` the filter still removes the echoes of other patches' cores (and
    the movers there) when ``f_stop`` is below the Nyquist rate ``prf / 2``; else ``[1.0]``
    (the band is the data's). On the grid of ``1 / p`` input pulses, within ``10^(-A/20)``
    in both bands once applied (:func:`~sarmotion.collection.resample.design`).
    """
    return design(up, passband_hz, prf_hz, stopband_db, guard=BAND_GUARD)


def _output_pulses(n_pulses: int, q: int, n_taps: int, *, up: int = 1) -> NDArray[np.int64]:
    """Grid indices of the output pulses: every ``q``-th with the filter's full support.

    On the grid of ``1 / up`` input pulses (the input pulses themselves when ``up = 1``),
    placed symmetrically in the aperture (:func:`~sarmotion.collection.resample.output_grid`).
    """
    return output_grid(n_pulses, up, q, n_taps)
