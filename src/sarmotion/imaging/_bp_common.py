"""What every backprojection kernel shares: the float64 geometry of a call and the table scales.

:class:`Setup` holds the quantities of ``eq:imagecompu`` that do not depend on the pixel,
derived once per call in float64; :class:`KernelConstants` converts a range offset
``d = |r - s u - rho| - |r - rho_o|`` (m) into a position in the upsampled trace table and
into carrier quarter cycles.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.fft as sp_fft
from numpy.typing import ArrayLike, NDArray

from ..core import C, Traces
from ..core.geometry import _as_velocity

#: Default fast-time upsampling of the trace tables: the cubic interpolation error bound of
#: :mod:`.backprojection` is then ``(pi / 6)^4 / 384`` of the trace's amplitude (-74 dB at
#: the band edge, about -88 dB in power over a flat band).
DEFAULT_UPSAMPLE = 6

#: Pulses per block of the numpy reference (progress granularity) and of the FFTs.
PULSE_BLOCK = 32


@dataclass(frozen=True)
class Setup:
    """Everything the kernels need, float64, derived once from the traces."""

    data: NDArray[np.complexfloating]  # (n_pulses, n) traces
    eff_positions: NDArray[np.float64]  # (n_pulses, 3) r(s_j) - s_j u
    ref_ranges: NDArray[np.float64]  # (n_pulses,) |r(s_j) - rho_o|
    carrier_hz: float
    sample_interval_s: float  # dt of the traces
    upsample: int


class KernelConstants(NamedTuple):
    """Scales of a trace table: ``d`` (m) to table position and to carrier quarter cycles."""

    idx_scale: float  # table samples per metre of d
    idx_offset: float  # table position of d = 0
    quarter_scale: float  # quarter carrier cycles per metre of d


def make_setup(traces: Traces, velocity_mps: ArrayLike | None, upsample: int) -> Setup:
    """Validate ``upsample`` and the velocity; the float64 geometry of ``eq:imagecompu``."""
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    if isinstance(upsample, bool) or not isinstance(upsample, (int, np.integer)):
        raise TypeError(f"upsample must be an integer, got {type(upsample).__name__}")
    if not 1 <= int(upsample) <= 64:
        raise ValueError(f"upsample must be between 1 and 64, got {upsample}")
    u = np.zeros(3) if velocity_mps is None else _as_velocity(velocity_mps, name="velocity_mps")
    if u[2] != 0.0:
        raise ValueError(f"velocity_mps must be a ground velocity (uz = 0), got {u}")
    pos = traces.positions_m
    s = traces.slow_times_s
    return Setup(
        data=traces.data,
        eff_positions=pos - s[:, None] * u[None, :],
        ref_ranges=np.linalg.norm(pos - traces.reference_point_m[None, :], axis=1),
        carrier_hz=float(traces.radar.carrier_hz),
        sample_interval_s=float(traces.radar.sample_interval_s),
        upsample=int(upsample),
    )


def table_samples(n_samples: int, upsample: int) -> int:
    """Samples ``N`` of an upsampled trace table over one period ``n dt`` of the trace.

    ``N = upsample n_fast``, ``n_fast = scipy.fft.next_fast_len(n)`` (``>= n``, its prime
    factors at most 11): the trace's ``n`` spectral bins zero-padded to ``n_fast`` sample
    the same band-limited trace over the same period, at ``h = n dt / N <= dt / upsample``
    (every interpolation bound stated for ``dt / upsample`` holds), with transforms of a
    length that has no large prime factor (GOTCHA's 424 = 8 x 53 becomes 432 = 2^4 3^3).
    """
    return int(upsample) * sp_fft.next_fast_len(int(n_samples))


def kernel_constants(
    sample_interval_s: float, carrier_hz: float, n_samples: int, n_up: int
) -> KernelConstants:
    """The scales of a table of ``n_up`` upsampled samples (entry ``p`` is sample ``p - 1``).

    The table samples one period ``n dt`` of traces of ``n = n_samples`` samples at
    ``h = n dt / n_up`` (:func:`table_samples`). ``t = 0`` is upsampled sample
    ``n_up // 2``, table entry ``n_up // 2 + 1``; a delay ``2 d / c`` is ``2 d / (c h)``
    samples; the carrier phase ``2 pi nu_o 2 d / c`` is ``4 (2 nu_o / c) d`` quarter cycles.
    """
    dt_up = sample_interval_s * n_samples / n_up
    return KernelConstants(2.0 / (C * dt_up), float(n_up // 2 + 1), 4.0 * 2.0 * carrier_hz / C)
