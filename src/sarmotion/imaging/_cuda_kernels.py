"""numba.cuda kernel of exact backprojection (:mod:`sarmotion.imaging.cuda`).

Importing this module imports :mod:`numba.cuda`; :mod:`sarmotion.imaging.cuda` does it
only when a CUDA image is asked for. numba-cuda 0.30 refers to ``np.row_stack``, which
numpy 2.5 removed: where it is missing it is aliased to :func:`numpy.vstack` (the same
function; numpy deprecated the name in 2.0) before :mod:`numba.cuda` is imported.

The kernel is written for the hardware and for numba's CUDA simulator
(``NUMBA_ENABLE_CUDASIM=1``), which runs it as Python on the CPU: ``math`` functions,
``cuda.shared``/``cuda.local`` arrays and float32/float64 scalars, and one device
function, the split of a table word into two float32 (libdevice bit casts on the GPU, a
numpy view under the simulator).
"""

from __future__ import annotations

import math

import numpy as np

if not hasattr(np, "row_stack"):  # numpy >= 2.5 removed the alias numba-cuda 0.30 uses
    np.row_stack = np.vstack  # noqa: NPY201 - restores the removed name, on purpose

from numba import config, cuda, float32, float64, int32, uint64  # noqa: E402

__all__ = ["BLOCK_X", "PULSE_CHUNK", "backprojection_kernel", "hermite_at"]

#: Threads per block along image columns (one warp: neighbouring pixels of a row, whose
#: table positions are close, share cache lines).
BLOCK_X = 32
#: Pulses staged in shared memory at once (4 float64 each: 4 KiB).
PULSE_CHUNK = 128

_TWO = np.float32(2.0)
_THREE = np.float32(3.0)
_ONE = np.float32(1.0)
_HALF32 = np.float32(0.5)
_TWO_PI = np.float32(2.0 * np.pi)
_ZERO = np.float32(0.0)

_KERNELS: dict[tuple[int, int], object] = {}

_LOW32 = np.uint64(0xFFFFFFFF)
_SHIFT32 = np.uint64(32)

if config.ENABLE_CUDASIM:

    @cuda.jit(device=True)
    def _split(word):  # pragma: no cover - the simulator's stand-in
        """The complex64 ``(re, im)`` whose bits are the uint64 ``word``."""
        z = np.array(word, dtype=np.uint64).view(np.complex64)[()]
        return float32(z.real), float32(z.imag)

else:  # pragma: no cover - needs a GPU
    from numba.cuda import libdevice

    @cuda.jit(device=True, inline=True)
    def _split(word):
        """The complex64 ``(re, im)`` whose bits are the uint64 ``word`` (no arithmetic)."""
        lo = int32(word & _LOW32)
        hi = int32(word >> _SHIFT32)
        return libdevice.int_as_float(lo), libdevice.int_as_float(hi)


@cuda.jit(device=True, inline=True, fastmath=True)
def hermite_at(table, o, u):  # pragma: no cover - compiled
    """``(re, im)`` of the cubic Hermite piece at fraction ``u`` (float32) past position ``o``.

    ``table[o]``, ``table[o + 1]`` hold ``V`` and ``h dV/dt`` at the position,
    ``table[o + 2]``, ``table[o + 3]`` at the next (each a complex64 word, uint64).
    """
    v = _ONE - u
    u2 = u * u
    h01 = u2 * (_THREE - _TWO * u)
    h00 = _ONE - h01
    h10 = u * v * v
    h11 = -u2 * v
    a_re, a_im = _split(table[o])
    b_re, b_im = _split(table[o + uint64(1)])
    c_re, c_im = _split(table[o + uint64(2)])
    d_re, d_im = _split(table[o + uint64(3)])
    return (h00 * a_re + h10 * b_re + h01 * c_re + h11 * d_re,
            h00 * a_im + h10 * b_im + h01 * c_im + h11 * d_im)  # fmt: skip


