"""Resolutions of the range and cross-range speed estimates over an aperture."""

from __future__ import annotations

from ..core import Acquisition, Traces
from ._aligned import _aperture_time_s

__all__ = ["range_speed_resolution", "cross_range_speed_resolution"]


def range_speed_resolution(traces: Acquisition | Traces) -> float:
    """Range-speed resolution of ``g`` (m/s): ``(c / 2B) / (T / 2)``.

    A range-speed error ``du`` tilts the aligned trace so that its ends move by
    ``du T / 2`` in range; once that reaches the range resolution ``c / (2B)`` the sum
    over slow time no longer adds the pulse peaks coherently in fast time. ``T`` is the
    aperture duration (s). For GOTCHA, one degree: 0.24 m / 0.88 s = 0.27 m/s.

    Parameters
    ----------
    traces : Acquisition or Traces
        Supplies the bandwidth and the slow times.

    Returns
    -------
    float
        Resolution (m/s).
    """
    _check_acquisition(traces)
    return traces.radar.range_resolution_m / (0.5 * _aperture_time_s(traces))


def cross_range_speed_resolution(traces: Acquisition | Traces) -> float:
    """Cross-range-speed resolution of ``g_perp`` (m/s): ``lambda L / (8 V (T / 2)^2)``.

    A cross-range-speed error ``du_perp`` changes the range acceleration of the target by
    ``-2 V du_perp / L`` (``eq:Dtau``, third term), i.e. the two-way phase by
    ``(4 pi / lambda) (V du_perp / L) s^2``: ``pi / 2`` at the aperture ends ``s = T/2``
    for the returned value (the usual quadratic-phase depth of focus). GOTCHA, one degree:
    0.74 m/s.

    Parameters
    ----------
    traces : Acquisition or Traces
        Supplies wavelength, range ``L``, platform speed ``V`` and slow times.

    Returns
    -------
    float
        Resolution (m/s).
    """
    _check_acquisition(traces)
    g = traces.geometry
    half = 0.5 * _aperture_time_s(traces)
    return traces.radar.wavelength_m * g.range_m / (8.0 * g.speed_mps * half**2)


def _check_acquisition(traces: object) -> None:
    if isinstance(traces, Traces):
        traces = traces.acquisition
    if not isinstance(traces, Acquisition):
        raise TypeError(f"traces must be a sarmotion Traces, got {type(traces).__name__}")
    if traces.n_pulses < 3:
        raise ValueError(f"traces must hold at least 3 pulses, got {traces.n_pulses}")
