"""Movers over an aperture of several degrees, and what no aperture of a few degrees tells.

**The family.** Over one sub-aperture of about a degree a straight flight sees a mover's
squared range ``|r(s) - rho - s u|^2`` as an exact quadratic in ``s``: three numbers for
four unknowns (two position and two velocity components on the ground). Every estimate
of :mod:`sarmotion.motion` is therefore one point of a one-parameter *family* of
uniform motions with the same traces: moving the position by ``dy`` in cross range
changes the range speed by about ``-(V - u_t) dy / L`` (``V`` platform speed, ``u_t``
the mover's speed along the flight, ``L`` range) and the cross-range speed slightly.
:func:`family_member` computes the member at any offset and :func:`family_direction`
its tangent, which :mod:`sarmotion.pipeline` reports with each mover.

**Circular flight does not lift it over a few degrees.** Expanding the range history of
a circular flight (angular rate ``w = V / R_h``) around ``s = 0``, the member at offset
``dy`` matches the true one up to the cubic term ``(2/3) R_h w^3 dy s^3`` of the squared
range, i.e. a range difference of about ``R_h w^3 dy s^3 / (3 L)``: it grows as the
cube of the aperture, and for ``dy = 10`` m at GOTCHA's geometry it stays a small
fraction of a millimetre over 4 degrees and reaches a wavelength only at tens of degrees
(Scene 1's mover 2: ``docs/notes/motion.md``). A cross-range error of metres thus costs
a negligible fraction of a wavelength over the 4 degrees of a GOTCHA file:
the data of a few degrees cannot place a mover in cross range, whatever the estimator;
only a location known from elsewhere (the paper's first scenario, ``position_m`` of
:func:`sarmotion.motion.estimate_velocity`) or tens of degrees of uniform motion can.

**Wide apertures.** The velocity estimation of :mod:`sarmotion.motion` assumes a
sub-aperture of about a degree (the traces of a wider one are not the straight segments
``g`` looks for). For a wider aperture, :mod:`sarmotion.pipeline` estimates each mover on
the central sub-aperture (:func:`central_sub_aperture`), moves the estimate to the
aperture's ``s = 0`` and refines it on the whole aperture by maximising the coherent
compensated point response (``eq:imagecompu``) over the ground-range coordinate and the
velocity, the cross-range coordinate held (:func:`refine_on_aperture`): that focuses the
mover over the whole aperture without pretending to move it along the family. On a
single degree the same refinement is the maximum-likelihood polish of ``g_perp``'s
cross-range speed for a point target in white noise.

The model is the paper's: uniform straight motion over the aperture (``eq:MOD9``).
Positions in m (data frame), velocities ground ``(ux, uy)`` in m/s, times in s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, minimize

from ..core import Acquisition, C, Traces, as_point, target_positions, travel_time
from ..core.ascent import ResponseDerivatives, newton_ascent
from ..core.spectral import FrequencyPlanes
from ..imaging import pulse_responses, resolution
from .speed_resolution import cross_range_speed_resolution

__all__ = [
    "ApertureFit",
    "azimuth_span_deg",
    "central_sub_aperture",
    "family_direction",
    "family_member",
    "refine_on_aperture",
]


def central_sub_aperture(traces: Traces, sub_aperture_deg: float = 1.0) -> slice:
    """Pulses of about ``sub_aperture_deg`` of azimuth centred on the aperture's middle.

    The whole aperture if it spans less than 1.5 sub-apertures (azimuth measured at the
    reference point, :func:`azimuth_span_deg`).
    """
    if not (np.isfinite(sub_aperture_deg) and sub_aperture_deg > 0):
        raise ValueError(f"sub_aperture_deg must be positive, got {sub_aperture_deg}")
    n = traces.n_pulses
    span = azimuth_span_deg(traces)
    if span <= 1.5 * sub_aperture_deg:
        return slice(0, n)
    m = max(2, int(round(n * sub_aperture_deg / span)))
    start = (n - m) // 2
    return slice(start, start + m)


def azimuth_span_deg(traces: Traces) -> float:
    """Change of the platform's azimuth seen from the reference point over the aperture."""
    ends = traces.positions_m[[0, -1], :2] - traces.reference_point_m[:2]
    cos_span = np.dot(ends[0], ends[1]) / np.prod(np.linalg.norm(ends, axis=1))
    return float(np.degrees(np.arccos(np.clip(cos_span, -1.0, 1.0))))


def ranges_m(
    traces: Acquisition | Traces, position_m: ArrayLike, velocity_mps: ArrayLike
) -> NDArray[np.float64]:
    """Range ``|r(s) - rho - s u|`` of a uniform mover at every pulse (m), shape (n_pulses,)."""
    where = target_positions(position_m, velocity_mps, traces.slow_times_s)
    return 0.5 * C * travel_time(traces.positions_m, where)


