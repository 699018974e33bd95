"""Range and cross-range speed of moving targets from their traces (paper ``sect:rotationopt``).

The traces ``D`` of the moving targets (the stationary ones removed) are brought to the
frame of a trial trajectory ``rho^e + s u`` by ``T_+^{u, rho^e}`` (``eq:TTu+``). Two
objective functions of the transformed traces measure how well the trial fits a trace:

``g(u)`` (``eq:OBJg``)
    ``max_l sum_j |[T_+^{u, rho^e} D](s_j, t_l)|`` with ``u`` along the ground projection
    of the look direction ``m_o`` (``eq:Mo``). The slope of a trace is set by the range
    speed (``eq:Dtau``): at the right ``u`` the trace is a vertical segment and its sum
    over slow time peaks. Several movers give several peaks.
``g_perp(u_perp; u^e, rho^e)`` (``eq:OBJ2``)
    ``sum_l sum_j |D_s^2 [T_+^{u, rho^e} D](s_j, t_l)|`` with ``u`` of range speed ``u^e``
    and cross-range speed ``u_perp`` (``eq:crangeu``). The curvature of the trace, mostly
    its carrier phase, is set by ``u_perp``; the slow-time second difference vanishes
    when it is compensated.

The pipeline (:func:`estimate_velocity`) is the paper's: range speed from the peak of
``g`` with ``rho^e = rho_o``; location from the motion-compensated image
(``eq:imagecompu``); cross-range speed from the minimum of ``g_perp``; then one round
of re-location on the focused image and re-minimisation of ``g_perp``.

Velocity convention. The paper writes the trial velocity of ``eq:OBJg`` as ``u (b_o, 0)``
with ``b_o`` the ground projection of ``m_o``; its range speed is ``|b_o|^2 u`` (about
``0.49 u`` at GOTCHA elevation). Here the trial is
:func:`~sarmotion.core.geometry.range_direction_velocity`, the vector along ``b_o`` whose range
speed is exactly ``u``, so that the peak of ``g`` *is* the range speed ``u . m_o``.

What one sub-aperture cannot tell. For straight flight the squared range of a target
moving on a straight line is exactly quadratic in slow time, so a trace carries three
numbers (range at ``s = 0``, range rate, range acceleration) for four unknowns (two
position and two velocity components). The cross-range position ``y`` and the range
speed trade along ``delta u = -(V - u_t) delta y / L`` (0.005-0.007 m/s per metre for
Scene 1; ``u_t`` the along-track speed), with a small change of ``u_perp``: the envelope
slope that ``g`` measures and the Doppler that focuses the image are the same range
rate. Circular flight breaks the tie only over tens of degrees (:mod:`sarmotion.motion.aperture`,
which also computes the family). When
``rho^e`` is unknown the estimate therefore sits near the cross range of the reference
used in ``g`` (``rho_o``): Scene 1's mover 2, 5 m off it, comes out 4.7 m off in cross
range with a range speed 0.027 m/s off, a triple that reproduces its trace. With a known
location (from tracking, the paper's first scenario) pass ``position_m``: the range
speed is then unbiased.

All speeds are in m/s, positions in m, times in s, phases in float64 reduced exactly to
``[-1/2, 1/2]`` cycles before the complex exponential.

Accuracy (:func:`estimate_velocity`)
------------------------------------
Noise-free, stage 3 places the range to about a centimetre and ``u_perp`` to a few
mm/s; ``u`` is off by the family offset of the cross range it settles on (module
notes). The round then brings the range to a few millimetres. With noise the round
improves the range location and the fit of the estimated trajectory to the trace,
while the ``u_perp`` component alone may move farther from the truth: the round lands
on the family point of the (noisy) range speed, whose ``u_perp`` differs from the truth
by about 0.1 m/s per metre along the family. Further rounds change nothing.
``tests/motion/test_velocity.py`` asserts these on Scene 1; the figures are in
``docs/notes/motion.md``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import finite as _finite
from .._validation import interval as _interval
from ..core import Traces, as_point, ground_velocity
from ..errors import EstimationError
from ..imaging import (
    point_response,
)
from ._aligned import (
    _Aligner,
    _check_traces,
    _range_trials,
    _refine_max,
)
from .cross_range import CrossRangeSpeed, estimate_cross_range_speed
from .location import locate_mover
from .range_speed import RangeSpeeds, estimate_range_speeds
from .speed_resolution import range_speed_resolution

__all__ = ["EstimationStep", "MoverEstimate", "estimate_velocity"]


# =============================================================== pipeline
@dataclass(frozen=True, kw_only=True, eq=False)
class EstimationStep:
    """The estimate after one step of :func:`estimate_velocity`.

    Attributes
    ----------
    step : str
        ``"g"`` (range speed), ``"locate"`` (location), ``"g_perp"`` (cross-range
        speed) or ``"round k"`` (the k-th alternation, from 1).
    range_speed_mps : float
        ``u^e`` after the step (m/s).
    position_m : (3,) ndarray
        ``rho^e`` after the step (m).
    cross_range_speed_mps : float or None
        ``u_perp^e`` after the step (m/s); None before the ``g_perp`` step.
    """

    step: str
    range_speed_mps: float
    position_m: NDArray[np.float64]
    cross_range_speed_mps: float | None


@dataclass(frozen=True, kw_only=True, eq=False)
class MoverEstimate:
    """Location and ground velocity of one mover (:func:`estimate_velocity`).

    Distinct from the analysis's mover record (:class:`~sarmotion.pipeline.Mover`, built on
    the maximum-likelihood fit, :class:`~sarmotion.motion.PointFit`): this is the result
    of the alternating ``g`` -> locate -> ``g_perp`` estimator, with its curves and the
    estimate after each step; the tracker uses it at a known position (the first
    scenario) and the paper's figures plot it. It holds no evidence, bound or image.

    Attributes
    ----------
    position_m : (3,) ndarray
        Location at ``s = 0`` (m), data frame. Its cross-range coordinate is tied to the
        range speed (module notes): without a known location it is the point of the
        data-consistent family nearest the cross range of ``reference_m``.
    velocity_mps : (2,) ndarray
        Ground velocity ``(ux, uy)`` (m/s), data frame.
    range_speed_mps : float
        ``u = u_vec . m_o`` (``eq:rangeu``), m/s.
    cross_range_speed_mps : float
        ``u_perp`` (``eq:crangeu``), m/s.
    peak_value : float
        ``g`` at the final range speed, location and cross-range speed (trace units).
    over_floor_db : float
        ``20 log10(peak_value / floor)`` with the global floor of the first, coarse ``g``
        (dB).
    image_value : complex
        Exact compensated image at the estimate (``eq:imagecompu``), data units times
        ``n_pulses``.
    range_curve : RangeSpeeds
        The coarse ``g(u)`` of the first stage and its strongest peak.
    cross_curve : CrossRangeSpeed
        The last ``g_perp`` search.
    history : tuple of EstimationStep
        The estimate after each step (``"g"``, ``"locate"``, ``"g_perp"``, ``"round k"``).
    """

    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64]
    range_speed_mps: float
    cross_range_speed_mps: float
    peak_value: float
    over_floor_db: float
    image_value: complex
    range_curve: RangeSpeeds
    cross_curve: CrossRangeSpeed
    history: tuple[EstimationStep, ...]


def estimate_velocity(
    traces: Traces,
    *,
    range_speed_mps: float | None = None,
    position_m: ArrayLike | None = None,
    speed_range_mps: tuple[float, float] = (-30.0, 30.0),
    cross_speed_range_mps: tuple[float, float] = (-30.0, 30.0),
    search_half_size_m: float = 30.0,
    n_alternations: int = 1,
    reference_m: ArrayLike | None = None,
    min_speed_mps: float | None = None,
    window_m: float | None = None,
    trim_fraction: float = 0.25,
    lag_pulses: int | None = None,
) -> MoverEstimate:
    """Location and velocity of one mover from its separated traces (``sect:rotationopt``).

    1. Range speed ``u^e``: the strongest peak of ``g`` (``eq:OBJg``) with
       ``|u| >= min_speed_mps``, or the peak nearest ``range_speed_mps`` if given; ``g``
       is taken at ``rho^e`` = ``position_m`` if known, else ``reference_m``.
    2. Location ``rho^e`` (unless ``position_m`` is given): from the image compensated
       for ``u^e`` along ground range (:func:`locate_mover`, defocused: cross range from
       the Doppler/energy centroid, which agrees with ``u^e``).
    3. Cross-range speed ``u_perp^e``: minimiser of ``g_perp`` (``eq:OBJ2``) over
       ``cross_speed_range_mps`` at ``(u^e, rho^e)``.
    4. ``n_alternations`` rounds, each: ``rho^e`` re-located on the image focused with
       the full velocity (its peak is the point whose range rate agrees with ``u^e``,
       within 2 cm under noise); ``u_perp^e`` re-minimised within four resolutions. When
       ``position_m`` is known, ``u^e`` is re-refined on ``g`` with the cross-range speed
       instead. Otherwise ``u^e`` is kept: re-refining the envelope-based ``g`` at each
       new ``rho^e`` lets the estimate random-walk along the degenerate family (module
       notes) under noise (mover 1 at 0 dB: cross-range rms 0.5, 1.2, 1.8 m after 0, 1, 2
       such rounds).

    Parameters
    ----------
    traces : Traces
        Traces of one mover (or of several, the strongest or the one nearest
        ``range_speed_mps`` being estimated), stationary targets removed.
    range_speed_mps : float, optional
        Approximate range speed (m/s), e.g. one of :func:`estimate_range_speeds`; refined
        on ``g`` within two range-speed resolutions.
    position_m : (2,) or (3,) array_like, optional
        Known location at ``s = 0`` (m), e.g. from tracking (the paper's first scenario):
        not re-estimated, and the range speed is then unbiased.
    speed_range_mps, cross_speed_range_mps : (float, float)
        Searched range and cross-range speeds (m/s).
    search_half_size_m : float
        Half-side of the square location search around ``reference_m`` (m).
    n_alternations : int
        Number of re-estimation rounds (step 4), >= 0.
    reference_m : (2,) or (3,) array_like, optional
        ``rho^e`` of the first ``g`` and centre of the location search (m); default the
        traces' reference point.
    min_speed_mps : float, optional
        Peaks of ``g`` slower than this are ignored (stationary residue), m/s; see
        :func:`estimate_range_speeds`.
    window_m, trim_fraction, lag_pulses
        Form of ``g_perp``, see :func:`cross_range_objective`.

    Returns
    -------
    MoverEstimate
    """
    tr = _check_traces(traces)
    if isinstance(n_alternations, bool) or not isinstance(n_alternations, (int, np.integer)):
        raise TypeError(f"n_alternations must be an integer, got {n_alternations!r}")
    if n_alternations < 0:
        raise ValueError(f"n_alternations must be >= 0, got {n_alternations}")
    lo, hi = _interval(speed_range_mps, "speed_range_mps")
    cross_range = _interval(cross_speed_range_mps, "cross_speed_range_mps")
    known = position_m is not None
    ref = tr.reference_point_m if reference_m is None else as_point(reference_m, name="reference_m")
    rho = as_point(position_m, name="position_m") if known else ref
    u_hint = None if range_speed_mps is None else _finite(range_speed_mps, "range_speed_mps")
    geom = tr.geometry
    res = range_speed_resolution(tr)
    g_perp_form = {"window_m": window_m, "trim_fraction": trim_fraction, "lag_pulses": lag_pulses}

    # 1. range speed
    curve = estimate_range_speeds(
        tr,
        speed_range_mps=(lo, hi),
        max_movers=1 if u_hint is None else 0,
        threshold_db=-np.inf,
        min_speed_mps=min_speed_mps,
        reference_m=rho,
    )
    if u_hint is None:
        if curve.n_movers == 0:
            raise EstimationError(
                f"g(u) has no peak with |u| >= min_speed_mps within speed_range_mps "
                f"{speed_range_mps!r}"
            )
        u = float(curve.speeds_mps[0])
    else:
        u, _ = _refine_max(_g_scalar(tr, rho, None), u_hint, 2.0 * res, 1e-3)
    history = [_step("g", u, rho, None)]

    # 2. location
    if not known:
        rho = locate_mover(tr, u, centre_m=ref, search_half_size_m=search_half_size_m).position_m
        history.append(_step("locate", u, rho, None))

    # 3. cross-range speed
    cross = estimate_cross_range_speed(
        tr, range_speed_mps=u, position_m=rho, speed_range_mps=cross_range, **g_perp_form
    )
    up = cross.speed_mps
    history.append(_step("g_perp", u, rho, up))

    # 4. alternations
    rho, u, up, cross = _alternate(
        tr,
        rho,
        u,
        up,
        cross,
        known=known,
        n_alternations=int(n_alternations),
        search_half_size_m=float(search_half_size_m),
        g_perp_form=g_perp_form,
        history=history,
    )

    vel = ground_velocity(u, up, geom)
    peak = _g_scalar(tr, rho, up)(u)
    value = complex(point_response(tr, rho, velocity_mps=vel)[0])
    return MoverEstimate(
        position_m=np.asarray(rho, dtype=np.float64).copy(),
        velocity_mps=vel,
        range_speed_mps=u,
        cross_range_speed_mps=up,
        peak_value=peak,
        over_floor_db=float(20.0 * np.log10(peak / curve.floor)) if curve.floor > 0 else np.inf,
        image_value=value,
        range_curve=curve,
        cross_curve=cross,
        history=tuple(history),
    )


def _alternate(
    tr: Traces,
    rho: NDArray[np.float64],
    u: float,
    up: float,
    cross: CrossRangeSpeed,
    *,
    known: bool,
    n_alternations: int,
    search_half_size_m: float,
    g_perp_form: dict[str, Any],
    history: list[EstimationStep],
) -> tuple[NDArray[np.float64], float, float, CrossRangeSpeed]:
    """Stage 4 of :func:`estimate_velocity`: rounds of location (or range speed) and u_perp.

    With a known position the range speed is re-refined on ``g`` at the cross-range
    speed; otherwise the location is searched again near the current one. Each round
    appends to ``history``. Returns the final ``(rho, u, u_perp, cross-range result)``.
    """
    res = range_speed_resolution(tr)
    for k in range(n_alternations):
        if known:
            u, _ = _refine_max(_g_scalar(tr, rho, up), u, res, 1e-4)
        else:
            rho = locate_mover(
                tr,
                u,
                cross_range_speed_mps=up,
                centre_m=rho,
                search_half_size_m=min(search_half_size_m, 10.0),
            ).position_m
        width = 4.0 * cross.resolution_mps
        cross = estimate_cross_range_speed(
            tr,
            range_speed_mps=u,
            position_m=rho,
            speed_range_mps=(up - width, up + width),
            **g_perp_form,
        )
        up = cross.speed_mps
        history.append(_step(f"round {k + 1}", u, rho, up))
    return rho, u, up, cross


def _step(step: str, u: float, rho: NDArray[np.float64], up: float | None) -> EstimationStep:
    return EstimationStep(
        step=step,
        range_speed_mps=float(u),
        position_m=np.array(rho, dtype=np.float64),
        cross_range_speed_mps=None if up is None else float(up),
    )


def _g_scalar(
    traces: Traces, rho: NDArray[np.float64], cross_range_speed: float | None
) -> Callable[[float], float]:
    """``u -> g(u)`` at ``rho^e = rho`` (one shared transform plan)."""
    aligner = _Aligner(traces, rho)
    geom = traces.geometry

    def g(u: float) -> float:
        vel = _range_trials(np.array([u]), geom, cross_range_speed)
        return float(aligner.g_values(vel)[0])

    return g
