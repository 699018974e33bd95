"""The trace table of the GPU kernels, built on the GPU (:func:`build_table`).

The table of :func:`sarmotion.imaging.cuda.hermite_table`: per pulse, the band-limited
trace ``V = D(t_m)`` and ``h D'(t_m)`` at ``t_m = (m - N//2) h``, ``h = n dt / N``,
``N = table_samples(n, U)`` (:func:`~._bp_common.table_samples`), ``m = 0 .. N``
(position ``N`` repeats position 0), each complex64 value stored as one uint64 word (its
two float32), two words per position. From the spectrum
``P_kappa`` of the pulse (:func:`~sarmotion.core.spectral.to_frequency`, signed bins
``kappa = k - n//2``),

    V_m = (1/n) sum_kappa P_kappa exp(2i pi kappa m' / N),
    h D'_m = (2i pi / N) (1/n) sum_kappa kappa P_kappa exp(2i pi kappa m' / N),

``m' = m - N//2``, summed directly: one GPU thread per position, the pulse's spectrum in
shared memory. The spectrum is one ``n``-point FFT per pulse on the host (float64),
``P / n`` rounded to complex64 (``2^-24`` relative). The phase ``kappa m' mod N`` is an
exact integer (advanced by ``m'`` per bin), its angle reduced to ``[-pi, pi)`` and rounded
to float32 (within ``pi 2^-24`` rad), its sine and cosine the GPU's approximations (within
``2^-21.4`` each), the products in float32 (``2^-23``) and the sums in float64. So each
term is within ``sqrt(2) (pi 2^-24 + 2^-21.4) + 2^-24 + 2^-23 < 2^-19`` of ``|P_kappa| / n``
and each entry ``V`` within ``eps = 2^-19`` of ``sum |P_kappa| / n`` (:func:`entry_error`;
``h D'`` within ``eps pi / U`` of it, ``|kappa| <= n / 2``), before its rounding to float32.
:func:`sarmotion.imaging.cuda.error_bound` counts it.

Cost ``N n`` terms per pulse (GOTCHA's 469 pulses of 424 samples at ``U = 8``,
``N = 3456``: 6.9e8 terms in all), on the device, against two ``N``-point FFTs per pulse
on the host for :func:`~sarmotion.imaging.cuda.hermite_table`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import config, float32, float64, int32, int64, uint32, uint64

from ._bp_common import table_samples
from ._cuda_kernels import cuda  # numba.cuda, after its numpy alias

__all__ = ["BINS_PER_STAGE", "THREADS", "build_table", "builds_on_device", "entry_error"]

#: Threads per block (positions of one pulse).
THREADS = 128
#: Spectrum bins staged in shared memory at once.
BINS_PER_STAGE = 512

_MASK32 = np.uint64(0xFFFFFFFF)
_SHIFT32 = np.uint64(32)

if config.ENABLE_CUDASIM:

    @cuda.jit(device=True)
    def _pack(re, im):  # pragma: no cover - the simulator's stand-in
        """The uint64 word whose bits are the complex64 ``re + 1j im``."""
        return np.array([re, im], dtype=np.float32).view(np.uint64)[0]

else:  # pragma: no cover - needs a GPU
    from numba.cuda import libdevice

    @cuda.jit(device=True, inline=True)
    def _pack(re, im):
        """The uint64 word whose bits are the complex64 ``re + 1j im`` (no arithmetic)."""
        lo = uint64(uint32(libdevice.float_as_int(re))) & _MASK32
        hi = uint64(uint32(libdevice.float_as_int(im))) & _MASK32
        return lo | (hi << _SHIFT32)


@cuda.jit(fastmath=True)
def _table_kernel(spec, n, big, out):  # pragma: no cover - compiled
    """Positions ``m <= big`` of pulse ``blockIdx.y``; ``spec`` (n_pulses, n, 2) ``P / n``."""
    sh = cuda.shared.array((BINS_PER_STAGE, 2), float32)
    j = cuda.blockIdx.y
    m = cuda.blockIdx.x * cuda.blockDim.x + cuda.threadIdx.x
    stride = 2 * (big + 1)
    mp = int64(m) - big // 2
    mp = mp % big  # m' mod N, in [0, N)
    kappa0 = -(n // 2)
    e = (int64(kappa0) * mp) % big  # kappa m' mod N, kappa = kappa0
    if e < 0:
        e += big
    step = float32(2.0 * math.pi / big)
    half = big // 2
    vr = float64(0.0)
    vi = float64(0.0)
    dr = float64(0.0)
    di = float64(0.0)
    for k0 in range(0, n, BINS_PER_STAGE):
        cnt = min(BINS_PER_STAGE, n - k0)
        cuda.syncthreads()
        for t in range(cuda.threadIdx.x, cnt, cuda.blockDim.x):
            sh[t, 0] = spec[j, k0 + t, 0]
            sh[t, 1] = spec[j, k0 + t, 1]
        cuda.syncthreads()
        if m <= big:
            for t in range(cnt):
                es = e - big if e >= half else e
                ang = float32(es) * step
                c = math.cos(ang)
                s = math.sin(ang)
                pr = sh[t, 0]
                pi = sh[t, 1]
                ar = pr * c - pi * s
                ai = pr * s + pi * c
                kap = float32(kappa0 + k0 + t)
                vr += ar
                vi += ai
                dr += kap * ar
                di += kap * ai
                e += mp
                if e >= big:
                    e -= big
    if m <= big:
        scale = 2.0 * math.pi / big
        o = j * stride + 2 * int32(m)
        out[o] = _pack(float32(vr), float32(vi))
        out[o + 1] = _pack(float32(-scale * di), float32(scale * dr))


def entry_error() -> float:
    """Bound of a table value's error over ``sum |P_kappa| / n``, before float32 rounding.

    ``2^-19`` (module docstring): float32 angle ``pi 2^-24``, approximate sine and cosine
    ``2^-21.4``, the spectrum's rounding ``2^-24`` and float32 products ``2^-23`` per term;
    the float64 sums add ``n 2^-53``, below the margin for any trace length.
    """
    return 2.0**-19


def builds_on_device() -> bool:
    """Whether images build their tables with :func:`build_table`.

    Not under numba's CUDA simulator, which runs a kernel's threads as Python (``N n``
    steps per pulse): there the images take :func:`~sarmotion.imaging.cuda.hermite_table`,
    the same table from the host's FFTs, and the tests run :func:`build_table` itself on
    small traces.
    """
    return not config.ENABLE_CUDASIM


def build_table(cuda_module, data: np.ndarray, upsample: int):
    """The flat uint64 device table of ``data`` (``(n_pulses, n)`` complex traces)."""
    from ..core import to_frequency

    d = np.asarray(data)
    n_pulses, n = d.shape
    spec = (to_frequency(np.asarray(d, np.complex128)) / n).astype(np.complex64)
    planes = np.ascontiguousarray(spec).view(np.float32).reshape(n_pulses, n, 2)
    dev_spec = cuda_module.to_device(planes)
    big = table_samples(n, upsample)
    out = cuda_module.device_array(n_pulses * 2 * (big + 1), dtype=np.uint64)
    blocks = (-(-(big + 1) // THREADS), n_pulses)
    _table_kernel[blocks, THREADS](dev_spec, n, big, out)
    return out
