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
@numba.njit(fastmath=_FASTMATH, inline="always")
def _quarter_turns(t):  # pragma: no cover - compiled
    """``(cos, sin)`` of ``pi t / 2``: ``t`` folded exactly to ``|t - k| <= 1/2``, float64."""
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
    return cs, sn


@numba.njit(fastmath=_FASTMATH, parallel=True, cache=True)
def _demodulate(re, im, n_images, us, vs, cu, cv, cz2, rref, quarter_scale):
    """``x[i, r, k] *= exp(-i pi/2 quarter_scale (|c - rho| - rref))`` for ``i < n_images``.

    In place; ``rho = (us[k], vs[r], 0)``, ``c = (cu, cv, sqrt(cz2))``. The phase is
    evaluated once per pixel (float64) and applied to every image.
    """  # pragma: no cover - compiled
    nv, nu = re.shape[1], re.shape[2]
    for r in numba.prange(nv):
        cs = np.empty(nu, np.float32)
        sn = np.empty(nu, np.float32)
        dv = vs[r] - cv
        c2 = dv * dv + cz2
        for k in range(nu):
            du = us[k] - cu
            a, b = _quarter_turns((math.sqrt(du * du + c2) - rref) * quarter_scale)
            cs[k] = a
            sn[k] = -b
        for i in range(n_images):
            for k in range(nu):
                a = re[i, r, k]
                b = im[i, r, k]
                re[i, r, k] = a * cs[k] - b * sn[k]
                im[i, r, k] = a * sn[k] + b * cs[k]


@numba.njit(fastmath=_FASTMATH, inline="always")
def _add_child(dre, dim, m, cre, cim, k0, ratio, g):  # pragma: no cover - compiled
    """Add parent row ``m`` of one child to the row ``dre + 1j dim`` (see :func:`_merge`)."""
    nu = dre.shape[0]
    if ratio == 1 or m % 2 == 0:
        mc = k0 + m if ratio == 1 else k0 + m // 2
        for i in range(nu):
            dre[i] += cre[mc, i]
            dim[i] += cim[mc, i]
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
        dre[i] += (
            g0r * x0r - g0i * x0i + g1r * x1r - g1i * x1i + g2r * x2r - g2i * x2i
            + g3r * x3r - g3i * x3i + g4r * x4r - g4i * x4i + g5r * x5r - g5i * x5i
            + g6r * x6r - g6i * x6i + g7r * x7r - g7i * x7i
        )  # fmt: skip
        dim[i] += (
            g0r * x0i + g0i * x0r + g1r * x1i + g1i * x1r + g2r * x2i + g2i * x2r
            + g3r * x3i + g3i * x3r + g4r * x4i + g4i * x4r + g5r * x5i + g5i * x5r
            + g6r * x6i + g6i * x6r + g7r * x7i + g7i * x7r
        )  # fmt: skip


