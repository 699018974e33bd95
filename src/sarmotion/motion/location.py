"""A mover's location at ``s = 0``: the peak of its motion-compensated image."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize_scalar

from .._validation import finite as _finite
from .._validation import positive as _positive
from ..core import LookGeometry, Traces, as_point, ground_velocity, range_direction_velocity
from ..imaging import (
    Image,
    ImageGrid,
    backproject,
    backproject_points,
    point_response,
    refine_location,
    resolution,
)
from ._aligned import _aperture_time_s, _check_traces

__all__ = ["MoverLocation", "locate_mover"]


# ================================================================= location
@dataclass(frozen=True, kw_only=True, eq=False)
class MoverLocation:
    """A mover's location at ``s = 0`` from its motion-compensated image (:func:`locate_mover`).

    Attributes
    ----------
    position_m : (3,) ndarray
        Location ``rho^e`` (m).
    value : complex
        Exact compensated image ``I_u(rho^e)`` (``eq:imagecompu``,
        :func:`sarmotion.imaging.point_response.point_response`), data units times ``n_pulses``.
    velocity_mps : (2,) ndarray
        Ground velocity used for the compensation (m/s).
    method : str
        ``"peak"`` (focused image: refined brightest point) or ``"centroid"`` (image
        defocused in cross range: energy centroid of a cross-range cut).
    image : sarmotion.imaging.Image
        The compensated image of the search window.
    cut_offsets_m : (n_cut,) ndarray
        Cross-range offsets of the cut (m) from its centre, the brightest pixel
        (``"centroid"`` only; empty otherwise).
    cut_values : (n_cut,) ndarray
        Compensated image along the cut (complex; ``"centroid"`` only).
    cross_axis : (3,) ndarray
        Unit ground vector of cross range (normal to the ground projection of ``m_o``,
        oriented along the flight).
    """

    position_m: NDArray[np.float64]
    value: complex
    velocity_mps: NDArray[np.float64]
    method: str
    image: Image
    cut_offsets_m: NDArray[np.float64]
    cut_values: NDArray[np.complex128]
    cross_axis: NDArray[np.float64]


def _image_axes(geometry: LookGeometry) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit ground vectors of ground range (along ``b_o``) and cross range (along flight)."""
    b = geometry.ground_m_o
    e_r = np.array([b[0], b[1], 0.0]) / np.linalg.norm(b)
    e_c = np.array([-e_r[1], e_r[0], 0.0])
    if e_c @ geometry.tangent < 0:
        e_c = -e_c
    return e_r, e_c


def _defocus_half_width_m(traces: Traces, cross_speed_mps: float) -> float:
    """Cross-range half-extent (m) of a mover imaged with an along-track speed error.

    The range acceleration of a trial, ``|P w|^2 / L`` with ``w = V t - u``, differs from
    the mover's by ``((V + du)^2 - V^2) / L`` for an along-track error ``du`` (worst sign);
    the Doppler then sweeps ``+- (4 pi / lambda) (T / 2)`` times that, and one metre of
    cross range is ``(4 pi / lambda) V / L`` of Doppler.
    """
    v = traces.geometry.speed_mps
    du = abs(cross_speed_mps)
    return 0.5 * _aperture_time_s(traces) * ((v + du) ** 2 - v**2) / v


def _centroid(
    tr: Traces,
    brightest: NDArray[np.float64],
    vel: NDArray[np.float64],
    ph: NDArray[np.complexfloating],
    *,
    half: float,
    step: float,
    max_up: float,
    thr: float,
) -> tuple[NDArray[np.float64], complex, NDArray[np.float64], NDArray[np.complex128]]:
    """The defocused streak's power centroid in cross range, then the range of best focus.

    Returns the position (m), the point response there, and the cross-range cut through
    the brightest pixel (offsets in m, values).
    """
    e_r, e_c = _image_axes(tr.geometry)
    cross_res = resolution(tr).cross_range_m
    reach = half + _defocus_half_width_m(tr, max_up)
    offsets = np.arange(-reach, reach + 0.125 * cross_res, 0.25 * cross_res)
    cut = backproject_points(
        tr, brightest[None, :] + offsets[:, None] * e_c[None, :], velocity_mps=vel
    )
    power = np.abs(cut) ** 2
    weight = np.where(power >= power.max() * 10.0 ** (thr / 10.0), power, 0.0)
    base = brightest + float((weight * offsets).sum() / weight.sum()) * e_c

    def neg_modulus(a: float) -> float:
        pt = base + a * e_r
        return -float(np.abs(point_response(tr, pt, velocity_mps=vel, phase_history=ph)[0]))

    best = minimize_scalar(
        neg_modulus, bounds=(-step, step), method="bounded", options={"xatol": 1e-3}
    )
    pos = base + float(best.x) * e_r
    value = complex(point_response(tr, pos, velocity_mps=vel, phase_history=ph)[0])
    return pos, value, offsets, cut


