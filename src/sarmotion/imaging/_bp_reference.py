"""The plain numpy reference of backprojection: float64 throughout, one pulse at a time.

It evaluates the same interpolation as the compiled kernels (the cubic pieces of
:mod:`._bp_table`, built in complex128), so the compiled kernels are checked against it to
their float32 rounding, and the interpolation itself against
:func:`~sarmotion.imaging.exact_sum.exact_sum`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..core import C, ProgressCallback
from ._bp_common import PULSE_BLOCK, Setup
from ._bp_table import hermite_coefficients


def accumulate(
    st: Setup, j0: int, j1: int, px: NDArray, py: NDArray, out: NDArray[np.complex128]
) -> None:
    """Add pulses ``j0:j1`` of ``eq:imagecompu`` at points ``(px, py, 0)`` to ``out``."""
    coef = hermite_coefficients(st.data[j0:j1], st.upsample)
    big = coef.shape[1] - 2
    h = st.sample_interval_s * st.data.shape[1] / big  # n dt / N
    for k, j in enumerate(range(j0, j1)):
        r = st.eff_positions[j]
        dist = np.sqrt((r[0] - px) ** 2 + (r[1] - py) ** 2 + r[2] ** 2)  # |r - s u - rho|
        dtau = 2.0 * (dist - st.ref_ranges[j]) / C  # eq:DeltaTau, float64
        q = dtau / h + big // 2  # upsampled sample position
        inside = (q >= 0.0) & (q < big - 1)
        m = np.where(inside, np.floor(q), -1.0)
        w = np.where(inside, q - m, 0.0)
        c = coef[k, m.astype(np.intp) + 1]  # entry 0 (m = -1) is zero
        sample = c[..., 0] + w * (c[..., 1] + w * (c[..., 2] + w * c[..., 3]))
        cycles = st.carrier_hz * dtau  # omega_o dtau / (2 pi), up to ~1e4 cycles
        cycles -= np.round(cycles)  # exact reduction before exp
        out += sample * np.exp(2j * np.pi * cycles)


def run_numpy(
    st: Setup, px: NDArray, py: NDArray, progress: ProgressCallback | None
) -> NDArray[np.complex128]:
    """The backprojection sum at points ``(px, py, 0)`` (any common shape)."""
    n_pulses = st.data.shape[0]
    out = np.zeros(np.shape(px), dtype=np.complex128)
    for j0 in range(0, n_pulses, PULSE_BLOCK):
        j1 = min(j0 + PULSE_BLOCK, n_pulses)
        accumulate(st, j0, j1, px, py, out)
        if progress is not None:
            progress("backprojection", j1, n_pulses)
    return out