@numba.njit(fastmath=_FASTMATH, parallel=True, cache=True)
def _merge(re, im, first, kids, cre, cim, k0, ratio, g):
    """Images ``first + p`` = children ``kids[p, 0]`` and ``kids[p, 1]`` resampled along ``v``.

    Arrays ``(images, rows v, columns u)``; ``re``, ``im`` of the parents' level, ``cre``,
    ``cim`` of the children's. Child row ``k0 + m / ratio`` sits at parent row ``m``.
    ``ratio == 1``: same spacing, rows added. ``ratio == 2``: even parent rows are child
    rows; odd ones the half-sample interpolation ``sum_t g[c, :, t] x[k0 + (m - 1)/2 + t - 3]``
    with child ``c``'s complex filter ``g[c] = (re[8], im[8])``.
    """  # pragma: no cover - compiled
    n_parents = kids.shape[0]
    nvp, nu = re.shape[1], re.shape[2]
    for task in numba.prange(n_parents * nvp):
        q = first + task // nvp
        m = task % nvp
        dre = re[q, m]
        dim = im[q, m]
        for i in range(nu):
            dre[i] = 0.0
            dim[i] = 0.0
        for c in (kids[task // nvp, 0], kids[task // nvp, 1]):
            _add_child(dre, dim, m, cre[c], cim[c], k0, ratio, g[c])


@numba.njit(fastmath=_FASTMATH, parallel=True, cache=True)
def _root_rows(out, r0, k_lo, kids, cre, cim, k0, ratio, g, n_sub, us, ys, cu, cv, cz2, rref,
               quarter_scale):  # fmt: skip
    """Image rows ``r0 + r`` = root row ``r n_sub`` (its children ``kids`` added), remodulated.

    ``out[r0 + r, k_lo + k] = J(us[k], ys[r]) exp(+i pi/2 quarter_scale (|c - rho| - rref))``
    (complex128), ``J`` the sum of the children rows as in :func:`_merge`.
    """  # pragma: no cover - compiled
    nu = us.size
    for r in numba.prange(ys.size):
        dre = np.zeros(nu, np.float32)
        dim = np.zeros(nu, np.float32)
        for c in kids:
            _add_child(dre, dim, r * n_sub, cre[c], cim[c], k0, ratio, g[c])
        dv = ys[r] - cv
        c2 = dv * dv + cz2
        for k in range(nu):
            du = us[k] - cu
            cs, sn = _quarter_turns((math.sqrt(du * du + c2) - rref) * quarter_scale)
            a = np.float64(dre[k])
            b = np.float64(dim[k])
            out[r0 + r, k_lo + k] = complex(a * cs - b * sn, a * sn + b * cs)


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


def _plan(n_pulses, band, dv_top, v0_top, nv_top, alpha) -> list[list[_Node]]:
    """Levels of the tree, root first.

    A node splits in two when both halves' bands fit twice its ``v`` spacing; otherwise it
    is a leaf. Level ``d + 1`` lists the children of the split nodes of level ``d``, in
    order. All nodes of a level share one grid; in its arrays the leaves come first.
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
        order = [n for n in level if not n.children] + [n for n in level if n.children]
        for slot, node in enumerate(order):
            node.slot = slot
        if not nxt:
            return levels
        levels.append(nxt)


@dataclass(frozen=True, eq=False)
class _Frame:
    """Everything the levels share, in the ``(u, v)`` frame (``u`` the image columns)."""

    table_values: NDArray[np.uint64]
    antennas: tuple[NDArray, NDArray, NDArray, NDArray]  # x, y, z^2, reference range
    us: NDArray[np.float64]  # the columns computed (m)
    constants: tuple[float, float, float]
    n_up: int
    centre: NDArray[np.float64]  # c, aperture centre (m)
    rref: float  # |c - rho_o| (m)
    tile_for: object
    tile_kernel: object
    pos: NDArray[np.float64]

    def grid(self, node: _Node) -> NDArray[np.float64]:
        return node.v0 + np.arange(node.nv) * node.dv


# ====================================================================== evaluation
def _leaves(fr: _Frame, level: list[_Node], re: NDArray, im: NDArray) -> int:
    """Leaves of one level, exact backprojection on the level's grid, demodulated.

    Writes slots ``0..n_leaves - 1`` of ``re``, ``im`` (zero on entry); returns the
    pixel-pulses computed.
    """
    leaves = [n for n in level if not n.children]
    first = level[0]
    us, vs = fr.us, fr.grid(first)
    starts = np.array([n.j0 for n in leaves], np.int64)
    stops = np.array([n.j1 for n in leaves], np.int64)
    rows, cols = fr.tile_for(fr.pos, us, vs)
    idx_scale, idx_offset, quarter_scale = fr.constants
    du = (us[-1] - us[0]) / (us.size - 1) if us.size > 1 else 1.0
    with numba.parallel_chunksize(1):  # tiles handed out one at a time
        fr.tile_kernel(
            fr.table_values, starts, stops, *fr.antennas, float(us[0]), du, us.size,
            float(vs[0]), first.dv, first.nv, idx_scale, idx_offset, fr.n_up, quarter_scale,
            rows, cols, 0, -(-first.nv // rows), re, im,
        )  # fmt: skip
    c = fr.centre
    _demodulate(re, im, len(leaves), us, vs, c[0], c[1], c[2] ** 2, fr.rref, quarter_scale)
    return int(np.sum(stops - starts)) * first.nv * us.size


def _filters(below: list[_Node]) -> NDArray[np.float32]:
    """``(len(below), 2, TAPS)`` complex half-sample filters of the nodes, by slot."""
    offsets = np.arange(TAPS) - (TAPS - 1) / 2.0
    g = np.zeros((len(below), 2, TAPS), np.float32)
    for kid in below:
        gc = half_sample_filter(kid.half * kid.dv)
        gc = gc * np.exp(-2j * np.pi * kid.centre * kid.dv * offsets)
        g[kid.slot, 0], g[kid.slot, 1] = gc.real, gc.imag
    return g


def _kids(nodes: list[_Node]) -> NDArray[np.int64]:
    """``(len(nodes), 2)`` slots of the nodes' children."""
    return np.array([[k.slot for k in n.children] for n in nodes], np.int64).reshape(-1, 2)


def _level(fr: _Frame, level: list[_Node], below, info: dict):
    """``(re, im)`` of one level below the root, ``(nodes, rows, columns)`` float32."""
    first = level[0]
    re = np.zeros((len(level), first.nv, fr.us.size), np.float32)
    im = np.zeros_like(re)
    n_leaves = sum(1 for n in level if not n.children)
    if n_leaves:
        info["leaf_pixel_pulses"] += _leaves(fr, level, re, im)
        info["leaves"] += n_leaves
    split = sorted((n for n in level if n.children), key=lambda n: n.slot)
    if split:  # every split node of the level in one parallel region
        kid = split[0].children[0]
        _merge(re, im, n_leaves, _kids(split), below[0], below[1], kid.k0, kid.ratio,
               _filters([k for n in split for k in n.children]))  # fmt: skip
    return re, im


def _strip(fr, levels, n_sub, ys, out, r0, k_lo, info, report) -> None:
    """Evaluate one strip's tree bottom-up and write its image rows ``out[r0:r0 + ys.size]``."""
    root = levels[0][0]
    c = fr.centre
    quarter_scale = fr.constants[2]
    if not root.children:  # the whole aperture is one leaf: on the image rows directly
        root.v0, root.dv, root.nv = float(ys[0]), float(ys[1] - ys[0]) if ys.size > 1 else 1.0, ys.size
        below = _level(fr, [root], None, info)
        kids, ratio, k0, g, n_sub = np.zeros(1, np.int64), 1, 0, np.zeros((1, 2, TAPS), np.float32), 1
    else:
        below = None
        for level in reversed(levels[1:]):
            below = _level(fr, level, below, info)
            report()
        kids, ratio, k0 = _kids([root])[0], root.children[0].ratio, root.children[0].k0
        g = _filters(root.children)
    _root_rows(out, r0, k_lo, kids, below[0], below[1], k0, ratio, g, n_sub, fr.us, ys, c[0],
               c[1], c[2] ** 2, fr.rref, quarter_scale)  # fmt: skip
    report()


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


def _strip_plans(pos, us, y, f_lo, f_hi, nu_o, alpha):
    """The cheapest cut of the rows in 1, 2, 4, 8 or 16 strips, by the cost model.

    A narrower strip sees the look direction turn less, which lowers the band floor and
    lets the leaves grow; each strip pays its own interpolation margins. Returns
    ``(cost, bounds, [(levels, n_sub), ...])``; the cost is in pixel-pulses of the leaves
    plus ~2 per merged sample (measured), the root's merge counted on the image rows only.
    """
    n_pulses, nv_ = pos.shape[0], y.size
    centre = pos.mean(axis=0)
    dy = (y[-1] - y[0]) / (nv_ - 1)

    def plan(r0: int, r1: int) -> tuple[list[list[_Node]], int]:
        ys = y[r0:r1]
        probes = np.array(
            [[a, b] for a in (us[0], us.mean(), us[-1]) for b in (ys[0], ys.mean(), ys[-1])]
        )
        lo_j, hi_j = _pulse_bands(pos, f_lo, f_hi, nu_o, centre, probes)
        lo_j, hi_j = lo_j.tolist(), hi_j.tolist()

        def band(j0: int, j1: int) -> tuple[float, float]:
            """First, middle and last pulse of ``j0:j1``: the band's extremes."""
            js = (j0, (j0 + j1 - 1) // 2, j1 - 1)
            return min(lo_j[j] for j in js), max(hi_j[j] for j in js)

        lo, hi = band(0, n_pulses)
        n_sub = max(1, math.ceil(alpha * (hi - lo) * dy))  # root rows per image row
        levels = _plan(n_pulses, band, dy / n_sub, float(ys[0]), (ys.size - 1) * n_sub + 1, alpha)
        return levels, n_sub

    def cost(levels: list[list[_Node]], rows: int) -> float:
        c = 0.0
        for d, level in enumerate(levels):
            for node in level:
                if node.children:
                    c += 2.0 * 2.0 * (rows if d == 0 else node.nv) * us.size
                else:
                    c += (node.j1 - node.j0) * (rows if d == 0 else node.nv) * us.size
        return c

    best = None
    for n_strips in (1, 2, 4, 8, 16):
        if nv_ // n_strips < 16:
            break
        bounds = np.linspace(0, nv_, n_strips + 1).round().astype(int)
        plans = [plan(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
        c = sum(cost(levels, b - a) for (levels, _), a, b in
                zip(plans, bounds[:-1], bounds[1:], strict=True))  # fmt: skip
        if best is not None and c >= best[0]:
            break  # more strips cost more margins than they save
        best = (c, bounds, plans)
    return best


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
    tile_kernel,
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
        ``tile_for(positions, u_m, v_m) -> (rows, cols)``, the tile of the exact kernel.
    tile_kernel : callable
        The exact float32 tile kernel of :mod:`.backprojection` (``_tile_kernel``); the
        leaves call it with float32 outputs.
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
    rho_o = np.asarray(reference_point_m, np.float64)
    if transpose:  # u = y, v = x: swap the coordinates of everything
        pos = np.ascontiguousarray(pos[:, [1, 0, 2]])
        rho_o = rho_o[[1, 0, 2]]
        x, y = y, x
    out = np.zeros((y.size, x.size), np.complex128)
    info: dict = {"levels": 0, "leaves": 0, "leaf_pixel_pulses": 0, "columns": 0}
    cols = _active_columns(pos, ref_ranges, x, y, constants, n_up)
    if cols.size == 0:
        return (out.T if transpose else out), info
    k_lo, k_hi = int(cols[0]), int(cols[-1]) + 1
    us = np.ascontiguousarray(x[k_lo:k_hi])
    f_lo = carrier_hz - 0.5 * bandwidth_hz
    f_hi = carrier_hz + 0.5 * bandwidth_hz
    c_best, bounds, plans = _strip_plans(pos, us, y, f_lo, f_hi, carrier_hz, alpha)
    if c_best > 0.7 * pos.shape[0] * y.size * us.size:
        return None, {"fallback": "exact (the factorisation would not save work here)"}
    centre = pos.mean(axis=0)
    fr = _Frame(
        table_values=table_values,
        antennas=(np.ascontiguousarray(pos[:, 0]), np.ascontiguousarray(pos[:, 1]),
                  np.ascontiguousarray(pos[:, 2] ** 2),
                  np.ascontiguousarray(ref_ranges, dtype=np.float64)),
        us=us, constants=tuple(float(c) for c in constants), n_up=int(n_up), centre=centre,
        rref=float(np.linalg.norm(centre - rho_o)), tile_for=tile_for, tile_kernel=tile_kernel,
        pos=pos,
    )  # fmt: skip
    info.update(levels=max(len(levels) for levels, _ in plans), columns=int(us.size),
                strips=len(plans))  # fmt: skip
    total = sum(len(levels) for levels, _ in plans)
    done = 0

    def report() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress("backprojection", done, total)

    for (levels, n_sub), r0, r1 in zip(plans, bounds[:-1], bounds[1:], strict=True):
        _strip(fr, levels, n_sub, y[r0:r1], out, int(r0), k_lo, info, report)
    return (out.T if transpose else out), info
