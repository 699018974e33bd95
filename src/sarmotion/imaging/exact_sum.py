"""The backprojection sum evaluated exactly: the yardstick of every imaging accuracy figure.

Backprojection (``eq:image``, ``eq:imagecompu``) reads each pulse's band-limited trace
at the pixel's differential delay ``dtau_j`` and restores the carrier phase. Written with
the deramped phase history ``P(s_j, f_k)`` (:meth:`~sarmotion.core.traces.Traces.phase_history`,
``f_k = radar.frequencies_hz``), both steps together are one sum over frequencies,

    I(rho) = sum_j w_j (1/n) sum_k P(s_j, f_k) exp(2i pi f_k dtau_j),
    dtau_j = 2 (|r(s_j) - s_j u - rho| - |r(s_j) - rho_o|) / c,

with no interpolation: the same value as
:func:`~sarmotion.imaging.point_response` (which sums every pulse). ``w_j`` is the
fast-time window rule of backprojection: 1 when ``dtau_j`` lies in the span of the traces'
table, ``[-(N//2) h, (N - 1 - N//2) h)`` with ``h = n dt / N`` and ``N`` its samples
(:func:`~._bp_common.table_samples`; :func:`fast_time_window`), else 0 (a pulse
contributes nothing where its fast-time window does not reach). The sums run compiled, in
float64, ``n`` complex products per pulse and pixel (the phasor advanced by a fixed
rotation and re-seeded exactly every 32 terms): slow, meant for references on a few
hundred thousand pixels.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import C, Traces
from ..core.geometry import _as_velocity
from ..core.spectral import unit_phasor
from ._bp_common import DEFAULT_UPSAMPLE, table_samples

__all__ = ["exact_sum", "fast_time_window"]


def fast_time_window(
    n_samples: int, sample_interval_s: float, upsample: int
) -> tuple[float, float]:
    """Delays ``[lo, hi)`` (s) at which backprojection reads a trace.

    The span of the upsampled table: from upsampled sample 0 to sample ``N - 1``
    (``N = table_samples(n_samples, upsample)``), ``t_m = (m - N//2) h``,
    ``h = n_samples dt / N``.
    """
    big = table_samples(n_samples, upsample)
    h = float(sample_interval_s) * int(n_samples) / big
    return -(big // 2) * h, (big - 1 - big // 2) * h


#: Pixels per task of the compiled sum; the inner loop runs across them (SIMD).
_BLOCK = 64


@numba.njit(nogil=True, parallel=True, cache=True, fastmath={"contract"})
def _exact_kernel(pr, pi, f0, df, ant, ref, px, py, t_lo, t_hi):  # pragma: no cover - compiled
    n_pix = px.size
    n_pulses, n = pr.shape
    out = np.zeros(n_pix, np.complex128)
    n_blocks = (n_pix + _BLOCK - 1) // _BLOCK
    for b in numba.prange(n_blocks):
        i0 = b * _BLOCK
        m = min(n_pix, i0 + _BLOCK) - i0
        acc_re = np.zeros(_BLOCK)
        acc_im = np.zeros(_BLOCK)
        tau = np.zeros(_BLOCK)
        inside = np.zeros(_BLOCK, np.bool_)
        rot_re = np.zeros(_BLOCK)
        rot_im = np.zeros(_BLOCK)
        w_re = np.zeros(_BLOCK)
        w_im = np.zeros(_BLOCK)
        for j in range(n_pulses):
            any_in = False
            for i in range(m):
                dx = ant[j, 0] - px[i0 + i]
                dy = ant[j, 1] - py[i0 + i]
                r = math.sqrt(dx * dx + dy * dy + ant[j, 2] * ant[j, 2])
                t = 2.0 * (r - ref[j]) / C
                inside[i] = t >= t_lo and t < t_hi
                any_in = any_in or inside[i]
                tau[i] = t if inside[i] else 0.0
                step = t * df
                z = unit_phasor(step - math.floor(step)) if inside[i] else 0j
                rot_re[i] = z.real
                rot_im[i] = z.imag
            if not any_in:
                continue
            for k0 in range(0, n, 32):
                for i in range(m):
                    c = tau[i] * (f0 + df * k0)
                    z = unit_phasor(c - math.floor(c)) if inside[i] else 0j
                    w_re[i] = z.real
                    w_im[i] = z.imag
                for k in range(k0, min(k0 + 32, n)):
                    a = pr[j, k]
                    bb = pi[j, k]
                    for i in range(_BLOCK):
                        wr = w_re[i]
                        wi = w_im[i]
                        acc_re[i] += a * wr - bb * wi
                        acc_im[i] += a * wi + bb * wr
                        w_re[i] = wr * rot_re[i] - wi * rot_im[i]
                        w_im[i] = wr * rot_im[i] + wi * rot_re[i]
        for i in range(m):
            out[i0 + i] = complex(acc_re[i], acc_im[i]) / n
    return out


def exact_sum(
    traces: Traces,
    points_m: ArrayLike,
    *,
    velocity_mps: ArrayLike | None = None,
    upsample: int = DEFAULT_UPSAMPLE,
    phase_history: ArrayLike | None = None,
) -> NDArray[np.complex128]:
    """The backprojection sum at ground points, without interpolation (module docstring).

    Parameters
    ----------
    traces : Traces
        Data and acquisition.
    points_m : (..., 2) array_like
        Ground points ``(x, y)`` (m), ``z = 0``.
    velocity_mps : (2,) array_like, optional
        Compensated ground velocity (m/s).
    upsample : int
        Upsampling of the image being checked: sets the fast-time window
        (:func:`fast_time_window`) only.
    phase_history : (n_pulses, n_samples) array_like, optional
        ``traces.phase_history()`` if already computed.

    Returns
    -------
    ndarray
        complex128, shape ``points_m.shape[:-1]``, the units of :func:`backproject`.
    """
    p = np.asarray(points_m, dtype=np.float64)
    if p.ndim < 1 or p.shape[-1] != 2:
        raise ValueError(f"points_m must have shape (..., 2) (m), got {p.shape}")
    u = np.zeros(3) if velocity_mps is None else _as_velocity(velocity_mps, name="velocity_mps")
    P = np.ascontiguousarray(
        traces.phase_history() if phase_history is None else phase_history, np.complex128
    )
    pos = traces.positions_m
    ant = np.ascontiguousarray(pos - traces.slow_times_s[:, None] * u[None, :])
    ref = np.linalg.norm(pos - traces.reference_point_m[None, :], axis=1)
    f = traces.frequencies_hz
    lo, hi = fast_time_window(traces.n_samples, traces.radar.sample_interval_s, upsample)
    flat = p.reshape(-1, 2)
    out = _exact_kernel(
        np.ascontiguousarray(P.real), np.ascontiguousarray(P.imag), float(f[0]),
        float(traces.radar.frequency_step_hz), ant, ref, np.ascontiguousarray(flat[:, 0]),
        np.ascontiguousarray(flat[:, 1]), lo, hi,
    )  # fmt: skip
    return out.reshape(p.shape[:-1])
