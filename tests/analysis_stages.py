"""The analysis's stages as ``analyze`` runs them, for tests that look inside."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarmotion.core import Traces, cross_range_speed, range_speed
from sarmotion.imaging import Image, resolution
from sarmotion.motion import RangeSpeedDetection, central_sub_aperture, family_member
from sarmotion.pipeline import AnalysisOptions
from sarmotion.pipeline.stages import estimate_movers, find_range_speeds, preliminary_image
from sarmotion.separation import Separation, SeparationOptions, separate


@dataclass
class Detected:
    """Separation and detection on the central sub-aperture (default options)."""

    traces: Traces
    options: AnalysisOptions
    central: slice
    sub: Traces
    image: Image
    separation: Separation
    detection: RangeSpeedDetection

    @property
    def moving_sub(self) -> np.ndarray:
        return self.separation.moving[self.central]

    def movers(self, *, refit: bool = True) -> list:
        """The movers' fits; ``refit=False`` stops at the fit on the separated traces."""
        fits, _ = estimate_movers(
            self.traces,
            self.separation.moving,
            self.detection,
            self.options,
            central=self.central,
            image=self.image if refit else None,
        )
        return fits


def detect(traces: Traces, method: str, size_m: float | None = None) -> Detected:
    """Preliminary image, separation by ``method`` and detection, as in ``analyze``."""
    opts = AnalysisOptions(
        separation=SeparationOptions(method=method), trajectory=False, image_size_m=size_m
    ).resolved(traces)
    central = central_sub_aperture(traces, opts.sub_aperture_deg)
    sub = traces.select_pulses(central.start, central.stop)
    prelim = preliminary_image(traces, opts)
    sep = separate(traces, prelim, opts.separation)
    detection = find_range_speeds(sub, sep.moving[central], opts)
    return Detected(traces, opts, central, sub, prelim, sep, detection)


def family_errors(sub: Traces, fit, truth) -> np.ndarray:
    """(range position, range speed, cross-range speed) errors on a common cross range.

    The truth is slid along its own (exact) family to the fit's cross-range coordinate,
    where the fit's bound is defined (cross-range coordinate held).
    """
    geom = sub.geometry
    cells = resolution(sub)
    dy = float((fit.position_m[:2] - truth.position_m[:2]) @ cells.cross_range_direction)
    p, v, _ = family_member(sub, truth.position_m, truth.velocity_mps, dy)
    return np.array(
        [
            float((fit.position_m[:2] - p[:2]) @ cells.range_direction),
            range_speed(fit.velocity_mps, geom) - range_speed(v, geom),
            cross_range_speed(fit.velocity_mps, geom) - cross_range_speed(v, geom),
        ]
    )
