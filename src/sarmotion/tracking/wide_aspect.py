"""A mover's position from the range histories of many looks: the wide-aspect fit.

**What a sub-aperture measures.** Over a sub-aperture of about a degree the data fix a
mover's range history, not its cross-range position (:mod:`sarmotion.motion.aperture`):
every member ``(p + t a, v + t b)`` of its cross-range family has the same history. What
a detection measures is therefore the history itself, described about the
sub-aperture's centre time ``s_c`` by three numbers: the range ``R`` from the antenna
to the mover, the range rate ``R'`` and the range acceleration ``R''``. For a uniform
mover at ground position ``p`` and velocity ``u`` (height of the reference point), and
the antenna at ``r``, ``r'``, ``r''`` (a polynomial fitted to its positions over the
sub-aperture's pulses, :func:`antenna_state`), with ``d = p - r`` and ``d' = u - r'``::

    R = |d|,   R' = d . d' / R,   R'' = (|d'|^2 - d . r'' - R'^2) / R.

A detection's measurement ``z`` is these three evaluated at its own estimate (any member
of its family gives the same ``z``); its covariance is ``J C J^T``, ``C`` the Cramér–Rao
bound of the detection's ground-range position, range speed and cross-range speed
(:attr:`~sarmotion.tracking.sub_apertures.Detection.bound_cov`, the parameters of
:mod:`sarmotion.motion.bounds`) and ``J`` the derivatives of ``z`` along them. The
model ``h_i(x)`` of a track's state ``x = (x, y, ux, uy)`` at a reference time ``t_0``
moves the mover to ``s_c`` (``p + (s_c - t_0) u``) and evaluates the same three numbers
through that sub-aperture's antenna: it knows the look. Overlapping sub-apertures share
pulses, so their errors are correlated; each covariance is multiplied by
``1 / (1 - overlap)``, the number of sub-apertures that see each pulse, so that the
information of a pulse is counted once.

**Errors above the bound.** The bound is what an efficient estimator reaches on the
detection's own data; clutter residue and the estimator's search leave larger errors
(on a simulated 10 degree pass at 20 dB: range errors of millimetres against a bound of
0.3 mm, range accelerations of 1e-3 m/s^2 against 2e-5 m/s^2). The errors are therefore
measured on the data, as a posteriori variance factors: each component's standard
deviation (range, rate, acceleration) is multiplied by ``f_c = sqrt(max(1, sum_i
e_ic^2 / C_icc / chi2_q(nu)))``, ``e_ic`` the fit's residual of look ``i``, ``nu = n -
4/3`` the component's share of the ``3 n - 4`` degrees of freedom and ``chi2_q`` the
chi-square quantile at :data:`FACTOR_CONFIDENCE`'s complement: the variance's upper
95 % confidence limit, not its point estimate ``sum / nu``, so that a few looks do not
claim a precision they have not shown (4 looks: 13 times the point estimate's
variance; 10 looks: 2.4 times; 30 looks: 1.6 times). On a simulated 4 degree pass the
point estimate let 2 of 8 fits declare a position fixed 5 sigma off. The fit is repeated
with the factors until they settle (:data:`_CALIBRATION_ROUNDS`). A factor is never
below 1 (the bound stays a bound). With fewer than 3 looks a track keeps the factors it is given:
:func:`join_tracks` pools them over the pass's tracks (each track's factors weighted by
its degrees of freedom), since the detections of one pass share their estimator and
their clutter.

**The fit.** A track's state is the weighted least-squares solution of
``sum_i |W_i (h_i(x) - z_i)|^2`` (``W_i^T W_i = C_i^-1``) plus the prior that the mover
is in the imaged scene: its position within ``sigma_f`` (half the scene's side) of the
reference point in each axis (:func:`fit_track`). Over a few degrees the families of all
the looks are nearly parallel, the data leave the position free along them, and the
prior decides it; over tens of degrees of a circular pass the families turn with the
look and cross at the mover. The search starts on the family of the detection nearest
``t_0`` (offsets within ``3 sigma_f`` scanned, the best polished by
:func:`scipy.optimize.least_squares`). The covariance it reports is that of the looks'
ranges and range rates at the solution, the scene prior and the coherence margin
(below) included: ``(A^T A)^-1`` of their whitened Jacobian ``A``.

**Fixed or not.** The data fix the position when they, not the prior, carry it: when the
prior holds at most :data:`PRIOR_SHARE` (1 %) of the position's information in every
direction, i.e. the largest standard deviation of the position is at most
``sqrt(PRIOR_SHARE) sigma_f`` (a tenth of ``sigma_f``). That standard deviation is taken
from the looks' ranges and range rates alone, their range accelerations marginalised
(each look's ``(R, R')`` block of its covariance, the scene prior included). A
sub-aperture's ``R''`` is the measurement its estimator gets least right, and not at
random: through the whole chain at 4 degrees, 20 dB (``benchmarks/wide_aspect.py``) its
a posteriori factors were 1.1-742 (median 11) against 1-232 (median 5) for ``R`` and
1-37 (median 3) for ``R'``, and on a simulated 10 degree pass its errors shared a sign
(``benchmarks/wide_aspect.py``): a systematic error, which the white-error covariance
counts as information. It is also where a mover's own range acceleration ``alpha``
enters whole (one sub-aperture cannot tell ``alpha`` from a cross-range speed ``alpha L
/ (2 (V - u_t))`` away, 73 s x ``alpha`` on GOTCHA,
:mod:`sarmotion.motion.acceleration`). Over a few degrees the looks' ``R''`` can carry
the position alone: with detection errors of 5 mm, 1e-4 m/s and 5e-4 m/s (ground range,
range speed, cross-range speed), 4 degrees gave standard deviations of 1.3-2.4 m that
the ranges and range rates alone leave at 24-30 m; over tens of degrees the families'
ranges and range rates cross at the mover. When the ranges and range rates do not fix
it, the fit reports the family, as a single sub-aperture does, with their covariance:
the family they leave, and its spread.

**The coherence margin.** Every fix assumes uniform motion, and what it rests on is a
fraction of a wavelength: along the family the range histories of the members differ
only in their higher-order terms (over 30 degrees a 10 m offset moves the history by
about a wavelength), and a mover's own acceleration makes such terms too (a constant
range acceleration is a range curvature, as a cross-range offset is). An exactly
uniform simulated mover lets the fit claim centimetres over a 4 degree pass, which no
vehicle's motion supports. The fit therefore allows the mover a constant ground
acceleration of standard deviation ``a_c = lambda / T^2`` in each axis
(:func:`coherence_acceleration_mps2`; ``lambda`` the central wavelength, ``T`` the span
of the looks' centre times), marginalised in the covariance it reports and in the
decision above: the acceleration that moves the mover ``a_c T^2 / 8 = lambda / 8`` off
its uniform path at the ends of the pass, a two-way phase of ``pi / 2``, the quadratic
phase error that coherent focusing of the whole pass tolerates. A mover closer to
uniform than that is within its stated spread; one that departs more is what the turn
test (:mod:`sarmotion.tracking.turns`) is for. The spread is an upper bound for an
exactly uniform mover, and the honest one for a vehicle. Without a wavelength
(``wavelength_m`` None) the motion is taken as exactly uniform.

**One track per vehicle.** A uniform mover's range speed turns with the look: what
changes between the sub-apertures of a wide pass is expected. Two tracks of one uniform
mover fit one state: the increase of the weighted residual of the joint fit over the
two separate fits, ``D = chi2(A + B) - chi2(A) - chi2(B)``, is chi-square with the
number of constraints that joining adds (4 when each track fixes its own four
parameters, 3 or 2 when a track holds a single detection). For a single detection
``j`` joined to a track this is, linearised, the innovation test
``(z_j - h_j(x))^T (C_j + H_j P H_j^T)^-1 (z_j - h_j(x))`` of a Kalman gate in the
measurement space of the new look. :func:`join_tracks` joins the pair with the least
``D`` while it is below the chi-square quantile at the gate probability
(:attr:`~sarmotion.tracking.TrackingOptions.gate_probability`), tracks that hold
detections of the same sub-aperture never.

Times in s (slow time of the whole acquisition), positions in m, velocities in m/s,
range accelerations in m/s^2; float64 throughout.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from ..core import Traces
from .sub_apertures import Detection, SubApertureDetections

__all__ = [
    "FACTOR_CONFIDENCE",
    "PRIOR_SHARE",
    "AntennaState",
    "LookMeasurement",
    "PositionFit",
    "antenna_state",
    "coherence_acceleration_mps2",
    "fit_track",
    "join_tracks",
    "look_measurement",
    "pooled_factors",
    "look_antennas",
    "range_histories",
    "range_history",
]

#: Largest share of the position's information the scene prior may hold, in any
#: direction, for the data to fix the position (module notes): 1 %, i.e. a standard
#: deviation at most a tenth of the prior's.
PRIOR_SHARE = 0.01

#: Confidence of the upper limit of the a posteriori variance factors (module notes).
FACTOR_CONFIDENCE = 0.95

#: Family offsets scanned for the starting point of a fit, in prior standard deviations
#: on each side (module notes), and their number.
_SCAN_SIGMAS = 3.0
_SCAN_POINTS = 61

#: Fits of a track with its variance factors re-estimated (module notes): the factors
#: change by less than a percent after the second on simulated passes.
_CALIBRATION_ROUNDS = 3


@dataclass(frozen=True, kw_only=True, eq=False)
class AntennaState:
    """The antenna about a sub-aperture's centre time (:func:`antenna_state`).

    Attributes
    ----------
    time_s : float
        The centre time ``s_c`` (s, slow time of the whole acquisition).
    position_m, velocity_mps, acceleration_mps2 : (3,) ndarray
        ``r(s_c)`` (m), ``r'(s_c)`` (m/s) and ``r''`` (m/s^2).
    """

    time_s: float
    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64]
    acceleration_mps2: NDArray[np.float64]


def antenna_state(traces: Traces, pulses: slice, time_s: float) -> AntennaState:
    """The antenna's position and derivatives at ``time_s``: a least-squares polynomial.

    Of degree 5 in slow time (fewer with fewer than 6 pulses), fitted to the positions
    of ``pulses``: a lower degree takes the higher derivatives for lower ones (over a
    degree of GOTCHA's circle a quadratic takes the jerk ``-w^2 r'`` for a speed error
    of 0.5 mm/s, 7e-6 m/s^2 of range acceleration; a cubic leaves 3e-6 m/s^2; degree 5
    agrees with the exact range's derivatives to 1e-10).

    Parameters
    ----------
    traces : Traces
        The whole acquisition.
    pulses : slice
        The sub-aperture's pulses (at least 3).
    time_s : float
        Its centre time (s).

    Returns
    -------
    AntennaState
    """
    s = np.asarray(traces.slow_times_s[pulses], dtype=np.float64) - float(time_s)
    r = np.asarray(traces.positions_m[pulses], dtype=np.float64)
    if s.size < 3:
        raise ValueError(f"a sub-aperture needs at least 3 pulses, got {s.size}")
    scale = float(np.max(np.abs(s))) or 1.0
    degree = min(5, s.size - 1)  # lower degrees take higher derivatives for lower ones
    basis = np.column_stack([(s / scale) ** k for k in range(degree + 1)])
    coef, *_ = np.linalg.lstsq(basis, r, rcond=None)
    return AntennaState(
        time_s=float(time_s),
        position_m=coef[0].copy(),
        velocity_mps=coef[1] / scale,
        acceleration_mps2=2.0 * coef[2] / scale**2,
    )


def range_history(
    position_m: NDArray[np.float64],
    velocity_mps: NDArray[np.float64],
    antenna: AntennaState,
    height_m: float = 0.0,
) -> NDArray[np.float64]:
    """``(R, R', R'')`` of a uniform mover at the antenna's centre time (module notes).

    Parameters
    ----------
    position_m : (2,) ndarray
        Ground position at ``antenna.time_s`` (m).
    velocity_mps : (2,) ndarray
        Ground velocity (m/s).
    antenna : AntennaState
        The sub-aperture's antenna.
    height_m : float
        The mover's height (m; the reference point's).

    Returns
    -------
    (3,) ndarray
        Range (m), range rate (m/s), range acceleration (m/s^2).
    """
    one = (antenna.position_m[None], antenna.velocity_mps[None], antenna.acceleration_mps2[None])
    p, v = np.asarray(position_m, dtype=np.float64), np.asarray(velocity_mps, dtype=np.float64)
    return range_histories(p[None, :2], v[None, :2], None, one, height_m)[0]


def range_histories(
    position_m: NDArray[np.float64],
    velocity_mps: NDArray[np.float64],
    acceleration_mps2: NDArray[np.float64] | None,
    antenna: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    height_m: float = 0.0,
) -> NDArray[np.float64]:
    """``(R, R', R'')`` of a mover at many looks at once (:func:`range_history`, vectorised).

    Parameters
    ----------
    position_m, velocity_mps : (n, 2) ndarray
        The mover's ground position (m) and velocity (m/s) at each look's centre time.
    acceleration_mps2 : (n, 2) ndarray or None
        Its ground acceleration there (m/s^2; its range component enters ``R''``);
        None: uniform motion.
    antenna : tuple of (n, 3) ndarray
        The antenna's positions (m), velocities (m/s) and accelerations (m/s^2) at them.
    height_m : float
        The mover's height (m).

    Returns
    -------
    (n, 3) ndarray
        Range (m), range rate (m/s), range acceleration (m/s^2) of each look.
    """
    r_a, v_a, acc_a = antenna
    n = r_a.shape[0]
    d = np.column_stack([position_m, np.full(n, height_m)]) - r_a
    dv = np.column_stack([velocity_mps, np.zeros(n)]) - v_a
    if acceleration_mps2 is None:
        da = -acc_a
    else:
        da = np.column_stack([acceleration_mps2, np.zeros(n)]) - acc_a
    r = np.sqrt(np.einsum("ij,ij->i", d, d))
    rate = np.einsum("ij,ij->i", d, dv) / r
    rdd = (np.einsum("ij,ij->i", dv, dv) + np.einsum("ij,ij->i", d, da) - rate**2) / r
    return np.column_stack([r, rate, rdd])


def look_antennas(
    looks: Sequence[LookMeasurement],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The looks' antenna positions, velocities and accelerations, stacked ``(n, 3)`` each."""
    return (
        np.stack([m.antenna.position_m for m in looks]),
        np.stack([m.antenna.velocity_mps for m in looks]),
        np.stack([m.antenna.acceleration_mps2 for m in looks]),
    )


@dataclass(frozen=True, kw_only=True, eq=False)
class LookMeasurement:
    """One detection as a measurement of the range history through its look.

    Attributes
    ----------
    sub_aperture : int
        Index of its sub-aperture.
    antenna : AntennaState
        The sub-aperture's antenna.
    z : (3,) ndarray
        ``(R, R', R'')`` of the detection's estimate (m, m/s, m/s^2).
    covariance : (3, 3) ndarray
        Their covariance (inflated for overlap, module notes).
    detection : Detection
        The detection.
    """

    sub_aperture: int
    antenna: AntennaState
    z: NDArray[np.float64]
    covariance: NDArray[np.float64]
    detection: Detection

    @property
    def time_s(self) -> float:
        """Centre time of the sub-aperture (s)."""
        return self.antenna.time_s


def look_measurement(
    sub: SubApertureDetections,
    det: Detection,
    antenna: AntennaState,
    *,
    height_m: float = 0.0,
    overlap: float = 0.0,
) -> LookMeasurement:
    """The measurement ``z`` and covariance ``J C J^T`` of one detection (module notes).

    Without the detection's bound (``bound_cov`` None), ``C`` is diagonal with half a
    ground-range cell and half a resolution of each speed as standard deviations, the
    tracker's measurement of :mod:`sarmotion.tracking.tracker`.
    """
    speeds = np.linalg.inv(np.vstack([sub.look_direction[:2], sub.cross_range_speed_row]))
    directions = (  # position, velocity changes per unit of (x_r, u_r, u_p)
        (np.asarray(sub.range_direction, dtype=np.float64), np.zeros(2)),
        (np.zeros(2), speeds[:, 0]),
        (np.zeros(2), speeds[:, 1]),
    )
    p, v = det.position_m, det.velocity_mps
    z = range_history(p, v, antenna, height_m)
    steps = (1e-3, 1e-4, 1e-4)  # m, m/s, m/s: central differences of a smooth function
    jac = np.column_stack(
        [
            (
                range_history(p + h * dp, v + h * dv, antenna, height_m)
                - range_history(p - h * dp, v - h * dv, antenna, height_m)
            )
            / (2.0 * h)
            for h, (dp, dv) in zip(steps, directions, strict=True)
        ]
    )
    if det.bound_cov is not None:
        c = np.asarray(det.bound_cov, dtype=np.float64)
    else:
        c = np.diag(
            [
                (0.5 * sub.range_cell_m) ** 2,
                (0.5 * sub.range_speed_resolution_mps) ** 2,
                (0.5 * sub.cross_range_speed_resolution_mps) ** 2,
            ]
        )
    cov = jac @ c @ jac.T / (1.0 - float(overlap))
    return LookMeasurement(
        sub_aperture=int(sub.index), antenna=antenna, z=z, covariance=0.5 * (cov + cov.T),
        detection=det,
    )  # fmt: skip


@dataclass(frozen=True, kw_only=True, eq=False)
class PositionFit:
    """A track's uniform motion fitted to the range histories of its looks.

    Attributes
    ----------
    time_s : float
        Reference time ``t_0`` of the state (s): the mean of the looks' centre times.
    state : (4,) ndarray
        ``(x, y, ux, uy)`` at ``time_s`` (m, m/s).
    covariance : (4, 4) ndarray
        Its covariance from the looks' ranges and range rates (their range
        accelerations marginalised), the scene prior and the coherence margin included
        (m^2, m^2/s, m^2/s^2; module notes).
    chi2 : float
        Weighted residual of the measurements at the solution (the prior left out).
    dof : int
        Its degrees of freedom, ``3 n - 4`` (at least 0).
    n_looks : int
        Number of detections fitted.
    aspect_deg : float
        Change of the look's azimuth between the first and last detections (degrees).
    prior_std_m : float
        ``sigma_f``, the scene prior's standard deviation in each axis (m).
    acceleration_std_mps2 : float
        The coherence margin: the standard deviation of a constant ground acceleration
        per axis that :attr:`covariance` allows (m/s^2; 0: exactly uniform motion).
    fixed : bool
        Whether the data fix the position (module notes): the position's largest
        standard deviation in :attr:`covariance` is at most
        ``sqrt(PRIOR_SHARE) prior_std_m``. When not, the state is the member of the
        family that the scene prior picks.
    family_position_per_m, family_velocity_per_m : (2,) ndarray
        The direction in which the position is least known and the velocity's change
        along it (m/m, (m/s)/m): the track's family when it is not fixed.
    error_factors : (3,) ndarray
        The variance factors ``f_c`` of range, rate and acceleration the fit used
        (module notes): its measurements' standard deviations over their bounds.
    """

    time_s: float
    state: NDArray[np.float64]
    covariance: NDArray[np.float64]
    chi2: float
    dof: int
    n_looks: int
    aspect_deg: float
    prior_std_m: float
    acceleration_std_mps2: float
    fixed: bool
    family_position_per_m: NDArray[np.float64]
    family_velocity_per_m: NDArray[np.float64]
    error_factors: NDArray[np.float64]

    def at(self, time_s: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """State ``(x, y, ux, uy)`` and its covariance at ``time_s`` (uniform motion).

        The coherence margin's acceleration adds ``(dt^2 / 2, dt)`` times its spread,
        taken as independent of the state at :attr:`time_s`.
        """
        dt = float(time_s) - self.time_s
        f = _transition(dt)
        g = np.vstack([0.5 * dt**2 * np.eye(2), dt * np.eye(2)])
        cov = f @ self.covariance @ f.T + self.acceleration_std_mps2**2 * (g @ g.T)
        return f @ self.state, cov

    @property
    def position_std_m(self) -> float:
        """Largest standard deviation of the position at :attr:`time_s` (m)."""
        return float(np.sqrt(max(0.0, np.linalg.eigvalsh(self.covariance[:2, :2])[-1])))

    def position_std_at(self, time_s: float) -> float:
        """Largest standard deviation of the position at ``time_s`` (m)."""
        _, cov = self.at(time_s)
        return float(np.sqrt(max(0.0, np.linalg.eigvalsh(cov[:2, :2])[-1])))


def _transition(dt: float) -> NDArray[np.float64]:
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    return f


def _whitener(cov: NDArray[np.float64]) -> NDArray[np.float64]:
    """``W`` with ``W^T W = cov^-1`` (symmetric inverse square root)."""
    w, v = np.linalg.eigh(cov)
    floor = 1e-12 * float(w[-1]) if w[-1] > 0 else 1e-30
    return (v / np.sqrt(np.maximum(w, floor))).T


def fit_track(
    looks: Sequence[LookMeasurement],
    *,
    prior_std_m: float,
    centre_m: NDArray[np.float64] | None = None,
    height_m: float = 0.0,
    error_factors: NDArray[np.float64] | None = None,
    calibrate: bool = True,
    wavelength_m: float | None = None,
) -> PositionFit:
    """The uniform motion that best fits the looks' range histories (module notes).

    Parameters
    ----------
    looks : sequence of LookMeasurement
        One track's detections (at least one).
    prior_std_m : float
        ``sigma_f``: standard deviation of the position about ``centre_m`` in each axis
        before the data (m; half the imaged scene's side).
    centre_m : (2,) ndarray, optional
        Centre of the imaged scene (m); default the origin.
    height_m : float
        The movers' height (m).
    error_factors : (3,) ndarray, optional
        Variance factors ``f_c`` to start from (default ones: the bounds).
    calibrate : bool
        Re-estimate them from the fit's residuals (with at least 3 looks).
    wavelength_m : float, optional
        The radar's central wavelength (m): the fix's covariance and whether the data
        fix the position allow the mover a constant ground acceleration of
        :func:`coherence_acceleration_mps2` (module notes). Without it the motion is
        taken as exactly uniform.

    Returns
    -------
    PositionFit
    """
    factors = np.ones(3) if error_factors is None else np.asarray(error_factors, dtype=float)
    rounds = _CALIBRATION_ROUNDS if calibrate and len(looks) >= 3 else 1
    margin = coherence_acceleration_mps2(looks, wavelength_m)
    fit = _fit_once(looks, prior_std_m, centre_m, height_m, factors, margin)
    for _ in range(rounds - 1):
        factors = _factors(looks, fit, height_m)
        fit = _fit_once(looks, prior_std_m, centre_m, height_m, factors, margin)
    return fit


def _factors(
    looks: Sequence[LookMeasurement], fit: PositionFit, height_m: float
) -> NDArray[np.float64]:
    """A posteriori variance factors of range, rate and acceleration (module notes)."""
    x = fit.state
    ratio = np.zeros(3)
    for m in looks:
        dt = m.time_s - fit.time_s
        e = range_history(x[:2] + dt * x[2:], x[2:], m.antenna, height_m) - m.z
        ratio += e**2 / np.diag(m.covariance)
    from scipy.stats import chi2

    nu = len(looks) - 4.0 / 3.0
    return np.sqrt(np.maximum(1.0, ratio / float(chi2.ppf(1.0 - FACTOR_CONFIDENCE, nu))))


def _fit_once(
    looks: Sequence[LookMeasurement],
    prior_std_m: float,
    centre_m: NDArray[np.float64] | None,
    height_m: float,
    factors: NDArray[np.float64],
    acceleration_std_mps2: float = 0.0,
) -> PositionFit:
    """One weighted least-squares fit with the measurements' deviations times ``factors``."""
    if not looks:
        raise ValueError("a fit needs at least one detection")
    if not (np.isfinite(prior_std_m) and prior_std_m > 0):
        raise ValueError(f"prior_std_m must be positive (m), got {prior_std_m!r}")
    centre = np.zeros(2) if centre_m is None else np.asarray(centre_m, dtype=np.float64)[:2]
    times = np.array([m.time_s for m in looks])
    t0 = float(np.mean(times))
    dts = (times - t0)[:, None]
    whiteners = np.stack([_whitener(m.covariance * np.outer(factors, factors)) for m in looks])
    z = np.stack([m.z for m in looks])
    antenna = look_antennas(looks)

    def data_residual(x: NDArray[np.float64]) -> NDArray[np.float64]:
        h = range_histories(x[:2] + dts * x[2:], np.tile(x[2:], (len(looks), 1)), None,
                            antenna, height_m)  # fmt: skip
        return np.einsum("nij,nj->ni", whiteners, h - z).ravel()

    def residual(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.r_[data_residual(x), (x[:2] - centre) / prior_std_m]

    # start: the family of the detection nearest t0, offsets scanned
    anchor = looks[int(np.argmin(np.abs(times - t0)))]
    det = anchor.detection
    a, b = det.family_position_per_m, det.family_velocity_per_m
    dt_a = anchor.time_s - t0
    offsets = (
        np.linspace(-_SCAN_SIGMAS, _SCAN_SIGMAS, _SCAN_POINTS)
        * prior_std_m
        / max(float(np.hypot(*a)), 1e-9)
    )
    starts = []
    for t in offsets:
        v = det.velocity_mps + t * b
        p = det.position_m + t * a - dt_a * v
        x = np.r_[p, v]
        starts.append((float(np.sum(residual(x) ** 2)), x))
    starts.sort(key=lambda c: c[0])
    scale = np.array([1.0, 1.0, 0.1, 0.1])
    best = None
    for _, x in starts[:3]:
        sol = least_squares(residual, x, x_scale=scale, xtol=1e-12, ftol=1e-12, method="lm")
        if best is None or sol.cost < best.cost:
            best = sol
    assert best is not None
    x = best.x
    chi2 = float(np.sum(data_residual(x) ** 2))
    # the ranges' and range rates' covariance, with the coherence margin: whether they
    # fix the position, and the spread reported either way (module notes)
    cov = _geometry_covariance(looks, x, t0, height_m, factors, prior_std_m, acceleration_std_mps2)
    fixed = bool(np.linalg.eigvalsh(cov[:2, :2])[-1] <= PRIOR_SHARE * prior_std_m**2)
    w, v = np.linalg.eigh(cov[:2, :2])
    worst = v[:, -1]
    # velocity change along the worst position direction (regression in the covariance)
    along = cov[2:, :2] @ worst / max(float(worst @ cov[:2, :2] @ worst), 1e-300)
    return PositionFit(
        time_s=t0,
        state=x,
        covariance=cov,
        chi2=chi2,
        dof=max(0, 3 * len(looks) - 4),
        n_looks=len(looks),
        aspect_deg=_aspect_deg(looks),
        prior_std_m=float(prior_std_m),
        acceleration_std_mps2=float(acceleration_std_mps2),
        fixed=fixed,
        family_position_per_m=worst,
        family_velocity_per_m=along,
        error_factors=np.array(factors, dtype=np.float64),
    )


def coherence_acceleration_mps2(
    looks: Sequence[LookMeasurement], wavelength_m: float | None
) -> float:
    """The ground acceleration a fix allows (module notes): ``lambda / T^2`` per axis.

    ``T`` is the span of the looks' centre times (s). 0 (exactly uniform motion) without
    a wavelength or with fewer than two distinct times.

    Parameters
    ----------
    looks : sequence of LookMeasurement
        A track's detections.
    wavelength_m : float or None
        The radar's central wavelength (m).

    Returns
    -------
    float
        The standard deviation of each ground component of the acceleration (m/s^2).
    """
    if wavelength_m is None or len(looks) < 2:
        return 0.0
    if not (np.isfinite(wavelength_m) and wavelength_m > 0):
        raise ValueError(f"wavelength_m must be positive (m), got {wavelength_m!r}")
    times = [m.time_s for m in looks]
    span = max(times) - min(times)
    return float(wavelength_m) / span**2 if span > 0 else 0.0


def _geometry_covariance(
    looks: Sequence[LookMeasurement],
    x: NDArray[np.float64],
    t0: float,
    height_m: float,
    factors: NDArray[np.float64],
    prior_std_m: float,
    acceleration_std_mps2: float = 0.0,
) -> NDArray[np.float64]:
    """Covariance of the state from the looks' ranges and range rates alone (notes).

    The range accelerations are marginalised (each look's ``(R, R')`` block of its
    covariance); the scene prior is included; with ``acceleration_std_mps2`` > 0 a
    constant ground acceleration of that spread per axis is marginalised too (the
    coherence margin, module notes). ``(4, 4)``, linearised at ``x``.
    """
    n = 6 if acceleration_std_mps2 > 0 else 4
    info = np.zeros((n, n))
    info[:2, :2] = np.eye(2) / prior_std_m**2
    if n == 6:
        info[4:, 4:] = np.eye(2) / acceleration_std_mps2**2
    # m, m, m/s, m/s, m/s^2, m/s^2: central differences of a smooth function
    steps = np.array([1e-3, 1e-3, 1e-4, 1e-4, 1e-5, 1e-5])[:n]
    state = np.r_[x, np.zeros(n - 4)]
    for m in looks:
        dt = m.time_s - t0

        def h(s: NDArray[np.float64], dt: float = dt, m: LookMeasurement = m):
            acc = s[4:6] if n == 6 else np.zeros(2)
            position = s[:2] + dt * s[2:4] + 0.5 * dt**2 * acc
            velocity = s[2:4] + dt * acc
            return range_history(position, velocity, m.antenna, height_m)[:2]

        jac = np.column_stack([(h(state + e) - h(state - e)) / (2.0 * e[k]) for k, e in
                               enumerate(np.diag(steps))])  # fmt: skip
        c = (m.covariance * np.outer(factors, factors))[:2, :2]
        info += jac.T @ np.linalg.solve(c, jac)
    cov = np.linalg.pinv(info)[:4, :4]
    return 0.5 * (cov + cov.T)


def _aspect_deg(looks: Sequence[LookMeasurement]) -> float:
    """Azimuth change of the antenna between the first and last looks (degrees)."""
    first = min(looks, key=lambda m: m.time_s).antenna.position_m[:2]
    last = max(looks, key=lambda m: m.time_s).antenna.position_m[:2]
    cosine = float(first @ last) / float(np.linalg.norm(first) * np.linalg.norm(last))
    return float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def _join_dof(n_a: int, n_b: int) -> int:
    """Constraints added by joining tracks of ``n_a`` and ``n_b`` detections (notes)."""
    return min(4, 3 * n_a) + min(4, 3 * n_b) - 4


def _joined(
    looks_i: list[LookMeasurement],
    looks_j: list[LookMeasurement],
    fit_i: PositionFit | None,
    fit_j: PositionFit | None,
    gate_probability: float,
    chi2_dist: object,
    **prior: object,
) -> tuple[float, PositionFit] | None:
    """The joint fit of two tracks and its residual increase, if within the gate."""
    if {m.sub_aperture for m in looks_i} & {m.sub_aperture for m in looks_j}:
        return None  # one mover gives one detection per sub-aperture
    assert fit_i is not None and fit_j is not None
    joint = fit_track(looks_i + looks_j, **prior)  # type: ignore[arg-type]
    increase = joint.chi2 - fit_i.chi2 - fit_j.chi2
    dof = _join_dof(len(looks_i), len(looks_j))
    gate = float(chi2_dist.ppf(gate_probability, dof))  # type: ignore[attr-defined]
    return (increase, joint) if increase <= gate else None


def pooled_factors(
    groups: Sequence[Sequence[LookMeasurement]],
    *,
    prior_std_m: float,
    centre_m: NDArray[np.float64] | None = None,
    height_m: float = 0.0,
) -> NDArray[np.float64]:
    """Variance factors of a pass: each track's, pooled by degrees of freedom (notes).

    Tracks of fewer than 3 looks do not count; ones when none has 3.
    """
    total, weight = np.zeros(3), 0.0
    for g in groups:
        if len(g) < 3:
            continue
        fit = fit_track(g, prior_std_m=prior_std_m, centre_m=centre_m, height_m=height_m)
        w = len(g) - 4.0 / 3.0
        total += w * fit.error_factors**2
        weight += w
    return np.sqrt(total / weight) if weight > 0 else np.ones(3)


def join_tracks(
    groups: Sequence[Sequence[LookMeasurement]],
    *,
    prior_std_m: float,
    gate_probability: float,
    centre_m: NDArray[np.float64] | None = None,
    height_m: float = 0.0,
    error_factors: NDArray[np.float64] | None = None,
) -> list[list[int]]:
    """Which tracks are one uniform mover: the joined groups' indices (module notes).

    Parameters
    ----------
    groups : sequence of sequence of LookMeasurement
        Each track's detections.
    prior_std_m, centre_m, height_m
        As in :func:`fit_track`.
    gate_probability : float
        Probability that two tracks of one uniform mover are joined (0 < p < 1).
    error_factors : (3,) ndarray, optional
        Variance factors of every look (:func:`pooled_factors`; default ones).

    Returns
    -------
    list of list of int
        Indices into ``groups``, each list one mover, in order of their first index.
    """
    from scipy.stats import chi2 as chi2_dist

    prior = {
        "prior_std_m": prior_std_m, "centre_m": centre_m, "height_m": height_m,
        "error_factors": error_factors, "calibrate": False,
    }  # fmt: skip
    members = [[k] for k in range(len(groups))]
    looks = [list(g) for g in groups]
    fits = [fit_track(g, **prior) if g else None for g in looks]  # type: ignore[arg-type]
    alive = [bool(g) for g in looks]
    pairs: dict[tuple[int, int], tuple[float, PositionFit] | None] = {}
    while True:
        best: tuple[float, int, int, PositionFit] | None = None
        for i in range(len(looks)):
            for j in range(i + 1, len(looks)):
                if not (alive[i] and alive[j]):
                    continue
                if (i, j) not in pairs:
                    pairs[(i, j)] = _joined(
                        looks[i], looks[j], fits[i], fits[j], gate_probability, chi2_dist, **prior
                    )
                found = pairs[(i, j)]
                if found is not None and (best is None or found[0] < best[0]):
                    best = (found[0], i, j, found[1])
        if best is None:
            break
        _, i, j, joint = best
        looks[i] = sorted(looks[i] + looks[j], key=lambda m: m.time_s)
        members[i] = members[i] + members[j]
        fits[i] = joint
        alive[j] = False
        for key in [k for k in pairs if i in k or j in k]:
            del pairs[key]
    return [sorted(members[k]) for k in range(len(looks)) if alive[k]]
