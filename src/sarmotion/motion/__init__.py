"""Motion estimation of the movers (paper ``sect:velocity``, ``sect:trajectory``).

Its public names fall in five groups (``__all__`` lists them in this order):

**The paper's objectives** -- the functions the paper maximises or reads:

- :mod:`~sarmotion.motion.range_speed` -- ``g(u)`` (``eq:OBJg``), whose peaks give the
  number of movers and their range speeds;
- :mod:`~sarmotion.motion.cross_range` -- ``g_perp`` (``eq:OBJ2``), whose minimum gives
  the cross-range speed;
- :mod:`~sarmotion.motion.wigner` -- the Wigner transform in slow time and its ridge;
- :mod:`~sarmotion.motion.speed_resolution` -- the resolutions of those speeds.

**The paper's estimators** -- the alternating ``g -> locate -> g_perp`` estimator and the
phase-space trajectory; they serve the paper's figures and the tracker (which knows the
position and seeks only the velocity):

- :mod:`~sarmotion.motion.location` -- a mover's location from its compensated image;
- :mod:`~sarmotion.motion.velocity` -- location and velocity together, alternating;
- :mod:`~sarmotion.motion.phase_space` -- trajectories from the Wigner ridges of
  sub-apertures.

**Detection** -- :mod:`~sarmotion.motion.detector`: detection as a statistical test, the
local-floor statistic of the ``g(u)`` peaks, its measured null distribution and
threshold, the shape test and the focus gain against a stationary explanation;
:mod:`~sarmotion.motion.coherent`: the two-stage coherent detector (``g(u)`` screen,
then the generalized likelihood ratio of the fit) and its clairvoyant bound;
:mod:`~sarmotion.motion.defocus`: movers whose traces look stationary (the stationary
band ``g(u)`` leaves untested), found by their focus over a bank of cross-range speeds.

**Maximum likelihood** -- the estimator of :func:`sarmotion.pipeline.analyze`:

- :mod:`~sarmotion.motion.likelihood` -- maximum-likelihood position and velocity (the
  matched filter, searched globally in cross-range speed), several movers jointly;
- :mod:`~sarmotion.motion.bounds` -- the Cramér–Rao bound of a point mover.

**The aperture** -- :mod:`~sarmotion.motion.aperture`: the cross-range family that fits
the data equally well, and the focus of an estimate on a whole (wide) aperture;
:mod:`~sarmotion.motion.acceleration`: the range acceleration over a wide aperture, with
its Cramér–Rao bound and the rule that says when the data separate it from the
cross-range speed.
"""

from .acceleration import (
    ACCELERATION_PSD,
    RangeAcceleration,
    acceleration_bound,
    acceleration_estimable,
    acceleration_gradients,
    fit_range_acceleration,
    separable_fraction,
)
from .aperture import (
    ApertureFit,
    azimuth_span_deg,
    central_sub_aperture,
    family_direction,
    family_member,
    refine_on_aperture,
)
from .bounds import PointBound, fisher_information, point_mover_bound, range_gradients
from .coherent import (
    COHERENT_NULL_TAIL,
    SCREEN_PROBABILITY,
    clairvoyant_threshold_db,
    coherent_false_alarm_probability,
    coherent_statistic_db,
    coherent_threshold_db,
    effective_cells,
    matched_filter_variance,
    neighbourhood_noise,
    screen_threshold_db,
    searching_threshold_db,
)
from .cross_range import CrossRangeSpeed, cross_range_objective, estimate_cross_range_speed
from .defocus import DefocusCandidate, DefocusScan, defocus_scan
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
    fit_point_mover_at,
    matched_filter_noise_variance,
    noise_variance,
    point_model,
    refine_jointly,
    refit_movers,
)
from .location import MoverLocation, locate_mover
from .phase_space import TrajectoryEstimate, estimate_trajectory, trajectory_error
from .range_speed import (
    RangeSpeeds,
    aligned_range,
    aligned_trace,
    estimate_range_speeds,
    range_speed_objective,
)
from .speed_resolution import cross_range_speed_resolution, range_speed_resolution
from .velocity import EstimationStep, MoverEstimate, estimate_velocity
from .wigner import WignerRidge, wigner_ridge, wigner_slow_time

__all__ = [
    # the paper's objectives
    "RangeSpeeds",
    "aligned_range",
    "aligned_trace",
    "range_speed_objective",
    "estimate_range_speeds",
    "cross_range_objective",
    "CrossRangeSpeed",
    "estimate_cross_range_speed",
    "WignerRidge",
    "wigner_ridge",
    "wigner_slow_time",
    "cross_range_speed_resolution",
    "range_speed_resolution",
    # the paper's estimators
    "MoverLocation",
    "locate_mover",
    "EstimationStep",
    "MoverEstimate",
    "estimate_velocity",
    "TrajectoryEstimate",
    "estimate_trajectory",
    "trajectory_error",
    # detection
    "NULL_TAIL",
    "PeakStatistics",
    "RangeSpeedDetection",
    "StationaryExplanation",
    "alias_free_extent_m",
    "detect_range_speeds",
    "duplicate_fits",
    "false_alarm_probability",
    "local_floor",
    "local_statistic",
    "peak_statistics",
    "point_peak_width",
    "stationary_explanation",
    "threshold_db",
    "COHERENT_NULL_TAIL",
    "SCREEN_PROBABILITY",
    "clairvoyant_threshold_db",
    "coherent_false_alarm_probability",
    "coherent_statistic_db",
    "coherent_threshold_db",
    "effective_cells",
    "matched_filter_variance",
    "neighbourhood_noise",
    "screen_threshold_db",
    "searching_threshold_db",
    "DefocusCandidate",
    "DefocusScan",
    "defocus_scan",
    # maximum likelihood
    "MatchedFilter",
    "PointFit",
    "fit_point_mover",
    "fit_point_mover_at",
    "matched_filter_noise_variance",
    "noise_variance",
    "point_model",
    "refine_jointly",
    "refit_movers",
    "PointBound",
    "fisher_information",
    "point_mover_bound",
    "range_gradients",
    # the aperture
    "ApertureFit",
    "azimuth_span_deg",
    "central_sub_aperture",
    "family_direction",
    "family_member",
    "refine_on_aperture",
    "ACCELERATION_PSD",
    "RangeAcceleration",
    "acceleration_bound",
    "acceleration_estimable",
    "acceleration_gradients",
    "fit_range_acceleration",
    "separable_fraction",
]
