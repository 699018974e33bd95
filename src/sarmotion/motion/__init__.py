"""Motion estimation of the movers (paper ``sect:velocity``, ``sect:trajectory``).

- :mod:`~sarmotion.motion.range_speed` — the number of movers and their range speeds,
  peaks of ``g(u)`` (``eq:OBJg``);
- :mod:`~sarmotion.motion.location` — a mover's location from its compensated image;
- :mod:`~sarmotion.motion.cross_range` — the cross-range speed from ``g_perp`` (``eq:OBJ2``);
- :mod:`~sarmotion.motion.velocity` — location and velocity together, alternating;
- :mod:`~sarmotion.motion.speed_resolution` — the resolutions of those speeds;
- :mod:`~sarmotion.motion.detector` — detection as a statistical test: the local-floor
  statistic of the ``g(u)`` peaks, its measured null distribution and threshold, the
  shape test and the focus gain against a stationary explanation;
- :mod:`~sarmotion.motion.likelihood` — maximum-likelihood position and velocity (the
  matched filter, searched globally in cross-range speed), several movers jointly;
- :mod:`~sarmotion.motion.bounds` — the Cramér–Rao bound of a point mover;
- :mod:`~sarmotion.motion.aperture` — the cross-range family that fits the data equally
  well, and the focus of an estimate on a whole (wide) aperture;
- :mod:`~sarmotion.motion.wigner` — the Wigner transform in slow time and its ridge;
- :mod:`~sarmotion.motion.phase_space` — trajectories from the Wigner ridges of sub-apertures.
"""

from .aperture import (
    ApertureFit,
    azimuth_span_deg,
    central_sub_aperture,
    family_direction,
    family_member,
    refine_on_aperture,
)
from .bounds import PointBound, fisher_information, point_mover_bound, range_gradients
from .cross_range import CrossRangeSpeed, cross_range_objective, estimate_cross_range_speed
from .detector import (
    NULL_TAIL,
    PeakStatistics,
    RangeSpeedDetection,
    StationaryExplanation,
    alias_free_extent_m,
    detect_range_speeds,
    false_alarm_probability,
    local_floor,
    local_statistic,
    peak_statistics,
    point_peak_width,
    stationary_explanation,
    threshold_db,
)
from .likelihood import (
    MatchedFilter,
    PointFit,
    duplicate_fits,
    fit_point_mover,
    matched_filter_noise_variance,
    noise_variance,
    point_model,
    refine_jointly,
    refit_movers,
)
from .location import MoverLocation, locate_mover
from .phase_space import TrajectoryEstimate, estimate_trajectory, trajectory_error
from .range_speed import RangeSpeeds, estimate_range_speeds, range_speed_objective
from .speed_resolution import cross_range_speed_resolution, range_speed_resolution
from .velocity import MoverEstimate, estimate_velocity
from .wigner import WignerRidge, wigner_ridge, wigner_slow_time

__all__ = [
    "NULL_TAIL",
    "MatchedFilter",
    "PeakStatistics",
    "PointBound",
    "PointFit",
    "RangeSpeedDetection",
    "StationaryExplanation",
    "alias_free_extent_m",
    "detect_range_speeds",
    "duplicate_fits",
    "false_alarm_probability",
    "fisher_information",
    "fit_point_mover",
    "local_floor",
    "local_statistic",
    "matched_filter_noise_variance",
    "noise_variance",
    "peak_statistics",
    "point_model",
    "point_peak_width",
    "point_mover_bound",
    "range_gradients",
    "refine_jointly",
    "refit_movers",
    "stationary_explanation",
    "threshold_db",
    "ApertureFit",
    "CrossRangeSpeed",
    "MoverEstimate",
    "MoverLocation",
    "RangeSpeeds",
    "TrajectoryEstimate",
    "WignerRidge",
    "azimuth_span_deg",
    "central_sub_aperture",
    "cross_range_objective",
    "cross_range_speed_resolution",
    "estimate_cross_range_speed",
    "estimate_range_speeds",
    "estimate_trajectory",
    "estimate_velocity",
    "family_direction",
    "family_member",
    "locate_mover",
    "range_speed_objective",
    "range_speed_resolution",
    "refine_on_aperture",
    "trajectory_error",
    "wigner_ridge",
    "wigner_slow_time",
]
