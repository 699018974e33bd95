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

- leaves: exact backprojection (the float32 kernel of :mod:`.backprojection`) of a few
  tens of pulses on their coarse grid, times the demodulation factor;
- a parent ``J_P = J_A + J_B`` on a grid twice as fine in ``v``: even rows are the
  children's rows, odd rows the half-sample interpolation of each child by an 8-tap filter,
  least-squares optimal over the child's band and shifted to its centre ``f_A`` (no phase
  correction is needed: all sub-images share the demodulation);
- the root is sampled at ``dy / n`` (``n`` the smallest integer that holds its band) and
  read on the image rows, then remodulated pixel by pixel.

Leaves stop where halving the aperture no longer halves the band (the floor dominates).
The rows are cut in strips (1 to 16, the cheapest by a cost model): a narrower strip sees
the look direction turn less, so its floor is lower. The floor also grows with the angle
between the look direction and the ``u`` axis (the range band leaks into ``v``): the
factorisation pays off within a few degrees of a grid axis (GOTCHA's first degrees, looking
along ``x``), and ``method="ffbp"`` runs exact backprojection when it would not save work.
The error against exact backprojection comes from the interpolations; measured on
GOTCHA (4 degrees, 0.25 m pixels, default ``alpha = 1.5``): 47 dB at 512 x 512, 45 dB at
2048 x 2048 (spec: >= 40 dB; see ``benchmarks/bench_backprojection.py``). Columns whose
pixels no pulse's fast-time window reaches are zero, as in exact backprojection.

References: L. M. H. Ulander, H. Hellsten, G. Stenström, "Synthetic-aperture radar
processing using fast factorized back-projection", IEEE Trans. AES 39(3), 2003 (polar
sub-images; here the sub-images share the image columns and a common demodulation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np
from numpy.typing import NDArray

from ..core import C, ProgressCallback

__all__ = ["ffbp_values"]

#: Taps of the half-sample interpolation filter (fixed: the merge kernel is unrolled).
TAPS = 8
#: Oversampling of every sub-image's band along ``v``.
DEFAULT_ALPHA = 1.5
#: Smallest leaf (pulses).
_MIN_LEAF = 2

_FASTMATH = {"nnan", "ninf", "nsz", "arcp", "contract", "afn"}
# float64 minimax sine/cosine of pi r / 2 on |r| <= 1/2 (as in .backprojection).
_S0, _S1, _S2, _S3, _S4, _S5 = (
    1.57079632679489, -0.6459640975043288, 0.07969262615641214, -0.0046817525994714984,
    0.00016042930460199835, -3.5564543255214174e-06,
)  # fmt: skip
_C0, _C1, _C2, _C3, _C4, _C5, _C6 = (
    0.9999999999999951, -1.2337005501361604, 0.2536695079002106, -0.02086348074043811,
    0.0009192599906072516, -2.5200275027694737e-05, 4.657112551982875e-07,
)  # fmt: skip


# ============================================================================ kernels
@numba.njit(fastmath=_FASTMATH, parallel=True, cache=True)
def _modulate(re_in, im_in, re_out, im_out, us, vs, cu, cv, cz2, rref, quarter_scale, sign):
    """``out[i, r, k] = in[i, r, k] exp(sign i pi/2 quarter_scale (|c - rho| - rref))``.

    ``rho = (us[k], vs[r], 0)`` in the ``(u, v)`` frame, ``c = (cu, cv, sqrt(cz2))``; the
    phase in quarter cycles is folded exactly before a float64 polynomial sine/cosine.
    """  # pragma: no cover - compiled
    n_img, nv, nu = re_in.shape
    for task in numba.prange(n_img * nv):
        i = task // nv
        r = task % nv
        dv = vs[r] - cv
        c2 = dv * dv + cz2
        for k in range(nu):
            du = us[k] - cu
            t = (math.sqrt(du * du + c2) - rref) * quarter_scale
            kq = np.rint(t)
            x = t - kq
            z = x * x
            s = x * (_S0 + z * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * _S5)))))
            c = _C0 + z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
            q = np.int64(kq)
            swap = (q & 1) != 0
            cs = s if swap else c
            sn = c if swap else s
            cs = -cs if ((q + 1) & 2) != 0 else cs
            sn = -sn if (q & 2) != 0 else sn
            sn = sn * sign
            a = re_in[i, r, k]
            b = im_in[i, r, k]
            re_out[i, r, k] = a * cs - b * sn
            im_out[i, r, k] = a * sn + b * cs


