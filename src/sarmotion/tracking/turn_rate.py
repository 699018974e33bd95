"""A mover's turn rate in the ground frame from the range histories of its looks.

**The model.** A mover turning at a constant rate ``w`` (rad/s, counter-clockwise
positive) at a constant speed has, ``dt`` from the reference time ``t_0``, the velocity
``u(dt) = Rot(w dt) u_0``, the position ``p(dt) = p_0 + (sin(w dt) u_0 + (1 - cos(w dt))
J u_0) / w`` (``J`` the rotation by 90 degrees) and the acceleration ``w J u(dt)``. Each
look measures ``(R, R', R'')`` of that motion through its antenna
(:mod:`sarmotion.tracking.wide_aspect`); the acceleration's range component enters
``R''``. Uniform motion is ``w = 0``.

**The profile.** For each ``w`` the state ``(p_0, u_0)`` is fitted by weighted least
squares, as the uniform fit is, from starts along the family of the detection nearest
``t_0`` (the fit's position is ambiguous along it over a few degrees and several
minima are common): ``chi2(w)``, the profile of the rate. Its grid spans
:data:`MAX_TURN_RATE_DEG_S` on each side in steps that turn the heading by
:data:`_STEP_RAD` over the looks' span (at most :data:`_MAX_GRID` rates: seconds a
track over 30 degrees, 9-13 s over 90); the lowest local minima are then refined. The
errors' scale is measured on the data, as the turn test does
(:mod:`sarmotion.tracking.turns`), but from the turning model's own residuals at its
best rate (each component's share ``n - 5/3`` of the ``3 n - 5`` degrees of freedom):
the uniform model's residuals hold a turning mover's misfit, which would make every
rate fit. With ``s^2 = chi2_min / (3 n - 5)`` the rates whose
``(chi2(w) - chi2_min) / s^2`` is within the quantile of ``F(1, 3 n - 5)`` at
:data:`TURN_RATE_CONFIDENCE` form the confidence set (the profile-likelihood interval
with the scale estimated). The rate is *fixed* when that set is one interval within the
searched range; otherwise (another minimum within the set, e.g. rates of both signs
that fit as well, as over 10 degrees they often do, or the set reaching the range's
end) the interval reported is the set's hull and the rate is not fixed.

Only detections whose sub-apertures share no pulse are used (their errors independent),
as by :func:`~sarmotion.tracking.turns.look_turn_test`. Times in s, positions in m,
velocities in m/s, rates in deg/s.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq, least_squares, minimize_scalar

from .wide_aspect import LookMeasurement, fit_track, look_antennas, range_histories

__all__ = ["MAX_TURN_RATE_DEG_S", "TURN_RATE_CONFIDENCE", "TurnRate", "turn_rate"]

#: Largest turn rate searched, each sense (deg/s): a vehicle at 5 m/s on a 14 m radius.
MAX_TURN_RATE_DEG_S = 20.0

#: Confidence of the turn rate's interval.
TURN_RATE_CONFIDENCE = 0.95

#: Heading change between neighbouring rates of the grid over the looks' span (rad).
_STEP_RAD = 0.2

#: Most rates on the grid: beyond, the steps widen (a track of over about 100 degrees of
#: GOTCHA's pass; over 150 degrees, made from the geometry, a uniform mover and a 3 deg/s
#: turn were still found, within 0.001 deg/s, in 22 and 15 s).
_MAX_GRID = 801

#: Local minima of the grid's profile refined.
_MINIMA_REFINED = 3

#: Starts along the family for each rate of the grid, over +-3 prior deviations.
_FAMILY_STARTS = 61

_J = np.array([[0.0, -1.0], [1.0, 0.0]])


@dataclass(frozen=True, kw_only=True)
class TurnRate:
    """A track's turn rate in the ground frame (module notes).

    Attributes
    ----------
    rate_deg_s : float
        The constant-rate turn that fits the looks best (deg/s, counter-clockwise
        positive).
    interval_deg_s : tuple of float
        The hull of the rates within the confidence set (deg/s).
    fixed : bool
        Whether the set is one interval within +-:data:`MAX_TURN_RATE_DEG_S`.
    confidence : float
        The set's confidence (:data:`TURN_RATE_CONFIDENCE`).
    n_looks : int
        Independent detections used.
    """

    rate_deg_s: float
    interval_deg_s: tuple[float, float]
    fixed: bool
    confidence: float
    n_looks: int


def turn_histories(
    x: NDArray[np.float64],
    rate_rad_s: float,
    dts: NDArray[np.float64],
    antenna: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    height_m: float = 0.0,
) -> NDArray[np.float64]:
    """``(R, R', R'')`` of every look for a mover turning at a constant rate (notes).

    Parameters
    ----------
    x : (4,) ndarray
        ``(x, y, ux, uy)`` at the reference time (m, m/s).
    rate_rad_s : float
        ``w`` (rad/s, counter-clockwise positive).
    dts : (n,) ndarray
        The looks' centre times from the reference time (s).
    antenna : tuple of (n, 3) ndarray
        The antenna's positions (m), velocities (m/s) and accelerations (m/s^2) at them.
    height_m : float
        The mover's height (m).

    Returns
    -------
    (n, 3) ndarray
        Range (m), range rate (m/s), range acceleration (m/s^2) of each look.
    """
    w = float(rate_rad_s)
    theta = w * dts
    c, s = np.cos(theta), np.sin(theta)
    u0 = x[2:4]
    u = np.column_stack([c * u0[0] - s * u0[1], s * u0[0] + c * u0[1]])
    if abs(w) * max(float(np.max(np.abs(dts), initial=0.0)), 1e-9) > 1e-6:
        along, across = s / w, (1.0 - c) / w
    else:  # the series: sin(w t) / w -> t, (1 - cos(w t)) / w -> w t^2 / 2
        along, across = dts, 0.5 * w * dts**2
    p = x[:2] + along[:, None] * u0 + across[:, None] * (_J @ u0)
    return range_histories(p, u, w * (u @ _J.T), antenna, height_m)


def turn_rate(
    looks: Sequence[LookMeasurement],
    *,
    prior_std_m: float,
    centre_m: NDArray[np.float64] | None = None,
    height_m: float = 0.0,
    error_factors: NDArray[np.float64] | None = None,
) -> TurnRate | None:
    """The constant turn rate that fits independent looks, with its interval (notes).

    Parameters
    ----------
    looks : sequence of LookMeasurement
        Detections of one track whose sub-apertures share no pulse, in time order.
    prior_std_m, centre_m, height_m
        The scene prior and the movers' height
        (:func:`~sarmotion.tracking.wide_aspect.fit_track`).
    error_factors : (3,) ndarray, optional
        Variance factors of the first pass (default: the uniform fit's, module notes;
        :func:`~sarmotion.tracking.turns.look_turn_test` passes its own).

    Returns
    -------
    TurnRate or None
        None with fewer than 3 looks (``3 n - 5 < 4``).
    """
    n = len(looks)
    if n < 3:
        return None
    centre = np.zeros(2) if centre_m is None else np.asarray(centre_m, dtype=np.float64)[:2]
    times = np.array([m.time_s for m in looks])
    t0 = float(np.mean(times))
    dts = times - t0
    span = float(np.ptp(times))
    if span <= 0.0:
        return None
    z = np.stack([m.z for m in looks])
    sd = np.sqrt(np.stack([np.diag(m.covariance) for m in looks]))
    antenna = look_antennas(looks)
    if error_factors is None:  # the uniform fit's (module notes)
        fit = fit_track(looks, prior_std_m=prior_std_m, centre_m=centre_m, height_m=height_m)
        factors = fit.error_factors
    else:
        factors = np.asarray(error_factors, dtype=np.float64)
    starts = _family_starts(looks, t0, prior_std_m)

    def residual(x: NDArray[np.float64], w: float, f: NDArray[np.float64]):
        e = (turn_histories(x, w, dts, antenna, height_m) - z) / (sd * f)
        return np.r_[e.ravel(), (x[:2] - centre) / prior_std_m]

    def solve(w: float, f: NDArray[np.float64], x: NDArray[np.float64]):
        sol = least_squares(
            residual, x, args=(w, f), x_scale=np.array([1.0, 1.0, 0.1, 0.1]),
            xtol=1e-12, ftol=1e-12, method="lm",
        )  # fmt: skip
        return 2.0 * float(sol.cost), sol.x

    def from_family(w: float, f: NDArray[np.float64]):
        costs = [float(np.sum(residual(x, w, f) ** 2)) for x in starts]
        best = min((solve(w, f, starts[k]) for k in np.argsort(costs)[:2]), key=lambda c: c[0])
        return best

    w_max = np.radians(MAX_TURN_RATE_DEG_S)
    half = min(int(np.ceil(w_max * span / _STEP_RAD)), _MAX_GRID // 2)
    grid = np.linspace(-w_max, w_max, 2 * half + 1)
    step = float(grid[1] - grid[0])

    def minima(f: NDArray[np.float64]):
        coarse = [from_family(w, f) for w in grid]
        chi = np.array([c[0] for c in coarse])
        local = [
            k for k in range(grid.size)
            if chi[k] <= chi[max(k - 1, 0)] and chi[k] <= chi[min(k + 1, grid.size - 1)]
        ]  # fmt: skip
        local = sorted(local, key=lambda k: chi[k])[:_MINIMA_REFINED]
        found = []
        for k in local:
            x_k = coarse[k][1]
            lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
            opt = minimize_scalar(
                lambda w, x_k=x_k: solve(w, f, x_k)[0], bounds=(lo, hi), method="bounded",
                options={"xatol": 1e-3 * step},
            )  # fmt: skip
            w_k = float(opt.x)
            found.append((*solve(w_k, f, x_k), w_k))
        found.sort(key=lambda c: c[0])
        return chi, found

    _, found = minima(factors)
    _, x_best, w_best = found[0]
    e = (turn_histories(x_best, w_best, dts, antenna, height_m) - z) / sd
    factors = np.sqrt(np.maximum(1.0, np.sum(e**2, axis=0) / (n - 5.0 / 3.0)))
    chi, found = minima(factors)
    chi_min, x_best, w_best = found[0]

    from scipy.stats import f as f_dist

    nu = 3 * n - 5
    delta = max(chi_min, 1e-300) / nu * float(f_dist.ppf(TURN_RATE_CONFIDENCE, 1, nu))
    others = [w for c, _, w in found[1:] if c - chi_min <= delta and abs(w - w_best) > step]

    def edge(direction: int) -> tuple[float, bool]:
        """The set's edge on one side of the best rate, and whether it is within range."""
        beyond = [
            k for k in range(grid.size)
            if direction * (grid[k] - w_best) > 0 and chi[k] - chi_min > delta
        ]  # fmt: skip
        if not beyond:
            return (direction * w_max, False)
        k = min(beyond, key=lambda k: abs(grid[k] - w_best))

        def excess(w: float) -> float:
            return solve(w, factors, x_best)[0] - chi_min - delta

        if excess(grid[k]) <= 0.0:  # the warm start stays below: the grid's value holds
            return (float(grid[k]), True)
        return (float(brentq(excess, w_best, grid[k], xtol=1e-4 * step)), True)

    lo, lo_in = edge(-1)
    hi, hi_in = edge(+1)
    hull = [lo, hi, *others]
    return TurnRate(
        rate_deg_s=float(np.degrees(w_best)),
        interval_deg_s=(float(np.degrees(min(hull))), float(np.degrees(max(hull)))),
        fixed=bool(lo_in and hi_in and not others),
        confidence=TURN_RATE_CONFIDENCE,
        n_looks=n,
    )


def _family_starts(
    looks: Sequence[LookMeasurement], t0: float, prior_std_m: float
) -> list[NDArray[np.float64]]:
    """States at ``t0`` along the family of the detection nearest it (module notes)."""
    anchor = min(looks, key=lambda m: abs(m.time_s - t0))
    det = anchor.detection
    a, b = det.family_position_per_m, det.family_velocity_per_m
    dt = anchor.time_s - t0
    offsets = np.linspace(-3.0, 3.0, _FAMILY_STARTS) * prior_std_m / max(float(np.hypot(*a)), 1e-9)
    out = []
    for t in offsets:
        v = det.velocity_mps + t * b
        out.append(np.r_[det.position_m + t * a - dt * v, v])
    return out
