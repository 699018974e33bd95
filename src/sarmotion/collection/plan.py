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
the speed range: every mover whose image lands on a core lies wholly inside at least
one patch. The cores tile the searched ground (below) without overlap.

**Region.** By default the image area the data declare
(:func:`~sarmotion.core.blocks.declared_area`: a CPHD's ``SceneCoordinates/ImageArea``
polygon, or its ``X1Y1``/``X2Y2`` rectangle, on the ground of the scene frame), clipped
to the data's unambiguous scene (:func:`unambiguous_scene`: the fast-time window
``1 / df`` in range and the pulse rate in cross range, mapped to the ground at every
pulse, so that the look's turn over the aperture does not wrap the scene's corners);
the part cut off is stated in m² and as a share of the declared area
(``PatchPlan.outside``) and logged. Where nothing is declared (GOTCHA, native traces),
the whole unambiguous scene. A declared area wholly outside the unambiguous scene, or
not a simple polygon of positive area, is refused. A given region (``region_m``) is a
box along ``x`` and ``y`` (or a ground polygon), or a box along the look's ground range
and cross range (``region_frame="look"``); it must lie in the unambiguous scene.

**Movers' images beyond the region.** A patch holds the echoes whose Doppler its band
passes, so a mover is found in the patch where its Doppler centre places its image:
shifted from its position in cross range by its Doppler centre ``f_o tau_x'(0)`` (the
range rate's, ``2 u_r / lambda``) over the stationary Doppler per metre of cross range at
the aperture centre, about ``R / V`` metres per m/s of range speed. A mover of the region
whose image lands outside it would be in no patch's data. So the patches search the
*searched* ground: the region widened either side in cross range by the largest such
shift over ground speeds ``<= max_speed_mps`` at the region's corners
(``PatchPlan.image_shift_m``), within the unambiguous scene; where the widening passes
either side of the unambiguous scene the shift wraps (by the pulse rate) onto its other
side, so the searched ground is then the scene's whole cross-range extent over the
region's range span. Where the region's patches hold every Doppler of the data (no
slow-time filter: a small scene), a mover imaged within a patch's keep box (its core's
Doppler band plus the movers' margin, :func:`~sarmotion.collection.run.in_band`) is
already estimated whole there: columns of cores are added beyond the region only for
the searched ground those boxes do not reach. Where a filter cuts each patch's band, a
mover imaged beyond a core's edge loses part of its spectrum, so cores cover all the
searched ground (its cross-range extent tiled afresh, the fewest columns of side at most
``P``). The cores outside the region search for movers only (``Patch.movers_only``):
they list no stationary target (the ground there is not the region's) and add nothing to
the mosaic. A pulse rate sized for ``k`` times the region's cross range gives about
``k`` times the region's patches; ``search_beyond=False`` tiles the region alone.

**Tiling.** The cores are rectangles of sides at most ``P`` along the aperture centre's
ground range ``e_r`` and cross range ``e_c`` (``P`` is a cross-range extent of the
migration rule and a range extent of the window), tiling the region's bounding
rectangle in that frame (and the columns beyond it, above); those that hold part of the
searched ground are kept, so the cores cover the region at any look azimuth, each point
of it in one core
(:meth:`Patch.inside`: a point-in-rotated-rectangle test, lower sides included). Each
patch carries its core's true outline; its image is the box along ``x`` and ``y`` that
holds it, the pixels outside the core not its own.

**Halo.** A patch's traces hold more of the ground than its core: in range, every
point whose echo falls in the fast-time window; in cross range, every point whose
Doppler the slow-time band passes, up to the filter's stop band ``(1 + 2 guard)
f_pass`` (every Doppler of the data's pulse rate where there is no filter), within the
unambiguous scene. ``Patch.halo_m`` is the side of the square along ``x`` and ``y``
about the patch's centre that holds that rectangle (the window's and band's half-widths
over the delay's and Doppler's smallest gradients over the pulses). A separation that
models the stationary scene from the preliminary image (``combined``, ``annihilation``)
takes out only the targets that image holds: the patch's image is its halo
(:func:`~sarmotion.collection.run.analyze_patch`), so that a stationary target near the
core, in the window but off the core's box, does not stay in the moving part and lift
the floor of every mover's ``g(u)`` statistic (measured at 1.3-1.5 dB on the look-azimuth
benchmark, ``benchmarks/results/look_azimuth.md``); only the core's targets are listed.
Where a slow-time filter bounds the band, the halo itself is a parallelogram turned to
the look (``Patch.halo_outline_m``, :func:`halo_outline`: its sides the window's ends
and the band's edges, linearised at the centre and widened by the linearisation's
error), a fraction of the square that holds it at an oblique look; the preliminary
image is formed only there (its pixels beyond are 0: the traces hold no echo from
them).

**False-alarm share.** The collection's false-alarm rate ``alpha`` is the probability of
a false mover anywhere in it. Patch ``p``'s ``g(u)`` test finds a null candidate
somewhere in the data it holds (``H_p``, in ground range and cross range: its window in
range; in cross range the halo's band, or the unambiguous scene's whole extent where the
patch keeps every Doppler, the Doppler wrapping at the pulse rate) and reports it only
where its band keeps the fit (:func:`~sarmotion.collection.run.in_band`: the core's
range span and ``ECHO_CELLS`` range cells, Doppler within the pass band; the box
``K_p``). Patches that keep every Doppler with one range window (the cores of one row
of a plan without a slow-time filter) hold the same echoes: the same null candidate,
seen from centres that shift its range speed, is reported by those whose keep holds it,
and merged into one mover. Such a group ``g`` is one test and its keeps count once,
``K_g`` their union; any other patch is a group of its own. With the null candidate as
likely anywhere in ``H_p``, ``alpha_p = alpha min(1, |H_p| / sum_g |K_g|)``
(``Patch.false_alarm_share``, :func:`false_alarm_shares`) bounds the collection's rate
by ``sum_g alpha_g |K_g| / |H_g| <= alpha`` (the union bound over the groups). Patches
holding disjoint data share ``alpha`` about as ``alpha / N``; patches holding the same
data each test near ``alpha``, as one analysis of those data does. Measured on null
scenes (``benchmarks/look_azimuth_null.py``, ``benchmarks/results/look_azimuth.md``).