def locate_mover(
    traces: Traces,
    range_speed_mps: float,
    *,
    cross_range_speed_mps: float | None = None,
    centre_m: ArrayLike | None = None,
    search_half_size_m: float = 30.0,
    spacing_m: float | None = None,
    max_cross_range_speed_mps: float = 30.0,
    threshold_db: float = -10.0,
) -> MoverLocation:
    """Location ``rho^e`` at ``s = 0`` from the motion-compensated image (``eq:imagecompu``).

    The image ``I_u`` compensated for the velocity ``u`` with range speed
    ``range_speed_mps`` (along ground range, or with the given cross-range speed) is
    formed by :func:`sarmotion.imaging.backproject` on a square grid around ``centre_m``.
    Its brightest pixel gives the ground range of the mover.

    *Focused* (``cross_range_speed_mps`` given): the brightest pixel is refined by
    maximising the exact point response (:func:`sarmotion.imaging.point_response.refine_location`).

    *Defocused* (the paper's first location, compensated along range only): an
    along-track speed ``u_perp`` leaves a quadratic phase of about
    ``(4 pi / lambda) (V u_perp / L) (T / 2)^2`` at the aperture ends, ~36 rad for
    Scene 1's 20 m/s mover over one GOTCHA degree: the image is a Fresnel smear +-30 m
    long in cross range and its brightest point is a ripple anywhere along it (23 m off
    for that mover). A quadratic phase spreads the Doppler symmetrically about its
    centroid, so the cross range is read as the energy centroid of ``|I|^2`` (samples
    within ``threshold_db`` of the maximum) along a cross-range cut through the brightest
    pixel (:func:`sarmotion.imaging.backproject_points`), long enough to hold the smear of
    ``|u_perp| <= max_cross_range_speed_mps``; the ground range is then refined by a
    bounded 1-D search of the exact point response. That centroid is the point whose
    range rate agrees with ``range_speed_mps`` (module notes), where ``g_perp`` must be
    evaluated.

    Parameters
    ----------
    traces : Traces
        Traces of the moving targets.
    range_speed_mps : float
        Range speed ``u^e`` (m/s).
    cross_range_speed_mps : float, optional
        Cross-range speed ``u_perp^e`` (m/s); default: compensate along ground range only.
    centre_m : (2,) or (3,) array_like, optional
        Centre of the search (m, on the ground); default the traces' reference point.
    search_half_size_m : float
        Half-side of the square image (m).
    spacing_m : float, optional
        Pixel spacing (m); default half the ground-range resolution ``c / (2B cos e)``
        (0.17 m for GOTCHA).
    max_cross_range_speed_mps : float
        Largest ``|u_perp|`` whose smear the defocused cut must hold (m/s).
    threshold_db : float
        Samples of the defocused cut counted in the centroid: ``|I|^2`` within this
        many dB of its maximum (negative, dB).

    Returns
    -------
    MoverLocation
    """
    tr = _check_traces(traces)
    u = _finite(range_speed_mps, "range_speed_mps")
    geom = tr.geometry
    focused = cross_range_speed_mps is not None
    if focused:
        vel = ground_velocity(u, _finite(cross_range_speed_mps, "cross_range_speed_mps"), geom)
    else:
        vel = range_direction_velocity(u, geom)
    centre = tr.reference_point_m if centre_m is None else as_point(centre_m, name="centre_m")
    if centre[2] != 0.0:
        raise ValueError(f"centre_m must lie on the ground z = 0, got {centre}")
    half = _positive(search_half_size_m, "search_half_size_m")
    if spacing_m is None:
        step = 0.5 * resolution(tr).ground_range_m
    else:
        step = _positive(spacing_m, "spacing_m")
    max_up = _finite(max_cross_range_speed_mps, "max_cross_range_speed_mps")
    thr = _finite(threshold_db, "threshold_db")
    if thr >= 0:
        raise ValueError(f"threshold_db must be negative (dB re the maximum), got {threshold_db!r}")
    grid = ImageGrid.from_extent(
        x_range_m=(centre[0] - half, centre[0] + half),
        y_range_m=(centre[1] - half, centre[1] + half),
        spacing_m=step,
    )
    image = backproject(tr, grid, velocity_mps=vel)
    x0, y0, _ = image.peak()
    brightest = np.array([x0, y0, 0.0])
    ph = tr.phase_history()
    e_r, e_c = _image_axes(geom)
    if focused:
        pos, value = refine_location(
            tr, brightest, velocity_mps=vel, phase_history=ph, step_m=0.5 * step
        )
        return MoverLocation(
            position_m=pos,
            value=value,
            velocity_mps=vel,
            method="peak",
            image=image,
            cut_offsets_m=np.zeros(0),
            cut_values=np.zeros(0, dtype=np.complex128),
            cross_axis=e_c,
        )
    pos, value, offsets, cut = _centroid(
        tr, brightest, vel, ph, half=half, step=step, max_up=max_up, thr=thr
    )
    return MoverLocation(
        position_m=pos,
        value=value,
        velocity_mps=vel,
        method="centroid",
        image=image,
        cut_offsets_m=offsets,
        cut_values=cut,
        cross_axis=e_c,
    )
