"""One answer from many patches: movers by range history, stationary targets, the mosaic.

**Movers.** The data fix a mover's range history ``R(s) = |r(s) - rho - s u|`` over the
aperture, not its place along its cross-range family (:mod:`sarmotion.motion.aperture`):
two patches may report the same mover at different family members. Over a degree the
history is fixed to first order, its range ``R(0)`` and range rate ``R'(0)``; its
curvature (the cross-range speed) is what the family and ``g_perp`` leave loose. Two
movers are one when

    |R_a(0) - R_b(0)| <= 3 sqrt(sigma_xa^2 + sigma_xb^2) + rho_r / 2,
    |R_a'(0) - R_b'(0)| <= 3 sqrt(sigma_ua^2 + sigma_ub^2) + rho_u / 2,

with ``sigma_x``, ``sigma_u`` the Cramér–Rao bounds of the range position and range speed
each patch reported, ``rho_r = c / 2B`` the range resolution and ``rho_u = rho_r / (T /
2)`` the range-speed resolution of ``g(u)`` (``T`` the analysed aperture's duration): two
point movers closer than half a cell in both are one peak of ``g`` in every patch. Of a
group the fit with the smallest range-position error (then the highest SNR) is kept.

**Which patch estimates a mover.** After re-referencing to a patch's centre
``rho_p``, a mover's echoes sit at range ``R(0) - R_p(0)`` and Doppler ``(2 f_o / c)
(R'(0) - R_p'(0))``, aliased by the data's pulse rate ``PRF``: ``R'`` is known modulo
``lambda_o PRF / 2`` (:func:`echo_offsets`). A patch passes a Doppler band of ``+-
f_pass`` (its core's band plus the movers' Doppler margin,
:mod:`~sarmotion.collection.plan`), and its core spans ``+- R_core`` in range about
``R_p(0)``. It estimates fully only the movers with ``|R(0) - R_p(0)| <= R_core +
ECHO_CELLS c / 2B`` and Doppler within ``+- f_pass``: those whose echoes it passes.
The others, leaking into its traces from beyond (through the filter's transition band,
or where there is no filter), are fitted once and subtracted there, not estimated
further: the patches whose band holds them do that.

A patch's ``g(u)`` tests only range speeds ``|R'(0) - R_p'(0)|`` above those of its
core's stationary points, ``c`` (their largest, at a corner; slower peaks are taken for
stationary residue, :func:`~sarmotion.collection.run.core_stationary_speed`). A mover
slower than ``c`` relative to a patch mimics a stationary point of that core; the next
patch across range has its reference about ``2 c'`` away in range rate (``c'`` the rate
of the core's cross-range edge, ``c' <= c``), so the mover is at ``2 c' - |r|`` there:
above that patch's ``c`` for ``|r| <= 2 c' - c``, and within its pass band when the pass
band reaches ``2 c'``. The generic band of an image, two range-speed resolutions, is
wider than a core's ``c`` and than the pass band's reach: taken per patch it left
movers of slow range rate to no patch.

**Stationary targets** are one when within one resolution cell in ground range and in
cross range (their positions, unlike a mover's, are fixed by the data); the brighter is
kept. Their levels are compared across patches on one scale: ``|I| / n_pulses`` of each
patch's stationary image (the slow-time filter has unit gain).

**Sidelobes.** A patch lists the local maxima of its stationary image; beside a bright
target some are its sidelobes (a neighbour's target seen across the core's edge, where
the separation's Doppler test has no say). A listing whose level is at most the bound
of the brighter listed targets' sidelobes there (the separable point-spread function's
envelope, :mod:`sarmotion.imaging.sidelobes`) can be their sidelobes alone: it is dropped
(:func:`drop_sidelobes`; the count is reported). A true target that weak on a brighter
one's sidelobe ridge cannot be told from the sidelobe by its level and is dropped with
it; one off the ridges is kept down to ``-20 dB - 20 log10 w`` below its neighbour (``w``
the least fraction of a peak its nearest pixel reads).

**Movers' images.** A stationary image holds each mover's smeared echo: the mover's
range and range rate at slow time ``s`` are a stationary point's at some ``p``, and
its energy lands on the locus of those points over the aperture. A slow mover's
Doppler test passes as stationary (its Doppler spread is small), so a patch may list
points of that locus. A listed stationary point ``p`` lies on a found mover's echo when
at some pulse of the analysed aperture ``|R_p(s) - R_m(s)| <= ECHO_CELLS c / 2B`` and
``|R_p'(s) - R_m'(s)| <= ECHO_CELLS lambda_o / (2 T)`` (a Doppler resolution ``1 / T``
in range rate, aliased by the pulse rate). The echo can make at ``p`` at most

    L_m(p) = |a_m| mean_s E(|R_p(s) - R_m(s)| / (c / 2B))

(the triangle inequality over the pulses, each pulse's compressed echo at most the
envelope ``E`` of :func:`~sarmotion.imaging.sidelobes.envelope`, the rect pulse's or the
Gaussian's; ``|a_m|`` the mover's fitted amplitude, in the image's level units: a
stationary point of reflectivity ``a`` reads ``|a|``). A listing on the echo whose
level ``|I(p)| / n_pulses`` is at most ``SMEAR_MARGIN`` (2) times ``L_m(p)``, so that half
its amplitude or more can be the mover's echo (the rest what else sums there: clutter,
other targets' sidelobes, noise), is the mover's image: dropped and counted
(:func:`drop_mover_images`). A listing above it holds more than the echo can explain
(a unit point crossed by a fast mover's echo for a few pulses: its range moves through
a cell in ``(c / 2B) / |u_r|``) and is kept. A true stationary target that close to a
mover's echo and no brighter than that cannot be told from it by the data of that
aperture.

**Mosaic.** Each patch's stationary image on its core, ``|I| / n_pulses``, on one grid
of a stated spacing: each patch's image is reduced to the mosaic's pixels by block
maxima where it is analysed (:func:`coarsen`) and pasted in as it arrives
(:func:`paste`), so the collection holds the mosaic, not every patch's image.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.geometry import Trajectory
from ..imaging.sidelobes import envelope, sidelobe_peaks

__all__ = [
    "ECHO_CELLS",
    "echo_offsets",
    "MoverRecord",
    "StationaryRecord",
    "PatchImage",
    "coarsen",
    "drop_sidelobes",
    "drop_mover_images",
    "mosaic_grid",
    "paste",
    "same_mover",
    "merge_movers",
    "merge_stationary",
    "mosaic",
]


#: Range cells ``c / 2B`` beyond a patch's core within which it estimates movers.
ECHO_CELLS = 2.0


def echo_offsets(
    trajectory: Trajectory,
    position_m: NDArray,
    velocity_mps: NDArray,
    centre_m: NDArray,
    rate_period_mps: float,
) -> tuple[float, float]:
    """A mover's ``R(0) - R_p(0)`` (m) and ``R'(0) - R_p'(0)`` (m/s) (module notes).

    Parameters
    ----------
    trajectory : Trajectory
        The pulses (``s = 0`` where the mover's position is given; the pulse nearest
        it is used).
    position_m : (2,) or (3,) ndarray
        Mover's position at ``s = 0`` (m; height 0 when 2-D).
    velocity_mps : (2,) ndarray
        Its ground velocity (m/s).
    centre_m : (3,) ndarray
        The patch centre ``rho_p`` (m).
    rate_period_mps : float
        ``lambda_o PRF / 2`` (m/s): the rate offset is taken in ``[-1/2, 1/2)`` of it
        (``inf``: not aliased).
    """
    s = trajectory.slow_times_s
    j0 = int(np.argmin(np.abs(s)))
    r0 = trajectory.positions_m[j0]
    rdot = np.gradient(trajectory.positions_m, s, axis=0)[j0]
    p = np.zeros(3)
    p[: np.size(position_m)] = np.asarray(position_m, float)
    v = np.r_[np.asarray(velocity_mps, float)[:2], 0.0]

    def history(x: NDArray, u: NDArray) -> tuple[float, float]:
        d = r0 - x
        n = float(np.linalg.norm(d))
        return n, float(d @ (rdot - u)) / n

    rm, dm = history(p, v)
    rc, dc = history(np.asarray(centre_m, float), np.zeros(3))
    rate = dm - dc
    if np.isfinite(rate_period_mps):
        rate -= rate_period_mps * np.floor(rate / rate_period_mps + 0.5)
    return rm - rc, float(rate)


@dataclass(frozen=True, kw_only=True)
class MoverRecord:
    """A mover as one patch reported it.

    Attributes
    ----------
    patch : int
        Index of the patch.
    position_m : (3,) ndarray
        Position at ``s = 0`` (m).
    velocity_mps : (2,) ndarray
        Ground velocity (m/s).
    sigma_range_m, sigma_range_speed_mps : float
        Standard errors of the range position (m) and range speed (m/s); ``inf`` when
        the patch gave none.
    snr_db : float
        Matched-filter SNR (dB); ``-inf`` when unknown.
    document : dict
        Its entry of the ``sarmotion.results/2`` document.
    amplitude : float
        ``|a|`` of its fit, in data units: the level ``|I| / n_pulses`` a stationary
        point of that reflectivity has in a stationary image; ``inf`` when unknown.
    """

    patch: int
    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64]
    sigma_range_m: float
    sigma_range_speed_mps: float
    snr_db: float
    document: dict[str, Any]
    amplitude: float = math.inf


@dataclass(frozen=True, kw_only=True)
class StationaryRecord:
    """A stationary target as one patch reported it.

    Attributes
    ----------
    patch : int
        Index of the patch.
    position_m : (float, float)
        Position (m).
    level : float
        ``|I| / n_pulses`` of its patch's stationary image at the target (data units).
    """

    patch: int
    position_m: tuple[float, float]
    level: float


@dataclass(frozen=True, kw_only=True)
class PatchImage:
    """A patch's stationary image on its core, ``|I| / n_pulses``.

    Attributes
    ----------
    x_m, y_m : ndarray
        Pixel coordinates (m), increasing, uniform.
    magnitude : (ny, nx) ndarray
        Image magnitude (float32).
    """

    x_m: NDArray[np.float64]
    y_m: NDArray[np.float64]
    magnitude: NDArray[np.float32]


def same_mover(
    a: MoverRecord, b: MoverRecord, trajectory: Trajectory, range_resolution_m: float
) -> bool:
    """Whether ``a`` and ``b`` have one range history within their errors (module notes).

    Parameters
    ----------
    a, b : MoverRecord
        Two reports.
    trajectory : Trajectory
        The analysed pulses, with the acquisition's slow times (``s = 0`` where the
        positions are given).
    range_resolution_m : float
        Slant-range resolution ``c / 2B`` (m).
    """
    s = trajectory.slow_times_s
    # Range and range rate at s = 0, each against the same point (it cancels).
    origin = np.zeros(3)
    ra, da = echo_offsets(trajectory, a.position_m, a.velocity_mps, origin, np.inf)
    rb, db = echo_offsets(trajectory, b.position_m, b.velocity_mps, origin, np.inf)
    duration = float(s[-1] - s[0])
    speed_cell = range_resolution_m / (0.5 * duration)
    sx = np.hypot(_finite(a.sigma_range_m), _finite(b.sigma_range_m))
    su = np.hypot(_finite(a.sigma_range_speed_mps), _finite(b.sigma_range_speed_mps))
    return bool(
        abs(ra - rb) <= 3.0 * sx + 0.5 * range_resolution_m
        and abs(da - db) <= 3.0 * su + 0.5 * speed_cell
    )


def _finite(v: float) -> float:
    return float(v) if np.isfinite(v) else 0.0


def _better(a: MoverRecord) -> tuple[float, float]:
    return (a.sigma_range_m, -a.snr_db)


def merge_movers(
    movers: Sequence[MoverRecord], trajectory: Trajectory, range_resolution_m: float
) -> list[tuple[MoverRecord, list[int]]]:
    """Group the reports of one mover; keep the best-determined of each group.

    Parameters
    ----------
    movers : sequence of MoverRecord
        Every patch's movers.
    trajectory : Trajectory
        The pulses the range histories are compared on.
    range_resolution_m : float
        Slant-range resolution (m).

    Returns
    -------
    list of (MoverRecord, list of int)
        The kept report and the patches that reported it, best-determined first.
    """
    order = sorted(range(len(movers)), key=lambda i: _better(movers[i]))
    kept: list[tuple[MoverRecord, list[int]]] = []
    for i in order:
        m = movers[i]
        for rep, patches in kept:
            if same_mover(rep, m, trajectory, range_resolution_m):
                patches.append(m.patch)
                break
        else:
            kept.append((m, [m.patch]))
    return kept


def merge_stationary(
    targets: Sequence[StationaryRecord],
    *,
    range_direction: NDArray,
    range_cell_m: float,
    cross_cell_m: float,
) -> list[StationaryRecord]:
    """One record per target, brightest first.

    Records within a resolution cell in range and in cross range of a brighter one are
    the same target (module notes).

    Parameters
    ----------
    targets : sequence of StationaryRecord
        Every patch's stationary targets.
    range_direction : (2,) ndarray
        Unit ground-range direction.
    range_cell_m, cross_cell_m : float
        Ground-range and cross-range resolution (m).
    """
    e_r = np.asarray(range_direction, float)
    e_c = np.array([-e_r[1], e_r[0]])
    kept: list[StationaryRecord] = []
    pts = np.zeros((0, 2))
    for t in sorted(targets, key=lambda t: -t.level):
        p = np.asarray(t.position_m, float)
        if pts.size:
            d = pts - p[None, :]
            close = (np.abs(d @ e_r) <= range_cell_m) & (np.abs(d @ e_c) <= cross_cell_m)
            if np.any(close):
                continue
        kept.append(t)
        pts = np.vstack([pts, p[None, :]])
    return kept


def drop_sidelobes(
    targets: Sequence[StationaryRecord],
    *,
    antenna_m: NDArray,
    range_cell_m: float,
    cross_cell_m: float,
    pixel_m: float,
    gaussian_range: bool = False,
) -> tuple[list[StationaryRecord], int]:
    """The listed targets that are not a brighter listed target's sidelobe (module notes).

    The rule of :func:`~sarmotion.imaging.sidelobes.sidelobe_peaks` on the records' levels.

    Parameters
    ----------
    targets : sequence of StationaryRecord
        De-duplicated targets.
    antenna_m, range_cell_m, cross_cell_m, pixel_m, gaussian_range
        The geometry, as for :func:`~sarmotion.imaging.sidelobes.sidelobe_peaks`.

    Returns
    -------
    (list of StationaryRecord, int)
        The kept targets, brightest first, and how many were dropped.
    """
    order = sorted(targets, key=lambda t: -t.level)
    if not order:
        return [], 0
    sidelobe = sidelobe_peaks(
        [t.position_m for t in order], [t.level for t in order], antenna_m=antenna_m,
        range_cell_m=range_cell_m, cross_cell_m=cross_cell_m, pixel_m=pixel_m,
        gaussian_range=gaussian_range,
    )  # fmt: skip
    kept = [t for t, s in zip(order, sidelobe, strict=True) if not s]
    return kept, len(order) - len(kept)


def _histories(
    trajectory: Trajectory, points_m: NDArray, velocities_mps: NDArray, step: int
) -> tuple[NDArray, NDArray]:
    """Ranges (m) and range rates (m/s) of points ``(k, 3)`` moving at ``(k, 2)``.

    Over every ``step``-th pulse of ``trajectory`` (slow times as given; the points'
    positions are at ``s = 0``); shapes ``(k, n)``.
    """
    s = trajectory.slow_times_s
    pos = trajectory.positions_m
    vel = np.gradient(pos, s, axis=0)
    sel = np.unique(np.r_[np.arange(0, s.size, step), s.size - 1])
    s, pos, vel = s[sel], pos[sel], vel[sel]
    v3 = np.zeros((len(points_m), 3))
    v3[:, :2] = velocities_mps
    d = pos[None, :, :] - (points_m[:, None, :] + s[None, :, None] * v3[:, None, :])
    r = np.linalg.norm(d, axis=-1)
    rate = np.einsum("kns,kns->kn", d, vel[None, :, :] - v3[:, None, :]) / r
    return r, rate


#: A listing on a mover's echo at most this many times the echo's bound there is the
#: mover's image (module notes): half its amplitude or more can be the echo.
SMEAR_MARGIN = 2.0


def drop_mover_images(
    targets: Sequence[StationaryRecord],
    movers: Sequence[MoverRecord],
    *,
    trajectory: Trajectory,
    range_resolution_m: float,
    wavelength_m: float,
    rate_period_mps: float,
    height_m: float = 0.0,
    gaussian_range: bool = False,
) -> tuple[list[StationaryRecord], int]:
    """Stationary listings that are a found mover's image, dropped (module notes).

    Parameters
    ----------
    targets : sequence of StationaryRecord
        Listed stationary targets.
    movers : sequence of MoverRecord
        Movers found.
    trajectory : Trajectory
        The analysed pulses (``s = 0`` where the movers' positions are given).
    range_resolution_m : float
        Slant-range resolution ``c / 2B`` (m).
    wavelength_m : float
        Carrier wavelength ``lambda_o`` (m).
    rate_period_mps : float
        ``lambda_o PRF / 2`` (m/s): range rates are compared modulo it.
    height_m : float
        Height of the stationary targets (m).
    gaussian_range : bool
        The pulse is Gaussian (its compressed envelope), else rect (a sinc).

    Returns
    -------
    (list of StationaryRecord, int)
        The listings kept, in order, and how many were dropped.
    """
    if not targets or not movers:
        return list(targets), 0
    s = trajectory.slow_times_s
    step = max(1, s.size // 64)
    duration = float(s[-1] - s[0])
    rate_cell = wavelength_m / (2.0 * duration)
    mpos = np.array([np.r_[np.asarray(m.position_m, float)[:2], height_m] for m in movers])
    mvel = np.array([np.asarray(m.velocity_mps, float)[:2] for m in movers])
    r_m, d_m = _histories(trajectory, mpos, mvel, step)
    spos = np.array([[*t.position_m, height_m] for t in targets], dtype=float)
    r_s, d_s = _histories(trajectory, spos, np.zeros((len(targets), 2)), step)
    dr = np.abs(r_s[:, None, :] - r_m[None, :, :])
    dd = d_s[:, None, :] - d_m[None, :, :]
    if np.isfinite(rate_period_mps):
        dd -= rate_period_mps * np.floor(dd / rate_period_mps + 0.5)
    on_echo = np.any(
        (dr <= ECHO_CELLS * range_resolution_m) & (np.abs(dd) <= ECHO_CELLS * rate_cell), axis=2
    )
    hit = np.zeros(len(targets), dtype=bool)
    rows, cols = np.nonzero(on_echo)
    if rows.size:
        # the echo's level at each listing on it, bounded over every pulse (module
        # notes): each history on the whole pulse grid once
        ti, t_of = np.unique(rows, return_inverse=True)
        mj, m_of = np.unique(cols, return_inverse=True)
        r_p, _ = _histories(trajectory, spos[ti], np.zeros((ti.size, 2)), 1)
        r_q, _ = _histories(trajectory, mpos[mj], mvel[mj], 1)
        reach = np.mean(envelope((r_p[t_of] - r_q[m_of]) / range_resolution_m, gaussian_range), 1)
        amplitude = np.array([float(m.amplitude) for m in movers])[cols]
        level = np.array([targets[i].level for i in rows])
        with np.errstate(invalid="ignore"):  # an unknown amplitude: the echo explains it
            dropped = ~np.isfinite(amplitude) | (level <= SMEAR_MARGIN * amplitude * reach)
        np.logical_or.at(hit, rows, dropped)
    kept = [t for t, h in zip(targets, hit, strict=True) if not h]
    return kept, int(np.sum(hit))


def coarsen(image: PatchImage, origin_m: tuple[float, float], spacing_m: float) -> PatchImage:
    """``image`` on the mosaic's pixels: the largest of its pixels in each.

    The mosaic's pixel ``(i, j)`` covers ``origin + [j, j + 1) spacing`` in ``x`` and
    ``origin + [i, i + 1) spacing`` in ``y``; the result's coordinates are the centres
    of the mosaic pixels it touches. An image already finer than ``spacing_m`` or
    as fine is reduced by block maxima; otherwise each of its pixels is one mosaic pixel.
    """
    x0, y0 = origin_m
    ix = np.floor((image.x_m - x0) / spacing_m).astype(np.int64)
    iy = np.floor((image.y_m - y0) / spacing_m).astype(np.int64)
    mag = image.magnitude
    if ix.size == 0 or iy.size == 0:
        return image
    ux, sx = np.unique(ix, return_index=True)
    uy, sy = np.unique(iy, return_index=True)
    mag = np.maximum.reduceat(np.maximum.reduceat(mag, sy, axis=0), sx, axis=1)
    return PatchImage(
        x_m=x0 + (ux + 0.5) * spacing_m,
        y_m=y0 + (uy + 0.5) * spacing_m,
        magnitude=mag.astype(np.float32),
    )


def paste(
    out: NDArray[np.float32], image: PatchImage, origin_m: tuple[float, float], spacing_m: float
) -> None:
    """Put ``image`` into the mosaic ``out`` in place: each pixel the largest that falls in it."""
    x0, y0 = origin_m
    ny, nx = out.shape
    ix = np.floor((image.x_m - x0) / spacing_m).astype(int)
    iy = np.floor((image.y_m - y0) / spacing_m).astype(int)
    okx = (ix >= 0) & (ix < nx)
    oky = (iy >= 0) & (iy < ny)
    if not (okx.any() and oky.any()):
        return
    sub = image.magnitude[np.ix_(oky, okx)]
    yy, xx = np.meshgrid(iy[oky], ix[okx], indexing="ij")
    np.maximum.at(out, (yy.ravel(), xx.ravel()), sub.ravel().astype(np.float32))


def mosaic_grid(
    region_m: tuple[float, float, float, float], spacing_m: float
) -> tuple[NDArray[np.float32], tuple[float, float, float, float]]:
    """An empty mosaic over ``region_m`` at ``spacing_m`` and its pixel-edge extent (m)."""
    x0, y0, x1, y1 = region_m
    nx = max(1, int(np.ceil((x1 - x0) / spacing_m)))
    ny = max(1, int(np.ceil((y1 - y0) / spacing_m)))
    return np.zeros((ny, nx), np.float32), (x0, x0 + nx * spacing_m, y0, y0 + ny * spacing_m)


def mosaic(
    images: Sequence[PatchImage], region_m: tuple[float, float, float, float], spacing_m: float
) -> tuple[NDArray[np.float32], tuple[float, float, float, float]]:
    """The patches' core images on one grid of ``spacing_m`` over ``region_m``.

    Each mosaic pixel takes the largest patch pixel that falls in it (:func:`paste`).

    Returns
    -------
    (ny, nx) ndarray, (left, right, bottom, top)
        The mosaic (float32, zero where no patch) and its pixel-edge extent (m).
    """
    out, extent = mosaic_grid(region_m, spacing_m)
    for im in images:
        paste(out, im, (region_m[0], region_m[1]), spacing_m)
    return out, extent