@numba.njit(fastmath=_FASTMATH, inline="always")
def _add_child(pre, pim, m, cre, cim, k0, ratio, g):  # pragma: no cover - compiled
    """Add child row(s) for parent row ``m`` (see :func:`_merge`)."""
    nu = pre.shape[1]
    if ratio == 1 or m % 2 == 0:
        mc = k0 + m if ratio == 1 else k0 + m // 2
        for i in range(nu):
            pre[m, i] += cre[mc, i]
            pim[m, i] += cim[mc, i]
        return
    b = k0 + (m - 1) // 2 - TAPS // 2 + 1
    g0r, g1r, g2r, g3r = g[0, 0], g[0, 1], g[0, 2], g[0, 3]
    g4r, g5r, g6r, g7r = g[0, 4], g[0, 5], g[0, 6], g[0, 7]
    g0i, g1i, g2i, g3i = g[1, 0], g[1, 1], g[1, 2], g[1, 3]
    g4i, g5i, g6i, g7i = g[1, 4], g[1, 5], g[1, 6], g[1, 7]
    for i in range(nu):
        x0r = cre[b, i]
        x0i = cim[b, i]
        x1r = cre[b + 1, i]
        x1i = cim[b + 1, i]
        x2r = cre[b + 2, i]
        x2i = cim[b + 2, i]
        x3r = cre[b + 3, i]
        x3i = cim[b + 3, i]
        x4r = cre[b + 4, i]
        x4i = cim[b + 4, i]
        x5r = cre[b + 5, i]
        x5i = cim[b + 5, i]
        x6r = cre[b + 6, i]
        x6i = cim[b + 6, i]
        x7r = cre[b + 7, i]
        x7i = cim[b + 7, i]
        pre[m, i] += (
            g0r * x0r - g0i * x0i + g1r * x1r - g1i * x1i + g2r * x2r - g2i * x2i
            + g3r * x3r - g3i * x3i + g4r * x4r - g4i * x4i + g5r * x5r - g5i * x5i
            + g6r * x6r - g6i * x6i + g7r * x7r - g7i * x7i
        )  # fmt: skip
        pim[m, i] += (
            g0r * x0i + g0i * x0r + g1r * x1i + g1i * x1r + g2r * x2i + g2i * x2r
            + g3r * x3i + g3i * x3r + g4r * x4i + g4i * x4r + g5r * x5i + g5i * x5r
            + g6r * x6i + g6i * x6r + g7r * x7i + g7i * x7r
        )  # fmt: skip


@numba.njit(fastmath=_FASTMATH, parallel=True, cache=True)
def _merge(pre, pim, cre, cim, k0, ratio, g):
    """Parents ``p`` = children ``2p`` and ``2p + 1`` resampled along ``v``.

    Arrays ``(n, rows v, columns u)``. Child row ``k0 + m / ratio`` sits at parent row
    ``m``. ``ratio == 1``: same spacing, rows added. ``ratio == 2``: even parent rows are
    child rows; odd ones the half-sample interpolation ``sum_t g[c, :, t] x[k0 + (m - 1)/2
    + t - 3]`` with child ``c``'s complex filter ``g[c] = (re[8], im[8])``.
    """  # pragma: no cover - compiled
    n_parents, nvp, _ = pre.shape
    for task in numba.prange(n_parents * nvp):
        p = task // nvp
        m = task % nvp
        for c in (2 * p, 2 * p + 1):
            _add_child(pre[p], pim[p], m, cre[c], cim[c], k0, ratio, g[c])


# ============================================================================= plan
_FILTERS: dict[float, NDArray[np.float64]] = {}


def half_sample_filter(band: float) -> NDArray[np.float64]:
    """Real 8-tap filter ``g`` with ``sum_t g[t] exp(2i pi f (t - 7/2)) ~= 1`` for ``|f| <= band``.

    Taps at offsets ``t - 7/2``, ``t = 0..7``, samples from the output point (a half-sample
    delay); least squares on 101 frequencies of ``[-band, band]`` (cycles per sample,
    ``band < 1/2``), rounded up to 1/200 and cached.

    Parameters
    ----------
    band : float
        Half-width of the band (cycles per sample).

    Returns
    -------
    (8,) ndarray
    """
    key = math.ceil(band * 200.0) / 200.0
    g = _FILTERS.get(key)
    if g is None:
        offsets = np.arange(TAPS) - (TAPS - 1) / 2.0
        f = np.linspace(-key, key, 101)
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
    children: list[_Node] = field(default_factory=list)


