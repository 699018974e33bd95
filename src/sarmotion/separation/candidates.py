"""Stationary target candidates: bright points of a preliminary image, Doppler-tested.

An image whose brightest pixel is what noise alone reaches has no candidate
(:func:`noise_only`): a patch of a large collection that holds no stationary target (the
pulse rate's cross range beyond the illuminated scene, say) would otherwise offer its
noise peaks within ``threshold_db`` of its own brightest, each then tested and removed
as a stationary target.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import Traces
from ..core.spectral import phased_row_sums
from ..imaging import find_peaks, resolution
from .transforms import travel_time_delays

__all__ = [
    "stationary_candidates",
    "doppler_contrast_db",
    "noise_level",
    "noise_only",
    "NOISE_FALSE_ALARM",
]

#: Probability that an image of noise alone is taken for one holding a target
#: (:func:`noise_only`).
NOISE_FALSE_ALARM = 1e-3

#: ``|I|^2`` at or below this share of the brightest pixel's is no pixel the data reach
#: (120 dB down: below any noise floor of single-precision data, above the rounding of
#: an empty pixel of a factorised sum).
REACHED = 1e-12


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
    noise_false_alarm: float | None = NOISE_FALSE_ALARM,
) -> NDArray[np.float64]:
    """Bright points of a preliminary image, resolution-aware (brightest first), m.

    The non-maximum-suppression radius is ``separation_cells`` times the larger of the
    ground-range and cross-range resolutions of ``traces`` (see
    :func:`sarmotion.imaging.resolution`). A candidate is within ``threshold_db`` of the
    brightest pixel and above the level noise alone reaches at ``noise_false_alarm``
    (:func:`noise_level`): none, shape ``(0, 3)``, when the image is consistent with
    noise alone (:func:`noise_only`; ``None`` skips both tests). In an image of noise
    whose brightest pixel just passes, the noise peaks within ``threshold_db`` of it
    were candidates, each tested and removed (200 of them in a patch beyond a square
    kilometre's scene, 2 of a patch's 5 CPU-s).
    """
    res = resolution(traces)
    if noise_false_alarm is not None:
        power = np.abs(np.asarray(image_values)) ** 2
        level = noise_level(
            power,
            n_cells=_n_cells(x_m, y_m, res.ground_range_m, res.cross_range_m),
            false_alarm=noise_false_alarm,
        )
        peak = float(power.max()) if power.size else 0.0
        if peak <= level:
            return np.zeros((0, 3))
        # a peak that noise alone reaches is no candidate either
        threshold_db = max(threshold_db, 10.0 * float(np.log10(level / peak)))
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


def noise_level(image_power: ArrayLike, *, n_cells: float, false_alarm: float) -> float:
    """``|I|^2`` that noise alone exceeds anywhere in the image with probability ``a``.

    Noise backprojected over many samples is a circular complex Gaussian field: ``|I|^2``
    is exponential with mean ``p``, estimated robustly as ``median(|I|^2) / ln 2`` (the
    median of an exponential; a few targets barely move it) over the pixels the data
    reach: those above :data:`REACHED` times the brightest ``|I|^2`` (a collection
    patch's halo image reaches beyond the fast-time window, where it is zero; with those
    pixels the median was zero and every noise image passed for one holding targets),
    the cells counted in proportion. Over ``n_cells`` independent resolution cells the
    largest ``|I|^2`` exceeds ``p ln(n_cells / a)`` with probability about ``a`` (the
    union bound ``n e^{-T}``).

    Parameters
    ----------
    image_power : (ny, nx) array_like
        ``|I|^2`` of the image.
    n_cells : float
        Independent resolution cells in the image (> 0).
    false_alarm : float
        ``a`` in (0, 1).

    Returns
    -------
    float
        The level (``|I|^2`` units); ``inf`` for an image without a pixel the data reach.
    """
    if not 0.0 < false_alarm < 1.0:
        raise ValueError(f"false_alarm must be in (0, 1), got {false_alarm!r}")
    power = np.asarray(image_power, dtype=np.float64)
    if power.size == 0:
        return float("inf")
    held = power[power > REACHED * float(power.max())]
    if held.size == 0:
        return float("inf")
    mean = float(np.median(held)) / np.log(2.0)
    cells = float(n_cells) * held.size / power.size
    return mean * float(np.log(max(cells, 1.0) / false_alarm))


def noise_only(image_values: ArrayLike, *, n_cells: float, false_alarm: float) -> bool:
    """Whether an image's brightest pixel is no brighter than noise alone would make it.

    Its largest ``|I|^2`` is at most :func:`noise_level` (same ``n_cells`` and
    ``false_alarm``); ``image_values`` is the complex image, shape (ny, nx).
    """
    power = np.abs(np.asarray(image_values)) ** 2
    if power.size == 0:
        return True
    return bool(float(power.max()) <= noise_level(power, n_cells=n_cells, false_alarm=false_alarm))


def _n_cells(x_m: ArrayLike, y_m: ArrayLike, range_cell_m: float, cross_cell_m: float) -> float:
    """Resolution cells (ground range by cross range) in the image's extent."""
    x, y = np.asarray(x_m, float), np.asarray(y_m, float)
    dx = float(np.ptp(x)) + (float(x[1] - x[0]) if x.size > 1 else 0.0)
    dy = float(np.ptp(y)) + (float(y[1] - y[0]) if y.size > 1 else 0.0)
    return max(dx * dy / (range_cell_m * cross_cell_m), 1.0)


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
