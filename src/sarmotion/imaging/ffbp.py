"""Fast factorised backprojection (FFBP) of large images, ``backproject(..., method="ffbp")``.

The aperture is split in a binary tree of sub-apertures. Every sub-image is demodulated by
the same reference, the carrier phase seen from the centre ``c`` of the whole aperture,

    J_A(rho) = I_A(rho) exp(-2i pi (2 nu_o / c) (|c - rho| - |c - rho_o|)),

where ``I_A`` is the backprojection sum ``eq:image`` over the pulses of ``A``. Along the
cross-range axis ``v`` (``y`` when the look direction is closer to ``x``, else ``x``) ``J_A``
is then a narrow-band signal: its local spatial frequencies are

    (2 f / c) d|r_j - rho|/dv - (2 nu_o / c) d|c - rho|/dv,   j in A, f in the radar band,

an interval of width ``2 b_A`` around ``f_A`` that grows with the length of ``A`` (the
cross-range bandwidth) plus a floor set by how the look direction turns over the image.
So ``J_A`` is sampled on the image's own columns ``u`` (no interpolation across range, ever)
and on rows ``v`` spaced ``1 / (2 alpha b_A)``: coarse for short sub-apertures. The tree is
evaluated bottom-up:

- leaves: exact backprojection (the float32 tile arithmetic of :mod:`._bp_kernels`) of
  a few to a hundred pulses on their coarse grid, demodulated as each tile is written;
- a parent ``J_P = J_A + J_B`` on a grid twice as fine in ``v``: even rows are the
  children's rows, odd rows the half-sample interpolation of each child by a filter
  (taps by depth, from the error budget below), least-squares optimal over the child's
  band and shifted to its centre ``f_A``
  (no phase correction is needed: all sub-images share the demodulation);
- the root's grid is ``dy / n`` (``n`` the smallest integer that holds its band), but only
  its rows on the image rows are formed (its children's rows added, or interpolated when
  ``n`` is 1), then remodulated pixel by pixel.

A node is split at its pulses' midpoint when both halves' bands fit the children's grid,
else where the two halves' bands are most nearly equal (the floor grows along an aperture
that turns away from ``u``: the half nearer ``u`` then takes more pulses), and is a leaf
where no split fits (the floor dominates) or where two leaves and a merge would cost
more. The rows are cut in strips (1 to 16, the cheapest by a cost model): a narrower
strip sees the look direction turn less, so its floor is lower. The floor also grows with the angle
between the look direction and the ``u`` axis (the range band leaks into ``v``): on the
image's own columns the factorisation pays off within a few degrees of a grid axis (GOTCHA's
first degrees, looking along ``x``).

Oblique looks (the ``"rotated"`` path, chosen when the axis-aligned plan would cost more
than 70 % of exact backprojection): the same factorisation runs on a grid turned to the look
direction (``u`` along it, ``v`` across), over the requested grid's footprint, sampled
at 1.6 times the demodulated image's range band along ``u`` and 2.05 ``alpha`` times its
cross-range band along ``v`` (the root's children then sit at the spacing their band
allows). ``J`` is band-limited there, so every requested pixel is ``J`` interpolated by a
separable least-squares filter (:data:`RESAMPLE_TAPS`, tabulated at 256 fractional
positions), then remodulated. The path runs when a time model (:data:`_TREE_COST`,
:data:`_RESAMPLE_COST`, :data:`_EDGE_COST`, fitted to timings of
``benchmarks/bench_backprojection.py``) predicts at most 80 % of exact; otherwise
``method="ffbp"`` runs exact backprojection.

Ends of the fast-time window. Each pulse's contribution steps to 0 where its fast-time
window ends (:func:`~sarmotion.imaging.exact_sum.fast_time_window`), which no band-limited
interpolation reproduces; the pixels whose interpolation would read such a step are
computed by exact backprojection: on the axis-aligned path, those where some pulse's
window ends within the last interpolation's reach along ``v`` (:func:`_reach_v`); on the
rotated path, also within the resampling's reach along ``u`` (:func:`_window_edge_blocks`).

Evaluation: the nodes of all strips at one depth of the tree are one parallel region
(:mod:`._ffbp_kernels`): leaf tiles and merged rows are tasks of the same loop, which the
threads take one at a time from a shared counter, dearest first (:func:`_task_order`;
numba's ``prange`` would give each thread an equal, contiguous count of iterations
whatever their cost), and the image rows of every strip one last region. Where leaves
lie at several depths (small grids, a floor that stops part of the aperture early) and
every depth's planes fit the scratch together, the leaves of all depths are one region
and each depth's merges one after it (:func:`_schedule`): the deep levels' few leaves
then share the threads with the others instead of running alone. Every region
ends in a barrier, which on a busy machine waits for a descheduled thread, so the number
of regions (about the depth, 7 at 2048 x 2048) is kept to one per level. Everything the
geometry decides (the tree, the kernel calls' arrays and task orders, the filters, the
pixels computed exactly) is planned once per geometry and grid and kept (:class:`PlanCache`):
an image of other data on the same acquisition and grid only runs the kernels.

Error budget. The defaults are chosen so that the image is at least :data:`TARGET_DB`
(55 dB) from the exact sum (:func:`~sarmotion.imaging.exact_sum.exact_sum`, no
interpolation), as a signal-to-error power ratio. The leaves are exact backprojection (some
87 dB from the exact sum, its own budget in :mod:`.backprojection`), so the error is the
interpolations':

- a merge: a child's band of half-width ``b`` cycles per row (its planned band times its
  row spacing, at most ``1 / (2 alpha)``) is interpolated by a ``T``-tap filter whose
  response error ``r(f) = sum_t g[t] exp(2i pi f (t - (T-1)/2)) - 1`` multiplies the
  spectrum, so, for a spectrum spread evenly over the band, an interpolated row carries
  the error power ``e_T(b) = (1/2b) integral_{-b}^{b} |r(f)|^2 df`` (:func:`merge_error`)
  relative to the row's power. Half of a parent's rows are interpolated;
- the ``S`` depths of the tree apply different filters to different sums of pulses:
  their errors are independent and add in power, and the children of one parent,
  incoherent for a distributed scene, add in power too, so the factorisation's error is
  ``E_f = sum_d 1/2 max_{nodes at depth d} e_{T_d}(b)``;
- the rotated path adds the resampling's error on each axis, ``e'_T(b)``, the same
  integral for the fractional filters averaged over the read position
  (:func:`resample_error`), at the bands its grid leaves (``1 / 3.2`` along ``u``,
  ``1 / (4.1 alpha)`` along ``v``).

The allowed error is ``E = 10^(-(TARGET_DB + BUDGET_MARGIN_DB) / 10)``: the factorisation
gets :data:`FACTORISATION_SHARE` of it, an equal share ``2 * 0.8 E / S`` per depth, and each
depth the fewest even taps (4 to the plan's cap, below) that keep all its nodes'
``e_T(b)`` within that share (:func:`_filters`; bands far below ``1 / (2 alpha)`` near
the root take 4 to 8 taps, the leaves' parents 12 to 18); the resampling gets the rest,
with the fewest taps
:data:`RESAMPLE_TAPS` = 10 x 6 that do so at the widest bands. Each depth's sub-images
hold the rows its own filters reach (its margins, :func:`_strip_plans`). The cap is
:func:`default_taps` of ``alpha``: the fewest taps that meet
the factorisation's share when every one of :data:`MAX_STAGES` depths sits at the widest
band ``1 / (2 alpha)`` (:data:`TAPS` = 14 at ``alpha`` = 1.4, 18 at 1.3). The axis-aligned
path plans with each ``alpha`` of :data:`ALPHAS` (1.4 and 1.3) and keeps the cheaper plan
by its cost model: raising ``alpha`` costs every leaf and merge in proportion; lowering it
costs wider margins and longer filters, and pays where a band floor that nearly fills a
sub-image's grid would stop the tree. ``info["budget_db"]`` is the
image's own ``-10 log10 (E_f + e'_u + e'_v)``, ``info["taps"]`` the taps by depth. Real
sub-images do not fill their planned band evenly (it is the union over the sub-aperture's
pulses and the whole region, the band edges reached only at its corners), so images lie
above the budget; ``tests/imaging/test_ffbp_accuracy.py`` holds FFBP to :data:`TARGET_DB` and to
its budget less the margin against the exact sum on simulated points at 0, 30 and 45
degree looks and on GOTCHA, and holds the formulas to the measured error of flat-band
signals. Float32 sums (``~1e-7`` relative) lie far below. Columns whose pixels no pulse's
fast-time window reaches are zero, as in exact backprojection. The figures per geometry
are in ``docs/notes/ffbp.md``.

References: L. M. H. Ulander, H. Hellsten, G. Stenström, "Synthetic-aperture radar
processing using fast factorized back-projection", IEEE Trans. AES 39(3), 2003 (polar
sub-images; here the sub-images share the image columns and a common demodulation).
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

import numba
import numpy as np
from numpy.typing import NDArray

from ..core import C, ProgressCallback
from . import _ffbp_kernels as _kernels
from ._bp_kernels import lane_spans
from ._simd import LANES
from .grid import ImageGrid, outline_columns

__all__ = ["FfbpPulses", "ffbp_values"]

#: Signal-to-error ratio (dB) against the exact sum that the defaults are chosen to meet
#: (module docstring, "Error budget").
TARGET_DB = 55.0
#: Margin (dB) of the budget over :data:`TARGET_DB`: the budget assumes a flat spectrum
#: over each band, real sub-images are not flat.
BUDGET_MARGIN_DB = 3.0
#: Share of the error budget given to the factorisation; the rotated path's resampling
#: has the rest.
FACTORISATION_SHARE = 0.8
#: Interpolation stages of the deepest tree the defaults are chosen for: a 2-pulse leaf
#: under 2^8 = 256-pulse halves is as deep as a few hundred pulses split.
MAX_STAGES = 8
#: Oversampling of every sub-image's band along ``v``.
DEFAULT_ALPHA = 1.4
#: Most taps of the half-sample interpolation filter (even), the margins a plan starts
#: from: the fewest for which a tree of :data:`MAX_STAGES` stages, every one at the widest band
#: ``1 / (2 alpha)`` of :data:`DEFAULT_ALPHA`, stays within its share of the budget
#: (:func:`default_taps`). Each depth of a tree uses, and holds margins for, the fewest
#: taps its own bands need (:func:`_filters`, :func:`_strip_plans`).
TAPS = 14
#: Oversamplings the axis-aligned path plans with when none is given, each with the taps
#: :func:`default_taps` gives it (14 and 18), the cheapest plan by the cost model kept
#: (:func:`_strip_plans`): a band floor that nearly fills a sub-image's grid at
#: :data:`DEFAULT_ALPHA` stops the tree there, and 1.3 lets it split once more (small
#: grids looking a few degrees off ``u``); where it does not, the longer filters (up to
#: 18 taps) and their wider margins make 1.3 the dearer plan.
ALPHAS = (DEFAULT_ALPHA, 1.3)
#: Work (pixel-pulses) under which a parallel region runs on one thread
#: (:func:`_threads_for`): about half a millisecond of one core.
SERIAL_WORK = 2.0**19
#: Merged rows per task of a tree level (:func:`._ffbp_kernels.level`): a few, so that
#: taking a task (one atomic step) costs little beside it, and the rows still spread over
#: the threads.
MERGE_BLOCK = 8
#: Bytes of sub-image planes a thread keeps between calls (:func:`_planes`).
SCRATCH_BYTES = 256 * 2**20
#: Smallest leaf (pulses).
_MIN_LEAF = 2
#: Cost of a merged sample in pixel-pulses (two children, half the rows interpolated).
_MERGE_COST = 4.0

# ===================================================================== error budget
_MERGE_ERRORS: dict[tuple[float, int], float] = {}


def merge_error(band: float, taps: int | None = None) -> float:
    """Mean-square error of the half-sample filter over a flat band, relative to the signal.

    ``(1 / 2b) integral_{-b}^{b} |sum_t g[t] exp(2i pi f (t - (T-1)/2)) - 1|^2 df`` for
    ``g = half_sample_filter(b, T)`` (evaluated on 2001 frequencies): the error power of
    one interpolated row of a sub-image whose spectrum fills ``[-b, b]`` evenly (Parseval:
    the error's spectrum is the filter's response error times the signal's).

    Parameters
    ----------
    band : float
        Half-width ``b`` of the band (cycles per sample, < 1/2).
    taps : int, optional
        Even number of taps; default :data:`TAPS`.

    Returns
    -------
    float
    """
    taps = TAPS if taps is None else int(taps)
    key = (math.ceil(band * 200.0) / 200.0, taps)
    e = _MERGE_ERRORS.get(key)
    if e is None:
        g = half_sample_filter(key[0], taps)
        f = np.linspace(-key[0], key[0], 2001)
        response = np.exp(2j * np.pi * np.outer(f, np.arange(taps) - (taps - 1) / 2.0)) @ g
        e = _MERGE_ERRORS[key] = float(np.mean(np.abs(response - 1.0) ** 2))
    return e


def factorisation_error(stages: int, alpha: float, taps: int | None = None) -> float:
    """Error power of the factorisation relative to the image's, flat bands, widest case.

    ``stages / 2 * merge_error(1 / (2 alpha), taps)``, every depth at the widest band: every
    sub-image is sampled at ``alpha`` times its band, so its band is at most
    ``1 / (2 alpha)`` cycles per sample; at
    each merge half of the parent's rows are interpolated; the errors of the ``stages``
    merges a pixel passes are independent (different filters on different sums of
    pulses) and add in power. Children of one parent are taken as incoherent (a
    distributed scene), so the parent's power is the sum of theirs.

    Parameters
    ----------
    stages : int
        Interpolation stages (tree depth below the root, ``info["levels"] - 1``).
    alpha : float
        Oversampling of the bands, > 1.
    taps : int, optional
        Taps of the half-sample filter; default :data:`TAPS`.

    Returns
    -------
    float
    """
    return 0.5 * stages * merge_error(0.5 / alpha, taps)


def error_allowed() -> float:
    """The error power the budget allows, ``10^(-(TARGET_DB + BUDGET_MARGIN_DB) / 10)``."""
    return 10.0 ** (-(TARGET_DB + BUDGET_MARGIN_DB) / 10.0)


def default_taps(alpha: float = DEFAULT_ALPHA, stages: int = MAX_STAGES) -> int:
    """Fewest even taps with ``factorisation_error <= FACTORISATION_SHARE * error_allowed()``."""
    want = FACTORISATION_SHARE * error_allowed()
    taps = 4
    while factorisation_error(stages, alpha, taps) > want:
        taps += 2
    return taps


def _oversamplings(alpha: float | None) -> list[tuple[float, int]]:
    """``(alpha, taps)`` pairs to plan with: ``alpha``, or each of :data:`ALPHAS`.

    The taps are :func:`default_taps` of each ``alpha``: the fewest that keep the
    factorisation within its share of the budget however deep the tree, so every plan
    meets :data:`TARGET_DB` by the same derivation.
    """
    return [(float(a), default_taps(float(a))) for a in (ALPHAS if alpha is None else (alpha,))]


def budget_db(error_power: float) -> float:
    """Signal-to-error ratio (dB) of a relative error power."""
    return math.inf if error_power <= 0.0 else -10.0 * math.log10(error_power)


# ============================================================================= plan
_FILTERS: dict[tuple[float, int], NDArray[np.float64]] = {}


def half_sample_filter(band: float, taps: int | None = None) -> NDArray[np.float64]:
    """Real filter ``g`` with ``sum_t g[t] exp(2i pi f (t - (T-1)/2)) ~= 1`` for ``|f| <= band``.

    ``T = taps`` taps at offsets ``t - (T - 1)/2``, ``t = 0..T-1``, samples from the output
    point (a half-sample delay); least squares on 101 frequencies of ``[-band, band]``
    (cycles per sample, ``band < 1/2``), rounded up to 1/200 and cached.

    Parameters
    ----------
    band : float
        Half-width of the band (cycles per sample).
    taps : int, optional
        Even number of taps ``T``; default :data:`TAPS`.

    Returns
    -------
    (T,) ndarray
    """
    taps = TAPS if taps is None else int(taps)
    key = (math.ceil(band * 200.0) / 200.0, taps)
    g = _FILTERS.get(key)
    if g is None:
        offsets = np.arange(taps) - (taps - 1) / 2.0
        f = np.linspace(-key[0], key[0], 101)
        a = np.exp(2j * np.pi * np.outer(f, offsets))
        rhs = np.concatenate([np.ones(f.size), np.zeros(f.size)])
        g = np.linalg.lstsq(np.vstack([a.real, a.imag]), rhs, rcond=None)[0]
        _FILTERS[key] = g
    return g


@dataclass(eq=False)
class _Node:
    j0: int
    j1: int
    dv: float = 0.0
    v0: float = 0.0  # first row's v (m)
    nv: int = 0
    k0: int = 0  # offset of the parent's row 0 in this grid (rows)
    ratio: int = 1
    centre: float = 0.0  # band centre (cycles/m)
    half: float = 0.0  # band half-width (cycles/m)
    slot: int = 0  # index in its level's arrays: leaves first, then split nodes
    children: list[_Node] = field(default_factory=list)


def _pulse_bands(pos, f_lo, f_hi, nu_o, centre, probes) -> tuple[NDArray, NDArray]:
    """Per pulse, ``(min, max)`` local ``v`` frequency (cycles/m) over the probes, demodulated.

    The probe points are the corners, edge midpoints and centre of a region; the extremes
    are over both band edges ``f_lo``, ``f_hi``. Returns two ``(n_pulses,)`` arrays.
    """
    pu, pv = probes[:, 0], probes[:, 1]
    dc = np.sqrt((pu - centre[0]) ** 2 + (pv - centre[1]) ** 2 + centre[2] ** 2)
    demod = (2.0 * nu_o / C) * (pv - centre[1]) / dc
    du = pu[None, :] - pos[:, 0:1]
    dv = pv[None, :] - pos[:, 1:2]
    slope = dv / np.sqrt(du * du + dv * dv + pos[:, 2:3] ** 2)  # d|r - rho|/dv
    g_lo = (2.0 / C) * np.minimum(f_lo * slope, f_hi * slope) - demod[None, :]
    g_hi = (2.0 / C) * np.maximum(f_lo * slope, f_hi * slope) - demod[None, :]
    return g_lo.min(axis=1), g_hi.max(axis=1)


def _halves(node: _Node, band, width: float) -> list[_Node] | None:
    """The two children of ``node`` whose bands are each at most ``width`` (cycles/m), or None.

    The pulses are split at their midpoint when both halves' bands fit; otherwise where
    the two bands are most nearly equal (the widest of the two is then the narrowest any
    split gives: the band of ``j0:m`` grows with ``m``, that of ``m:j1`` shrinks), when
    both fit there. A sub-aperture's band is the pulses' spread in look angle plus a
    floor that grows with the angle between the look direction and ``u`` (module
    docstring): where the floor differs along the aperture, the balanced split lets the
    half with the smaller floor take more pulses.
    """
    j0, j1 = node.j0, node.j1

    def extent(a: int, b: int) -> float:
        lo, hi = band(a, b)
        return hi - lo

    mid = (j0 + j1) // 2
    if max(extent(j0, mid), extent(mid, j1)) > width:
        a, b = j0 + _MIN_LEAF, j1 - _MIN_LEAF  # the first m with extent(j0, m) >= extent(m, j1)
        while a < b:
            m = (a + b) // 2
            if extent(j0, m) < extent(m, j1):
                a = m + 1
            else:
                b = m
        mid = min((m for m in (a - 1, a) if j0 + _MIN_LEAF <= m <= j1 - _MIN_LEAF),
                  key=lambda m: max(extent(j0, m), extent(m, j1)))  # fmt: skip
        if max(extent(j0, mid), extent(mid, j1)) > width:
            return None
    kids = [_Node(j0, mid), _Node(mid, j1)]
    for kid in kids:
        lo, hi = band(kid.j0, kid.j1)
        kid.centre, kid.half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    return kids


def _plan(n_pulses, band, dv_top, v0_top, nv_top, alpha, taps=TAPS) -> list[list[_Node]]:
    """Levels of the tree, root first.

    A node splits in two (:func:`_halves`) when both children's bands fit twice its ``v``
    spacing at oversampling ``alpha`` and two leaves plus the merge cost less than the
    node as a leaf (rows times pulses, a merged row :data:`_MERGE_COST` pulses);
    otherwise it is a leaf. The second rule also keeps the tree shallow: every level of
    interpolation adds error (a tree split down to 2-pulse leaves misses the 40 dB
    specification, ``docs/notes/ffbp.md``). Each child at depth ``d`` holds ``T_d / 2``
    rows beyond its parent's on either side, the reach of a ``T_d``-tap filter: ``taps``
    is one ``T`` for every depth or one per depth (depth 1 first; deeper depths take the
    last). Level ``d + 1`` lists the children of the split nodes of level ``d``, in order.
    All nodes of a level share one grid.
    """
    per_depth = (int(taps),) if np.ndim(taps) == 0 else tuple(int(t) for t in taps)
    root = _Node(0, n_pulses, dv=dv_top, v0=v0_top, nv=nv_top)
    levels = [[root]]
    while True:
        level = levels[-1]
        t = per_depth[min(len(levels), len(per_depth)) - 1]  # the children's depth's taps
        k0 = t // 2 - 1  # child rows before the parent's row 0 (the filter's reach)
        dv = 2.0 * level[0].dv
        nv = k0 + (level[0].nv - 2) // 2 + t // 2 + 1
        nxt: list[_Node] = []
        for node in level:
            if node.j1 - node.j0 < 2 * _MIN_LEAF:
                continue
            if (node.j1 - node.j0) * node.nv <= (node.j1 - node.j0) * nv + _MERGE_COST * node.nv:
                continue  # two leaves and a merge would cost more than this leaf
            kids = _halves(node, band, 1.0 / (alpha * dv))
            if kids is None:
                continue  # halving the aperture does not halve the band: a leaf
            for kid in kids:
                kid.ratio = 2
                kid.dv = dv
                kid.k0 = k0
                kid.v0 = level[0].v0 - k0 * dv
                kid.nv = nv
            node.children = kids
            nxt.extend(kids)
        if not nxt:
            return levels
        levels.append(nxt)


# ====================================================================== evaluation
def _depths(plans, bounds, y) -> tuple[list[list[_Node]], list[_Node | None]]:
    """The nodes below the roots, all strips together, by depth (1, 2, ...).

    Slots: in each depth's arrays the leaves come first, then the split nodes. A strip
    whose root does not split gets one leaf on its image rows at depth 1 (read unfiltered).
    Returns the depths and, per strip, that substitute leaf (else ``None``).
    """
    depths: list[list[_Node]] = []
    substitutes: list[_Node | None] = []
    dy = (y[-1] - y[0]) / (y.size - 1)
    for (levels, _), r0, r1 in zip(plans, bounds[:-1], bounds[1:], strict=True):
        root = levels[0][0]
        if root.children:
            below = levels[1:]
            substitutes.append(None)
        else:
            leaf = _Node(root.j0, root.j1, dv=dy, v0=float(y[r0]), nv=int(r1 - r0))
            below = [[leaf]]
            substitutes.append(leaf)
        for d, nodes in enumerate(below):
            if d == len(depths):
                depths.append([])
            depths[d].extend(nodes)
    for nodes in depths:
        order = [n for n in nodes if not n.children] + [n for n in nodes if n.children]
        nodes[:] = order
        for slot, node in enumerate(order):
            node.slot = slot
    return depths, substitutes


def _filters(
    nodes: list[_Node], allowed: float, most: int = TAPS, n_slots: int | None = None
) -> tuple[NDArray[np.float32], float]:
    """Complex half-sample filters of the nodes, by slot, and the depth's merge error.

    The taps are the fewest even number (4 to ``most``, the plan's margins) for which
    every node's :func:`merge_error` over its own band is at most ``allowed``. Returns the
    ``(n_slots, 2, taps)`` filters (default ``n_slots``: ``len(nodes)``) and the largest
    merge error among the nodes.
    """
    bands = [node.half * node.dv for node in nodes if node.ratio == 2]
    taps = _fewest_taps(bands, allowed, most)
    worst = max((merge_error(b, taps) for b in bands), default=0.0)
    offsets = np.arange(taps) - (taps - 1) / 2.0
    g = np.zeros((max(len(nodes) if n_slots is None else n_slots, 1), 2, taps), np.float32)
    for node in nodes:
        if node.ratio == 2:
            gc = half_sample_filter(node.half * node.dv, taps)
            gc = gc * np.exp(-2j * np.pi * node.centre * node.dv * offsets)
            g[node.slot, 0], g[node.slot, 1] = gc.real, gc.imag
    return g, worst


def _fewest_taps(bands, allowed: float, most: int) -> int:
    """Fewest even taps (4 to ``most``) with :func:`merge_error` within ``allowed`` on each band."""
    taps = 4
    while taps < most and any(merge_error(b, taps) > allowed for b in bands):
        taps += 2
    return taps


def _depth_taps(plans, allowed: float, most: int) -> tuple[int, ...]:
    """The taps each depth's filters need (depth 1 first), over every strip's tree.

    The rule of :func:`_schedule`: an equal share ``2 allowed / S`` of the factorisation's
    error per depth (``S`` depths, the deepest strip's), the fewest taps up to ``most``
    (:func:`_fewest_taps`) that keep every node of the depth within it.
    """
    by_depth: list[list[float]] = []
    for levels, _ in plans:
        for d, level in enumerate(levels[1:]):
            if d == len(by_depth):
                by_depth.append([])
            by_depth[d].extend(node.half * node.dv for node in level)
    per_depth = 2.0 * allowed / max(len(by_depth), 1)
    return tuple(_fewest_taps(bands, per_depth, most) for bands in by_depth)


_SCRATCH = threading.local()


@contextmanager
def _threads_for(work: float):
    """Run the parallel region inside on the calling thread alone when ``work`` is small.

    ``work`` in pixel-pulses (a merged sample counted as :data:`_MERGE_COST`). Below
    :data:`SERIAL_WORK` the region's barrier, which on a busy machine waits for a
    descheduled thread, would cost more than the second thread saves. ``numba``'s thread
    count is the calling thread's own, so concurrent calls do not interfere.
    """
    if work >= SERIAL_WORK:
        yield
        return
    n = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(n)


def _planes(slot: int, shape: tuple[int, int, int]) -> tuple[NDArray, NDArray]:
    """Uninitialised float32 planes ``(re, im)`` of ``shape`` for one depth of the tree.

    Views of the calling thread's scratch buffer ``slot`` (depths alternate between 0 and
    1: a depth's planes and its children's are never the same), kept between calls while
    the buffers stay within :data:`SCRATCH_BYTES`: the operating system zeroes fresh memory
    on first touch, which at 2048 x 2048 costs about as much as all the merges. The planes
    are valid until the thread's next FFBP call.
    """
    pool = getattr(_SCRATCH, "pool", None)
    if pool is None:
        pool = _SCRATCH.pool = {}
    n = math.prod(shape)
    buf = pool.get(slot)
    if buf is None or buf.shape[1] < n:
        pool.pop(slot, None)
        buf = np.empty((2, n), np.float32)
        if buf.nbytes + sum(b.nbytes for b in pool.values()) <= SCRATCH_BYTES:
            pool[slot] = buf
    return buf[0, :n].reshape(shape), buf[1, :n].reshape(shape)


def _tasks(pulses, leaf_rows, tiles, merged_rows, n_cols, block):
    """The tasks of one call of :func:`._ffbp_kernels.level`, dearest first, and their cost.

    Leaf ``i`` (``pulses[i]`` pulses on ``leaf_rows[i]`` rows) in tiles of ``tiles[i]``
    (rows, columns): a task ``(i, r0, c0)`` per tile, costing its pulses times its pixels;
    parent ``p`` (``merged_rows[p]`` rows) in blocks of ``block`` rows: ``(-1 - p, m0, 0)``,
    :data:`_MERGE_COST` per sample. Returns the ``(n, 3)`` int64 tasks in the order
    :func:`_task_order` gives, their costs (pixel-pulses) in that order, and the total.
    """
    rows: list[tuple[int, int, int]] = []
    costs: list[float] = []
    for i, (p, nv, (tr, tc)) in enumerate(zip(pulses, leaf_rows, tiles, strict=True)):
        for r0 in range(0, int(nv), int(tr)):
            for c0 in range(0, n_cols, int(tc)):
                rows.append((i, r0, c0))
                costs.append(float(p) * min(tr, nv - r0) * min(tc, n_cols - c0))
    for p, nv in enumerate(merged_rows):
        for m0 in range(0, int(nv), block):
            rows.append((-1 - p, m0, 0))
            costs.append(_MERGE_COST * n_cols * min(block, nv - m0))
    cost = np.array(costs, np.float64)
    order = _task_order(cost)
    tasks = np.array(rows, np.int64).reshape(-1, 3)[order]
    return np.ascontiguousarray(tasks), cost[order], float(cost.sum())


def _task_order(costs: NDArray[np.float64]) -> NDArray[np.int64]:
    """The tasks of cost > 0, dearest first: the order the threads take them in.

    Each thread takes the next task when it is free (:func:`._ffbp_kernels.level`): taken
    dearest first, the threads finish within about the cheapest tasks' cost of each other
    (longest-processing-time-first scheduling), the merged rows filling in at the end.
    """
    idx = np.flatnonzero(costs > 0.0)
    return np.ascontiguousarray(idx[np.argsort(-costs[idx], kind="stable")], np.int64)


def _rows(grid: tuple[float, float, int]) -> NDArray[np.float64]:
    """The rows ``v`` (m) of a sub-image grid ``(v0, dv, nv)``."""
    v0, dv, nv = grid
    return v0 + np.arange(nv) * dv


@dataclass(frozen=True, eq=False)
class _Level:
    """One parallel region of the tree as :func:`._ffbp_kernels.level` reads it.

    The planes: ``shape`` (images, rows, columns), kept in scratch buffer ``slot``; the
    previous region's planes are the children. Leaves (planes ``0 .. L - 1``): pulses
    ``starts:stops``, ``tiles``, ``lanes_v``; parents: planes ``p0 + p`` from children
    ``kids[p]``, with the children's filters ``g`` and rows ``k0`` before their parent's
    row 0 (:class:`_Node`), by child plane; every plane's rows ``v0``, ``dv``, ``nv``;
    ``tasks`` dearest first (:func:`_tasks`), ``work`` their cost in pixel-pulses.
    """

    shape: tuple[int, int, int]
    slot: int
    starts: NDArray[np.int64]
    stops: NDArray[np.int64]
    tiles: NDArray[np.int64]
    lanes_v: NDArray[np.bool_]
    v0: NDArray[np.float64]
    dv: NDArray[np.float64]
    nv: NDArray[np.int64]
    p0: int
    kids: NDArray[np.int64]
    k0: NDArray[np.int64]
    g: NDArray[np.float32]
    tasks: NDArray[np.int64]
    work: float


def _leaf_layout(leaves: list[_Node], frame: dict, tile_for) -> tuple[NDArray, NDArray]:
    """Per leaf, its SIMD lanes' axis and its tile: ``(lanes_v (L,), tiles (L, 2))``.

    The lanes run along ``v`` where, for the leaf's own pulses, along ``u`` they would
    span more than a window of the table and along ``v`` less (:mod:`._simd` reads a
    window without gathers); else along ``u``, where the tile's demodulation vectorises.
    The tile is the exact kernel's for the leaf's grid in that orientation (``tile_for``,
    the mirrored frame's with its axes swapped back), at most the leaf's rows by 64.
    """
    us = frame["us"]
    mirrored = np.ascontiguousarray(frame["pos"][:, [1, 0, 2]])
    lanes_v = np.zeros(len(leaves), np.bool_)
    tiles = np.zeros((len(leaves), 2), np.int64)
    found: dict = {}
    for i, n in enumerate(leaves):
        v = _rows((n.v0, n.dv, n.nv))
        span_u, span_v = lane_spans(frame["pos"][n.j0 : n.j1], us, v, frame["constants"][0])
        lanes_v[i] = along_v = span_u >= LANES and span_v < span_u
        key = (n.v0, n.dv, n.nv, along_v)
        if key not in found:
            if along_v:
                cols, rows = tile_for(mirrored, v, us)
            else:
                rows, cols = tile_for(frame["pos"], us, v)
            found[key] = (min(n.nv, rows), min(64, cols))
        tiles[i] = found[key]
    return lanes_v, tiles


def _schedule(depths, frame: dict, tile_for, info: dict) -> tuple[list[_Level], NDArray]:
    """The tree's parallel regions, in order, and the filters the root reads (depth 1's).

    Two layouts. Where leaves lie at more than one depth and the planes of every depth
    fit :data:`SCRATCH_BYTES` together, all nodes share one set of planes (leaves first):
    one region forms every leaf, then one region per depth merges its parents, deepest
    first (the leaves of all depths share the threads, and the deep levels' few leaves
    do not run alone). Otherwise one region per depth, deepest first, forms its leaves
    and merges its parents from the depth below (two sets of planes, alternating).

    Each depth's filters take the fewest taps that keep its merge error within an equal
    share of ``frame["allowed"]`` (half of the rows interpolated: ``2 allowed / S`` per
    depth, ``S`` depths); ``info["taps"]`` (by depth, 1 first) and
    ``info["factorisation_error"]`` record them, ``info["leaves"]`` and
    ``info["leaf_pixel_pulses"]`` the leaves.
    """
    nu = frame["us"].size
    leaves_at = [[n for n in nodes if not n.children] for nodes in depths]
    split_at = [[n for n in nodes if n.children] for nodes in depths]
    n_all = sum(len(nodes) for nodes in depths)
    rows_all = max(n.nv for nodes in depths for n in nodes)
    fused = (sum(1 for lv in leaves_at if lv) > 1
             and 8 * n_all * rows_all * nu <= SCRATCH_BYTES)  # fmt: skip
    if fused:  # every node its own plane: the leaves, then the parents, deepest first
        order = [n for lv in leaves_at[::-1] for n in lv] + [n for sp in split_at[::-1] for n in sp]
        for slot, node in enumerate(order):
            node.slot = slot
    per_depth = 2.0 * frame["allowed"] / max(len(depths), 1)
    taps: list[int] = []
    error = 0.0
    filters: list[tuple[NDArray, NDArray]] = []  # by depth: (g, k0) by plane
    for nodes in depths:
        n_slots = n_all if fused else len(nodes)
        k0 = np.zeros(n_slots, np.int64)
        for n in nodes:
            k0[n.slot] = n.k0
        # The depth's filters take at most the taps of its narrowest margins, 2 (k0 + 1)
        # (one for every depth of a plan, :func:`_strip_plans`).
        most = 2 * (min((n.k0 for n in nodes if n.ratio == 2), default=1) + 1)
        g, worst = _filters(nodes, per_depth, most, n_slots)
        filters.append((g, k0))
        taps.append(int(g.shape[2]))
        error += 0.5 * worst
        info["leaves"] += sum(1 for n in nodes if not n.children)
        info["leaf_pixel_pulses"] += int(sum((n.j1 - n.j0) * n.nv for n in nodes
                                             if not n.children)) * nu  # fmt: skip
    info.update(taps=taps, factorisation_error=error)
    none = np.zeros(0, np.int64)

    def region(nodes, leaves, split, shape, slot, below) -> _Level:
        lanes_v, tiles = _leaf_layout(leaves, frame, tile_for)
        g, k0 = below if below is not None else (np.zeros((1, 2, 4), np.float32), none)
        starts = np.array([n.j0 for n in leaves], np.int64)
        stops = np.array([n.j1 for n in leaves], np.int64)
        nv = np.zeros(shape[0], np.int64)
        v0 = np.zeros(shape[0])
        dv = np.ones(shape[0])
        for n in nodes:
            nv[n.slot], v0[n.slot], dv[n.slot] = n.nv, n.v0, n.dv
        tasks, _, work = _tasks(stops - starts, [n.nv for n in leaves], tiles,
                                [n.nv for n in split], nu, MERGE_BLOCK)  # fmt: skip
        return _Level(
            shape=shape, slot=slot, starts=starts, stops=stops, tiles=tiles, lanes_v=lanes_v,
            v0=v0, dv=dv, nv=nv, p0=split[0].slot if split else 0,
            kids=np.array([[k.slot for k in n.children] for n in split], np.int64).reshape(-1, 2),
            k0=k0, g=g, tasks=tasks, work=work,
        )  # fmt: skip

    out: list[_Level] = []
    if fused:
        every = [n for nodes in depths for n in nodes]
        shape = (n_all, rows_all, nu)
        leaves = [n for lv in leaves_at[::-1] for n in lv]
        out.append(region(every, leaves, [], shape, 0, None))
        for d in range(len(depths) - 2, -1, -1):
            if split_at[d]:
                out.append(region(every, [], split_at[d], shape, 0, filters[d + 1]))
    else:
        for d in range(len(depths) - 1, -1, -1):
            shape = (len(depths[d]), max(n.nv for n in depths[d]), nu)
            below = filters[d + 1] if d + 1 < len(depths) else None
            out.append(region(depths[d], leaves_at[d], split_at[d], shape, d % 2, below))
    return out, filters[0][0]


def _run_levels(levels: list[_Level], frame: dict, table, report):
    """Run the regions in order; returns the last one's planes (depth 1's)."""
    us = frame["us"]
    du = (us[-1] - us[0]) / (us.size - 1) if us.size > 1 else 1.0
    cre = np.zeros((1, 1, us.size), np.float32)
    cim = cre
    for lv in levels:
        # Every row a parent reads is written (leaf tiles and merged rows below nv).
        re, im = _planes(lv.slot, lv.shape)
        with _threads_for(lv.work):
            _kernels.level(
                re, im, table, lv.starts, lv.stops, *frame["antennas"], float(us[0]), du,
                lv.v0, lv.dv, lv.nv, *frame["constants"][:2], frame["n_up"],
                frame["constants"][2], lv.tiles, *frame["centre"], lv.p0, lv.kids, cre, cim,
                lv.k0, 2, lv.g, lv.lanes_v, lv.tasks, np.zeros(1, np.int64),
                numba.get_num_threads(), MERGE_BLOCK,
            )  # fmt: skip
        cre, cim = re, im
        report()
    return cre, cim


def _root_rows(plans, bounds, substitutes, ny: int) -> tuple[NDArray[np.int64], ...]:
    """The arrays :func:`._ffbp_kernels.root_rows` reads the image rows by.

    Row ``r`` of strip ``s`` is root row ``r n_sub[s]``: the roots' children (slots
    ``kids[s]``, ``k0[s]``, ``ratio[s]``) added, or a strip's substitute leaf read as is.
    Returns ``(row_strip, row_local, kids, n_sub, k0, ratio)``.
    """
    n_strips = len(plans)
    kids = np.full((n_strips, 2), -1, np.int64)
    n_sub = np.ones(n_strips, np.int64)
    k0 = np.zeros(n_strips, np.int64)
    ratio = np.ones(n_strips, np.int64)
    for s, ((levels, ns), leaf) in enumerate(zip(plans, substitutes, strict=True)):
        if leaf is not None:
            kids[s, 0] = leaf.slot
        else:
            root = levels[0][0]
            kids[s] = [k.slot for k in root.children]
            n_sub[s], k0[s], ratio[s] = ns, root.children[0].k0, root.children[0].ratio
    row_strip = np.repeat(np.arange(n_strips), np.diff(bounds)).astype(np.int64)
    row_local = (np.arange(ny) - bounds[row_strip]).astype(np.int64)
    return row_strip, row_local, kids, n_sub, k0, ratio


def _image_rows(out, k_lo, rows, cre, cim, g, frame: dict, remodulate: bool = True) -> None:
    """Write the image rows (:func:`_root_rows`) into ``out``, from column ``k_lo`` on.

    The root rows are the roots' children (planes ``cre``, ``cim`` of depth 1, filters
    ``g``) added, then remodulated (unless ``remodulate`` is false).
    """
    with _threads_for(_MERGE_COST * out.shape[0] * frame["us"].size):
        _kernels.root_rows(
            out, k_lo, *rows, cre, cim, g, frame["us"], frame["y"], *frame["centre"],
            frame["constants"][2], remodulate,
        )  # fmt: skip


class CpuKernels:
    """The compiled CPU kernels that evaluate a plan (:mod:`._ffbp_kernels`): the default.

    A plan (the tree, its filters, the image rows' layout) is the same on every device;
    an object with these three methods evaluates it (the GPU's is
    :class:`sarmotion.imaging.cuda_ffbp.CudaKernels`).
    """

    def run_levels(self, levels: list[_Level], frame: dict, table, report):
        """The tree's regions in order (:func:`_run_levels`); returns depth 1's planes."""
        return _run_levels(levels, frame, table, report)

    def host_image(self, shape: tuple[int, int], covered: bool) -> NDArray[np.complex128]:
        """The complex128 host array :meth:`image_rows` fills; zero unless ``covered``.

        ``covered``: the rows will write every element (then the GPU's may skip zeroing).
        """
        return np.zeros(shape, np.complex128)

    def image_rows(self, out, k_lo, rows, cre, cim, g, frame: dict, remodulate: bool = True):
        """The image rows into the host array ``out`` (:func:`_image_rows`)."""
        _image_rows(out, k_lo, rows, cre, cim, g, frame, remodulate)

    def resample(self, out, j, *args) -> None:
        """The rotated path's resampling into ``out`` (:func:`._ffbp_kernels.resample`)."""
        _kernels.resample(out, j, *args)


#: The kernels :func:`ffbp_values` runs by default.
CPU_KERNELS = CpuKernels()


def _active_columns(pos, ref_ranges, x, y, constants, n_up) -> NDArray[np.intp]:
    """Columns ``x`` that some pulse's fast-time window reaches (1 m margin), ascending."""
    idx_scale, idx_offset, _ = constants
    n_pulses = pos.shape[0]
    d_lo = (1.0 - idx_offset) / idx_scale - 1.0
    d_hi = (n_up - idx_offset) / idx_scale + 1.0
    centre = pos.mean(axis=0)
    v_probe = np.array([y[0], y[-1], min(max(centre[1], y[0]), y[-1])])
    active = np.zeros(x.size, bool)
    for j in sorted({0, n_pulses // 2, n_pulses - 1}):
        r = pos[j]
        d = np.sqrt((x[None, :] - r[0]) ** 2 + (v_probe[:, None] - r[1]) ** 2 + r[2] ** 2)
        d -= ref_ranges[j]
        active |= (d.max(axis=0) >= d_lo) & (d.min(axis=0) <= d_hi)
    return np.flatnonzero(active)


def _reach_v(plans) -> float:
    """How far along ``v`` (m) the last interpolation reads, over all strips.

    An image row is read from the root's children within ``T / 2`` of their spacing
    (``T`` the taps of their margins, ``2 (k0 + 1)``): a
    pulse whose contribution steps to 0 there (an end of its fast-time window) enters the
    row through taps of up to 0.63, so the row is computed exactly (:func:`ffbp_values`).
    Deeper stages are not counted: there a step sits in a sub-image of ``2^-d`` of the
    pulses (depth ``d >= 2``), a fraction of the pixel's power, and its interpolation error
    is left to the budget's margin (``tests/imaging/test_ffbp_accuracy.py`` and
    ``tests/imaging/test_fast_imaging.py`` hold images whose window ends lie inside them to
    :data:`TARGET_DB`); counting every stage's reach would compute several times as many
    pixels exactly.
    """
    return max(((levels[1][0].k0 + 1) * levels[1][0].dv if len(levels) > 1 else 0.0)
               for levels, _ in plans)  # fmt: skip


def _max_v_slope(pos, us, y) -> float:
    """Largest ``|d|r_j - rho| / dv|`` over the pulses and the corners of the grid."""
    corners = np.array([[a, b] for a in (us[0], us[-1]) for b in (y[0], y[-1])])
    du = corners[None, :, 0] - pos[:, 0:1]
    dv = corners[None, :, 1] - pos[:, 1:2]
    return float(np.max(np.abs(dv) / np.sqrt(du * du + dv * dv + pos[:, 2:3] ** 2)))


def _strip_plans(pos, us, y, f_lo, f_hi, nu_o, choices):
    """The cheapest cut of the rows in 1, 2, 4, 8 or 16 strips and oversampling, by the cost model.

    A narrower strip sees the look direction turn less, which lowers the band floor and
    lets the leaves grow; each strip pays its own interpolation margins. ``choices`` lists
    the ``(alpha, taps)`` pairs to plan with (:func:`_oversamplings`): a lower ``alpha``
    lets a sub-aperture whose band floor nearly fills its grid split once more, at the
    price of wider margins (more taps). Each depth's margins are the taps its filters need
    (:func:`_depth_taps`, at most ``taps``): the strips are planned with ``taps`` at every
    depth, then again with the taps that tree's depths need, until every depth's filters
    fit its margins (the margins only grow, so this ends). Returns ``(cost, bounds,
    [(levels, n_sub), ...], (alpha, taps))``; the cost is in pixel-pulses of the leaves
    plus :data:`_MERGE_COST` per merged sample (two children read, half the rows
    interpolated), the root's merge counted on the image rows only; ``None`` when the grid
    has fewer than 16 rows along ``v`` (nothing to factorise).
    """
    n_pulses, nv_ = pos.shape[0], y.size
    centre = pos.mean(axis=0)
    dy = (y[-1] - y[0]) / (nv_ - 1)
    allowed = FACTORISATION_SHARE * error_allowed()

    def strip(r0: int, r1: int):
        """The strip's band of a sub-aperture, ``band(j0, j1) -> (lo, hi)``, and its rows."""
        ys = y[r0:r1]
        probes = np.array(
            [[a, b] for a in (us[0], us.mean(), us[-1]) for b in (ys[0], ys.mean(), ys[-1])]
        )
        lo_j, hi_j = _pulse_bands(pos, f_lo, f_hi, nu_o, centre, probes)
        lo_j, hi_j = lo_j.tolist(), hi_j.tolist()

        def band(j0: int, j1: int) -> tuple[float, float]:
            """First, middle and last pulse of ``j0:j1``: the band's extremes."""
            jm = (j0 + j1 - 1) // 2
            return (min(lo_j[j0], lo_j[jm], lo_j[j1 - 1]),
                    max(hi_j[j0], hi_j[jm], hi_j[j1 - 1]))  # fmt: skip

        return band, ys

    def plan(strips, alpha: float, taps: int) -> list[tuple[list[list[_Node]], int]]:
        """Every strip's tree at ``alpha``, each depth's margins the taps it needs."""

        def trees(margins: tuple[int, ...]) -> list[tuple[list[list[_Node]], int]]:
            out = []
            for band, ys in strips:
                lo, hi = band(0, n_pulses)
                n_sub = max(1, math.ceil(alpha * (hi - lo) * dy))  # root rows per image row
                levels = _plan(n_pulses, band, dy / n_sub, float(ys[0]),
                               (ys.size - 1) * n_sub + 1, alpha, margins + (taps,))  # fmt: skip
                out.append((levels, n_sub))
            return out

        margins = _depth_taps(trees(()), allowed, taps)
        for _ in range(taps):  # each pass grows a depth's margins by 2 taps or ends
            plans = trees(margins)
            need = _depth_taps(plans, allowed, taps)
            used = margins + (taps,) * max(0, len(need) - len(margins))
            if all(n <= m for n, m in zip(need, used, strict=False)):
                return plans
            margins = tuple(max(n, m) for n, m in zip(need, used, strict=False))
        return trees(())  # the margins of ``taps`` taps at every depth hold any filter

    def cost(levels: list[list[_Node]], rows: int) -> float:
        c = 0.0
        for d, level in enumerate(levels):
            for node in level:
                if node.children:
                    c += _MERGE_COST * (rows if d == 0 else node.nv) * us.size
                else:
                    c += (node.j1 - node.j0) * (rows if d == 0 else node.nv) * us.size
        return c

    best = None
    for n_strips in (1, 2, 4, 8, 16):
        if nv_ // n_strips < 16:
            break
        bounds = np.linspace(0, nv_, n_strips + 1).round().astype(int)
        strips = [strip(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
        here = None
        for choice in choices:
            plans = plan(strips, *choice)
            c = sum(cost(levels, b - a) for (levels, _), a, b in
                    zip(plans, bounds[:-1], bounds[1:], strict=True))  # fmt: skip
            if here is None or c < here[0]:
                here = (c, bounds, plans, choice)
        if best is not None and here[0] >= best[0]:
            break  # more strips cost more margins than they save
        best = here
    return best


# ========================================================================= driver
@dataclass(frozen=True, kw_only=True, eq=False)
class FfbpPulses:
    """The pulses as the factorisation reads them: trace table and float64 geometry.

    One frame for all of them: the rotated path turns ``positions`` and
    ``reference_point_m`` with its grid (:meth:`in_frame`); ranges, hence the table, the
    reference ranges and the demodulation, do not change.

    Attributes
    ----------
    table_values : (n_pulses, 8 plane_length(n_up)) ndarray
        Trace table (:attr:`~._bp_table.TraceTable.values`).
    positions : (n_pulses, 3) ndarray
        Effective antenna positions ``r(s_j) - s_j u`` (m), float64.
    ref_ranges : (n_pulses,) ndarray
        ``|r(s_j) - rho_o|`` (m).
    reference_point_m : (3,) ndarray
        ``rho_o`` (m), float64.
    constants : (float, float, float)
        ``(idx_scale, idx_offset, quarter_scale)`` of the table.
    n_up : int
        Upsampled samples per pulse.
    carrier_hz, bandwidth_hz : float
        ``nu_o`` and ``B`` (Hz).
    """

    table_values: NDArray[np.float32]
    positions: NDArray[np.float64]
    ref_ranges: NDArray[np.float64]
    reference_point_m: NDArray[np.float64]
    constants: tuple[float, float, float]
    n_up: int
    carrier_hz: float
    bandwidth_hz: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "positions", np.asarray(self.positions, np.float64))
        object.__setattr__(
            self, "reference_point_m", np.asarray(self.reference_point_m, np.float64)
        )

    @property
    def band_hz(self) -> tuple[float, float]:
        """``(nu_o - B/2, nu_o + B/2)`` (Hz)."""
        return (self.carrier_hz - 0.5 * self.bandwidth_hz,
                self.carrier_hz + 0.5 * self.bandwidth_hz)  # fmt: skip

    def in_frame(self, positions: NDArray, reference_point_m: NDArray) -> FfbpPulses:
        """The same pulses with the antennas and ``rho_o`` given in another frame."""
        return replace(self, positions=positions, reference_point_m=reference_point_m)

    def geometry_key(self) -> tuple:
        """Everything but the table that an axis-aligned plan depends on, as bytes and numbers."""
        return (np.ascontiguousarray(self.positions).tobytes(),
                np.ascontiguousarray(self.ref_ranges, np.float64).tobytes(),
                self.reference_point_m.tobytes(), tuple(float(c) for c in self.constants),
                int(self.n_up), float(self.carrier_hz), float(self.bandwidth_hz),
                self.table_values.shape)  # fmt: skip


@dataclass(eq=False)
class _AlignedPlan:
    """Everything of the axis-aligned path that the geometry decides (:func:`_plan_aligned`).

    ``admitted`` is false when the path would not save work (then only ``info`` is set).
    ``frame`` holds the geometry the kernels read; ``levels`` the tree's kernel calls,
    deepest first; ``g`` the filters of depth 1; ``rows`` the image rows'
    (:func:`_root_rows`); ``k_lo`` the first used column; ``transpose`` whether ``u = y``.
    """

    info: dict
    admitted: bool = False
    transpose: bool = False
    shape: tuple[int, int] = (0, 0)
    k_lo: int = 0
    frame: dict = field(default_factory=dict)
    levels: list[_Level] = field(default_factory=list)
    g: NDArray[np.float32] | None = None
    rows: tuple = ()
    edges: list = field(default_factory=list)


class PlanCache:
    """Axis-aligned plans by geometry (:meth:`FfbpPulses.geometry_key`, grid, options).

    A plan is a pure function of its key: the pulses' positions, reference ranges,
    reference point, table constants and band, the grid's axes, the oversampling asked
    for and whether exact backprojection is at hand for the window ends. Images of other
    data on the same acquisition and grid (the stationary and moving parts of one
    collection, other frames of a track) reuse it. At most :data:`PLAN_CACHE_ENTRIES`
    plans are kept (least recently used dropped first); every access holds one lock, so
    threads may image concurrently (a plan is read, never changed, by its evaluation).
    """

    def __init__(self, entries: int) -> None:
        self._lock = threading.Lock()
        self._entries: OrderedDict[tuple, _AlignedPlan] = OrderedDict()
        self.entries = int(entries)

    def get(self, key: tuple) -> _AlignedPlan | None:
        with self._lock:
            plan = self._entries.get(key)
            if plan is not None:
                self._entries.move_to_end(key)
            return plan

    def put(self, key: tuple, plan: _AlignedPlan) -> None:
        with self._lock:
            self._entries[key] = plan
            self._entries.move_to_end(key)
            while len(self._entries) > self.entries:
                self._entries.popitem(last=False)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()


#: Axis-aligned plans kept by :data:`PLANS`.
PLAN_CACHE_ENTRIES = 8
#: The plan cache of :func:`ffbp_values`.
PLANS = PlanCache(PLAN_CACHE_ENTRIES)


def ffbp_values(
    pulses: FfbpPulses,
    x_m: NDArray[np.float64],
    y_m: NDArray[np.float64],
    *,
    tile_for,
    alpha: float | None = None,
    progress: ProgressCallback | None = None,
    exact_for=None,
    kernels: CpuKernels = CPU_KERNELS,
    outline_m: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.complex128] | None, dict]:
    """FFBP image on the axis-aligned grid ``x_m`` x ``y_m``; returns ``(values, info)``.

    Two paths, the first that saves work (costs at most 70 % of exact backprojection):

    - ``"axis-aligned"``: the factorisation on the grid's own columns (module docstring);
      it pays off when the look direction is within a few degrees of a grid axis;
    - ``"rotated"``: the same factorisation on a grid turned to the look direction, then
      resampled onto the requested pixels (:func:`_rotated_values`), at any look direction.

    ``values`` is ``None`` when neither would save work (small images): the caller runs
    exact backprojection. The axis-aligned path's plan (tree, schedule, filters, the
    pixels computed exactly) is kept in :data:`PLANS` for the next image on the same
    geometry and grid.

    Parameters
    ----------
    pulses : FfbpPulses
        Trace table and geometry of the pulses.
    x_m, y_m : ndarray
        Grid axes (m), uniform.
    tile_for : callable
        ``tile_for(positions, u_m, v_m) -> (rows, cols)``, the tile of the exact kernel
        (the leaves use its float32 arithmetic, so its bounds); a function of its
        arguments and of ``pulses.constants`` alone (plans that used it are reused).
    alpha : float, optional
        Oversampling of each sub-image's band, > 1, with the taps :func:`default_taps`
        gives it. Default: the axis-aligned path plans with each of :data:`ALPHAS` and
        keeps the cheapest plan; the rotated path uses :data:`DEFAULT_ALPHA`.
    progress : callable, optional
        ``progress("backprojection", done, total)`` per tree level (and the resampling).
    exact_for : callable, optional
        ``exact_for(x_m, y_m) -> (len(y_m), len(x_m))`` complex exact backprojection on a
        sub-grid; the rotated path needs it (without it only the axis-aligned path runs).
    kernels : CpuKernels, optional
        What evaluates the plan: the CPU's compiled kernels by default, or an object with
        the same methods for another device (the table in ``pulses`` is the one it reads).
    outline_m : (k, 2) ndarray, optional
        Ground points (m) whose hull holds every pixel the caller needs: the rotated path
        factorises only the part of the grid's footprint within their box in its frame
        (the pixels beyond it are 0). Default: the whole grid.

    Returns
    -------
    values : (ny, nx) complex ndarray or None
    info : dict
        ``path`` (``"axis-aligned"``, ``"rotated"`` or ``"exact"``), ``levels``,
        ``leaves``, ``leaf_pixel_pulses``, ``columns`` used, ``strips``, ``stages``,
        ``alpha`` and ``most_taps`` (the plan's oversampling and margins), ``budget_db``
        (the error budget, module docstring), ``exact_pixels`` (near the ends of the
        fast-time window), ``edge_margin_m``; the rotated path adds
        ``rotation_deg``, ``rotated_grid`` (rows, columns factorised) and
        ``resample_taps``; ``"exact"`` adds ``fallback``.
    """
    x = np.asarray(x_m, np.float64)
    y = np.asarray(y_m, np.float64)
    pos, ref_ranges = pulses.positions, pulses.ref_ranges
    n_pulses = pos.shape[0]
    budget = 0.7 * n_pulses  # pixel-pulses per pixel of exact on the same pixels
    key = (pulses.geometry_key(), x.tobytes(), y.tobytes(), alpha, exact_for is None)
    plan = PLANS.get(key)
    if plan is None:
        edges: list = []

        def admit(cost: float, margin: float, n_used: int) -> bool:
            """The factorisation and the exact pixels near the window ends within the budget."""
            if exact_for is None:
                return cost <= budget * n_used
            edges[:] = _window_edge_blocks(pos, ref_ranges, x, y, pulses.constants, pulses.n_up,
                                           margin, block=EDGE_BLOCK_ROWS)  # fmt: skip
            return cost + _EDGE_COST * n_pulses * _n_pixels(edges) <= budget * n_used

        plan = _plan_aligned(pulses, x, y, tile_for=tile_for, alpha=alpha, budget=budget,
                             admit=admit)  # fmt: skip
        plan.edges = list(edges)
        PLANS.put(key, plan)
    if plan.admitted:
        values, info = _run_aligned(plan, pulses.table_values, progress, kernels=kernels)
        for rows, cols in plan.edges:  # exact where the window's ends make J a step along v
            values[rows, cols] = exact_for(x[cols], y[rows])
        info["exact_pixels"] = _n_pixels(plan.edges)
        return values, info
    if exact_for is not None and x.size > 1 and y.size > 1:
        turned = DEFAULT_ALPHA if alpha is None else alpha
        values, info = _rotated_values(pulses, x, y, alpha=turned, budget=budget,
                                       exact_for=exact_for, tile_for=tile_for,
                                       progress=progress, kernels=kernels,
                                       outline_m=outline_m)  # fmt: skip
        if values is not None:
            return values, info
    return None, {"path": "exact", "fallback": "exact (the factorisation would not save work here)"}


def _plan_aligned(
    pulses: FfbpPulses, x, y, *, tile_for, alpha, budget, demodulated=False, admit=None
) -> _AlignedPlan:
    """The plan of the factorisation on the grid's own columns (the ``"axis-aligned"`` path).

    ``alpha``: the oversampling, or ``None`` for the cheapest of :data:`ALPHAS`
    (:func:`_oversamplings`). Not admitted when it would cost more than ``budget``
    pixel-pulses per pixel of the used columns (or when ``admit(cost, margin_m, n_used)``
    is false, when given: the factorisation's cost, how far in range (m) the last
    interpolation's reach along ``v`` spans, :func:`_reach_v` times the largest
    ``|d|r_j - rho| / dv|``, and the pixels of the used columns). ``demodulated``: the
    plan of ``J`` on the used columns (a frame looking along ``x``).
    """
    pos, ref_ranges = pulses.positions, pulses.ref_ranges
    rho_o, constants, n_up = pulses.reference_point_m, pulses.constants, pulses.n_up
    look = np.array([x.mean(), y.mean()]) - pos.mean(axis=0)[:2]
    transpose = abs(look[1]) > abs(look[0])
    shape = (y.size, x.size)
    if transpose:  # u = y, v = x: swap the coordinates of everything
        if demodulated:
            raise ValueError("a demodulated image is formed in a frame looking along x")
        pos = np.ascontiguousarray(pos[:, [1, 0, 2]])
        rho_o = rho_o[[1, 0, 2]]
        x, y = y, x
    info: dict = {"path": "axis-aligned", "levels": 0, "leaves": 0, "leaf_pixel_pulses": 0,
                  "columns": 0}  # fmt: skip
    plan = _AlignedPlan(info=info, transpose=transpose, shape=shape)
    cols = _active_columns(pos, ref_ranges, x, y, constants, n_up)
    if cols.size == 0:
        plan.admitted = True  # nothing to form: zeros
        plan.k_lo = 0
        return plan
    k_lo, k_hi = int(cols[0]), int(cols[-1]) + 1
    us = np.ascontiguousarray(x[k_lo:k_hi])
    f_lo, f_hi = pulses.band_hz
    found = _strip_plans(pos, us, y, f_lo, f_hi, pulses.carrier_hz, _oversamplings(alpha))
    if found is None:  # too few rows along v to factorise: not admitted
        return plan
    c_best, bounds, plans, (alpha, taps) = found
    margin = _reach_v(plans) * _max_v_slope(pos, us, y)
    info.update(cost_pixel_pulses=float(c_best), edge_margin_m=margin, alpha=alpha,
                most_taps=taps)  # fmt: skip
    n_used = y.size * us.size
    if not (c_best <= budget * n_used if admit is None else admit(c_best, margin, n_used)):
        return plan
    centre = pos.mean(axis=0)
    frame = {
        "antennas": (np.ascontiguousarray(pos[:, 0]), np.ascontiguousarray(pos[:, 1]),
                     np.ascontiguousarray(pos[:, 2] ** 2),
                     np.ascontiguousarray(ref_ranges, dtype=np.float64)),
        "us": us,
        "y": y,
        "constants": tuple(float(c) for c in constants),
        "n_up": int(n_up),
        "pos": pos,
        # c, |c|_z^2, |c - rho_o|: the demodulation (see the module docstring)
        "centre": (float(centre[0]), float(centre[1]), float(centre[2] ** 2),
                   float(np.linalg.norm(centre - rho_o))),
        "allowed": FACTORISATION_SHARE * error_allowed(),
    }  # fmt: skip
    depths, substitutes = _depths(plans, bounds, y)
    info.update(levels=len(depths) + 1, stages=len(depths), columns=int(us.size),
                strips=len(plans))  # fmt: skip
    plan.levels, plan.g = _schedule(depths, frame, tile_for, info)
    info["budget_db"] = budget_db(info["factorisation_error"])
    plan.rows = _root_rows(plans, bounds, substitutes, y.size)
    plan.frame, plan.k_lo, plan.admitted = frame, k_lo, True
    return plan


def _run_aligned(
    plan: _AlignedPlan, table, progress, demodulated: bool = False, kernels=CPU_KERNELS
):
    """Evaluate an admitted plan (:func:`_plan_aligned`); returns ``(values, info)``.

    With ``demodulated``, the values are ``J`` (complex64, not remodulated) on the used
    columns only, ``info["first_column"]`` the first one's index.
    """
    info = dict(plan.info)
    ny, nx = plan.shape
    if not plan.frame:  # no column in the fast-time window
        if demodulated:
            info["first_column"] = 0
            return np.zeros((ny, 0), np.complex64), info
        return np.zeros((ny, nx), np.complex128), info
    n_steps = len(plan.levels) + 1
    done = 0

    def report() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress("backprojection", done, n_steps)

    frame = plan.frame
    cre, cim = kernels.run_levels(plan.levels, frame, table, report)
    if demodulated:
        out = np.zeros((frame["y"].size, frame["us"].size), np.complex64)
        kernels.image_rows(out, 0, plan.rows, cre, cim, plan.g, frame, remodulate=False)
        info["first_column"] = plan.k_lo
        report()
        return out, info
    width = nx if not plan.transpose else ny
    out = kernels.host_image((frame["y"].size, width), plan.k_lo == 0 and frame["us"].size == width)
    kernels.image_rows(out, plan.k_lo, plan.rows, cre, cim, plan.g, frame)
    report()
    return (out.T if plan.transpose else out), info


# ==================================================================== rotated path
#: Taps per axis (``u``, ``v``) of the filter that resamples the rotated image onto the
#: requested pixels (the ``v`` band is oversampled more, see below): the fewest for which
#: :func:`resample_error` at the widest bands :data:`RESAMPLE_OVERSAMPLING` leaves stays
#: within ``1 - FACTORISATION_SHARE`` of the allowed error (module docstring).
RESAMPLE_TAPS = (10, 6)
#: Pulses spread on the aperture that find the edge zone.
N_EDGE_PULSES = 5
#: Rows per exact block of the axis-aligned path's window-end zone: there the zone is a
#: band of columns across the rows, so tall blocks cover it with few extra pixels, and
#: each block is one call (one parallel region) of exact backprojection.
EDGE_BLOCK_ROWS = 128
#: Edge-zone margin, in ``u`` samples (see :func:`_window_edge_blocks`).
EDGE_MARGIN = 2.0
#: Oversampling of the demodulated image's band on the rotated grid along ``u`` (range),
#: and along ``v`` in multiples of ``alpha``: 2.05 alpha makes the root one image row per
#: row (``n`` = 1) with its children at the coarsest spacing their band allows; 1.6 along
#: ``u`` is the least that keeps the 40 dB specification with margin (alternatives in
#: ``docs/notes/ffbp.md``).
RESAMPLE_OVERSAMPLING = (1.6, 2.05)
#: Phases of the tabulated resampling filters (linearly interpolated between).
_RESAMPLE_PHASES = 256
#: Time model of the rotated path, in exact backprojection's pixel-pulses: the time of a
#: pixel-pulse of the factorisation's cost model, of a requested pixel (resampling and
#: edge search) and of an exact pixel-pulse of the edge zone (sub-grids of 32 rows), each
#: over the time of an exact pixel-pulse. Ratios of timings, so independent of the
#: machine's speed to first order; fitted on GOTCHA rotated to 45 degrees
#: (``benchmarks/bench_backprojection.py``, ``docs/notes/ffbp.md``).
#: The resampling's cost scales with its multiply-adds per pixel from the 8 x 6 taps it
#: was fitted with, ``T_u T_v + T_u + T_v``.
_TREE_COST = 1.75
_RESAMPLE_COST = 73.0 * (RESAMPLE_TAPS[0] * RESAMPLE_TAPS[1] + sum(RESAMPLE_TAPS)) / 62.0
_EDGE_COST = 1.7
#: The rotated path runs when its predicted time is at most this fraction of exact.
_ROTATED_BUDGET = 0.8
_FRACTIONAL: dict[tuple[float, int], NDArray[np.float32]] = {}
_RESAMPLE_ERRORS: dict[tuple[float, int], float] = {}


def fractional_filters(band: float, taps: int | None = None) -> NDArray[np.float32]:
    """Real least-squares interpolation filters at ``P + 1`` fractional positions.

    Row ``p`` holds ``g`` with ``sum_t g[t] exp(2i pi f (t - T/2 + 1 - p/P)) ~= 1`` for
    ``|f| <= band``: the value ``p / P`` samples past tap ``T/2 - 1`` of a signal whose
    band is ``[-band, band]`` (cycles per sample, ``< 1/2``); least squares on 101
    frequencies, ``P =`` :data:`_RESAMPLE_PHASES`, ``band`` rounded up to 1/200, cached.

    Parameters
    ----------
    band : float
        Half-width of the band (cycles per sample).
    taps : int, optional
        Even number of taps ``T``; default ``RESAMPLE_TAPS[0]``.

    Returns
    -------
    (P + 1, T) float32 ndarray
    """
    taps = RESAMPLE_TAPS[0] if taps is None else int(taps)
    key = (math.ceil(band * 200.0) / 200.0, taps)
    table = _FRACTIONAL.get(key)
    if table is None:
        f = np.linspace(-key[0], key[0], 101)
        rhs = np.concatenate([np.ones(f.size), np.zeros(f.size)])
        table = np.empty((_RESAMPLE_PHASES + 1, taps), np.float32)
        for p in range(_RESAMPLE_PHASES + 1):
            offsets = np.arange(taps) - (taps // 2 - 1) - p / _RESAMPLE_PHASES
            a = np.exp(2j * np.pi * np.outer(f, offsets))
            table[p] = np.linalg.lstsq(np.vstack([a.real, a.imag]), rhs, rcond=None)[0]
        _FRACTIONAL[key] = table
    return table


def resample_error(band: float, taps: int) -> float:
    """Mean-square error of the fractional filters over a flat band, relative to the signal.

    ``|sum_t g_p[t] exp(2i pi f (t - T/2 + 1 - p/P)) - 1|^2`` averaged over ``|f| <= band``
    (801 frequencies) and over every fourth tabulated phase ``p``
    (:func:`fractional_filters`, whose band is ``band`` rounded up to 1/200, as here):
    the error power of one axis of the resampling at uniformly spread read positions. The
    two axes' errors are independent and add. Cached.

    Parameters
    ----------
    band : float
        Half-width of the band (cycles per sample, < 1/2).
    taps : int
        Even number of taps.

    Returns
    -------
    float
    """
    key = (math.ceil(band * 200.0) / 200.0, int(taps))
    e = _RESAMPLE_ERRORS.get(key)
    if e is None:
        table = fractional_filters(key[0], key[1]).astype(np.float64)
        phases = table.shape[0] - 1
        f = np.linspace(-key[0], key[0], 801)
        errors = []
        for p in range(0, phases, 4):
            offsets = np.arange(key[1]) - (key[1] // 2 - 1) - p / phases
            response = np.exp(2j * np.pi * np.outer(f, offsets)) @ table[p]
            errors.append(np.mean(np.abs(response - 1.0) ** 2))
        e = _RESAMPLE_ERRORS[key] = float(np.mean(errors))
    return e


def _rotated_values(
    pulses: FfbpPulses, x, y, *, tile_for, alpha, budget, progress, exact_for,
    kernels=CPU_KERNELS, outline_m=None,
):  # fmt: skip
    """The ``"rotated"`` path: factorise on a grid turned to the look direction, resample.

    Frame: ``u`` along the look direction from the aperture centre ``c`` to the grid
    centre ``o``, ``v`` across it, origin ``o``; the antennas and ``rho_o`` are turned with
    the grid (ranges, hence the backprojection sum and the demodulation, do not change).
    The demodulated image ``J`` has, over the grid's footprint, a band ``[lo_u, hi_u]`` x
    ``[lo_v, hi_v]`` (:func:`_pulse_bands` on the grid's corners, edge midpoints and
    centre); the rotated grid samples it at :data:`RESAMPLE_OVERSAMPLING` times those
    widths, covers the footprint with the filter's reach, and is factorised along ``v``
    (the axis-aligned path, demodulated, on the columns the fast-time window reaches).
    Every requested pixel is then ``J`` interpolated by a separable least-squares filter of
    :data:`RESAMPLE_TAPS` taps (:func:`fractional_filters`), remodulated, except the
    pixels near an end of the fast-time window (:func:`_window_edge_blocks`), computed by
    ``exact_for``. Error budget: the factorisation's error on the rotated grid plus the
    resampling's (independent, they add in power). Returns ``(None, info)`` when the time
    model (:data:`_TREE_COST`, :data:`_RESAMPLE_COST`, :data:`_EDGE_COST`) predicts more
    than :data:`_ROTATED_BUDGET` of exact backprojection on the requested grid.
    ``outline_m``: the rotated grid covers only the footprint's part within the box of
    these ground points in the frame (plus the filter's reach); pixels beyond it are 0.
    """
    pos, ref_ranges, rho_o = pulses.positions, pulses.ref_ranges, pulses.reference_point_m
    constants, n_up, carrier_hz = pulses.constants, pulses.n_up, pulses.carrier_hz
    n_pulses = pos.shape[0]
    centre = pos.mean(axis=0)
    ox, oy = float(x.mean()), float(y.mean())
    theta = math.atan2(oy - centre[1], ox - centre[0])
    ct, st = math.cos(theta), math.sin(theta)

    def turn(px, py):
        return ct * (px - ox) + st * (py - oy), -st * (px - ox) + ct * (py - oy)

    pos_r = np.column_stack([*turn(pos[:, 0], pos[:, 1]), pos[:, 2]])
    rho_r = np.array([*turn(rho_o[0], rho_o[1]), rho_o[2]])
    px = np.array([x[0], x.mean(), x[-1]])
    py = np.array([y[0], y.mean(), y[-1]])
    pu, pv = turn(*np.meshgrid(px, py))
    probes = np.column_stack([pu.ravel(), pv.ravel()])
    f_lo, f_hi = pulses.band_hz
    c_r = pos_r.mean(axis=0)
    lo_v, hi_v = _pulse_bands(pos_r, f_lo, f_hi, carrier_hz, c_r, probes)
    lo_u, hi_u = _pulse_bands(pos_r[:, [1, 0, 2]], f_lo, f_hi, carrier_hz, c_r[[1, 0, 2]],
                              probes[:, ::-1])  # fmt: skip
    lo_u, hi_u, lo_v, hi_v = lo_u.min(), hi_u.max(), lo_v.min(), hi_v.max()
    du = 1.0 / (RESAMPLE_OVERSAMPLING[0] * (hi_u - lo_u))
    dv = 1.0 / (RESAMPLE_OVERSAMPLING[1] * alpha * (hi_v - lo_v))
    reach = max(RESAMPLE_TAPS) // 2 + 1
    u_lo, u_hi, v_lo, v_hi = pu.min(), pu.max(), pv.min(), pv.max()
    if outline_m is not None:  # only the footprint's part the caller needs
        ou, ov = turn(np.asarray(outline_m)[:, 0], np.asarray(outline_m)[:, 1])
        u_lo, u_hi = max(u_lo, ou.min()), min(u_hi, ou.max())
        v_lo, v_hi = max(v_lo, ov.min()), min(v_hi, ov.max())
        if not (u_lo < u_hi and v_lo < v_hi):
            return None, {"path": "exact", "fallback": "exact (the outline misses the grid)"}
    u0 = u_lo - reach * du
    v0 = v_lo - reach * dv
    us = u0 + du * np.arange(math.ceil((u_hi + reach * du - u0) / du) + 1)
    vs = v0 + dv * np.arange(math.ceil((v_hi + reach * dv - v0) / dv) + 1)
    # Work of the resampling, in pixel-pulses, counted against the factorisation's budget.
    n_pixels = x.size * y.size
    edges: list = []

    def admit(cost: float, margin: float, n_used: int) -> bool:
        """The time model; the edge zone is looked for only if the rest fits."""
        left = (_ROTATED_BUDGET * n_pulses - _RESAMPLE_COST) * n_pixels - _TREE_COST * cost
        if left < 0.0:
            return False
        edges[:] = _window_edge_blocks(pos, ref_ranges, x, y, constants, n_up,
                                       EDGE_MARGIN * du + margin, outline=outline_m)  # fmt: skip
        return _EDGE_COST * n_pulses * _n_pixels(edges) <= left

    total = [1]

    def inner_progress(stage, done, n):
        total[0] = n + 1
        if progress is not None:
            progress(stage, done, n + 1)

    plan = _plan_aligned(
        pulses.in_frame(pos_r, rho_r), us, vs, tile_for=tile_for, alpha=alpha, budget=budget,
        demodulated=True, admit=admit,
    )  # fmt: skip
    if not plan.admitted:
        return None, plan.info
    j, info = _run_aligned(plan, pulses.table_values, inner_progress, demodulated=True,
                           kernels=kernels)  # fmt: skip
    info.update(
        path="rotated", rotation_deg=math.degrees(theta), resample_taps=RESAMPLE_TAPS,
        rotated_grid=(int(vs.size), int(j.shape[1])), spacing_m=(float(du), float(dv)),
    )  # fmt: skip
    k_lo = info.pop("first_column")
    band_u = max(abs(lo_u), abs(hi_u)) * du
    band_v = max(abs(lo_v), abs(hi_v)) * dv
    wu = fractional_filters(band_u, RESAMPLE_TAPS[0])
    wv = fractional_filters(band_v, RESAMPLE_TAPS[1])
    resampling = resample_error(band_u, RESAMPLE_TAPS[0]) + resample_error(band_v, RESAMPLE_TAPS[1])
    info["budget_db"] = budget_db(info["factorisation_error"] + resampling)
    out = np.zeros((y.size, x.size), np.complex128)
    if j.shape[1] >= RESAMPLE_TAPS[0]:
        quarter_scale = float(constants[2])
        kernels.resample(
            out, j, float(us[k_lo]), du, float(vs[0]), dv, x, y, ox, oy, ct, st, wu, wv,
            float(centre[0]), float(centre[1]), float(centre[2] ** 2),
            float(np.linalg.norm(centre - rho_o)), quarter_scale,
        )  # fmt: skip
    for rows, cols in edges:  # exact where the window's ends make J a step along u
        out[rows, cols] = exact_for(x[cols], y[rows])
    if progress is not None:
        progress("backprojection", total[0], total[0])
    info["levels"] += 1
    info["exact_pixels"] = _n_pixels(edges)
    return out, info


def _n_pixels(blocks) -> int:
    """Pixels of the rectangles ``(row slice, column slice)``."""
    return sum((r.stop - r.start) * (c.stop - c.start) for r, c in blocks)


def _window_edge_blocks(pos, ref_ranges, x, y, constants, n_up, margin, block=32, outline=None):
    """Rectangles ``(row slice, column slice)`` covering the pixels near a window end.

    Near an end of the fast-time window each pulse's contribution steps to 0 along the
    range axis: the demodulated image is not band-limited there, and interpolating it
    across the step costs ~1/beta of the step (the image falls to the 40 dB specification
    with these pixels resampled, ``docs/notes/ffbp.md``). A pixel is near an end when, over
    :data:`N_EDGE_PULSES` pulses spread on the aperture, ``[min d_j - margin, max d_j +
    margin]`` holds one (``margin`` the filter's reach). Rows in blocks of ``block``;
    columns in runs, gaps under ``block`` closed. ``outline``: only pixels within that
    ground parallelogram (the others are not wanted).
    """
    idx_scale, idx_offset, _ = constants
    d_lo = (1.0 - idx_offset) / idx_scale
    d_hi = (n_up - idx_offset) / idx_scale
    js = np.unique(np.linspace(0, pos.shape[0] - 1, N_EDGE_PULSES).round().astype(int))
    with _threads_for(float(x.size * y.size)):  # blocks mostly skipped: ~a pixel each
        mask = _kernels.window_edges(
            x, y, np.ascontiguousarray(pos[js, 0]), np.ascontiguousarray(pos[js, 1]),
            np.ascontiguousarray(pos[js, 2] ** 2), np.ascontiguousarray(ref_ranges[js], np.float64),
            float(d_lo), float(d_hi), float(margin),
        )  # fmt: skip
    if outline is not None:
        lo, hi = outline_columns(ImageGrid(x_m=x, y_m=y), outline)
        mask &= (x[None, :] >= lo[:, None]) & (x[None, :] <= hi[:, None])
    out = []
    for r0 in range(0, y.size, block):
        rows = slice(r0, min(r0 + block, y.size))
        cols = np.flatnonzero(mask[rows].any(axis=0))
        if cols.size == 0:
            continue
        cut = np.flatnonzero(np.diff(cols) > block)
        for a, b in zip(np.r_[0, cut + 1], np.r_[cut, cols.size - 1], strict=True):
            out.append((rows, slice(int(cols[a]), int(cols[b]) + 1)))
    return out
