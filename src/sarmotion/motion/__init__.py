"""Motion estimation of the movers (paper ``sect:velocity``, ``sect:trajectory``).

- :mod:`~sarmotion.motion.range_speed` — the number of movers and their range speeds,
  peaks of ``g(u)`` (``eq:OBJg``);
- :mod:`~sarmotion.motion.location` — a mover's location from its compensated image;
- :mod:`~sarmotion.motion.cross_range` — the cross-range speed from ``g_perp`` (``eq:OBJ2``);
- :mod:`~sarmotion.motion.velocity` — location and velocity together, alternating;
- :mod:`~sarmotion.motion.speed_resolution` — the resolutions of those speeds;
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
from .cross_range import CrossRangeSpeed, cross_range_objective, estimate_cross_range_speed
from .location import MoverLocation, locate_mover
from .phase_space import TrajectoryEstimate, estimate_trajectory, trajectory_error
from .range_speed import RangeSpeeds, estimate_range_speeds, range_speed_objective
from .speed_resolution import cross_range_speed_resolution, range_speed_resolution
from .velocity import MoverEstimate, estimate_velocity
from .wigner import WignerRidge, wigner_ridge, wigner_slow_time

__all__ = [
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