def family_member(
    traces: Acquisition | Traces,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    cross_offset_m: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """The motion with the same range history over ``traces`` whose position is offset.

    Parameters
    ----------
    traces : Acquisition or Traces
        The (sub-)aperture over which the range histories must agree; its ``s = 0`` is
        the time of ``position_m``.
    position_m : (2,) or (3,) array_like
        A mover's estimated position (m).
    velocity_mps : (2,) array_like
        Its estimated ground velocity (m/s).
    cross_offset_m : float
        Cross-range offset ``dy`` of the member's position (m, along
        :func:`sarmotion.imaging.resolution`'s cross-range direction).

    Returns
    -------
    position : (3,) ndarray
        The member's position (m): offset by ``dy`` in cross range and re-fitted in
        ground range.
    velocity : (2,) ndarray
        Its ground velocity (m/s).
    rms_m : float
        RMS difference of the two range histories over ``traces`` (m); near zero for a
        sub-aperture of a degree (the family is exact for straight flight).
    """
    p0 = as_point(position_m, name="position_m")
    v0 = np.asarray(velocity_mps, dtype=np.float64).reshape(2)
    cells = resolution(traces)
    e_r = np.r_[cells.range_direction, 0.0]
    e_c = np.r_[cells.cross_range_direction, 0.0]
    target = ranges_m(traces, p0, v0)
    base = p0 + float(cross_offset_m) * e_c

    def residual(q: NDArray[np.float64]) -> NDArray[np.float64]:
        return ranges_m(traces, base + q[0] * e_r, v0 + q[1:]) - target

    fit = least_squares(residual, np.zeros(3), x_scale=np.array([0.1, 0.1, 0.1]), xtol=1e-12)
    q = fit.x
    rms = float(np.sqrt(np.mean(fit.fun**2)))
    return base + q[0] * e_r, v0 + q[1:], rms


def family_direction(
    traces: Acquisition | Traces, position_m: ArrayLike, velocity_mps: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Tangent of the family at an estimate: change per metre of cross-range offset.

    Central difference of :func:`family_member` at ``dy = +-1`` m.

    Returns
    -------
    position_per_m : (2,) ndarray
        Ground position change per metre along the family (m/m; its cross-range
        component is 1).
    velocity_per_m : (2,) ndarray
        Ground velocity change per metre along the family ((m/s)/m).
    """
    plus = family_member(traces, position_m, velocity_mps, 1.0)
    minus = family_member(traces, position_m, velocity_mps, -1.0)
    return 0.5 * (plus[0][:2] - minus[0][:2]), 0.5 * (plus[1] - minus[1])


@dataclass(frozen=True, kw_only=True, eq=False)
class ApertureFit:
    """Result of :func:`refine_on_aperture`.

    Attributes
    ----------
    position_m : (3,) ndarray
        Position at the whole aperture's ``s = 0`` (m).
    velocity_mps : (2,) ndarray
        Ground velocity (m/s).
    focus : float
        ``|I_u(rho)|`` over the whole aperture at the result (data units times
        ``n_pulses``; ``n_pulses |sigma|`` for a perfectly focused point target).
    start_focus : float
        The same at the sub-aperture estimate moved to ``s = 0``.
    """

    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64]
    focus: float
    start_focus: float


def refine_on_aperture(
    traces: Traces,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    *,
    central: slice,
    phase_history: ArrayLike | None = None,
    max_iter: int = 1000,
) -> ApertureFit:
    """Focus a sub-aperture estimate of a mover on the whole aperture.

    The estimate, made on the pulses ``central`` (its position at their ``s = 0``), is
    moved to the whole aperture's ``s = 0`` along its velocity; then the ground-range
    coordinate and the velocity's ground-range and cross-range components maximise the
    coherent compensated point response ``|sum_s c(s)|``
    (:func:`sarmotion.imaging.point_response.pulse_responses`) over
    a window of pulses that doubles from ``central`` itself to the whole aperture
    (at each width: the cross-range speed on a grid of half the width's
    resolution ``lambda L / (8 V T^2)`` over +-2 resolutions of ``central``, then
    a Nelder-Mead in steps of about a quarter cycle of phase over the width, to 1/20 of
    them, then a Newton ascent (:func:`sarmotion.core.ascent.newton_ascent`) in the same
    units).
    Each width's estimate is within the next one's capture range: a cross-range speed
    error of 0.2 m/s is most of a cycle of quadratic phase over 4 degrees, so a single
    4-degree search from a 1-degree estimate can stop on a local maximum of the focus.
    The grid matters on real clutter, where the central degree's ``g_perp`` can be off by
    more than a resolution (``docs/notes/motion.md``). The cross-range coordinate is held: the data
    do not fix it (module notes) and a free search would only wander along the family.

    Parameters
    ----------
    traces : Traces
        The mover's traces over the whole aperture (e.g. the moving residual).
    position_m : (2,) or (3,) array_like
        Estimate at the sub-aperture's ``s = 0`` (m).
    velocity_mps : (2,) array_like
        Its ground velocity (m/s).
    central : slice
        The sub-aperture's pulses.
    phase_history : array_like, optional
        ``traces.phase_history()`` if already computed.
    max_iter : int
        Cap on the simplex's iterations and on the ascent's evaluations, per width.

    Returns
    -------
    ApertureFit
    """
    # many sums of the same rows: frequency-major planes (contiguous reads, same sums)
    P = FrequencyPlanes(traces.phase_history() if phase_history is None else phase_history)
    sub = traces.select_pulses(*central.indices(traces.n_pulses)[:2])
    s_c = float(np.mean(traces.slow_times_s[central]) - np.mean(sub.slow_times_s))
    v0 = np.asarray(velocity_mps, dtype=np.float64).reshape(2)
    p0 = as_point(position_m, name="position_m") - s_c * np.r_[v0, 0.0]
    cells = resolution(traces)
    e_r, e_c = cells.range_direction, cells.cross_range_direction

    def unpack(q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return p0 + q[0] * np.r_[e_r, 0.0], v0 + q[1] * e_r + q[2] * e_c

    def cost(q: NDArray[np.float64], pulses: slice = slice(None)) -> float:
        p, v = unpack(q)
        return -abs(pulse_responses(traces, p, v, phase_history=P, pulses=pulses).sum())

    n = traces.n_pulses
    start, stop = central.indices(n)[:2]
    middle, half = 0.5 * (start + stop), 0.5 * (stop - start)
    q = np.zeros(3)
    start_focus = -cost(q)
    # Initial steps: about a quarter cycle of round-trip phase at the window's ends from the
    # range drift and from the quadratic range error: 0.002 m/s / T and 0.2 m/s / T^2 (T
    # window half-length, s), and 1 cm of range; the focus falls steeply with these errors
    # (docs/notes/motion.md).
    dt = float(np.median(np.diff(traces.slow_times_s)))
    res_c = cross_range_speed_resolution(sub)  # scales as 1 / T^2
    while True:
        window = slice(max(0, int(round(middle - half))), min(n, int(round(middle + half))))
        t_half = 0.5 * (window.stop - window.start) * dt
        steps = np.array([0.01, 0.002 / t_half, 0.2 / t_half**2])
        # Cross-range speed first on a grid (half this width's resolution, over
        # two resolutions of the central sub-aperture): its focus curve has side maxima.
        res_w = res_c * ((stop - start) / (window.stop - window.start)) ** 2
        grid = q[2] + np.arange(-2.0 * res_c, 2.0 * res_c + 1e-9, 0.5 * res_w)
        values = [cost(np.r_[q[:2], g], window) for g in grid]
        before = cost(q, window)
        if min(values) < before:
            q = np.r_[q[:2], grid[int(np.argmin(values))]]
            before = min(values)
        # the lobe by a loose simplex, then the Newton ascent on it (as the matched
        # filter's local fit, motion.likelihood._local_fit: from a start off the lobe's
        # concave part the gradient alone can follow a ridge to a lower maximum)
        res = minimize(
            lambda z, unit, pulses: cost(z * unit, pulses),
            q / steps,
            args=(steps, window),
            method="Nelder-Mead",
            options={
                "initial_simplex": np.vstack([q / steps, q / steps + np.eye(3)]),
                "xatol": 0.05,
                "fatol": 1e-6 * abs(before),
                "maxiter": max_iter,
            },
        )
        if res.fun <= before:
            q = res.x * steps
        q, _, _, _ = newton_ascent(
            _window_response(traces, P, p0, v0, e_r, e_c, window),
            q,
            radius=1.0,
            tol=1e-3,
            max_iter=max_iter,
            scale=steps,
        )
        if window == slice(0, n) or half >= 0.5 * n:
            break
        half = min(2.0 * half, 0.5 * n)
    p, v = unpack(q)
    return ApertureFit(position_m=p, velocity_mps=v, focus=-cost(q), start_focus=start_focus)


def _window_response(
    traces: Traces,
    planes: FrequencyPlanes,
    p0: NDArray[np.float64],
    v0: NDArray[np.float64],
    e_r: NDArray[np.float64],
    e_c: NDArray[np.float64],
    window: slice,
):
    """``q -> (|I|^2, gradient, Hessian, I)`` over the pulses ``window``.

    ``q`` are :func:`refine_on_aperture`'s parameters: range offset (m), ground-range and
    cross-range velocity changes (m/s).
    """
    ant = traces.positions_m[window]
    s = traces.slow_times_s[window]
    response = ResponseDerivatives(
        planes,
        ant,
        travel_time(ant, traces.reference_point_m),
        float(traces.frequencies_hz[0]),
        float(traces.radar.frequency_step_hz),
        1.0 / traces.n_samples,
        rows=window,
    )
    return response.on_track(s, p0, v0, e_r, (e_r, e_c))
