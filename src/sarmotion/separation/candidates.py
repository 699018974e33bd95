"""Stationary target candidates: bright points of a preliminary image, Doppler-tested."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import Traces
from ..core.spectral import phased_row_sums
from ..imaging import find_peaks, resolution
from .transforms import travel_time_delays

__all__ = ["stationary_candidates", "doppler_contrast_db"]


# ----------------------------------------------------------------- candidates
def stationary_candidates(
    image_values: ArrayLike,
    *,
    x_m: ArrayLike,
    y_m: ArrayLike,
    traces: Traces,
    threshold_db: float = -25.0,
    max_targets: int = 100,
    separation_cells: float = 0.5,
) -> NDArray[np.float64]:
    """Bright points of a preliminary image, resolution-aware (brightest first), m.

    The non-maximum-suppression radius is ``separation_cells`` times the larger of the
    ground-range and cross-range resolutions of ``traces`` (see
    :func:`sarmotion.imaging.resolution`).
    """
    res = resolution(traces)
    radius = separation_cells * max(res.ground_range_m, res.cross_range_m)
    return find_peaks(
        image_values,
        x_m=x_m,
        y_m=y_m,
        threshold_db=threshold_db,
        min_separation_m=radius,
        max_peaks=max_targets,
        suppression="window",
    )


def doppler_contrast_db(
    traces: Traces, point_m: ArrayLike, *, phase_history: ArrayLike | None = None
) -> float:
    """Zero-Doppler over median Doppler power (dB) of the column ``t = 0`` after ``T_+^{rho}``.

    A stationary target at ``rho`` is a zero-Doppler peak of that column (tens of dB);
    the streak of a mover is a short burst with a flat Doppler spectrum (~0 dB).
    """
    P = traces.phase_history() if phase_history is None else np.asarray(phase_history)
    f = traces.frequencies_hz
    delays = np.ascontiguousarray(travel_time_delays(traces, point_m), dtype=np.float64)
    rows = np.ascontiguousarray(P, dtype=np.complex128)
    column = phased_row_sums(rows, delays, float(f[0]), float(traces.radar.frequency_step_hz))
    column /= traces.n_samples
    doppler = np.abs(np.fft.fft(column)) ** 2
    floor = float(np.median(doppler))
    if floor <= 0:
        return float("inf")
    return float(10 * np.log10(max(doppler[0], np.finfo(float).tiny) / floor))
