"""Movers followed through a long acquisition: sub-apertures, tracks, roads, Dask.

- :mod:`~sarmotion.tracking.sub_apertures` — overlapping sub-apertures and the
  detections of each one's analysis;
- :mod:`~sarmotion.tracking.scale` — the sub-apertures as independent Dask tasks (a
  local cluster or any scheduler), results in slow-time order;
- :mod:`~sarmotion.tracking.tracker` — Stone Soup association and Kalman filtering, and
  the paper's first scenario: the track's prediction as the known position;
- :mod:`~sarmotion.tracking.roads` — the member of a cross-range family on a road;
- :mod:`~sarmotion.tracking.turns` — a turn as a change of velocity between
  sub-apertures: the chi-square test and the turn rate, and uniform motion against a
  constant acceleration through the looks;
- :mod:`~sarmotion.tracking.wide_aspect` — each detection as a measurement of the range
  history through its look, a track's position fixed where the look turns enough, and
  the tracks of one uniform mover joined;
- :mod:`~sarmotion.tracking.ends` — why a track ends: the data's end, the imaged
  scene's edge, or no detection;
- :mod:`~sarmotion.tracking.track` — :func:`track`, the whole chain.
"""

from .coherent import CoherentFit
from .ends import TrackEnd, track_end
from .roads import Road, RoadFix, road_fix, road_misses
from .scale import map_sub_apertures
from .sub_apertures import (
    Detection,
    SubApertureDetections,
    analyze_sub_aperture,
    sub_aperture_slices,
)
from .track import TrackingResult, track
from .tracker import Track, Tracker, TrackingOptions, TrackState
from .turn_rate import TurnRate
from .turns import TurnTest, turn_test
from .wide_aspect import PositionFit, fit_track, join_tracks

__all__ = [
    "CoherentFit",
    "Detection",
    "PositionFit",
    "Road",
    "RoadFix",
    "SubApertureDetections",
    "Track",
    "TrackEnd",
    "TrackState",
    "Tracker",
    "TrackingOptions",
    "TrackingResult",
    "TurnRate",
    "TurnTest",
    "analyze_sub_aperture",
    "fit_track",
    "track_end",
    "join_tracks",
    "map_sub_apertures",
    "road_fix",
    "road_misses",
    "sub_aperture_slices",
    "track",
    "turn_test",
]
