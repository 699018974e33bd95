"""The summed echoes of many point targets, compiled: the forward model's hot loop.

The deramped phase history of point targets ``t`` of complex reflectivity ``a_t`` is

    ``P(s_j, f_k) = sum_t a_t exp(-2i pi f_k dtau_t(s_j))``,

``dtau_t(s) = tau(s, rho_t(s)) - tau(s, rho_o)`` (``eq:DeltaTau``, ``rho_t(s) = rho_t(0) + s
u_t``, straight lines). :func:`~sarmotion.simulation.forward.simulate_phase_history` forms
it one target at a time in numpy (an array of phasors per target); a scene of thousands of
scatterers over thousands of pulses and samples (a square kilometre of clutter) needs the
sum without those arrays. :func:`point_echoes` computes each pulse's row in one compiled
pass over the targets, the pulses shared among threads:

- ``dtau`` in float64 as ``2 (|r - rho| - |r - rho_o|) / c`` with the difference of the
  two ranges formed without cancellation, ``(rho_o - rho) . (2 r - rho - rho_o) / (|r -
  rho| + |r - rho_o|)``: exact to the rounding of the difference (``~1e-13`` m for a
  scene of a kilometre), where :func:`~sarmotion.core.delta_tau`'s difference of two
  travel times keeps the rounding of each range (``~1e-12`` m at 10 km, a phase of
  ``~4e-10`` rad at X band);
- each phasor from the exactly reduced phase ``f_k dtau`` by the polynomials of
  :func:`~sarmotion.core.spectral.quarter_turns` (error < 1e-14), as
  :func:`~sarmotion.core.delay_phase` does; no recursion over frequency, so no error
  grows along the row.

The sum agrees with the target-by-target one to that rounding of its travel times: a
travel time ``tau ~ 7e-5`` s rounded to a few ``eps tau ~ 3e-20`` s is a phase of a few
``1e-9`` rad at 10 GHz per term, so ``|err| <= 1e-8 sum_t |a_t|`` (times the largest
spectral weight, where applied) with a margin of about 3
(``tests/simulation/test_echoes.py``; the measured error on
``tests/collection/test_collection_cphd.py``'s scene is a twentieth of that bound).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import C
from ..core.spectral import quarter_turns

__all__ = ["point_echoes"]


def point_echoes(
    antenna_m: ArrayLike,
    slow_times_s: ArrayLike,
    positions_m: ArrayLike,
    velocities_mps: ArrayLike,
    reflectivities: ArrayLike,
    reference_point_m: ArrayLike,
    frequencies_hz: ArrayLike,
) -> NDArray[np.complex128]:
    """Summed echoes of straight-moving point targets, ``P[j, k]`` above.

    Parameters
    ----------
    antenna_m : (n_pulses, 3) array_like
        Antenna positions (m).
    slow_times_s : (n_pulses,) array_like
        Slow times of the pulses (s).
    positions_m : (n_targets, 3) array_like
        Target positions ``rho_t(0)`` at slow time 0 (m).
    velocities_mps : (n_targets, 3) array_like
        Target velocities ``u_t`` (m/s); zeros for stationary targets.
    reflectivities : (n_targets,) array_like
        Complex reflectivities ``a_t``.
    reference_point_m : (3,) array_like
        Range-compression reference ``rho_o`` (m).
    frequencies_hz : (n_freq,) array_like
        Absolute frequencies ``f_k`` (Hz).

    Returns
    -------
    (n_pulses, n_freq) ndarray of complex128
        The phase history, before the pulse's spectral weights.
    """
    r = np.ascontiguousarray(antenna_m, dtype=np.float64).reshape(-1, 3)
    s = np.ascontiguousarray(slow_times_s, dtype=np.float64).reshape(-1)
    p = np.ascontiguousarray(positions_m, dtype=np.float64).reshape(-1, 3)
    u = np.ascontiguousarray(velocities_mps, dtype=np.float64).reshape(-1, 3)
    a = np.ascontiguousarray(reflectivities, dtype=np.complex128).reshape(-1)
    o = np.ascontiguousarray(reference_point_m, dtype=np.float64).reshape(3)
    f = np.ascontiguousarray(frequencies_hz, dtype=np.float64).reshape(-1)
    if s.size != r.shape[0]:
        raise ValueError(f"{s.size} slow times for {r.shape[0]} antenna positions")
    if not (p.shape[0] == u.shape[0] == a.size):
        raise ValueError(
            f"{p.shape[0]} positions, {u.shape[0]} velocities and {a.size} reflectivities "
            "must be one per target"
        )
    out = np.zeros((r.shape[0], f.size), dtype=np.complex128)
    if a.size and f.size:
        _echo_rows(r, s, p, u, a.real.copy(), a.imag.copy(), o, f, out.view(np.float64))
    return out


@numba.njit(nogil=True, parallel=True, cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def _echo_rows(r, s, p, u, ar, ai, o, f, out):  # pragma: no cover - compiled
    """``out[j]`` (float64 (re, im) view) = pulse ``j``'s summed echoes."""
    n_f = f.size
    for j in numba.prange(r.shape[0]):
        re = np.zeros(n_f)
        im = np.zeros(n_f)
        rx, ry, rz = r[j, 0], r[j, 1], r[j, 2]
        sj = s[j]
        ox, oy, oz = o[0], o[1], o[2]
        r_o = math.sqrt((rx - ox) ** 2 + (ry - oy) ** 2 + (rz - oz) ** 2)
        for t in range(ar.size):
            px = p[t, 0] + sj * u[t, 0]
            py = p[t, 1] + sj * u[t, 1]
            pz = p[t, 2] + sj * u[t, 2]
            r_p = math.sqrt((rx - px) ** 2 + (ry - py) ** 2 + (rz - pz) ** 2)
            # |r - p| - |r - o| = (o - p).(2 r - p - o) / (|r - p| + |r - o|): no cancellation
            gap = (ox - px) * (2.0 * rx - px - ox)
            gap += (oy - py) * (2.0 * ry - py - oy)
            gap += (oz - pz) * (2.0 * rz - pz - oz)
            d = -2.0 * gap / ((r_p + r_o) * C)
            a_re, a_im = ar[t], ai[t]
            for k in range(n_f):
                c = d * f[k]
                cs, sn = quarter_turns(4.0 * (c - math.floor(c)))
                re[k] += a_re * cs - a_im * sn
                im[k] += a_re * sn + a_im * cs
        for k in range(n_f):
            out[j, 2 * k] = re[k]
            out[j, 2 * k + 1] = im[k]
