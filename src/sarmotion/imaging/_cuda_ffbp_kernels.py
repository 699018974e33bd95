"""numba.cuda kernels of fast factorised backprojection (:mod:`sarmotion.imaging.cuda_ffbp`).

The GPU counterparts of :mod:`._ffbp_kernels`, one thread per output sample, on the same
plan (:mod:`.ffbp`): sub-images are ``(images, rows v, columns u)`` float32 planes ``re``,
``im``, image ``i`` on rows ``v0[i] + r dv[i]``, ``r < nv[i]``, all on the columns ``us``.

- :func:`leaves`: exact backprojection of a leaf's pulses on its rows, demodulated. The
  range of every pixel-pulse, its table position and its carrier phase (reduced exactly
  to ``[-1/2, 1/2]`` cycle) in float64, the cubic Hermite interpolation of the table of
  :mod:`.cuda` and the sum in float32;
- :func:`merges`: a parent's rows from its two children (even rows added, odd rows the
  children's half-sample filters), float32;
- :func:`root_rows`: the image rows from the roots' children, remodulated in float64;
- :func:`resample`: the rotated path's separable fractional filters, remodulated.

The demodulation is the carrier phase seen from the aperture centre ``c``,
``exp(-2i pi (2 nu_o / c) (|c - rho| - rref))``, as on the CPU. Launch with
:data:`BLOCK` threads per block and the grid :func:`blocks` gives: ``x`` over columns,
``y`` over rows, ``z`` over images. The kernels run on the hardware and under numba's
CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import float32, float64, int32, uint64

from ._cuda_kernels import cuda, hermite_at  # numba.cuda, after its numpy alias

__all__ = ["BLOCK", "blocks", "leaves", "merges", "resample", "root_rows"]

#: Threads per block: 32 columns (a warp reads neighbouring samples of a row) by 8 rows.
BLOCK = (32, 8, 1)

_TWO_PI32 = np.float32(2.0 * np.pi)
_ZERO = np.float32(0.0)
_TWO_PI = 2.0 * math.pi


def blocks(n_cols: int, n_rows: int, n_images: int = 1) -> tuple[int, int, int]:
    """The launch grid covering ``n_images`` x ``n_rows`` x ``n_cols`` samples."""
    return (-(-n_cols // BLOCK[0]), -(-max(n_rows, 1) // BLOCK[1]), max(n_images, 1))


@cuda.jit(device=True, inline=True)
def _phasor(x, y, cu, cv, cz2, rref, cycles_per_m):  # pragma: no cover - compiled
    """``(cos, sin)`` of ``2 pi (2 nu_o / c) (|c - rho| - rref)``, float64."""
    wx = x - cu
    wy = y - cv
    c = (math.sqrt(wx * wx + wy * wy + cz2) - rref) * cycles_per_m
    ang = _TWO_PI * (c - math.floor(c + 0.5))
    return math.cos(ang), math.sin(ang)


@cuda.jit(fastmath=True)
def leaves(
    re, im, table, n_table, ax, ay, az2, ref, starts, stops, us, v0, dv, nv, idx_scale,
    idx_offset, cycles_per_m, cu, cv, cz2, rref,
):  # pragma: no cover - compiled  # fmt: skip
    """Leaf ``i`` (plane ``i``): pulses ``starts[i]:stops[i]`` on its rows, demodulated.

    ``table`` uint64, flat: per pulse ``n_table + 1`` positions of two words, the complex64
    trace ``V`` and ``h dV/dt`` (:func:`sarmotion.imaging.cuda.hermite_table`); a delay
    ``d = |p_j - rho| - ref[j]`` (m) is at position ``d idx_scale + idx_offset``, and
    contributes 0 outside ``[0, n_table)``. ``ax``, ``ay``, ``az2``: antenna ``u``, ``v``
    and squared height (m, m^2) in the plan's frame.
    """
    k = cuda.blockIdx.x * cuda.blockDim.x + cuda.threadIdx.x
    r = cuda.blockIdx.y * cuda.blockDim.y + cuda.threadIdx.y
    i = cuda.blockIdx.z
    if k >= us.size or r >= nv[i]:
        return
    x = us[k]
    y = v0[i] + r * dv[i]
    stride = uint64(2 * (n_table + 1))
    acc_re = _ZERO
    acc_im = _ZERO
    for j in range(starts[i], stops[i]):
        wx = x - ax[j]
        wy = y - ay[j]
        d = math.sqrt(wx * wx + wy * wy + az2[j]) - ref[j]
        q = min(max(d * idx_scale + idx_offset, -1.0e6), 1.0e6)
        fl = math.floor(q)
        idx = int32(fl)
        if idx >= 0 and idx < n_table:
            vr, vi = hermite_at(table, uint64(j) * stride + uint64(2 * idx), float32(q - fl))
            c = d * cycles_per_m
            ang = _TWO_PI32 * float32(c - math.floor(c + 0.5))
            cs = math.cos(ang)
            sn = math.sin(ang)
            acc_re += vr * cs - vi * sn
            acc_im += vr * sn + vi * cs
    cs64, sn64 = _phasor(x, y, cu, cv, cz2, rref, cycles_per_m)
    cs = float32(cs64)
    sn = float32(sn64)
    re[i, r, k] = acc_re * cs + acc_im * sn
    im[i, r, k] = acc_im * cs - acc_re * sn


@cuda.jit(fastmath=True)
def merges(re, im, cre, cim, p0, kids, k0, g, nv):  # pragma: no cover - compiled
    """Parent ``p`` (plane ``p0 + p``) from children ``kids[p]`` of ``cre``, ``cim``.

    Parent row ``m`` is child row ``k0[a] + m / 2`` of both children when ``m`` is even,
    else ``sum_t g[child, 0, t] + 1j g[child, 1, t]`` times child row
    ``k0[a] + (m - 1) / 2 + t - taps / 2 + 1`` (as :func:`._ffbp_kernels._merge_row`).
    """
    k = cuda.blockIdx.x * cuda.blockDim.x + cuda.threadIdx.x
    m = cuda.blockIdx.y * cuda.blockDim.y + cuda.threadIdx.y
    p = cuda.blockIdx.z
    q = p0 + p
    if k >= re.shape[2] or m >= nv[q]:
        return
    a = kids[p, 0]
    b = kids[p, 1]
    if m % 2 == 0:
        mc = k0[a] + m // 2
        re[q, m, k] = cre[a, mc, k] + cre[b, mc, k]
        im[q, m, k] = cim[a, mc, k] + cim[b, mc, k]
        return
    taps = g.shape[2]
    base = k0[a] + (m - 1) // 2 - taps // 2 + 1
    sr = _ZERO
    si = _ZERO
    for t in range(taps):
        gar = g[a, 0, t]
        gai = g[a, 1, t]
        gbr = g[b, 0, t]
        gbi = g[b, 1, t]
        xa = cre[a, base + t, k]
        ya = cim[a, base + t, k]
        xb = cre[b, base + t, k]
        yb = cim[b, base + t, k]
        sr += (gar * xa - gai * ya) + (gbr * xb - gbi * yb)
        si += (gar * ya + gai * xa) + (gbr * yb + gbi * xb)
    re[q, m, k] = sr
    im[q, m, k] = si


@cuda.jit(fastmath=True)
def root_rows(
    out, row_strip, row_local, kids, n_sub, k0, ratio, cre, cim, g, us, ys, cu, cv, cz2, rref,
    cycles_per_m, remodulate,
):  # pragma: no cover - compiled  # fmt: skip
    """Image row ``r``, column ``k`` into ``out[r, k]`` (``(re, im)``, float64).

    Row ``row_local[r] n_sub[s]`` of strip ``s = row_strip[r]``'s root: its children
    ``kids[s]`` (``-1``: none) added, each read as in :func:`merges` with ``k0[s]`` and
    ``ratio[s]`` (``1``: row ``k0 + m`` as is); then remodulated,
    ``J exp(+2i pi (2 nu_o / c) (|c - rho| - rref))``, unless ``remodulate`` is false.
    """
    k = cuda.blockIdx.x * cuda.blockDim.x + cuda.threadIdx.x
    r = cuda.blockIdx.y * cuda.blockDim.y + cuda.threadIdx.y
    if k >= us.size or r >= ys.size:
        return
    s = row_strip[r]
    m = row_local[r] * n_sub[s]
    taps = g.shape[2]
    sr = _ZERO
    si = _ZERO
    for h in range(2):
        c = kids[s, h]
        if c < 0:
            continue
        if ratio[s] == 1 or m % 2 == 0:
            mc = k0[s] + m if ratio[s] == 1 else k0[s] + m // 2
            sr += cre[c, mc, k]
            si += cim[c, mc, k]
            continue
        base = k0[s] + (m - 1) // 2 - taps // 2 + 1
        for t in range(taps):
            gr = g[c, 0, t]
            gi = g[c, 1, t]
            xr = cre[c, base + t, k]
            xi = cim[c, base + t, k]
            sr += gr * xr - gi * xi
            si += gr * xi + gi * xr
    a = float64(sr)
    b = float64(si)
    if remodulate:
        cs, sn = _phasor(us[k], ys[r], cu, cv, cz2, rref, cycles_per_m)
        out[r, k, 0] = a * cs - b * sn
        out[r, k, 1] = a * sn + b * cs
    else:
        out[r, k, 0] = a
        out[r, k, 1] = b


@cuda.jit(fastmath=True)
def resample(
    out, src, u0, du, v0, dv, xs, ys, ox, oy, cos_t, sin_t, wu_table, wv_table, cx, cy, cz2,
    rref, cycles_per_m,
):  # pragma: no cover - compiled  # fmt: skip
    """The demodulated image ``src`` interpolated onto ``xs`` x ``ys``, remodulated.

    As :func:`._ffbp_kernels.resample`: ``src[i, k]`` (``(re, im)`` float32) is ``J`` at
    ``u = u0 + k du``, ``v = v0 + i dv`` of the frame turned by ``(cos_t, sin_t)`` about
    ``(ox, oy)``; the filters ``wu_table``, ``wv_table`` ``(P + 1, T)`` linearly
    interpolated between phases; pixels whose taps leave ``src`` are 0.
    """
    k = cuda.blockIdx.x * cuda.blockDim.x + cuda.threadIdx.x
    r = cuda.blockIdx.y * cuda.blockDim.y + cuda.threadIdx.y
    if k >= xs.size or r >= ys.size:
        return
    ddx = xs[k] - ox
    ddy = ys[r] - oy
    fu = (cos_t * ddx + sin_t * ddy - u0) / du
    fv = (-sin_t * ddx + cos_t * ddy - v0) / dv
    n_phase = wu_table.shape[0] - 1
    taps = wu_table.shape[1]
    taps_v = wv_table.shape[1]
    iu = int32(math.floor(fu))
    iv = int32(math.floor(fv))
    bu = iu - (taps // 2 - 1)
    bv = iv - (taps_v // 2 - 1)
    if bu < 0 or bv < 0 or bu + taps > src.shape[1] or bv + taps_v > src.shape[0]:
        out[r, k, 0] = 0.0
        out[r, k, 1] = 0.0
        return
    pu = (fu - iu) * n_phase
    pv = (fv - iv) * n_phase
    ju = min(int32(pu), n_phase - 1)
    jv = min(int32(pv), n_phase - 1)
    au = float32(pu - ju)
    av = float32(pv - jv)
    sr = _ZERO
    si = _ZERO
    for a in range(taps_v):
        w = wv_table[jv, a] + av * (wv_table[jv + 1, a] - wv_table[jv, a])
        rr = _ZERO
        ri = _ZERO
        for t in range(taps):
            wu = wu_table[ju, t] + au * (wu_table[ju + 1, t] - wu_table[ju, t])
            rr += wu * src[bv + a, bu + t, 0]
            ri += wu * src[bv + a, bu + t, 1]
        sr += w * rr
        si += w * ri
    cs, sn = _phasor(xs[k], ys[r], cx, cy, cz2, rref, cycles_per_m)
    a64 = float64(sr)
    b64 = float64(si)
    out[r, k, 0] = a64 * cs - b64 * sn
    out[r, k, 1] = a64 * sn + b64 * cs
