"""The core vocabulary: radar, acquisition geometry, traces and their spectral conventions.

- :mod:`~sarmotion.core.constants` — physical constants (``C``);
- :mod:`~sarmotion.core.radar` — :class:`Radar` (carrier, bandwidth, sampling);
- :mod:`~sarmotion.core.geometry` — :class:`Trajectory`, look geometry, travel times and
  velocity components;
- :mod:`~sarmotion.core.spectral` — fast time and frequency, exact delays;
- :mod:`~sarmotion.core.ascent` — Newton ascent of exact point responses (analytic
  derivatives), for location and velocity fits;
- :mod:`~sarmotion.core.acquisition` — :class:`Acquisition`: trajectory, radar and
  reference point, with their geometry and resolution computed once;
- :mod:`~sarmotion.core.traces` — :class:`Traces`, an acquisition and its data
  ``(n_pulses, n_samples)``;
- :mod:`~sarmotion.core.progress` — the progress-callback convention.
"""

from .acquisition import Acquisition, Resolution
from .constants import C
from .geometry import (
    LookGeometry,
    Trajectory,
    as_point,
    cross_range_speed,
    delta_tau,
    ground_velocity,
    look_geometry,
    range_direction_velocity,
    range_speed,
    target_positions,
    travel_time,
)
from .progress import ProgressCallback
from .radar import PulseShape, Radar
from .spectral import delay_phase, shift_fast_time, to_fast_time, to_frequency
from .traces import Traces, as_traces

__all__ = [
    "Acquisition",
    "C",
    "LookGeometry",
    "ProgressCallback",
    "PulseShape",
    "Radar",
    "Resolution",
    "Trajectory",
    "Traces",
    "as_point",
    "as_traces",
    "cross_range_speed",
    "delay_phase",
    "delta_tau",
    "ground_velocity",
    "look_geometry",
    "range_direction_velocity",
    "range_speed",
    "shift_fast_time",
    "target_positions",
    "to_fast_time",
    "to_frequency",
    "travel_time",
]
