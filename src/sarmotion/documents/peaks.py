"""The ``sarmotion.peaks/1`` document: the brightest points of an image.

Keys: ``schema``; ``peaks``, each ``{"position_m": [x, y], "peak_db", "quality"}`` with
``peak_db`` the point's level re the brightest one (``20 log10 |v| / |v_max|``, dB;
zero-valued points are left out) and ``quality`` its point-target quality
(:func:`sarmotion.imaging.point_quality`, or why it has none); ``autofocus`` (the
phase-gradient autofocus applied, or null); ``seconds`` (wall-clock of the image, s) and
``pixel_pulses_per_second`` (pixels times pulses over ``seconds``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .schema import stamped

__all__ = ["PEAKS_SCHEMA", "peaks_document"]

#: Schema name of the peaks document.
PEAKS_SCHEMA = "sarmotion.peaks/1"


def peaks_document(
    peaks: Sequence[tuple[float, float, complex]],
    *,
    quality: Sequence[dict[str, Any]],
    autofocus: dict[str, Any] | None,
    seconds: float,
    pixel_pulses: int,
) -> dict[str, Any]:
    """The ``sarmotion.peaks/1`` document (module notes).

    Parameters
    ----------
    peaks : sequence of (x, y, value)
        The image's brightest points, brightest first (:meth:`sarmotion.imaging.Image.peaks`):
        position (m) and complex pixel value.
    quality : sequence of dict
        The point-target quality of each non-zero peak, in the same order.
    autofocus : dict or None
        The autofocus applied to the traces (``AutofocusResult.to_dict()``), or None.
    seconds : float
        Wall-clock time of the image (s), > 0.
    pixel_pulses : int
        Pixels of the image times pulses backprojected.
    """
    return stamped(
        PEAKS_SCHEMA,
        {
            "peaks": [
                {
                    "position_m": [x, y],
                    "peak_db": 20 * np.log10(abs(v) / abs(peaks[0][2])),
                    "quality": q,
                }
                for (x, y, v), q in zip([p for p in peaks if abs(p[2]) > 0], quality, strict=True)
            ],
            "autofocus": autofocus,
            "seconds": seconds,
            "pixel_pulses_per_second": pixel_pulses / seconds,
        },
    )