def _band(pos, j0, j1, f_lo, f_hi, nu_o, centre, probes) -> tuple[float, float]:
    """``(min, max)`` local ``v`` frequency (cycles/m) of pulses ``j0:j1``, demodulated.

    Over the probe points (corners, edge midpoints, centre of the region), the first,
    middle and last pulse and the two band edges.
    """
    pu, pv = probes[:, 0], probes[:, 1]
    dc = np.sqrt((pu - centre[0]) ** 2 + (pv - centre[1]) ** 2 + centre[2] ** 2)
    demod = (2.0 * nu_o / C) * (pv - centre[1]) / dc
    r = pos[[j0, (j0 + j1 - 1) // 2, j1 - 1]]
    du = pu[None, :] - r[:, 0:1]
    dv = pv[None, :] - r[:, 1:2]
    slope = dv / np.sqrt(du * du + dv * dv + r[:, 2:3] ** 2)  # d|r - rho|/dv
    g_lo = (2.0 / C) * np.minimum(f_lo * slope, f_hi * slope) - demod[None, :]
    g_hi = (2.0 / C) * np.maximum(f_lo * slope, f_hi * slope) - demod[None, :]
    return float(g_lo.min()), float(g_hi.max())


def _plan(n_pulses, band, dv_top, v0_top, nv_top, alpha) -> list[list[_Node]]:
    """Levels of the tree, root first.

    A node splits in two when both halves' bands fit twice its ``v`` spacing; otherwise it
    is a leaf. Level ``d + 1`` lists the children of the split nodes of level ``d``, in
    order, so node ``i`` of a level's split nodes has children ``2i`` and ``2i + 1``. All
    nodes of a level share one grid.
    """
    root = _Node(0, n_pulses, dv=dv_top, v0=v0_top, nv=nv_top)
    levels = [[root]]
    margin = TAPS // 2 + 1
    while True:
        level = levels[-1]
        dv = 2.0 * level[0].dv
        nxt: list[_Node] = []
        for node in level:
            if node.j1 - node.j0 < 2 * _MIN_LEAF:
                continue
            mid = (node.j0 + node.j1) // 2
            kids = [_Node(node.j0, mid), _Node(mid, node.j1)]
            for kid in kids:
                lo, hi = band(kid.j0, kid.j1)
                kid.centre, kid.half = 0.5 * (lo + hi), 0.5 * (hi - lo)
            if any(dv * 2.0 * alpha * kid.half > 1.0 for kid in kids):
                continue  # halving the aperture does not halve the band: a leaf
            for kid in kids:
                kid.ratio = 2
                kid.dv = dv
                kid.k0 = margin
                kid.v0 = level[0].v0 - margin * dv
                kid.nv = (level[0].nv + 1) // 2 + 2 * margin + 1
            node.children = kids
            nxt.extend(kids)
        if not nxt:
            return levels
        levels.append(nxt)


# ========================================================================= driver
def ffbp_values(
    table_values: NDArray[np.uint64],
    positions: NDArray[np.float64],
    ref_ranges: NDArray[np.float64],
    reference_point_m: NDArray[np.float64],
    x_m: NDArray[np.float64],
    y_m: NDArray[np.float64],
    *,
    constants: tuple[float, float, float],
    n_up: int,
    carrier_hz: float,
    bandwidth_hz: float,
    tile_for,
    backproject_f32,
    alpha: float = DEFAULT_ALPHA,
    progress: ProgressCallback | None = None,
) -> tuple[NDArray[np.complex128] | None, dict]:
    """FFBP image on the axis-aligned grid ``x_m`` x ``y_m``; returns ``(values, info)``.

    ``values`` is ``None`` when the factorisation would cost more than 70 % of exact
    backprojection on the same columns: when the look direction is far (more than ~10
    degrees) from both grid axes, the range band leaks into the cross-range axis and the
    leaves must be nearly as long as the aperture.

    Parameters
    ----------
    table_values : (n_pulses, n_up + 2) ndarray
        Trace table of :mod:`.backprojection` (uint64 view of complex64).
    positions : (n_pulses, 3) ndarray
        Effective antenna positions ``r(s_j) - s_j u`` (m).
    ref_ranges : (n_pulses,) ndarray
        ``|r(s_j) - rho_o|`` (m).
    reference_point_m : (3,) ndarray
        ``rho_o`` (m).
    x_m, y_m : ndarray
        Grid axes (m), uniform.
    constants : (float, float, float)
        ``(idx_scale, idx_offset, quarter_scale)`` of the table.
    n_up : int
        Upsampled samples per pulse.
    carrier_hz, bandwidth_hz : float
        ``nu_o`` and ``B`` (Hz).
    tile_for : callable
        ``tile_for(positions, u_m, v_m) -> (rows, cols) | None``, the tile of the exact kernel.
    backproject_f32 : callable
        The exact float32 kernel driver of :mod:`.backprojection`.
    alpha : float
        Oversampling of each sub-image's band, > 1.
    progress : callable, optional
        ``progress("backprojection", done, total)`` per tree level.

    Returns
    -------
    values : (ny, nx) complex ndarray or None
    info : dict
        ``levels``, ``leaves``, ``leaf_pixel_pulses``, ``columns`` used, ``strips``.
    """
    x = np.asarray(x_m, np.float64)
    y = np.asarray(y_m, np.float64)
    pos = np.asarray(positions, np.float64)
    look = np.array([x.mean(), y.mean()]) - pos.mean(axis=0)[:2]
    transpose = abs(look[1]) > abs(look[0])
    if transpose:  # u = y, v = x: swap the coordinates of everything
        pos = pos[:, [1, 0, 2]]
        rho_o = np.asarray(reference_point_m, np.float64)[[1, 0, 2]]
        x, y = y, x
    else:
        rho_o = np.asarray(reference_point_m, np.float64)
    nu_, nv_ = x.size, y.size  # image columns (u) and rows (v)
    out = np.zeros((nv_, nu_), np.complex128)
    idx_scale, idx_offset, quarter_scale = constants
    centre = pos.mean(axis=0)
    n_pulses = pos.shape[0]
    # Columns that some pulse's fast-time window reaches (1 m margin).
    d_lo = (1.0 - idx_offset) / idx_scale - 1.0
    d_hi = (n_up - idx_offset) / idx_scale + 1.0
    v_probe = np.array([y[0], y[-1], min(max(centre[1], y[0]), y[-1])])
    active = np.zeros(nu_, bool)
    for j in sorted({0, n_pulses // 2, n_pulses - 1}):
        r = pos[j]
        d = np.sqrt((x[None, :] - r[0]) ** 2 + (v_probe[:, None] - r[1]) ** 2 + r[2] ** 2)
        d -= ref_ranges[j]
        active |= (d.max(axis=0) >= d_lo) & (d.min(axis=0) <= d_hi)
    info: dict = {"levels": 0, "leaves": 0, "leaf_pixel_pulses": 0, "columns": 0}
    cols = np.flatnonzero(active)
    if cols.size == 0:
        return (out.T if transpose else out), info
    k_lo, k_hi = int(cols[0]), int(cols[-1]) + 1
    us = np.ascontiguousarray(x[k_lo:k_hi])
    dy = (y[-1] - y[0]) / (nv_ - 1)
    f_lo = carrier_hz - 0.5 * bandwidth_hz
    f_hi = carrier_hz + 0.5 * bandwidth_hz

    def plan(r0: int, r1: int) -> tuple[list[list[_Node]], int]:
        ys = y[r0:r1]
        probes = np.array(
            [[a, b] for a in (us[0], us.mean(), us[-1]) for b in (ys[0], ys.mean(), ys[-1])]
        )
        cache: dict[tuple[int, int], tuple[float, float]] = {}

        def band(j0: int, j1: int) -> tuple[float, float]:
            if (j0, j1) not in cache:
                cache[(j0, j1)] = _band(pos, j0, j1, f_lo, f_hi, carrier_hz, centre, probes)
            return cache[(j0, j1)]

        lo, hi = band(0, n_pulses)
        n_sub = max(1, math.ceil(alpha * (hi - lo) * dy))  # root rows per image row
        levels = _plan(n_pulses, band, dy / n_sub, float(ys[0]), (ys.size - 1) * n_sub + 1, alpha)
        return levels, n_sub

    def cost(levels: list[list[_Node]]) -> float:
        """Relative cost: pixel-pulses of the leaves plus ~2 per merged sample (measured)."""
        c = 0.0
        for level in levels:
            for node in level:
                if node.children:
                    c += 2.0 * 2.0 * node.nv * us.size
                else:
                    c += (node.j1 - node.j0) * node.nv * us.size
        return c

    # Strips of rows: a narrower strip sees the look direction turn less, which lowers the
    # band floor and lets the leaves grow; each strip pays its own interpolation margins.
    best = None
    for n_strips in (1, 2, 4, 8, 16):
        if nv_ // n_strips < 16:
            break
        bounds = np.linspace(0, nv_, n_strips + 1).round().astype(int)
        plans = [plan(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
        c = sum(cost(levels) for levels, _ in plans)
        if best is not None and c >= best[0]:
            break  # more strips cost more margins than they save
        best = (c, bounds, plans)
    c_best, bounds, plans = best
    if c_best > 0.7 * n_pulses * nv_ * us.size:
        return None, {"fallback": "exact (the factorisation would not save work here)"}
    rref = float(np.linalg.norm(centre - rho_o))
    cz2 = float(centre[2] ** 2)
    info.update(levels=max(len(levels) for levels, _ in plans), columns=int(us.size),
                strips=len(plans))  # fmt: skip
    total = sum(len(levels) for levels, _ in plans)
    done = 0
    offsets = np.arange(TAPS) - (TAPS - 1) / 2.0
    for (levels, n_sub), r0, r1 in zip(plans, bounds[:-1], bounds[1:], strict=True):
        below: tuple[NDArray[np.float32], NDArray[np.float32]] | None = None
        for level in reversed(levels):
            first = level[0]
            jr = np.empty((len(level), first.nv, us.size), np.float32)
            ji = np.empty_like(jr)
            leaves = [i for i, node in enumerate(level) if not node.children]
            split = [i for i, node in enumerate(level) if node.children]
            if leaves:  # one batch of backprojections on the level's grid, demodulated
                vs = first.v0 + np.arange(first.nv) * first.dv
                ranges = np.array([[level[i].j0, level[i].j1] for i in leaves], dtype=np.int64)
                re, im = backproject_f32(
                    table_values, pos, ref_ranges, us, vs, constants, n_up,
                    tile_for(pos, us, vs), pulse_ranges=ranges,
                )  # fmt: skip
                lr = np.empty(re.shape, np.float32)
                li = np.empty(re.shape, np.float32)
                _modulate(re, im, lr, li, us, vs, centre[0], centre[1], cz2, rref,
                          quarter_scale, -1.0)  # fmt: skip
                jr[leaves] = lr
                ji[leaves] = li
                info["leaves"] += len(leaves)
                info["leaf_pixel_pulses"] += int(np.sum(ranges[:, 1] - ranges[:, 0])) * re[0].size
            if split:  # children 2i, 2i + 1 of split node i, all in one parallel region
                kids = [kid for i in split for kid in level[i].children]
                g = np.empty((len(kids), 2, TAPS), np.float32)
                for c, kid in enumerate(kids):
                    gc = half_sample_filter(kid.half * kid.dv)
                    gc = gc * np.exp(-2j * np.pi * kid.centre * kid.dv * offsets)
                    g[c, 0], g[c, 1] = gc.real, gc.imag
                pre = np.zeros((len(split), first.nv, us.size), np.float32)
                pim = np.zeros_like(pre)
                _merge(pre, pim, below[0], below[1], kids[0].k0, kids[0].ratio, g)
                jr[split] = pre
                ji[split] = pim
            below = (jr, ji)
            done += 1
            if progress is not None:
                progress("backprojection", done, total)
        jr, ji = below
        rows_re = np.ascontiguousarray(jr[:, ::n_sub], np.float64)
        rows_im = np.ascontiguousarray(ji[:, ::n_sub], np.float64)
        ore = np.empty_like(rows_re)
        oim = np.empty_like(rows_im)
        _modulate(rows_re, rows_im, ore, oim, us, y[r0:r1], centre[0], centre[1], cz2, rref,
                  quarter_scale, 1.0)  # fmt: skip
        out[r0:r1, k_lo:k_hi] = ore[0] + 1j * oim[0]
    return (out.T if transpose else out), info