def backprojection_kernel(rows_per_thread: int, block_rows: int):
    """The kernel for ``rows_per_thread`` pixels per thread (compiled on first launch).

    Launch with ``(BLOCK_X, block_rows)`` threads per block, as
    ``kernel[blocks, (BLOCK_X, block_rows)](table, n_table, ant, xs, ys, idx_scale,
    idx_offset, cycles_per_m, out)``:

    - ``table`` uint64, flat: per pulse ``n_table + 1`` table positions ``m``, each two
      words holding the bits of the complex64 band-limited trace ``V`` and of its
      derivative ``D = h dV/dt`` (``h`` the table step; position ``n_table`` repeats
      position 0: one period of the trace). A pixel reads four 8-byte words, the two
      positions around its delay (half the load instructions of float32 words);
    - ``ant`` (n_pulses, 4) float64: antenna ``x``, ``y``, ``z**2`` and the reference range
      ``|r - rho_o|`` (m);
    - ``xs`` (nx,), ``ys`` (ny,) float64: the pixel ``(iy, ix)`` is ``(xs[ix], ys[iy], 0)`` (m);
    - ``idx_scale`` table steps per metre of ``d = |r - rho| - |r - rho_o|``,
      ``idx_offset`` the table position of ``d = 0``, ``cycles_per_m = 2 nu_o / c``;
    - ``out`` (ny, nx, 2) float64, written (not accumulated).

    Each thread sums, over all pulses, ``rows_per_thread`` pixels of one column, rows
    ``P g .. P g + P - 1``. Per pulse it computes in float64 the range ``R_a`` to an
    anchor at the middle of its pixels, the table position and the carrier phase there
    (reduced exactly to ``[-1/2, 1/2]`` cycle), then per pixel the range offset in float32,
    ``R - R_a = N / (R_a + sqrt(R_a**2 + N))``, ``N = e (e + 2 (y_a - y_r))`` with ``e`` the
    pixel's offset from the anchor along ``y`` (no cancellation: ``N`` is formed from the
    offset, never as a difference of two ranges).
    """
    key = (int(rows_per_thread), int(block_rows))
    kernel = _KERNELS.get(key)
    if kernel is None:
        kernel = _make_kernel(*key)
        _KERNELS[key] = kernel
    return kernel


def _make_kernel(P: int, by: int):  # noqa: N803 - the paper-style name
    bx = BLOCK_X
    nthreads = bx * by
    chunk = PULSE_CHUNK
    words = 2  # table words per position

    @cuda.jit(fastmath=True)
    def kernel(table, n_table, ant, xs, ys, idx_scale, idx_offset, cycles_per_m, out):
        sh = cuda.shared.array((PULSE_CHUNK, 4), float64)
        acc_re = cuda.local.array(P, float32)
        acc_im = cuda.local.array(P, float32)
        offs = cuda.local.array(P, float32)
        tx = cuda.threadIdx.x
        ty = cuda.threadIdx.y
        tid = ty * bx + tx
        nx = xs.size
        ny = ys.size
        ix = cuda.blockIdx.x * bx + tx
        iy0 = (cuda.blockIdx.y * by + ty) * P
        x = xs[min(ix, nx - 1)]
        ya = 0.5 * (ys[min(iy0, ny - 1)] + ys[min(iy0 + P - 1, ny - 1)])
        for p in range(P):
            acc_re[p] = _ZERO
            acc_im[p] = _ZERO
            offs[p] = float32(ys[min(iy0 + p, ny - 1)] - ya)
        scale32 = float32(idx_scale)
        k_hi = float32(cycles_per_m)
        k_lo = float32(cycles_per_m - float64(k_hi))
        stride = uint64(words * (n_table + 1))
        n_pulses = ant.shape[0]
        for c0 in range(0, n_pulses, chunk):
            n = min(chunk, n_pulses - c0)
            cuda.syncthreads()
            for t in range(tid, 4 * n, nthreads):
                sh[t // 4, t % 4] = ant[c0 + t // 4, t % 4]
            cuda.syncthreads()
            for jj in range(n):
                base = uint64(c0 + jj) * stride
                jr = uint64(jj)
                wx = x - sh[jr, 0]
                wy = ya - sh[jr, 1]
                r2 = wx * wx + wy * wy + sh[jr, 2]
                ra = math.sqrt(r2)
                d0 = ra - sh[jr, 3]
                q0 = d0 * idx_scale + idx_offset
                q0 = min(max(q0, -1.0e6), 1.0e6)  # far outside the table: stays out
                fl0 = math.floor(q0)
                i0 = int32(fl0)
                f0 = float32(q0 - fl0)
                c = d0 * cycles_per_m
                c0f = float32(c - math.floor(c + 0.5))
                raf = float32(ra)
                r2f = float32(r2)
                wyf = float32(wy)
                for p in range(P):
                    if P == 1:
                        dd = _ZERO
                    else:
                        e = offs[p]
                        nn = e * (e + _TWO * wyf)
                        dd = nn / (raf + math.sqrt(r2f + nn))
                    q = f0 + dd * scale32
                    fq = math.floor(q)
                    i = i0 + int32(fq)
                    if i >= 0 and i < n_table:
                        u = float32(q - fq)
                        vr, vi = hermite_at(table, base + uint64(words * i), u)
                        cyc = c0f + dd * k_hi + dd * k_lo
                        cyc = cyc - math.floor(cyc + _HALF32)
                        ang = _TWO_PI * cyc
                        cs = math.cos(ang)
                        sn = math.sin(ang)
                        acc_re[p] += vr * cs - vi * sn
                        acc_im[p] += vr * sn + vi * cs
        for p in range(P):
            iy = iy0 + p
            if ix < nx and iy < ny:
                out[iy, ix, 0] = acc_re[p]
                out[iy, ix, 1] = acc_im[p]

    return kernel
