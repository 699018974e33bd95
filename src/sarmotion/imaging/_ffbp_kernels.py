"""Compiled kernels of fast factorised backprojection (:mod:`.ffbp`).

A parallel region (:func:`level`) runs independent tasks: leaf tiles (exact backprojection,
demodulated as they are written) and merged rows (parents from their children's planes),
of one tree level, or the leaves of every level (:func:`~.ffbp._schedule`), taken one at a
time by each thread from a shared counter (:func:`_take`), dearest first.
numba's ``prange`` would hand each thread a contiguous, equal count of iterations whatever
their cost (``parallel_chunksize`` does not change that here): the leaf tiles, listed
first, would all fall to one thread. Taking tasks from a counter also keeps a descheduled
thread from holding up the others by more than its current task. Each region ends in a
barrier, which on a busy machine waits for a descheduled thread, so the number of
regions, not only the arithmetic, sets the time.

Sub-images are ``(images, rows v, columns u)`` float32 planes ``re``, ``im``; image ``i``
has its own row grid ``v0[i] + r dv[i]``, ``r < nv[i]``, and all share the columns ``us``.
The demodulation is the carrier phase seen from the aperture centre ``c``,
``exp(-i pi/2 quarter_scale (|c - rho| - rref))``, evaluated in float64.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba.core import cgutils, types
from numba.extending import intrinsic

from ..core.spectral import quarter_turns
from ._simd import LANES, tile_pulses

#: The version of :mod:`._simd`'s inner loop compiled into this module's kernels. numba's
#: on-disk cache keys on this file's contents, not on :mod:`._simd`'s: change this line
#: whenever the inner loop or its table layout changes, or a stale kernel is loaded.
SIMD_VERSION = "hermite-float32-planes-window-9-avx2-unmasked"

_FASTMATH = {"nnan", "ninf", "nsz", "arcp", "contract", "afn"}


@intrinsic
def _take(typingctx, counter):
    """``counter[0] += 1`` as one atomic step; returns the value before it (int64).

    ``counter`` is a 1-d int64 array shared by the threads of a parallel region: each call
    hands out the next rank once, whichever thread asks.
    """
    if not (isinstance(counter, types.Array) and counter.dtype == types.int64):
        return None

    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        zero = context.get_constant(types.intp, 0)
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [zero])
        one = context.get_constant(types.int64, 1)
        return builder.atomic_rmw("add", ptr, one, "monotonic")

    return types.int64(counter), codegen


@numba.njit(fastmath=_FASTMATH, inline="always")
def _add_child(dre, dim, m, cre, cim, k0, ratio, g):  # pragma: no cover - compiled
    """Add parent row ``m`` of one child (planes ``cre``, ``cim``) to the row ``dre + 1j dim``.

    Child row ``k0 + m / ratio`` sits at parent row ``m``. ``ratio == 1`` or ``m`` even:
    that child row. Otherwise the half-sample interpolation
    ``sum_t (g[0, t] + 1j g[1, t]) x[k0 + (m - 1)/2 + t - taps/2 + 1]``.
    """
    nu = dre.shape[0]
    if ratio == 1 or m % 2 == 0:
        mc = k0 + m if ratio == 1 else k0 + m // 2
        for i in range(nu):
            dre[i] += cre[mc, i]
            dim[i] += cim[mc, i]
        return
    taps = g.shape[1]
    b = k0 + (m - 1) // 2 - taps // 2 + 1
    for t in range(taps):
        gr = g[0, t]
        gi = g[1, t]
        xr = cre[b + t]
        xi = cim[b + t]
        for i in range(nu):
            dre[i] += gr * xr[i] - gi * xi[i]
            dim[i] += gr * xi[i] + gi * xr[i]


@numba.njit(fastmath=_FASTMATH, inline="always")
def _merge_row(dre, dim, m, are, aim, bre, bim, k0, ratio, ga, gb):
    # pragma: no cover - compiled
    """Parent row ``m`` of two children into ``dre + 1j dim`` (overwritten), in one pass.

    The sum of :func:`_add_child` of both children (the same taps, ``k0`` and ``ratio``),
    each tap of both read in the same loop, so the row is read and written once per tap.
    """
    nu = dre.shape[0]
    if ratio == 1 or m % 2 == 0:
        mc = k0 + m if ratio == 1 else k0 + m // 2
        xa = are[mc]
        ya = aim[mc]
        xb = bre[mc]
        yb = bim[mc]
        for i in range(nu):
            dre[i] = xa[i] + xb[i]
            dim[i] = ya[i] + yb[i]
        return
    taps = ga.shape[1]
    b = k0 + (m - 1) // 2 - taps // 2 + 1
    for i in range(nu):
        dre[i] = 0.0
        dim[i] = 0.0
    for t in range(taps):
        gar = ga[0, t]
        gai = ga[1, t]
        gbr = gb[0, t]
        gbi = gb[1, t]
        xa = are[b + t]
        ya = aim[b + t]
        xb = bre[b + t]
        yb = bim[b + t]
        for i in range(nu):
            dre[i] += (gar * xa[i] - gai * ya[i]) + (gbr * xb[i] - gbi * yb[i])
            dim[i] += (gar * ya[i] + gai * xa[i]) + (gbr * yb[i] + gbi * xb[i])


@numba.njit(fastmath=_FASTMATH, inline="always")
def _leaf_tile(
    tab, j0, j1, ant_x, ant_y, ant_z2, ref, x0, dx, y0, dy, r0, c0, nr, nc, idx_scale,
    idx_offset, hi, quarter_scale, cu, cv, cz2, rref, ore, oim, lanes_v,
):  # pragma: no cover - compiled  # fmt: skip
    """Pulses ``j0:j1`` on one tile (rows ``r0:r0 + nr``, columns ``c0:c0 + nc``), demodulated.

    The pulses are added as by exact backprojection
    (:func:`~sarmotion.imaging._simd.tile_pulses`: float64 anchor, float32 pixels), its
    SIMD lanes along the columns or, ``lanes_v``, along the rows (the tile's axes and the
    antennas' ``x``, ``y`` swapped: every range is unchanged).
    """
    rc = r0 + nr // 2
    cc = c0 + nc // 2
    xc = x0 + cc * dx
    yc = y0 + rc * dy
    nrp = (nr + LANES - 1) // LANES * LANES if lanes_v else nr
    ncp = nc if lanes_v else (nc + LANES - 1) // LANES * LANES
    acc_re = np.zeros(nrp * ncp, np.float32)
    acc_im = np.zeros(nrp * ncp, np.float32)
    if lanes_v:  # acc[k * nrp + r]
        tile_pulses(
            tab, j0, j1, ant_y, ant_x, ant_z2, ref, yc, xc, dy, dx, r0, rc, c0, cc, nc, nrp,
            idx_scale, idx_offset, hi, quarter_scale, acc_re, acc_im,
        )  # fmt: skip
        tre = acc_re.reshape(ncp, nrp).T.copy()  # acc[r * ncp + k], as below
        tim = acc_im.reshape(ncp, nrp).T.copy()
        acc_re = tre.reshape(-1)
        acc_im = tim.reshape(-1)
    else:  # acc[r * ncp + k]
        tile_pulses(
            tab, j0, j1, ant_x, ant_y, ant_z2, ref, xc, yc, dx, dy, c0, cc, r0, rc, nr, ncp,
            idx_scale, idx_offset, hi, quarter_scale, acc_re, acc_im,
        )  # fmt: skip
    for r in range(nr):
        dv = y0 + (r0 + r) * dy - cv
        c2 = dv * dv + cz2
        for k in range(nc):
            du = x0 + (c0 + k) * dx - cu
            cs, sn = quarter_turns((math.sqrt(du * du + c2) - rref) * quarter_scale)
            a = acc_re[r * ncp + k]
            b = acc_im[r * ncp + k]
            ore[r0 + r, c0 + k] = a * cs + b * sn
            oim[r0 + r, c0 + k] = b * cs - a * sn


@numba.njit(nogil=True, fastmath=_FASTMATH, parallel=True, cache=True)
def level(
    re, im, tab, starts, stops, ant_x, ant_y, ant_z2, ref, x0, dx, v0, dv, nv, idx_scale,
    idx_offset, n_up, quarter_scale, tiles, cu, cv, cz2, rref, p0, kids, cre, cim, k0, ratio,
    g, lanes_v, tasks, counter, workers, block,
):  # pragma: no cover - compiled  # fmt: skip
    """One parallel region of the tree: leaf tiles and merged rows of ``re``, ``im``, in place.

    Leaf ``i < starts.size`` (plane ``i``) is the backprojection of pulses
    ``starts[i]:stops[i]`` (table ``tab``, antennas ``ant_*``, reference ranges ``ref``) on
    rows ``v0[i] + r dv[i]``, ``r < nv[i]``, and columns ``x0 + k dx``, demodulated, in
    tiles of ``tiles[i]`` (rows, columns), its SIMD lanes along the rows when
    ``lanes_v[i]``. Parent ``p < kids.shape[0]`` (plane ``q = p0 + p``) is the sum of
    children ``kids[p, 0]``, ``kids[p, 1]`` (planes of ``cre``, ``cim``; filters
    ``g[child]``, ``k0[child]`` its rows before the parent's row 0, the same for both)
    resampled to its rows (:func:`_add_child`). ``cre``, ``cim`` may be ``re``, ``im``
    themselves (other planes).

    Task ``tasks[t] = (i, r0, c0)``: the tile of leaf ``i >= 0`` from row ``r0``, column
    ``c0``; ``(-1 - p, m0, 0)``: parent ``p``'s rows ``m0 .. m0 + block - 1`` (below
    ``nv``). ``workers`` loops (one per thread) take the tasks ``tasks[counter[0]]``,
    ``counter[0]`` advanced atomically (:func:`_take`; start it at 0), until all are done:
    a task's place in ``tasks`` is when it starts (:func:`~.ffbp._task_order`: dearest
    first).
    """
    nx = re.shape[2]
    hi = np.float32(n_up)
    n_tasks = tasks.shape[0]
    for _ in numba.prange(workers):
        while True:
            at = _take(counter)
            if at >= n_tasks:
                break
            i = tasks[at, 0]
            if i >= 0:
                r0 = tasks[at, 1]
                c0 = tasks[at, 2]
                nr = min(nv[i], r0 + tiles[i, 0]) - r0
                nc = min(nx, c0 + tiles[i, 1]) - c0
                _leaf_tile(
                    tab, starts[i], stops[i], ant_x, ant_y, ant_z2, ref, x0, dx, v0[i],
                    dv[i], r0, c0, nr, nc, idx_scale, idx_offset, hi, quarter_scale, cu, cv,
                    cz2, rref, re[i], im[i], lanes_v[i],
                )  # fmt: skip
                continue
            p = -1 - i
            q = p0 + p
            a, b = kids[p, 0], kids[p, 1]
            m0 = tasks[at, 1]
            for m in range(m0, min(m0 + block, nv[q])):
                _merge_row(re[q, m], im[q, m], m, cre[a], cim[a], cre[b], cim[b], k0[a],
                           ratio, g[a], g[b])  # fmt: skip


@numba.njit(nogil=True, fastmath=_FASTMATH, parallel=True, cache=True)
def root_rows(
    out, k_lo, row_strip, row_local, kids, n_sub, k0, ratio, cre, cim, g, us, ys, cu, cv, cz2,
    rref, quarter_scale, remodulate=True,
):  # pragma: no cover - compiled  # fmt: skip
    """Image rows from the roots' children, remodulated, into ``out`` (complex128).

    Image row ``r`` (at ``v = ys[r]``) is row ``row_local[r] n_sub[s]`` of the root of strip
    ``s = row_strip[r]``: the sum of its children ``kids[s]`` (``-1``: none) of the planes
    ``cre``, ``cim``, with ``k0[s]``, ``ratio[s]`` and filters ``g`` as in
    :func:`_add_child`; ``out[r, k_lo + k] = J exp(+i pi/2 quarter_scale (|c - rho| - rref))``,
    or ``J`` itself when ``remodulate`` is false.
    """
    nu = us.size
    for r in numba.prange(ys.size):
        s = row_strip[r]
        m = row_local[r] * n_sub[s]
        dre = np.zeros(nu, np.float32)
        dim = np.zeros(nu, np.float32)
        for c in (kids[s, 0], kids[s, 1]):
            if c >= 0:
                _add_child(dre, dim, m, cre[c], cim[c], k0[s], ratio[s], g[c])
        if not remodulate:
            for k in range(nu):
                out[r, k_lo + k] = complex(dre[k], dim[k])
            continue
        dv = ys[r] - cv
        c2 = dv * dv + cz2
        pc = np.empty(nu)
        ps = np.empty(nu)
        for k in range(nu):  # the phasors apart: this loop vectorises
            du = us[k] - cu
            pc[k], ps[k] = quarter_turns((math.sqrt(du * du + c2) - rref) * quarter_scale)
        for k in range(nu):
            a = np.float64(dre[k])
            b = np.float64(dim[k])
            out[r, k_lo + k] = complex(a * pc[k] - b * ps[k], a * ps[k] + b * pc[k])


@numba.njit(fastmath=_FASTMATH, inline="always")
def _resample_pixel(
    src, fu, fv, wu_table, wv_table, wu, wv, acc_re, acc_im
):  # pragma: no cover - compiled  # fmt: skip
    """``(re, im, ok)``: ``J`` at the fractional source position ``(fv, fu)``, float32.

    ``fv``, ``fu`` in rows and columns of ``src``; ``ok`` is false (and the value 0) when
    the taps leave ``src``. ``wu``, ``wv``, ``acc_re``, ``acc_im``: scratch arrays.
    """
    n_phase = wu_table.shape[0] - 1
    taps = wu_table.shape[1]
    taps_v = wv_table.shape[1]
    nv, nu = src.shape
    iu = int(math.floor(fu))
    iv = int(math.floor(fv))
    bu = iu - (taps // 2 - 1)
    bv = iv - (taps_v // 2 - 1)
    if bu < 0 or bv < 0 or bu + taps > nu or bv + taps_v > nv:
        return np.float32(0.0), np.float32(0.0), False
    pu = (fu - iu) * n_phase
    pv = (fv - iv) * n_phase
    ju = min(int(pu), n_phase - 1)
    jv = min(int(pv), n_phase - 1)
    au = np.float32(pu - ju)
    av = np.float32(pv - jv)
    for t in range(taps):
        wu[t] = wu_table[ju, t] + au * (wu_table[ju + 1, t] - wu_table[ju, t])
        acc_re[t] = 0.0
        acc_im[t] = 0.0
    for t in range(taps_v):
        wv[t] = wv_table[jv, t] + av * (wv_table[jv + 1, t] - wv_table[jv, t])
    for a in range(taps_v):
        w = wv[a]
        row = src[bv + a]
        for t in range(taps):
            z = row[bu + t]
            acc_re[t] += w * z.real
            acc_im[t] += w * z.imag
    sr = np.float32(0.0)
    si = np.float32(0.0)
    for t in range(taps):
        sr += wu[t] * acc_re[t]
        si += wu[t] * acc_im[t]
    return sr, si, True


@numba.njit(nogil=True, fastmath=_FASTMATH, parallel=True, cache=True)
def resample(
    out, src, u0, du, v0, dv, xs, ys, ox, oy, cos_t, sin_t, wu_table, wv_table, cx, cy, cz2,
    rref, quarter_scale, block=16,
):  # pragma: no cover - compiled  # fmt: skip
    """Interpolate the demodulated image ``src`` onto the grid ``xs`` x ``ys``, remodulated.

    ``src[i, k]`` (complex64) is ``J`` at ``u = u0 + k du``, ``v = v0 + i dv`` of the frame
    ``u = cos_t (x - ox) + sin_t (y - oy)``, ``v = -sin_t (x - ox) + cos_t (y - oy)``.
    ``wu_table``, ``wv_table`` ``(P + 1, T)`` (``T`` of each its own): the ``T``-tap filter
    for a position ``p / P`` samples past tap ``T/2 - 1``, linearly interpolated between
    the ``P + 1`` phases. Pixels whose taps leave ``src`` are 0. ``out[r, k] = J exp(+i
    pi/2 quarter_scale (|c - rho| - rref))`` (complex128), the demodulation of :mod:`.ffbp`
    undone. Pixels are visited in ``block`` x ``block`` squares, so that neighbouring rows
    find the source rows they read in the cache (2048^2 at 45 degrees: 0.098 s, 0.124 s
    row by row).
    """
    taps = wu_table.shape[1]
    n_rb = (ys.size + block - 1) // block
    n_kb = (xs.size + block - 1) // block
    for rb in numba.prange(n_rb):
        wu = np.empty(taps, np.float32)
        wv = np.empty(wv_table.shape[1], np.float32)
        acc_re = np.empty(taps, np.float32)
        acc_im = np.empty(taps, np.float32)
        for kb in range(n_kb):
            for r in range(rb * block, min((rb + 1) * block, ys.size)):
                ddy = ys[r] - oy
                cdy = ys[r] - cy
                c2 = cdy * cdy + cz2
                for k in range(kb * block, min((kb + 1) * block, xs.size)):
                    ddx = xs[k] - ox
                    fu = (cos_t * ddx + sin_t * ddy - u0) / du
                    fv = (-sin_t * ddx + cos_t * ddy - v0) / dv
                    sr, si, ok = _resample_pixel(src, fu, fv, wu_table, wv_table, wu, wv,
                                                 acc_re, acc_im)  # fmt: skip
                    if not ok:
                        out[r, k] = 0.0
                        continue
                    cdx = xs[k] - cx
                    cs, sn = quarter_turns((math.sqrt(cdx * cdx + c2) - rref) * quarter_scale)
                    a64 = np.float64(sr)
                    b64 = np.float64(si)
                    out[r, k] = complex(a64 * cs - b64 * sn, a64 * sn + b64 * cs)


@numba.njit(nogil=True, fastmath=_FASTMATH, parallel=True, cache=True)
def window_edges(xs, ys, px, py, pz2, ref, d_lo, d_hi, margin, block=32):
    # pragma: no cover - compiled
    """``(ny, nx)`` mask of the pixels near an end of the fast-time window.

    Pixel ``(r, k)`` is marked when ``[min_j d_j - margin, max_j d_j + margin]`` holds
    ``d_lo`` or ``d_hi``, ``d_j = |p_j - rho| - ref[j]`` over the given antennas ``p_j``
    (``pz2`` their squared heights). The pixels are visited in ``block x block`` squares;
    a square is skipped when the same test fails for the extremes of ``d_j`` over its
    rectangle (the nearest point: the antenna's ground position clamped into it; the
    farthest: a corner, the distance being convex), widened by 1 um for rounding: no
    pixel of it can be marked.
    """
    mask = np.zeros((ys.size, xs.size), np.bool_)
    n_rb = (ys.size + block - 1) // block
    n_kb = (xs.size + block - 1) // block
    for rb in numba.prange(n_rb):
        r0 = rb * block
        r1 = min(ys.size, r0 + block)
        ylo = min(ys[r0], ys[r1 - 1])
        yhi = max(ys[r0], ys[r1 - 1])
        for kb in range(n_kb):
            k0 = kb * block
            k1 = min(xs.size, k0 + block)
            xlo = min(xs[k0], xs[k1 - 1])
            xhi = max(xs[k0], xs[k1 - 1])
            lo = np.inf
            hi = -np.inf
            for j in range(px.size):
                nx_ = min(max(px[j], xlo), xhi) - px[j]
                ny_ = min(max(py[j], ylo), yhi) - py[j]
                fx = max(abs(xlo - px[j]), abs(xhi - px[j]))
                fy = max(abs(ylo - py[j]), abs(yhi - py[j]))
                lo = min(lo, math.sqrt(nx_ * nx_ + ny_ * ny_ + pz2[j]) - ref[j])
                hi = max(hi, math.sqrt(fx * fx + fy * fy + pz2[j]) - ref[j])
            lo -= margin + 1e-6
            hi += margin + 1e-6
            if not ((lo <= d_lo <= hi) or (lo <= d_hi <= hi)):
                continue
            for r in range(r0, r1):
                for k in range(k0, k1):
                    lo = np.inf
                    hi = -np.inf
                    for j in range(px.size):
                        dx = xs[k] - px[j]
                        dy = ys[r] - py[j]
                        d = math.sqrt(dx * dx + dy * dy + pz2[j]) - ref[j]
                        lo = min(lo, d)
                        hi = max(hi, d)
                    lo -= margin
                    hi += margin
                    mask[r, k] = (lo <= d_lo <= hi) or (lo <= d_hi <= hi)
    return mask
