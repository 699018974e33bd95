"""A turn as a change of velocity between sub-apertures: the test and the turn rate.

Each sub-aperture's analysis gives a mover's velocity with its Cramér–Rao covariance
(:attr:`~sarmotion.tracking.sub_apertures.Detection.velocity_cov_m2ps2`). A mover that
moves uniformly has the same velocity in every sub-aperture; a turn (or a change of
speed) changes it.

**Comparable velocities.** A detection is one member of its cross-range family
(:mod:`sarmotion.motion.aperture`): the one at the reference point's cross range, whose
velocity differs from the truth's by ``dy b`` for a mover ``dy`` metres off it (``b``
the family's velocity change per metre, about ``(V - u_t) / L`` = 0.007 (m/s)/m of range
speed on GOTCHA). Between two sub-apertures a mover's cross-range offset changes by its
cross-range displacement, so the two members' velocities would differ for a uniform
mover. The later detection is therefore slid along its family (its tangent ``a, b``,
:func:`sarmotion.motion.family_direction`) to the point nearest the earlier one carried
forward, ``p_i + v_i (t_j - t_i)``: the two then describe one uniform motion if there
was one.

**The test.** For detections ``i`` and ``j`` whose sub-apertures share no pulse (their
errors independent; with overlapping sub-apertures, the next one that does not overlap)
the difference ``d = v_j' - v_i`` (``v_j'`` the slid velocity) has, for a uniform mover,
zero mean and covariance ``S = C_j + (I - b a^T dt / |a|^2) C_i (.)^T`` (the slide
depends on ``v_i``; positions are exact enough to leave out). ``d^T S^-1 d`` is then
chi-square with 2 degrees of freedom. A track is flagged as turning when any of its
``n`` pairs exceeds the chi-square quantile at ``1 - p / n`` (Bonferroni): a uniform
mover's track is flagged with probability at most ``p``
(:attr:`~sarmotion.tracking.TrackingOptions.turn_false_alarm`), insofar as the
detections' errors reach their bounds.

**The apparent turn rate** is the heading change of the detections' velocities between
the track's first and last detections (when they share no pulse) over the time between
them, ``(theta_j - theta_i) / dt`` (``theta = atan2(u_y, u_x)``, the difference wrapped to
+-180 degrees, the last velocity slid as above), with the standard error from the two
covariances through ``d theta / d u = (-u_y, u_x) / |u|^2``. It is the rate of the
*estimates'* heading, not the mover's: over a sub-aperture of about a degree a range
acceleration ``alpha`` is one with a cross-range speed ``alpha L / (2 (V - u_t))`` away
(73 s x alpha on GOTCHA, :mod:`sarmotion.motion.acceleration`), and a turn's centripetal
acceleration has a range component, so each sub-aperture's cross-range speed carries it.
A mover turning at 3 deg/s at 7 m/s (0.37 m/s^2) is thus estimated metres per second off
in cross-range speed, by an amount that changes along the turn; the test above still
sees the change, the apparent rate need not have the true rate's size or sign
(``docs/notes/acceleration.md``). The mover's own turn rate needs sub-apertures wide
enough to estimate its acceleration (:func:`sarmotion.motion.fit_range_acceleration`, 2
degrees and more).

**Through the looks** (:func:`look_turn_test`). Over a wide pass a uniform mover's
velocity estimates drift as the look turns, and their errors are well above their
bounds (clutter residue, the estimator's search): the pairs above then flag uniform
movers (on simulated 4 and 10 degree passes at 20 dB, 13 of 19 and 7 of 7 tracks at
``p`` = 0.01). Where a track has the fit of its range histories through their looks
(:mod:`sarmotion.tracking.wide_aspect`), the test is instead a nested comparison of two
models of those histories: uniform motion ``(x, y, ux, uy)`` against a constant ground
acceleration ``(x, y, ux, uy, ax, ay)`` (a turn of rate ``w`` at speed ``s`` is, over the
track, an acceleration ``w s`` across the velocity). Only detections of sub-apertures
that share no pulse are used (greedily in time), so that their errors are independent:
overlapping windows' correlated errors are not counted twice. The errors' size is not
taken from the bounds but from the data: each component's (range, range rate, range
acceleration) a posteriori variance factor is estimated from the uniform model's
residuals, ``f_c^2 = max(1, sum_i e_ic^2 / C_icc / (n - 4/3))`` (its share of the
``3 n - 4`` degrees of freedom, as in :mod:`sarmotion.tracking.wide_aspect`): for a
uniform mover they carry the clutter residue; for a turning one the misfit too, which
costs power, not false alarms. Estimated from the accelerating model's residuals
instead (``n - 2`` degrees of freedom each), they flagged 64 of 100 uniform movers at
``p`` = 0.05 over 4 degrees (4 independent looks): its two extra parameters spend a
component's few degrees of freedom, its factor comes out small, and that component's
weight large. With
those weights the decrease of the weighted residual from the uniform to the accelerating
fit, ``D``, against the accelerating fit's residual per degree of freedom ``s^2 =
chi2_1 / (3 n - 6)``, ``F = (D / 2) / s^2``, is F-distributed with ``(2, 3 n - 6)``
degrees of freedom for a uniform mover whose errors are independent between the looks
(the unknown error scale cancels). The track is flagged when ``F`` exceeds its quantile
at ``1 - p``; the statistic reported is the chi-square (2 degrees of freedom) of the same
tail probability, with its quantile at ``1 - p``, so that both tests read alike. At least
3 independent detections are needed (``3 n - 6 >= 3``).

The accelerating model's ``(u x a) / |u|^2`` is not a turn's rate once the heading turns
by a good part of a radian (a 3 deg/s turn over 30 degrees of GOTCHA's pass: +1.7 deg/s
for -3); the rate in the ground frame is instead fitted as a constant-rate turn, with
its confidence interval, by :mod:`sarmotion.tracking.turn_rate` (``rate=True``), which
also says when the looks leave it ambiguous (rates of both signs that fit as well are
common over 10 degrees).

Times in s, velocities in m/s, angles in degrees.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from .sub_apertures import disjoint_in_time
from .turn_rate import TurnRate, turn_rate
from .wide_aspect import LookMeasurement, fit_track, look_antennas, range_histories

__all__ = ["TurnTest", "look_turn_test", "turn_test"]


@dataclass(frozen=True, kw_only=True)
class TurnTest:
    """The turn test of one track (module notes).

    Attributes
    ----------
    flagged : bool
        The velocity changed beyond its uncertainty between two independent detections.
    statistic : float or None
        The largest ``d^T S^-1 d`` of the pairs (chi-square, 2 degrees of freedom); None
        when no two detections are independent.
    threshold : float or None
        Its chi-square quantile at ``1 - false_alarm / n_pairs``.
    false_alarm : float
        ``p``: the probability that a uniform mover's track is flagged.
    n_pairs : int
        Pairs of detections tested.
    apparent_turn_rate_deg_s, apparent_turn_rate_std_deg_s : float or None
        Heading rate of the velocity estimates between the first and last detections and
        its standard error (degrees per second, positive counter-clockwise; module notes:
        not the mover's own rate when it accelerates); None when they are not
        independent; always None through the looks (module notes).
    model : str
        ``"pairs"``: the pairs of velocities; ``"looks"``: the models of the range
        histories through their looks (:func:`look_turn_test`).
    n_looks : int
        Independent detections the looks' test used (0 for the pairs).
    turn_rate : TurnRate or None
        The turn rate in the ground frame through the looks
        (:mod:`sarmotion.tracking.turn_rate`), where it was asked for (the tracker asks
        where the track's position is fixed).
    """

    flagged: bool
    statistic: float | None
    threshold: float | None
    false_alarm: float
    n_pairs: int
    apparent_turn_rate_deg_s: float | None
    apparent_turn_rate_std_deg_s: float | None
    model: str = "pairs"
    n_looks: int = 0
    turn_rate: TurnRate | None = None


def _heading(v: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
    """Heading (rad) of a ground velocity and its gradient (rad per m/s)."""
    speed2 = float(v @ v)
    return float(np.arctan2(v[1], v[0])), np.array([-v[1], v[0]]) / max(speed2, 1e-300)


def turn_test(
    times_s: ArrayLike,
    pulses: Sequence[tuple[int, int]],
    positions_m: ArrayLike,
    velocities_mps: ArrayLike,
    velocity_covs: ArrayLike,
    family: tuple[ArrayLike, ArrayLike],
    *,
    false_alarm: float,
) -> TurnTest:
    """Test a track's detections for a change of velocity (module notes).

    Parameters
    ----------
    times_s : (n,) array_like
        Centre times of the detections' sub-apertures (s), increasing.
    pulses : sequence of (int, int)
        Each sub-aperture's ``(start, stop)`` pulses in the whole acquisition.
    positions_m, velocities_mps : (n, 2) array_like
        The detections' ground positions (m) and velocities (m/s): members of their
        families.
    velocity_covs : (n, 2, 2) array_like
        Their velocities' covariances ((m/s)^2).
    family : ((n, 2), (n, 2)) array_like
        Each detection's family tangent: position (m/m) and velocity ((m/s)/m) per metre
        of cross-range offset.
    false_alarm : float
        ``p`` of the test (0 < p < 1).

    Returns
    -------
    TurnTest
    """
    if not 0.0 < false_alarm < 1.0:
        raise ValueError(f"false_alarm must be in (0, 1), got {false_alarm!r}")
    t = np.asarray(times_s, dtype=np.float64)
    p = np.asarray(positions_m, dtype=np.float64).reshape(-1, 2)
    v = np.asarray(velocities_mps, dtype=np.float64).reshape(-1, 2)
    c = np.asarray(velocity_covs, dtype=np.float64).reshape(-1, 2, 2)
    fa = np.asarray(family[0], dtype=np.float64).reshape(-1, 2)
    fb = np.asarray(family[1], dtype=np.float64).reshape(-1, 2)
    n = t.size

    def compared(i: int, j: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``v_j' - v_i`` and its covariance (``j`` slid to ``i`` carried forward)."""
        dt = t[j] - t[i]
        a, b = fa[j], fb[j]
        aa = max(float(a @ a), 1e-300)
        slide = float(a @ (p[i] + v[i] * dt - p[j])) / aa
        d = v[j] + slide * b - v[i]
        jac_i = np.outer(b, a) * dt / aa - np.eye(2)
        return d, c[j] + jac_i @ c[i] @ jac_i.T

    pairs = []
    for i in range(n):
        j = next((k for k in range(i + 1, n) if pulses[k][0] >= pulses[i][1]), None)
        if j is not None:
            pairs.append((i, j))
    stats = []
    for i, j in pairs:
        d, s = compared(i, j)
        stats.append(float(d @ np.linalg.solve(s, d)))
    from scipy.stats import chi2  # scipy.stats takes ~0.7 s to import: when needed

    statistic = max(stats) if stats else None
    threshold = float(chi2.isf(false_alarm / len(pairs), 2)) if pairs else None
    rate = rate_std = None
    if n >= 2 and pulses[-1][0] >= pulses[0][1]:
        d, s = compared(0, n - 1)
        v_end = v[0] + d  # the last velocity, slid
        h0, g0 = _heading(v[0])
        h1, g1 = _heading(v_end)
        dt = t[-1] - t[0]
        dh = (h1 - h0 + np.pi) % (2.0 * np.pi) - np.pi
        # var(h1 - h0): h1 through d = v_j' - v_i, whose covariance s holds both detections
        g = np.concatenate([g1 - g0, g1])  # d(h1 - h0) / d(v_i, d) with v_j' = v_i + d
        cov = np.zeros((4, 4))
        cov[:2, :2] = c[0]
        cov[2:, 2:] = s
        # cov(v_i, d) = C_i J_i^T: d depends on v_i through J_i (compared)
        a, b = fa[-1], fb[-1]
        jac_i = np.outer(b, a) * dt / max(float(a @ a), 1e-300) - np.eye(2)
        cov[:2, 2:] = c[0] @ jac_i.T
        cov[2:, :2] = cov[:2, 2:].T
        rate = float(np.degrees(dh / dt))
        rate_std = float(np.degrees(np.sqrt(max(g @ cov @ g, 0.0)) / dt))
    return TurnTest(
        flagged=bool(statistic is not None and threshold is not None and statistic > threshold),
        statistic=statistic,
        threshold=threshold,
        false_alarm=float(false_alarm),
        n_pairs=len(pairs),
        apparent_turn_rate_deg_s=rate,
        apparent_turn_rate_std_deg_s=rate_std,
    )


def _histories(
    x: NDArray[np.float64],
    dts: NDArray[np.float64],
    antenna: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    height_m: float,
) -> NDArray[np.float64]:
    """``(R, R', R'')`` of every look for a mover of constant acceleration ``x[4:6]``.

    ``x = (x, y, ux, uy[, ax, ay])`` at the reference time (m, m/s, m/s^2); without the
    acceleration, a uniform mover.
    """
    acc = x[4:6] if x.size > 4 else np.zeros(2)
    dt = dts[:, None]
    p = x[:2] + dt * x[2:4] + 0.5 * dt**2 * acc
    u = x[2:4] + dt * acc
    return range_histories(p, u, np.tile(acc, (dts.size, 1)), antenna, height_m)


def look_turn_test(
    looks: Sequence[LookMeasurement],
    pulses: Sequence[tuple[int, int]],
    *,
    false_alarm: float,
    prior_std_m: float,
    centre_m: NDArray[np.float64] | None = None,
    height_m: float = 0.0,
    rate: bool = False,
) -> TurnTest | None:
    """Uniform motion against a constant acceleration through the looks (module notes).

    Parameters
    ----------
    looks : sequence of LookMeasurement
        A track's detections in time order.
    pulses : sequence of (int, int)
        Each one's sub-aperture's ``(start, stop)`` pulses in the whole acquisition.
    false_alarm : float
        ``p`` of the test (0 < p < 1).
    prior_std_m, centre_m, height_m
        The scene prior and the movers' height
        (:func:`~sarmotion.tracking.wide_aspect.fit_track`).
    rate : bool
        Also estimate the turn rate in the ground frame
        (:func:`~sarmotion.tracking.turn_rate.turn_rate`, seconds a track over tens of
        degrees).

    Returns
    -------
    TurnTest or None
        None with fewer than 3 independent detections.
    """
    from scipy.stats import chi2
    from scipy.stats import f as f_dist

    if not 0.0 < false_alarm < 1.0:
        raise ValueError(f"false_alarm must be in (0, 1), got {false_alarm!r}")
    if len(pulses) != len(looks):
        raise ValueError(f"{len(looks)} looks but {len(pulses)} pulse ranges")
    sel = [looks[k] for k in disjoint_in_time(pulses)]
    n = len(sel)
    if n < 3:
        return None
    centre = np.zeros(2) if centre_m is None else np.asarray(centre_m, dtype=np.float64)[:2]
    t0 = float(np.mean([m.time_s for m in sel]))
    dts = np.array([m.time_s for m in sel]) - t0
    z = np.stack([m.z for m in sel])
    sd = np.sqrt(np.stack([np.diag(m.covariance) for m in sel]))
    antenna = look_antennas(sel)

    def residual(x: NDArray[np.float64], factors: NDArray[np.float64]) -> NDArray[np.float64]:
        e = (_histories(x, dts, antenna, height_m) - z) / (sd * factors)
        return np.r_[e.ravel(), (x[:2] - centre) / prior_std_m]

    def solve(x: NDArray[np.float64], factors: NDArray[np.float64]):
        scale = np.array([1.0, 1.0, 0.1, 0.1, 0.01, 0.01])[: x.size]
        return least_squares(
            residual, x, args=(factors,), x_scale=scale, xtol=1e-12, ftol=1e-12, method="lm"
        )

    # uniform start: the wide-aspect fit (its search of the family) at t0
    uniform = fit_track(sel, prior_std_m=prior_std_m, centre_m=centre_m, height_m=height_m)
    x0, _ = uniform.at(t0)
    factors = np.ones(3)
    for _ in range(3):  # the uniform model's factors, settled (wide_aspect notes)
        h0 = solve(x0, factors)
        e = (_histories(h0.x, dts, antenna, height_m) - z) / sd
        factors = np.sqrt(np.maximum(1.0, np.sum(e**2, axis=0) / (n - 4.0 / 3.0)))
    h0 = solve(x0, factors)
    h1 = solve(np.r_[h0.x, 0.0, 0.0], factors)
    # the uniform model again from the accelerating one's point: its least residual
    h0 = min(h0, solve(h1.x[:4], factors), key=lambda sol: sol.cost)
    chi2_1, chi2_0 = 2.0 * float(h1.cost), 2.0 * float(h0.cost)
    nu = 3 * n - 6
    stat_f = max(0.0, chi2_0 - chi2_1) / 2.0 / (chi2_1 / nu)
    tail = float(f_dist.sf(stat_f, 2, nu))
    statistic = float(chi2.isf(tail, 2)) if tail > 0.0 else float("inf")
    threshold = float(chi2.isf(false_alarm, 2))

    return TurnTest(
        flagged=bool(tail < false_alarm),
        statistic=statistic,
        threshold=threshold,
        false_alarm=float(false_alarm),
        n_pairs=n - 1,
        apparent_turn_rate_deg_s=None,
        apparent_turn_rate_std_deg_s=None,
        model="looks",
        n_looks=n,
        turn_rate=(
            turn_rate(
                sel,
                prior_std_m=prior_std_m,
                centre_m=centre_m,
                height_m=height_m,
                error_factors=factors,
            )  # fmt: skip
            if rate
            else None
        ),
    )
