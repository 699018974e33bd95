"""Imaging: pixel grids and complex images, backprojection, resolution, peaks, point responses.

- :mod:`~sarmotion.imaging.grid` — :class:`ImageGrid` (pixel axes in m) and :class:`Image`;
- :mod:`~sarmotion.imaging.backprojection` — :func:`backproject` (``eq:image``, with motion
  compensation ``eq:imagecompu``), at pixels or at arbitrary points, with its error bound;
  the trace tables (cubic pieces of the exactly upsampled traces) in ``_bp_table``, the
  numpy reference in ``_bp_reference``, the compiled kernels in ``_bp_kernels`` (float32
  tiles, inner loop in ``_simd``);
- :mod:`~sarmotion.imaging.exact_sum` — the backprojection sum without interpolation, the
  reference of every accuracy figure;
- :mod:`~sarmotion.imaging.ffbp` — fast factorised backprojection for large images
  (``backproject(..., method="ffbp")``);
- :mod:`~sarmotion.imaging.resolution` — the theoretical resolution cell and 3 dB widths;
- :mod:`~sarmotion.imaging.peaks` — the one peak finder (non-maximum suppression);
- :mod:`~sarmotion.imaging.point_response` — the exact point response from the phase
  history, per pulse or summed, and locations refined on it;
- :mod:`~sarmotion.imaging.quality` — point-target quality (IRW, PSLR, ISLR) against
  rect-spectrum theory;
- :mod:`~sarmotion.imaging.autofocus` — phase-gradient autofocus of the phase history.
"""

from .autofocus import AutofocusResult, apply_phase_correction, focus_mover, pga
from .backprojection import backproject, backproject_phase_history, backproject_points
from .exact_sum import exact_sum
from .grid import Image, ImageGrid, default_scene_size_m, in_outline, outline_columns, scene_grid
from .peaks import find_peaks, parabolic_peak
from .point_response import point_response, pulse_responses, refine_location
from .quality import PointQuality, cut_quality, point_quality
from .resolution import Resolution, resolution, width_3db

__all__ = [
    "AutofocusResult",
    "PointQuality",
    "apply_phase_correction",
    "cut_quality",
    "focus_mover",
    "pga",
    "point_quality",
    "Image",
    "ImageGrid",
    "Resolution",
    "backproject",
    "default_scene_size_m",
    "exact_sum",
    "scene_grid",
    "backproject_phase_history",
    "backproject_points",
    "in_outline",
    "outline_columns",
    "find_peaks",
    "parabolic_peak",
    "point_response",
    "pulse_responses",
    "refine_location",
    "resolution",
    "width_3db",
]
