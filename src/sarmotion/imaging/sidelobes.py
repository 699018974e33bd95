"""Which listed peaks of an image a brighter listed peak's sidelobes can explain.

The point-spread function of a focused point is separable in ground range and cross
range about it: along each axis ``|sinc(a)|`` (``a`` the offset in resolution cells; flat
spectra: the rect pulse in range, evenly spaced pulses in cross range), or
``exp(-a^2 / 2)`` in range for a Gaussian pulse. Outside the main lobe
``|sinc(a)| <= 1 / (pi |a|)``, so a target ``b`` produces nowhere more than
``E(a_r) E(a_c)`` of its level, ``E(a) = 1`` for ``|a| < 1`` and ``1 / (pi |a|)`` beyond
(``a_r``, ``a_c`` along ``b``'s own look direction). The image is the sum of the
targets' responses, so a listed peak whose level is at most the sum of that bound over
the brighter kept peaks, divided by ``w``, can be their sidelobes alone
(:func:`sidelobe_peaks`). ``w`` is the least fraction of a peak its nearest pixel reads
(levels are read there): ``sinc(h / rho_r) sinc(h / rho_c)``, ``h`` half the pixel
spacing. A true target that weak on a brighter one's sidelobe ridge cannot be told from
the sidelobe by its level and goes with it; one off the ridges (``|a_r| >= 1`` and
``|a_c| >= 1``) is kept down to ``E E / w``, at least ``-20 dB - 20 log10 w`` below its
neighbour.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["envelope", "sidelobe_peaks"]


def envelope(a: ArrayLike, gaussian: bool = False) -> NDArray[np.float64]:
    """``E(a)``: 1 in the main lobe, ``1 / (pi |a|)`` beyond; ``exp(-a^2/2)`` if Gaussian.

    ``a`` is the offset from the peak in resolution cells (any shape).
    """
    a = np.abs(np.asarray(a, np.float64))
    if gaussian:
        return np.exp(-0.5 * a * a)
    return np.where(a < 1.0, 1.0, 1.0 / (np.pi * np.maximum(a, 1.0)))


def sidelobe_peaks(
    positions_m: ArrayLike,
    levels: ArrayLike,
    *,
    antenna_m: ArrayLike,
    range_cell_m: float,
    cross_cell_m: float,
    pixel_m: float,
    gaussian_range: bool = False,
) -> NDArray[np.bool_]:
    """Whether each listed peak can be the brighter listed peaks' sidelobes (module notes).

    The peaks are taken brightest first; a peak is a sidelobe when its level is at most
    ``sum_b level_b E(a_r) E(a_c) / w`` over the brighter peaks ``b`` kept so far.

    Parameters
    ----------
    positions_m : (k, 2) array_like
        Ground positions of the peaks (m).
    levels : (k,) array_like
        Their levels, as amplitudes on one linear scale (``|I|``, not dB).
    antenna_m : (3,) array_like
        Antenna position at the aperture centre (m): each peak's look direction.
    range_cell_m, cross_cell_m : float
        Ground-range and cross-range resolution (m).
    pixel_m : float
        Pixel spacing the levels were read at (m).
    gaussian_range : bool
        The compressed pulse is Gaussian (no range sidelobes).

    Returns
    -------
    (k,) ndarray of bool
        True for the peaks the brighter ones' sidelobes explain, in the input order.
    """
    pos = np.asarray(positions_m, np.float64).reshape(-1, 2)
    level = np.asarray(levels, np.float64).reshape(-1)
    if pos.shape[0] != level.size:
        raise ValueError(f"{pos.shape[0]} positions for {level.size} levels")
    out = np.zeros(level.size, np.bool_)
    if level.size == 0:
        return out
    h = 0.5 * pixel_m
    w = float(np.sinc(h / range_cell_m) * np.sinc(h / cross_cell_m))
    look = np.asarray(antenna_m, np.float64)[:2][None, :] - pos
    e_r = look / np.linalg.norm(look, axis=1, keepdims=True)
    kept: list[int] = []
    for i in np.argsort(-level, kind="stable"):
        if kept:
            k = np.array(kept)
            d = pos[i][None, :] - pos[k]
            a_r = np.einsum("ij,ij->i", d, e_r[k]) / range_cell_m
            a_c = (d[:, 0] * -e_r[k, 1] + d[:, 1] * e_r[k, 0]) / cross_cell_m
            bound = level[k] * envelope(a_r, gaussian_range) * envelope(a_c) / w
            if level[i] <= float(bound.sum()):
                out[i] = True
                continue
        kept.append(int(i))
    return out
