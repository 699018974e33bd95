"""Point-target quality: impulse-response width, PSLR and ISLR against their theory.

A bright isolated point is measured on two cuts through its (refined) peak, along the
look's ground-range direction and its cross-range direction (:func:`resolution`). The
cuts are the exact point response of the phase history (:func:`point_response`: the
backprojection sum without interpolation), sampled ``samples_per_cell`` times per
resolution cell over ``+-n_cells`` cells: an arbitrarily oversampled chip, free of the
pixel grid and of the carrier phase a pixel grid cannot sample.

On each cut ``|I(l)|``, with its maximum at ``l_0`` and its main lobe between the first
local minima either side (the first nulls):

- **IRW**: the distance between the two ``-3 dB`` crossings of ``|I|`` (m);
- **PSLR**: ``20 log10(max |I| outside the main lobe / |I(l_0)|)`` (dB);
- **ISLR**: ``10 log10(sum |I|^2 outside the main lobe / sum |I|^2 inside)`` over the
  cut (dB): a 1-D ISLR over ``+-n_cells`` cells.

Theory (:func:`sinc_quality`): a flat (rect) spectrum of width ``1 / cell`` gives the
response ``sinc(l / cell)``, ``sinc(x) = sin(pi x) / (pi x)``, so

- IRW ``= 0.8859 cell`` (``sinc^2(x) = 1/2`` at ``|x| = 0.44295``);
- PSLR ``= -13.26 dB`` (the first sidelobe, ``|x| = 1.4303``);
- ISLR over ``|x| <= n`` ``= 10 log10((F(n) - F(1)) / F(1))`` with
  ``F(X) = int_0^X sinc^2 = Si(2 pi X) / pi - sin^2(pi X) / (pi^2 X)`` (by parts):
  ``-9.68 dB`` for ``n -> inf``, ``-10.16 dB`` for ``n = 10``.

The cells are those of :func:`~sarmotion.imaging.resolution`: ground range
``c / (2 B cos(elevation))``, cross range ``lambda_o L / (2 a)``. The range spectrum of
the data is the rect of ``Radar(pulse="rect")``; the cross-range spectrum is flat when
the pulses are evenly spaced in look angle with equal weights, up to the polar support's
keystone (its width grows with frequency by the fractional bandwidth ``B / nu_o``), which
softens its edges slightly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import sici

from ..core import Traces, as_point
from .point_response import point_response, refine_location
from .resolution import _half_power_width, resolution

__all__ = [
    "CutQuality",
    "PointQuality",
    "SINC_IRW_FACTOR",
    "SINC_PSLR_DB",
    "cut_quality",
    "gaussian_quality",
    "point_quality",
    "sinc_islr_db",
    "sinc_quality",
]

#: 3 dB width of ``sinc^2`` in units of its cell: ``2 x`` with ``sinc^2(x) = 1/2``.
SINC_IRW_FACTOR = 0.88589
#: Peak sidelobe of ``sinc`` (dB): ``20 log10 |sinc(1.4303)|``.
SINC_PSLR_DB = -13.2619


# ======================================================================== theory
def sinc_islr_db(n_cells: float) -> float:
    """ISLR (dB) of ``sinc`` over ``|x| <= n_cells``, main lobe ``|x| < 1`` (module docstring)."""
    n = float(n_cells)
    if not (math.isfinite(n) and n > 1):
        raise ValueError(f"n_cells must be a number > 1, got {n_cells!r}")

    def integral(x: float) -> float:
        return float(sici(2.0 * math.pi * x)[0]) / math.pi - math.sin(math.pi * x) ** 2 / (
            math.pi**2 * x
        )

    main = integral(1.0)
    return 10.0 * math.log10((integral(n) - main) / main)


def gaussian_quality(cell_m: float) -> CutQuality:
    """Theoretical quality of the pulse ``exp(-B^2 t^2 / 2)`` of ``Radar(pulse="gaussian")``.

    The power ``exp(-B^2 t^2)`` is one half at ``B t = sqrt(ln 2)``: an IRW of
    ``2 sqrt(ln 2) / B`` in time, ``2 sqrt(ln 2) cell`` along the cut with ``cell`` the
    resolution cell ``c / (2B)`` projected on it. No sidelobes: PSLR and ISLR ``-inf``.
    """
    return CutQuality(
        irw_m=2.0 * math.sqrt(math.log(2.0)) * float(cell_m),
        pslr_db=-math.inf,
        islr_db=-math.inf,
        offset_m=0.0,
    )


def sinc_quality(cell_m: float, *, n_cells: float = 10.0) -> CutQuality:
    """Theoretical quality of a rect spectrum of resolution cell ``cell_m`` (m)."""
    return CutQuality(
        irw_m=SINC_IRW_FACTOR * float(cell_m),
        pslr_db=SINC_PSLR_DB,
        islr_db=sinc_islr_db(n_cells),
        offset_m=0.0,
    )


# ======================================================================= measure
@dataclass(frozen=True, kw_only=True)
class CutQuality:
    """Quality figures of one cut through a point.

    Attributes
    ----------
    irw_m : float
        -3 dB impulse-response width (m).
    pslr_db : float
        Peak sidelobe ratio (dB, < 0).
    islr_db : float
        Integrated sidelobe ratio over the cut (dB).
    offset_m : float
        Position of the cut's maximum relative to the cut centre (m).
    """

    irw_m: float
    pslr_db: float
    islr_db: float
    offset_m: float


def cut_quality(offsets_m: ArrayLike, profile: ArrayLike) -> CutQuality:
    """IRW, PSLR and ISLR of a uniformly sampled cut ``|I(l)|`` (module docstring).

    Parameters
    ----------
    offsets_m : (n,) array_like
        Uniform, increasing positions along the cut (m).
    profile : (n,) array_like
        The response on the cut (complex or magnitude).

    Returns
    -------
    CutQuality

    Raises
    ------
    ValueError
        If the main lobe has no null (local minimum) on either side within the cut, or
        no sidelobe lies in the cut.
    """
    ell = np.asarray(offsets_m, dtype=np.float64)
    a = np.abs(np.asarray(profile))
    if ell.ndim != 1 or a.shape != ell.shape or ell.size < 11:
        raise ValueError(
            f"offsets_m and profile must be 1-D of the same length >= 11, got {ell.shape}, "
            f"{a.shape}"
        )
    k = int(np.argmax(a))
    if a[k] == 0:
        raise ValueError("the profile is identically zero")
    left = k
    while left > 0 and a[left - 1] <= a[left]:
        left -= 1
    right = k
    while right < a.size - 1 and a[right + 1] <= a[right]:
        right += 1
    if left == 0 or right == a.size - 1:
        raise ValueError(
            "the main lobe has no null within the cut on both sides: the point is not "
            "isolated, or the cut is too short"
        )
    main = np.zeros(a.size, dtype=bool)
    main[left : right + 1] = True
    side = a[~main]
    power = a**2
    return CutQuality(
        irw_m=_half_power_width(ell, a),
        pslr_db=float(20.0 * np.log10(side.max() / a[k])),
        islr_db=float(10.0 * np.log10(power[~main].sum() / power[main].sum())),
        offset_m=float(ell[k]),
    )


@dataclass(frozen=True, kw_only=True, eq=False)
class PointQuality:
    """Quality of one point: measured and theoretical figures along range and cross range.

    Attributes
    ----------
    position_m : (3,) ndarray
        The refined peak (m).
    amplitude : float
        ``|I|`` at the peak (data units times ``n_pulses``).
    range, cross_range : CutQuality
        Measured along the ground-range and cross-range directions.
    range_theory, cross_range_theory : CutQuality
        Rect-spectrum theory for the data's bandwidth and aperture (:func:`sinc_quality`).
    range_direction, cross_range_direction : (2,) ndarray
        The unit ground directions of the cuts.
    n_cells : float
        Half length of the cuts in resolution cells.
    """

    position_m: NDArray[np.float64]
    amplitude: float
    range: CutQuality
    cross_range: CutQuality
    range_theory: CutQuality
    cross_range_theory: CutQuality
    range_direction: NDArray[np.float64]
    cross_range_direction: NDArray[np.float64]
    n_cells: float

    def to_dict(self) -> dict:
        """JSON-ready figures (m, dB)."""

        def cut(q: CutQuality, t: CutQuality) -> dict:
            pairs = {
                "irw_m": q.irw_m,
                "irw_theory_m": t.irw_m,
                "pslr_db": q.pslr_db,
                "pslr_theory_db": t.pslr_db,
                "islr_db": q.islr_db,
                "islr_theory_db": t.islr_db,
            }
            return {k: (v if math.isfinite(v) else None) for k, v in pairs.items()}

        return {
            "position_m": [float(v) for v in self.position_m[:2]],
            "range": cut(self.range, self.range_theory),
            "cross_range": cut(self.cross_range, self.cross_range_theory),
            "n_cells": self.n_cells,
        }


def point_quality(
    traces: Traces,
    point_m: ArrayLike,
    *,
    velocity_mps: ArrayLike | None = None,
    refine: bool = True,
    n_cells: float = 10.0,
    samples_per_cell: int = 16,
) -> PointQuality:
    """Measure IRW, PSLR and ISLR of the point near ``point_m`` (module docstring).

    Parameters
    ----------
    traces : Traces
        The data (its phase history is summed exactly along the cuts).
    point_m : (2,) or (3,) array_like
        The point (m), e.g. an image peak.
    velocity_mps : (2,) array_like, optional
        Compensated ground velocity (m/s), for a mover's image.
    refine : bool
        First move ``point_m`` to the maximum of ``|I|`` (:func:`refine_location`).
    n_cells : float
        Half length of each cut in resolution cells (> 1.5, to hold the first sidelobe).
    samples_per_cell : int
        Samples per resolution cell along each cut (>= 8).

    Returns
    -------
    PointQuality
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    if not (math.isfinite(float(n_cells)) and n_cells > 1.5):
        raise ValueError(f"n_cells must be a number > 1.5, got {n_cells!r}")
    if not (isinstance(samples_per_cell, (int, np.integer)) and samples_per_cell >= 8):
        raise ValueError(f"samples_per_cell must be an integer >= 8, got {samples_per_cell!r}")
    p = as_point(point_m, name="point_m")
    ph = traces.phase_history()
    if refine:
        p, _ = refine_location(traces, p, velocity_mps=velocity_mps, phase_history=ph)
    res = resolution(traces, point_m=p)
    figures = []
    for cell, direction in (
        (res.ground_range_m, res.range_direction),
        (res.cross_range_m, res.cross_range_direction),
    ):
        n = int(math.ceil(n_cells * samples_per_cell))
        ell = np.arange(-n, n + 1, dtype=np.float64) * (cell / samples_per_cell)
        line = np.zeros((ell.size, 3))
        line[:, :2] = p[None, :2] + ell[:, None] * direction[None, :]
        prof = point_response(traces, line, velocity_mps=velocity_mps, phase_history=ph)
        figures.append(cut_quality(ell, prof))
    amplitude = float(
        np.abs(point_response(traces, p, velocity_mps=velocity_mps, phase_history=ph))[0]
    )
    return PointQuality(
        position_m=p,
        amplitude=amplitude,
        range=figures[0],
        cross_range=figures[1],
        range_theory=(
            gaussian_quality(res.ground_range_m)
            if traces.radar.pulse == "gaussian"
            else sinc_quality(res.ground_range_m, n_cells=n_cells)
        ),
        cross_range_theory=sinc_quality(res.cross_range_m, n_cells=n_cells),
        range_direction=res.range_direction,
        cross_range_direction=res.cross_range_direction,
        n_cells=float(n_cells),
    )