**Bounds.** A core side below ``MIN_CORE_CELLS`` = 8 resolution cells is refused: the
fast-time guard either side of a core is ``PULSE_GUARD`` = 8 compressed-pulse lengths,
so a narrower core makes each patch more guard than core. A region narrower than that
least core in range or cross range is refused, and so is a plan of more than
``MAX_PATCHES`` patches (refused from the region's area before the cores are cut).

A default region whose extent along the look today's single analysis covers (0.6 of it,
the rule of :func:`~sarmotion.imaging.default_scene_size_m`, within ``P``) is one patch,
provided a declared area lies inside that analysis's image (a square along ``x`` and
``y`` about the reference point).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import ConvexHull

from .._validation import integer, positive
from ..core.acquisition import Acquisition
from ..core.blocks import PulseBlocks, declared_area
from ..core.constants import C
from ..core.geometry import look_geometry, travel_time
from ..core.polygon import clip_convex, inside_convex, polygon_area, polygon_problem
from ..errors import InputError
from ..motion.detector import alias_free_extent_m
from ..pipeline import AnalysisOptions
from .resample import aliased_doppler_hz, design, output_grid, slow_time_ratio

__all__ = [
    "CollectionOptions",
    "Patch",
    "PatchPlan",
    "RegionError",
    "false_alarm_shares",
    "halo_outline",
    "plan_patches",
]

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
#: Least core side, in resolution cells (the larger of ground range and cross range):
#: the fast-time guard either side of a core is ``PULSE_GUARD`` = 8 compressed-pulse
#: lengths, so a core narrower than 8 cells makes each patch's window more guard than
#: core, and its image (the core) holds a target's main lobe and first sidelobes (3 cells)
#: only about its centre.
MIN_CORE_CELLS = 8.0
#: Most patches a plan holds. A patch costs seconds to tens of seconds (its traces
#: extracted, imaged, separated and searched), and a square kilometre at a 2-degree
#: aperture is some 180 cores of 75 m, about 300 with the widening for the movers' images
#: at a pulse rate sized for 1.7 times the scene; more than 1024 is a core far below the
#: side the data need (a typo), or a scene to analyse region by region.
MAX_PATCHES = 1024

log = logging.getLogger(__name__)


class RegionError(InputError):
    """A region or patch size the data cannot serve (outside the extent, below a cell).

    An :class:`~sarmotion.errors.InputError` (and so a ``ValueError``): the command line
    reports it in one line, exit status 2.
    """


@dataclass(frozen=True, kw_only=True)
class CollectionOptions:
    """Choices of the analysis of a whole collection (:func:`~sarmotion.collection.run`).

    Attributes
    ----------
    analysis : AnalysisOptions
        Options of each patch's analysis (:func:`~sarmotion.pipeline.analyze`).
        ``image_size_m`` is set per patch to its halo (module notes; its core's box
        for robust PCA); ``max_stationary`` is per patch.
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
    search_beyond : bool
        Patches beyond the region, out to the cross-range shift of a mover's image at
        ``max_speed_mps``, search for movers only (module notes). Default True; False:
        the cores tile the region alone, and a mover whose image lands outside it is
        not seen.
    """

    analysis: AnalysisOptions = field(default_factory=AnalysisOptions)
    patch_size_m: float | None = None
    max_speed_mps: float = 15.0
    stopband_db: float = 60.0
    block_pulses: int = 256
    search_beyond: bool = True

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
            "search_beyond": bool(self.search_beyond),
        }


