"""Separation of the echoes of stationary and moving targets (paper ``sect:algdesc``).

- :mod:`~sarmotion.separation.transforms` — travel-time transformations ``T_+``, ``T_-``
  (``eq:TT+``, ``eq:TTu+``) and the annihilation filters ``Q`` (``eq:OP1``, ``eq:OP2``);
- :mod:`~sarmotion.separation.rpca` — complex robust PCA (principal component pursuit,
  IALM), whole or windowed in fast time (the windows solved together by
  ``_stacked_ialm``); ``solver="accaltproj"`` selects the accelerated alternating
  projections of :mod:`~sarmotion.separation.accaltproj` (fixed rank);
- the methods: :mod:`~sarmotion.separation.annihilation`,
  :mod:`~sarmotion.separation.rpca_separation`, :mod:`~sarmotion.separation.combined`,
  behind one dispatcher :func:`separate` (:mod:`~sarmotion.separation.dispatch`);
- :mod:`~sarmotion.separation.candidates` — stationary candidates from a preliminary image;
- :mod:`~sarmotion.separation.quality` — errors against the true traces.

The rank theory of the trace matrix (``sect:rank``), which only the paper's figures use,
is :mod:`sarmotion.paper.rank`.
"""

from .annihilation import separate_annihilation
from .candidates import (
    NOISE_FALSE_ALARM,
    doppler_contrast_db,
    noise_level,
    noise_only,
    stationary_candidates,
)
from .combined import aligned_constant_part, default_half_window, separate_combined
from .dispatch import METHODS, SeparationOptions, default_method, separate
from .quality import mover_trace_coverage, quality_against_truth, separation_quality
from .result import Separation
from .rpca import (
    RPCAResult,
    choose_window,
    default_eta,
    rpca,
    singular_value_threshold,
    soft_threshold,
    window_bounds,
    window_weights,
    windowed_rpca,
)
from .rpca_separation import separate_rpca
from .transforms import (
    Annihilator,
    annihilate,
    slow_time_difference,
    transform_minus,
    transform_plus,
    travel_time_delays,
)

__all__ = [
    "METHODS",
    "Annihilator",
    "RPCAResult",
    "Separation",
    "SeparationOptions",
    "aligned_constant_part",
    "annihilate",
    "choose_window",
    "default_half_window",
    "default_method",
    "doppler_contrast_db",
    "mover_trace_coverage",
    "rpca",
    "separate",
    "separate_annihilation",
    "separate_combined",
    "separate_rpca",
    "quality_against_truth",
    "separation_quality",
    "slow_time_difference",
    "stationary_candidates",
    "noise_level",
    "noise_only",
    "NOISE_FALSE_ALARM",
    "transform_minus",
    "transform_plus",
    "travel_time_delays",
    "windowed_rpca",
    "default_eta",
    "singular_value_threshold",
    "soft_threshold",
    "window_bounds",
    "window_weights",
]