@dataclass(frozen=True, kw_only=True)
class Patch:
    """One patch: its core, reference point, and how its traces are cut from the data.

    Attributes
    ----------
    index : int
        Position in the plan.
    core_m : (float, float, float, float)
        The core's bounding box along ``x`` and ``y``, ``(x0, y0, x1, y1)`` (m).
    outline_m : (4, 2) ndarray or None
        The core's corners on the ground (m), counter-clockwise: a rectangle along the
        aperture centre's ground range and cross range, ``o, o + u, o + u + v, o + v``.
        None: the box ``core_m`` itself.
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
    halo_m : float or None
        Side (m) of the square along ``x`` and ``y`` about ``centre_m`` that holds the
        ground whose stationary echoes its traces hold (its *halo*: the fast-time window
        in range, the slow-time band up to the filter's stop band in cross range, within
        the unambiguous scene; module notes). None: the core's box.
    halo_outline_m : (4, 2) ndarray or None
        The halo itself, where a slow-time filter bounds it in cross range: the ground
        parallelogram ``o, o + u, o + u + v, o + v`` (m) whose sides are the window's
        ends (lines of equal delay) and the band's edges (lines of equal Doppler) about
        the centre, at the aperture's centre, widened by their curvature and migration
        over the halo and the aperture and a resolution cell (:func:`halo_outline`).
        The separation's image is formed only there
        (:func:`~sarmotion.collection.run.analyze_patch`). None: no filter (every Doppler
        of the data: the halo is the square ``halo_m``).
    false_alarm_share : float
        Its share of the collection's false-alarm rate, in (0, 1] (module notes).
    alias_free_m : (x, y, extent) or None
        The data's reference point (m) and cross-range extent free of azimuth aliasing
        at the data's pulse rate, ``lambda L / (2 dx)`` (m): where a stationary point may
        explain a candidate of this patch, as in the analysis of the whole data
        (:func:`~sarmotion.collection.run.analyze_patch`; the data's pulse rate wraps
        the Doppler of stationary points beyond the patch's band into it). None: the
        traces' own.
    movers_only : bool
        The core lies outside the region, in its widening for the movers' images
        (module notes): the patch reports the movers whose echoes its band holds, and no
        stationary target or mosaic pixel.
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
    outline_m: NDArray[np.float64] | None = None
    halo_m: float | None = None
    halo_outline_m: NDArray[np.float64] | None = None
    false_alarm_share: float = 1.0
    alias_free_m: tuple[float, float, float] | None = None
    movers_only: bool = False

    @property
    def pulse_positions(self) -> NDArray[np.float64]:
        """Output pulses' positions on the data's pulse axis, ``pulses / p`` (pulses)."""
        return self.pulses / float(self.interpolation)

    @property
    def size_m(self) -> float:
        """Larger side of the core's box along ``x`` and ``y`` (m): an image that holds it."""
        x0, y0, x1, y1 = self.core_m
        return float(max(x1 - x0, y1 - y0))

    @property
    def corners_m(self) -> NDArray[np.float64]:
        """The core's four ground corners ``(4, 2)`` (m), counter-clockwise."""
        if self.outline_m is not None:
            return np.asarray(self.outline_m, dtype=np.float64)
        x0, y0, x1, y1 = self.core_m
        return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)

    def inside(self, points_m: ArrayLike) -> NDArray[np.bool_]:
        """Whether each ground point ``(n, 2)`` lies in the core (its lower sides included).

        Cores sharing sides hold each point once
        (:func:`~sarmotion.core.polygon.inside_convex`).
        """
        pts = np.atleast_2d(np.asarray(points_m, dtype=np.float64))[:, :2]
        return inside_convex(pts, self.corners_m)

    def contains(self, point_m: ArrayLike) -> bool:
        """Whether the ground point ``(x, y)`` lies in the core (lower sides included)."""
        return bool(self.inside(np.asarray(point_m, dtype=float)[:2])[0])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the patch table of ``results.json``)."""
        return {
            "index": self.index,
            "core_m": [float(v) for v in self.core_m],
            "outline_m": self.corners_m.tolist(),
            "centre_m": [float(v) for v in self.centre_m[:2]],
            "n_pulses": int(self.pulses.size),
            "n_samples": int(self.n_samples),
            "decimation": int(self.decimation),
            "interpolation": int(self.interpolation),
            "passband_hz": float(self.passband_hz),
            "n_taps": int(self.taps.size),
            "movers_only": bool(self.movers_only),
        }


@dataclass(frozen=True, kw_only=True)
class PatchPlan:
    """The patches of a region.

    Attributes
    ----------
    patches : tuple of Patch
        The patches, row by row along the look (cross range, then ground range); the
        columns added beyond the region's after them.
    region_m : (float, float, float, float)
        The region's bounding box ``(x0, y0, x1, y1)`` along ``x`` and ``y`` (m).
    patch_size_m : float
        Core side ``P`` used (m).
    unambiguous_m : (4, 2) ndarray
        Corners of the data's unambiguous scene on the ground (m).
    range_margin_m, doppler_margin_hz : float
        A mover's largest range migration (m) and Doppler spread (Hz) in the speed range.
    single : bool
        The region is today's single analysis (no re-referencing needed).
    region_polygon_m : (n, 2) ndarray or None
        The region the cores cover, on the ground (m); None: the box ``region_m``.
    declared_area_m : (k, 2) ndarray or None
        The image area the data declare (m), where the region is it (the default).
    declared_outside_m2 : float
        Area of the declared image area outside the unambiguous scene (m²), not analysed.
    range_direction : (2,) ndarray or None
        Ground range direction ``e_r`` at the aperture centre (the cores' first side).
    region_source : str
        Where the region comes from: ``"declared"`` (the data's image area within the
        unambiguous scene), ``"unambiguous scene"`` (nothing declared) or ``"given"``.
    search_polygon_m : (n, 2) ndarray or None
        The ground the cores cover for the movers (m): the region widened in cross range
        by ``image_shift_m`` within the unambiguous scene; None: the region.
    image_shift_m : float
        Largest cross-range shift of a mover's image from its position (m), at the
        movers' largest ground speed (module notes).
    """

    patches: tuple[Patch, ...]
    region_m: tuple[float, float, float, float]
    patch_size_m: float
    unambiguous_m: NDArray[np.float64]
    range_margin_m: float
    doppler_margin_hz: float
    single: bool
    region_polygon_m: NDArray[np.float64] | None = None
    declared_area_m: NDArray[np.float64] | None = None
    declared_outside_m2: float = 0.0
    range_direction: NDArray[np.float64] | None = None
    region_source: str = "given"
    search_polygon_m: NDArray[np.float64] | None = None
    image_shift_m: float = 0.0

    @property
    def region(self) -> dict[str, Any]:
        """The region as the plan states it (JSON-ready): its source, polygon and frame."""
        return {
            "source": self.region_source,
            "frame": "ground x, y of the scene frame (m)",
            "polygon_m": self.region_polygon.tolist(),
            "declared_m": (
                None if self.declared_area_m is None else np.asarray(self.declared_area_m).tolist()
            ),
        }

    @property
    def unambiguous_scene(self) -> dict[str, Any]:
        """The data's unambiguous scene (JSON-ready): corners, area, the look's range axis."""
        return {
            "corners_m": np.asarray(self.unambiguous_m).tolist(),
            "area_m2": abs(polygon_area(self.unambiguous_m)),
            "range_direction": (
                None if self.range_direction is None else np.asarray(self.range_direction).tolist()
            ),
        }

    @property
    def outside(self) -> dict[str, float] | None:
        """What of the declared image area falls outside the unambiguous scene (m², share).

        None where the region is not a declared area.
        """
        if self.declared_area_m is None:
            return None
        return {"area_m2": float(self.declared_outside_m2), "share": self.declared_outside_share}

    @property
    def region_polygon(self) -> NDArray[np.float64]:
        """The region's polygon on the ground ``(n, 2)`` (m)."""
        if self.region_polygon_m is not None:
            return np.asarray(self.region_polygon_m, dtype=np.float64)
        x0, y0, x1, y1 = self.region_m
        return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)

    @property
    def declared_outside_share(self) -> float:
        """Share of the declared image area outside the unambiguous scene (0 to 1)."""
        if self.declared_area_m is None:
            return 0.0
        whole = abs(polygon_area(self.declared_area_m))
        return float(self.declared_outside_m2 / whole) if whole > 0 else 0.0

    @property
    def search_polygon(self) -> NDArray[np.float64]:
        """The ground searched for movers ``(n, 2)`` (m): the region and its widening."""
        if self.search_polygon_m is not None:
            return np.asarray(self.search_polygon_m, dtype=np.float64)
        return self.region_polygon

    @property
    def extent_m(self) -> tuple[float, float, float, float]:
        """Bounding box ``(x0, y0, x1, y1)`` of the region and its cores (m): the mosaic's.

        The cores searched for movers only (``Patch.movers_only``) are not in it.
        """
        cores = (p.corners_m for p in self.patches if not p.movers_only)
        pts = np.vstack([self.region_polygon, *cores])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary of the plan and its patch table."""
        return {
            "region_m": [float(v) for v in self.region_m],
            "region_polygon_m": self.region_polygon.tolist(),
            "declared_area_m": (
                None if self.declared_area_m is None else np.asarray(self.declared_area_m).tolist()
            ),
            "declared_outside_m2": float(self.declared_outside_m2),
            "declared_outside_share": self.declared_outside_share,
            "search_polygon_m": self.search_polygon.tolist(),
            "image_shift_m": float(self.image_shift_m),
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


def halo_outline(
    positions_m: NDArray,
    slow_times_s: NDArray,
    centre_m: NDArray,
    half_window_s: float,
    edge_hz: float,
    carrier_hz: float,
    cell_m: float,
) -> NDArray[np.float64]:
    """The ground a patch's traces hold, as a parallelogram ``(4, 2)`` (m) about its centre.

    The points ``x`` with ``|tau(s_0, x) - tau(s_0, c)| <= half_window_s`` and
    ``|f(x) - f(c)| <= edge_hz`` (``f = f_o d tau / ds`` at the aperture's centre ``s_0``,
    ``c`` the centre): to first order in ``x - c`` a parallelogram, whose sides are the
    lines of equal delay and of equal Doppler at those bounds. It is widened on every side
    by ``cell_m`` and by the first order's error, the most that the exact delay (at every
    pulse: a point migrates in range over the aperture) and Doppler depart from it at the
    parallelogram's corners and sides' midpoints, expressed in metres along each side's
    normal: so it holds every such point to second order.
    """
    pos = np.asarray(positions_m, dtype=np.float64)
    s = np.asarray(slow_times_s, dtype=np.float64)
    c = np.asarray(centre_m, dtype=np.float64)
    z = float(c[2])
    j0 = int(np.argmin(np.abs(s)))

    def offsets(xy: NDArray) -> tuple[NDArray, NDArray]:
        """Delay offsets at every pulse (n, n_pulses) (s) and Doppler offsets (n,) (Hz)."""
        rel = _delays(pos, _lift(xy, z)) - travel_time(pos, c)[None, :]
        doppler = carrier_hz * np.gradient(rel, s, axis=1)[:, j0]
        return rel, doppler

    step = 1.0  # m: the gradients by differences over a metre (the delay is smooth)
    rel, dop = offsets(c[None, :2] + step * np.array([[1.0, 0.0], [0.0, 1.0]]))
    grad = np.array([rel[:, j0], dop]) / step  # rows: delay (s/m), Doppler (Hz/m)
    inv = np.linalg.inv(grad)
    bounds = np.array([half_window_s, edge_hz])
    signs = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    corners = c[:2] + (signs * bounds) @ inv.T
    probes = np.vstack([corners, 0.5 * (corners + np.roll(corners, -1, axis=0))])
    lin = (probes - c[:2]) @ grad.T  # the first order at the probes
    rel, dop = offsets(probes)
    norm = np.linalg.norm(grad, axis=1)  # (s or Hz) per m along each side's normal
    err_t = np.max(np.abs(rel - lin[:, :1]), axis=1) / norm[0]
    err_f = np.abs(dop - lin[:, 1]) / norm[1]
    widen = cell_m + float(max(err_t.max(), err_f.max()))
    # each bound moved out by ``widen`` metres along its normal
    bounds = bounds + widen * norm
    return c[:2] + (signs * bounds) @ inv.T


def _velocities(speed: float) -> NDArray:
    phi = 2 * np.pi * np.arange(_N_DIRECTIONS) / _N_DIRECTIONS
    return speed * np.stack([np.cos(phi), np.sin(phi)], axis=1)


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
    region_frame: str = "ground",
) -> PatchPlan:
    """Cut a region (default: the data's declared image area) into patches.

    Parameters
    ----------
    source : PulseBlocks
        The data's axes (radar, reference point, trajectory) and, in its metadata, the
        image area it declares (:func:`~sarmotion.core.blocks.declared_area`).
    options : CollectionOptions, optional
        Core side, movers' speed, filter attenuation.
    region_m : array_like, optional
        With ``region_frame="ground"``: ``(x0, y0, x1, y1)`` in scene metres, ``x0 < x1``,
        ``y0 < y1``, or a polygon ``(n, 2)`` of ground ``x, y`` (m). With
        ``region_frame="look"``: ``(a0, b0, a1, b1)``, ``a0 < a1``, ``b0 < b1``, in ground
        range ``a`` (along ``e_r``, towards the antenna) and cross range ``b`` (``e_c``,
        ``e_r`` turned a quarter counter-clockwise) about the reference point at the
        aperture centre (m). It must lie in the data's unambiguous scene. Default: the
        declared image area within the unambiguous scene, or the whole unambiguous scene
        where none is declared (module notes).
    region_frame : {"ground", "look"}
        The frame of ``region_m``.

    Returns
    -------
    PatchPlan

    Raises
    ------
    RegionError
        The region leaves the unambiguous scene, is narrower than a core, or the
        declared image area is degenerate or wholly outside the unambiguous scene; the
        core side is below ``MIN_CORE_CELLS`` resolution cells, or the plan needs more
        than ``MAX_PATCHES`` patches.
    """
    opts = options or CollectionOptions()
    radar = source.radar
    traj = source.trajectory
    pos, s = traj.positions_m, traj.slow_times_s
    e_r, e_c, z = _frame(source)
    amb = unambiguous_scene(source)
    rho = np.asarray(source.reference_point_m[:2], dtype=np.float64)
    to_look = np.stack([e_r, e_c], axis=1)  # ground offset @ to_look: (range, cross)
    # resolution cells: slant range c / 2B on the ground, cross range lambda L / 2a
    geom = look_geometry(traj, source.reference_point_m)
    # the data's alias-free cross-range extent, about the data's reference point
    data = Acquisition(trajectory=traj, radar=radar, reference_point_m=source.reference_point_m)
    alias_free = (float(rho[0]), float(rho[1]), alias_free_extent_m(data))
    cell_r = radar.range_resolution_m / math.cos(geom.elevation_rad)
    cell_c = radar.wavelength_m * geom.range_m / (2.0 * traj.aperture_length_m)
    cell = max(cell_r, cell_c)
    least = MIN_CORE_CELLS * cell

    analysed = _analysed_pulses(source, opts.analysis.sub_aperture_deg)
    if opts.patch_size_m is not None:
        size = float(opts.patch_size_m)
    else:
        m1 = _migration_per_m(source, e_c, z, analysed)
        size = 2.0 * MIGRATION_CELLS * radar.range_resolution_m / max(m1, 1e-12)
    if size < least:
        raise RegionError(
            f"patch size {size:g} m is below {MIN_CORE_CELLS:g} resolution cells "
            f"({least:.3g} m; a resolution cell is {cell:.3g} m)"
        )

    explicit = region_m is not None
    region, declared, outside = _region(source, amb, to_look, region_m, region_frame)
    kind = "given" if explicit else ("declared" if declared is not None else "unambiguous scene")
    what = {"given": "region", "declared": "the declared image area"}.get(kind, f"the {kind}")
    ab = (region - rho) @ to_look
    lo, hi = ab.min(axis=0), ab.max(axis=0)
    extent = hi - lo
    if float(extent.min()) < least * (1.0 - 1e-9):
        raise RegionError(
            f"{what} is {extent[0]:.3g} m x {extent[1]:.3g} m in range and cross range, "
            f"narrower than the least patch core ({MIN_CORE_CELLS:g} resolution cells, "
            f"{least:.3g} m)"
        )
    if declared is not None and outside > 0.0:
        log.info(
            "the declared image area: %.4g m^2 (%.1f %%) outside the data's unambiguous "
            "scene, not analysed",
            outside,
            100.0 * outside / abs(polygon_area(declared)),
        )
    single = (not explicit) and TRUSTED_SHARE * float(extent.max()) <= size
    if single and declared is not None:  # today's analysis images its square: it must hold it
        side = opts.analysis.image_size_m or _single_image_m(source, geom.elevation_rad)
        single = bool(np.all(np.abs(region - rho) <= 0.5 * side * (1.0 + 1e-9)))

    def ground(a: float, b: float) -> NDArray[np.float64]:
        return rho + a * e_r + b * e_c

    # movers' margins, common to all patches (module notes): at the region's rectangle's
    # corners in the look frame; and the largest Doppler centre of a mover there, which
    # shifts its image in cross range
    vel = _velocities(opts.speed_mps)
    f_lo = radar.carrier_hz - 0.5 * radar.bandwidth_hz
    f_hi = radar.carrier_hz + 0.5 * radar.bandwidth_hz
    j0 = int(np.argmin(np.abs(s)))
    margin_t = 0.0
    margin_d = 0.0
    shift_hz = 0.0
    rect = ((lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1]))
    tiled = np.array([ground(a, b) for a, b in rect])
    for x in _lift(tiled, z):
        still = travel_time(pos, x)
        moving = _moving_delays(pos, s, x, vel) - still[None, :]
        margin_t = max(margin_t, float(np.max(np.abs(moving))))
        rate = np.gradient(moving, s, axis=1)
        centre = radar.carrier_hz * rate[:, j0 : j0 + 1]
        spread = np.maximum(np.abs(f_lo * rate - centre), np.abs(f_hi * rate - centre))
        margin_d = max(margin_d, float(np.max(spread)))
        shift_hz = max(shift_hz, float(np.max(np.abs(centre))))

    # the gradients of the delay along e_r and of the Doppler along e_c at the reference
    # point, every pulse: the halo and keep rectangles' sides, and the image shift
    grad = _delays(pos, _lift(np.stack([rho, rho + e_r, rho + e_c]), z))
    delay_per_m = np.abs(grad[1] - grad[0])  # s per m of ground range, (n_pulses,)
    doppler_per_m = np.abs(np.gradient(grad[2] - grad[0], s)) * radar.carrier_hz  # Hz per m
    amb_ab = (amb - rho) @ to_look
    amb_lo, amb_hi = amb_ab.min(axis=0), amb_ab.max(axis=0)

    # the ground searched: the region widened in cross range by the image shift, within
    # the unambiguous scene; a shift past either side of it wraps (by the pulse rate)
    # onto the other, so then the scene's whole cross-range extent
    image_shift = 0.0 if single else shift_hz / max(float(doppler_per_m[j0]), 1e-300)
    if not opts.search_beyond:
        image_shift = 0.0
    search = region
    need_lo, need_hi = float(lo[1]), float(hi[1])
    if image_shift > 0.0:
        reach = image_shift
        if lo[1] - reach < amb_lo[1] or hi[1] + reach > amb_hi[1]:
            reach = float(amb_hi[1] - amb_lo[1])
        widened = np.vstack([region - reach * e_c, region + reach * e_c])
        search = clip_convex(widened[ConvexHull(widened).vertices], amb)
        need_lo = max(float(lo[1]) - reach, float(amb_lo[1]))
        need_hi = min(float(hi[1]) + reach, float(amb_hi[1]))
    widening, lower = "", ""
    if image_shift > 0.0:
        widening = (
            f" (with the {need_hi - need_lo - float(extent[1]):.0f} m it is widened by in "
            "cross range for the movers' images)"
        )
        lower = ", a lower max speed, or no search beyond it"
    if single:
        n_a = n_b = 1
    else:
        n_a = max(1, math.ceil(extent[0] / size - 1e-9))
        n_b = max(1, math.ceil(extent[1] / size - 1e-9))
        least_count = abs(polygon_area(region)) / size**2
        if least_count > MAX_PATCHES:
            raise RegionError(
                f"{what} needs at least {math.ceil(least_count)} patches of patch size "
                f"{size:g} m, more than the {MAX_PATCHES} a plan may hold (a larger patch "
                "size, or a smaller region)"
            )
    a_edges = np.linspace(lo[0], hi[0], n_a + 1)
    b_edges = np.linspace(lo[1], hi[1], n_b + 1)

    def tile(b_cuts: NDArray[np.float64]) -> list[tuple[NDArray[np.float64], bool]]:
        """The cores of the rows ``a_edges`` and columns ``b_cuts`` holding searched ground.

        Each with whether it lies beyond the region (it searches for movers only).
        """
        out = []
        for ib in range(b_cuts.size - 1):
            for ia in range(n_a):
                a0, a1, b0, b1 = a_edges[ia], a_edges[ia + 1], b_cuts[ib], b_cuts[ib + 1]
                outline = np.array([ground(a0, b0), ground(a1, b0), ground(a1, b1), ground(a0, b1)])
                # to the nanometre: a look along x or y leaves no 1e-20 m of rounding in
                # the corners (a core's box is then its core, exactly)
                outline = np.round(outline, 9) + 0.0
                if single:
                    out.append((outline, False))
                    continue
                tiny = 1e-9 * (a1 - a0) * (b1 - b0)
                if not abs(polygon_area(clip_convex(search, outline))) > tiny:
                    continue  # no part of the searched ground in this core
                ours = abs(polygon_area(clip_convex(region, outline))) > tiny
                out.append((outline, not ours))
        return out

    guard_t = PULSE_GUARD / radar.bandwidth_hz
    prf = 1.0 / traj.pulse_interval_s
    dt = radar.sample_interval_s
    dt_window = dt * radar.n_samples / window_transform_length(radar.n_samples)

    from .merge import ECHO_CELLS

    patches: list[Patch] = []
    rects: list[tuple[tuple[NDArray, NDArray], tuple[NDArray, NDArray]]] = []
    # per patch, for the false-alarm shares: the key of the data it holds, and in cross
    # range its keep's centre and half-width (module notes)
    tests: list[tuple[tuple, float, float]] = []

    def bounded(cores: list[tuple[NDArray[np.float64], bool]]) -> list:
        """``cores``, refused before any is built when the plan would pass ``MAX_PATCHES``."""
        if len(patches) + len(cores) > MAX_PATCHES:
            raise RegionError(
                f"{what} needs {len(patches) + len(cores)} patches of patch size {size:g} m"
                f"{widening}, more than the {MAX_PATCHES} a plan may hold (a larger patch "
                f"size, a smaller region{lower})"
            )
        return cores

    def build(outline: NDArray[np.float64], movers_only: bool) -> None:
        """Append the patch of a core and its halo and keep rectangles (look frame)."""
        pts = _outline_points(outline, z)
        centre = pts[4].copy()
        rel = _delays(pos, pts) - travel_time(pos, centre)[None, :]
        half_t = float(np.max(np.abs(rel))) + margin_t + guard_t
        n_samples = _window_samples(half_t, dt_window, radar.n_samples)
        step_t = dt_window if n_samples < radar.n_samples else dt
        rate = np.gradient(rel, s, axis=1)
        core_band = float(max(np.max(np.abs(f_lo * rate)), np.max(np.abs(f_hi * rate))))
        passband = core_band + margin_d
        need = (1.0 + BAND_GUARD) * 2.0 * passband
        up, q = slow_time_ratio(prf, need)
        if (
            up > 1
            and aliased_doppler_hz(pos, s, centre, _lift(tiled, z), vel, (f_lo, f_hi))
            >= prf - passband
        ):
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
        lo_xy, hi_xy = outline.min(axis=0), outline.max(axis=0)
        core_ab = (outline - rho) @ to_look
        mid, half_core = core_ab.mean(axis=0), 0.5 * (core_ab.max(axis=0) - core_ab.min(axis=0))
        # the data the traces hold: the window in range; in cross range the band up to the
        # filter's stop band (every Doppler of the data's pulse rate without a filter)
        edge = prf / 2.0 if taps.size == 1 else min(prf / 2.0, (1.0 + 2.0 * BAND_GUARD) * passband)
        halo_half = np.array(
            [
                0.5 * n_samples * step_t / float(np.min(delay_per_m)),
                edge / float(np.min(doppler_per_m)),
            ]
        )
        # what it reports (run.in_band): the core's range span and ECHO_CELLS range cells,
        # Doppler within the pass band
        keep_half = np.array(
            [
                half_core[0] + ECHO_CELLS * cell_r,
                min(passband, prf / 2.0) / float(np.min(doppler_per_m)),
            ]
        )
        halo = _clip_box(mid - halo_half, mid + halo_half, amb_lo, amb_hi)
        keep = _clip_box(mid - keep_half, mid + keep_half, *halo)
        rects.append((halo, keep))
        whole = taps.size == 1 and q == up == 1
        key = (
            round(float(core_ab[:, 0].min()), 6),
            round(float(core_ab[:, 0].max()), 6),
            n_samples,
        )
        tests.append((key if whole else (len(patches),), float(mid[1]), float(keep_half[1])))
        corners_ab = np.array(
            [[a, b] for a in (halo[0][0], halo[1][0]) for b in (halo[0][1], halo[1][1])]
        )
        offsets = corners_ab @ to_look.T - (centre[:2] - rho)
        halo_side = max(float(hi_xy[0] - lo_xy[0]), float(hi_xy[1] - lo_xy[1]))
        halo_side = max(halo_side, 2.0 * float(np.max(np.abs(offsets))))
        held = None
        if taps.size > 1 and not single:
            held = halo_outline(
                pos, s, centre, 0.5 * n_samples * step_t, edge, radar.carrier_hz, cell_r
            )
        patches.append(
            Patch(
                index=len(patches),
                core_m=(float(lo_xy[0]), float(lo_xy[1]), float(hi_xy[0]), float(hi_xy[1])),
                outline_m=outline,
                centre_m=centre if not single else source.reference_point_m.copy(),
                n_samples=n_samples,
                decimation=q,
                interpolation=up,
                passband_hz=passband,
                taps=taps,
                pulses=pulses,
                halo_m=None if single else halo_side,
                halo_outline_m=held,
                alias_free_m=alias_free,
                movers_only=movers_only,
            )
        )

    for outline, beyond in bounded(tile(b_edges)):
        build(outline, beyond)
    if need_lo < lo[1] or need_hi > hi[1]:
        # the searched ground beyond the region's cores (module notes). Where the region's
        # patches hold every Doppler of the data (no slow-time filter), their keep boxes
        # already reach part of it: columns beyond them for the rest. Else (a filter cuts
        # a spectrum at its band's edge) cores over all of it: the searched extent tiled
        # afresh, the fewest columns of side at most P.
        whole = all(p.taps.size == 1 and p.decimation == p.interpolation == 1 for p in patches)
        if whole:
            reach_lo = min(min(float(k[0][1]) for _, k in rects), float(lo[1]))
            reach_hi = max(max(float(k[1][1]) for _, k in rects), float(hi[1]))
            for far, near, side in ((need_lo, reach_lo, -1.0), (need_hi, reach_hi, 1.0)):
                if abs(far - near) <= 1e-9 * size or (far - near) * side < 0.0:
                    continue
                edge = float(hi[1] if side > 0 else lo[1])
                room = float(amb_hi[1] - hi[1] if side > 0 else lo[1] - amb_lo[1])
                width = min(max(abs(far - near), least), room)
                if width <= 0.0:
                    continue
                n = max(1, math.ceil(width / size - 1e-9))
                cut = np.sort(edge + side * np.linspace(0.0, width, n + 1))
                for outline, _ in bounded(tile(cut)):
                    build(outline, True)
        else:
            patches.clear()
            rects.clear()
            tests.clear()
            n_b = max(1, math.ceil((need_hi - need_lo) / size - 1e-9))
            for outline, beyond in bounded(tile(np.linspace(need_lo, need_hi, n_b + 1))):
                build(outline, beyond)
    if len(patches) > 1:  # each patch's share of the false-alarm rate (module notes)
        shares = false_alarm_shares(rects, tests, float(amb_hi[1] - amb_lo[1]))
        patches = [replace(p, false_alarm_share=a) for p, a in zip(patches, shares, strict=True)]
    box_lo, box_hi = region.min(axis=0), region.max(axis=0)
    return PatchPlan(
        patches=tuple(patches),
        region_m=(float(box_lo[0]), float(box_lo[1]), float(box_hi[0]), float(box_hi[1])),
        region_polygon_m=region,
        declared_area_m=declared,
        declared_outside_m2=float(outside),
        patch_size_m=float(size),
        unambiguous_m=amb,
        range_direction=np.asarray(e_r, dtype=np.float64),
        region_source=kind,
        search_polygon_m=search,
        image_shift_m=float(image_shift),
        range_margin_m=0.5 * C * margin_t,
        doppler_margin_hz=margin_d,
        single=bool(single),
    )


def _clip_box(
    lo: NDArray[np.float64], hi: NDArray[np.float64], lo2: NDArray, hi2: NDArray
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The box ``[lo, hi]`` cut to ``[lo2, hi2]`` (empty sides kept at zero length)."""
    a, b = np.maximum(lo, lo2), np.minimum(hi, hi2)
    return a, np.maximum(a, b)


def _box_area(box: tuple[NDArray[np.float64], NDArray[np.float64]]) -> float:
    return float(np.prod(box[1] - box[0]))


def false_alarm_shares(
    rects: list[tuple[tuple[NDArray, NDArray], tuple[NDArray, NDArray]]],
    tests: list[tuple[tuple, float, float]],
    width_m: float,
) -> list[float]:
    """Each patch's share of the collection's false-alarm rate (module notes).

    Parameters
    ----------
    rects : list of (halo, keep)
        Per patch, its halo and keep boxes ``(lo, hi)`` in ground range and cross range
        about the reference point (m).
    tests : list of (key, centre, half)
        Per patch, the key of the data it holds: patches with one key hold the same
        echoes (every Doppler, one range window; a key of one element is a patch's own),
        and in cross range its keep's centre and half-width (m).
    width_m : float
        The unambiguous scene's cross-range extent (m): what a patch holding every
        Doppler holds, its Doppler wrapping at the pulse rate.

    Returns
    -------
    list of float
        ``min(1, |H_p| / sum_g |K_g|)`` per patch, in (0, 1]: ``H_p`` the ground whose
        echoes it holds, ``K_g`` the ground that the patches of data key ``g`` report.
    """
    groups: dict[tuple, list[int]] = {}
    for i, (key, _, _) in enumerate(tests):
        groups.setdefault(key, []).append(i)
    kept = 0.0
    held = []
    for i, ((halo, keep), (key, _, _)) in enumerate(zip(rects, tests, strict=True)):
        depth = float(halo[1][0] - halo[0][0])
        held.append(depth * width_m if len(key) > 1 else _box_area(halo))
        if len(key) == 1:
            kept += _box_area(keep)
        elif groups[key][0] == i:  # the group's keeps in cross range, on the circle
            arcs = [(tests[j][1], tests[j][2]) for j in groups[key]]
            kept += float(keep[1][0] - keep[0][0]) * _arc_union(arcs, width_m)
    return [min(1.0, h / kept) if kept > 0.0 else 1.0 for h in held]


def _arc_union(arcs: list[tuple[float, float]], period: float) -> float:
    """Length of the union of intervals ``centre +- half`` on a circle of ``period``."""
    cuts = []
    for centre, half in arcs:
        if 2.0 * half >= period:
            return period
        a = (centre - half) % period
        b = a + 2.0 * half
        cuts += [(a, b)] if b <= period else [(a, period), (0.0, b - period)]
    cuts.sort()
    total, end = 0.0, -np.inf
    for a, b in cuts:
        if b > end:
            total += b - max(a, end)
            end = b
    return total


def _single_image_m(source: PulseBlocks, elevation_rad: float) -> float:
    """Side of today's single analysis's image (m): ``default_scene_size_m``'s rule."""
    span = 0.5 * C / source.radar.frequency_step_hz
    return float(min(100.0, TRUSTED_SHARE * span / math.cos(elevation_rad)))


def _region(
    source: PulseBlocks,
    amb: NDArray[np.float64],
    to_look: NDArray[np.float64],
    region_m: ArrayLike | None,
    frame: str,
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, float]:
    """The region's polygon (ground, m), the declared area (or None) and its part outside.

    An explicit region must lie in the unambiguous scene ``amb``; the declared image
    area is clipped to it, the area cut off returned (m²).
    """
    rho = np.asarray(source.reference_point_m[:2], dtype=np.float64)
    if region_m is not None:
        if frame not in ("ground", "look"):
            raise RegionError(f"region frame must be 'ground' or 'look', got {frame!r}")
        poly = _explicit_region(region_m, frame, rho, to_look)
        ab = (poly - rho) @ to_look
        amb_ab = (amb - rho) @ to_look
        lo, hi = amb_ab.min(axis=0), amb_ab.max(axis=0)
        tol = 1e-6
        if np.any(ab < lo - tol) or np.any(ab > hi + tol):
            raise RegionError(
                "region ("
                + ", ".join(f"({x:g}, {y:g})" for x, y in poly)
                + ") m leaves the data's unambiguous scene, a rectangle turned to the look "
                "direction with corners " + ", ".join(f"({a:.1f}, {b:.1f})" for a, b in amb) + " m"
            )
        return poly, None, 0.0
    try:
        area = declared_area(source)
    except (TypeError, ValueError):
        raise RegionError("the declared image area is not a list of (x, y) vertices") from None
    if area is None:
        return amb.copy(), None, 0.0
    problem = polygon_problem(area)
    if problem is not None:
        raise RegionError(f"the declared image area: {problem}")
    whole = abs(polygon_area(area))
    inside = clip_convex(area, amb)
    kept = abs(polygon_area(inside))
    if not kept > 1e-9 * whole:
        raise RegionError(
            "the declared image area ("
            + ", ".join(f"({x:.1f}, {y:.1f})" for x, y in area)
            + ") m lies outside the data's unambiguous scene, a rectangle turned to the "
            "look direction with corners " + ", ".join(f"({a:.1f}, {b:.1f})" for a, b in amb) + " m"
        )
    return inside, area, max(0.0, whole - kept)


def _explicit_region(
    region_m: ArrayLike, frame: str, rho: NDArray[np.float64], to_look: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``region_m`` as a ground polygon (m): a box in its frame, or a ground polygon."""
    try:
        r = np.asarray(region_m, dtype=np.float64)
    except (TypeError, ValueError):
        raise RegionError(f"region must be numbers, got {region_m!r}") from None
    if r.ndim == 2 and frame == "ground":
        problem = polygon_problem(r)
        if problem is not None:
            raise RegionError(f"region: {problem}")
        return r.copy()
    r = r.reshape(-1)
    names = "X0 Y0 X1 Y1" if frame == "ground" else "A0 B0 A1 B1"
    if r.shape != (4,) or not np.all(np.isfinite(r)):
        raise RegionError(f"region must be 4 finite numbers {names} (m), got {region_m}")
    x0, y0, x1, y1 = (float(v) for v in r)
    if not (x1 > x0 and y1 > y0):
        a, b = names.split()[:2]
        raise RegionError(
            f"region must have {a} < {names.split()[2]} and {b} < {names.split()[3]}, "
            f"got {tuple(r)}"
        )
    box = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    if frame == "ground":
        return box
    return rho + box @ to_look.T


def _outline_points(outline: NDArray[np.float64], z: float) -> NDArray:
    """Corners, side midpoints and centre (index 4) of a parallelogram, at height ``z``."""
    o, u, v = outline[0], outline[1] - outline[0], outline[3] - outline[0]
    pts = [o + a * u + b * v for b in (0.0, 0.5, 1.0) for a in (0.0, 0.5, 1.0)]
    return _lift(np.array(pts), z)


def window_transform_length(n_samples: int) -> int:
    """Length of the inverse transform that cuts a patch's fast-time window from the data.

    The data's own length ``n`` may hold a large prime factor (a CPHD's sample count is
    the writer's), which makes its transform several times slower than a length of small
    factors. The data's spectrum, zero-padded about its centre to ``n' =
    next_fast_len(n) >= n``, transforms to the same band-limited traces sampled at
    ``dt n / n'`` (exactly: the same trigonometric polynomial, its samples scaled by
    ``n' / n``). A patch whose window is narrower than the data is cut from those
    samples (:class:`~sarmotion.collection.extract.PatchBuilder`); its radar has the
    span ``n' df`` and its window covers ``n_samples dt n / n'``.
    """
    from scipy.fft import next_fast_len

    return int(next_fast_len(int(n_samples)))


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
