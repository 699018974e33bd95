r"""Range acceleration of a mover over a wide aperture, with its Cramér–Rao bound.

**The quantity.** The uniform model (``eq:MOD9``) is extended by one parameter: the mover
moves as

.. math::

    \rho(s) = \rho + s\, u + \tfrac{1}{2} s^2 \alpha\, b_r, \qquad
    b_r = \texttt{ground\_velocity}(1, 0),

``b_r`` the ground vector of unit range speed and zero cross-range speed. ``alpha`` is
therefore the rate of change of the range speed, ``alpha = d u_r / ds`` (m/s^2, with the
sign of ``u_r = u . m_o``: positive towards the radar), the cross-range speed held
constant. Its range history is the uniform one's minus ``alpha (n . b_r) s^2 / 2`` to
second order in ``s`` (``n`` the unit line of sight, ``n . b_r ~ m_o . b_r = 1``): ``-alpha``
is the second derivative of the range at ``s = 0`` beyond what the uniform motion gives.

**Why only over wide apertures.** Over about a degree the range history is fixed to
second order in ``s`` (:mod:`sarmotion.motion.aperture`), and its curvature is shared by
the two: a cross-range speed change ``du_p`` changes it by ``-2 (V - u_t) du_p / L``
(``V`` platform speed, ``u_t`` the mover's speed along the flight, ``L`` range), a range
acceleration by ``-alpha``. An acceleration ``alpha`` is thus a cross-range speed
``alpha L / (2 (V - u_t))`` away (73 s x alpha on GOTCHA's geometry at ``u_t = 0``:
1 m/s^2 looks like 73 m/s of cross-range speed). Only the higher orders of the range
history (the circular flight's and the square root's) tell them apart, and they grow
with the aperture (:func:`separable_fraction`: the fraction of the acceleration's Fisher
information the uniform motion does not share). The cross-range coordinate ``y`` of the
position, which the pipeline holds at the reference point's cross range (the data of a
few degrees hardly fix it), enters at the same orders: a mover ``dy`` off the held cross
range has its acceleration estimated ``beta dy`` off (``beta`` the shift of the fit that
best mimics ``dy``, :func:`acceleration_bound`), which the standard error counts for a
``dy`` of spread ``cross_range_std_m`` (half the imaged scene in the analysis).

**The limit of the uniform start, and the central searches.** A uniform motion's range
curvature is about ``(V - u_t)^2 / L`` or more (0.48 m/s^2 on GOTCHA at ``u_t = 0``): a
mover accelerating towards the radar by more than that has a range history that bends
the other way over the central degree, no uniform motion matches it, and the uniform
stage does not hold it (its ``|I|`` a small fraction of the mover's amplitude).
Accelerations away from the radar, and towards it below that, look like a cross-range
speed (beyond the default search interval of +-30 m/s from about 0.4 m/s^2). And where
the uniform stage holds the mover over the central degree, its focus on the whole
aperture is a uniform motion's compromise with the acceleration, whose range history
away from the centre is not the mover's. The profile (below) therefore runs from two
measured range histories, and of their maxima the higher ``|I|`` is kept (both are
maxima of the same likelihood; the first is kept unless the second's log-likelihood,
``|I|^2 sum W^2 / (n sigma_P^2)``, is higher by more than 1/2, the drop one standard
error away from a maximum: two ascents that end closer found the same maximum):

1. the uniform start's over the whole aperture;
2. the data's over the central degree, where a uniform motion and the acceleration
   share the range history to second order. Where the uniform start holds the mover
   there (:func:`uniform_start_holds`: its coherent sum keeps at least
   :data:`HOLD_COHERENCE` of the per-pulse terms' power, the main lobe's half-power
   point), it is the uniform start's. Where it does not, it is measured without assuming
   a uniform motion, by the *central searches*: at each ``alpha`` of the profile's grid
   the central traces are shifted in range by ``+alpha s^2 / 2`` (which takes that much
   acceleration off every echo) and searched by the uniform search
   (:func:`sarmotion.motion.fit_point_mover`) over cross-range speeds ``+-w``; the fit of
   largest ``|I|`` gives the data's range history (its own minus the known shift). ``w =
   step L / (2 V)``, ``step`` the grid's spacing: a grid step of acceleration moves the
   curvature as ``L step / (2 (V - u_t))`` of cross-range speed, so each curvature of
   the grid's span falls in the windows of two neighbouring grid points at ``u_t = 0``
   and of at least one for ``|u_t|`` up to ``V / 2``.

A uniform mover's answer is the first start's (the second's maximum is the same one).

**The rule** (:func:`acceleration_estimable`). The acceleration is reported when the data
say more about it than the motion model assumed before the data: its information (one
over its squared standard error: the uniform parameters and the phase eliminated, the
held ``y``'s spread counted) exceeds the information ``T / q`` of the prior the tracker
uses for a road vehicle, white-noise acceleration of spectral density ``q``
(:data:`ACCELERATION_PSD`, 1 m^2/s^3 as :class:`sarmotion.tracking.TrackingOptions`),
whose mean over an aperture of duration ``T`` has variance ``q / T``. Equivalently
``std(alpha)^2 < q / T``. It depends on the
mover's SNR, not only on the aperture; the analysis runs the step only where the
aperture is wide enough to be refined on (:mod:`sarmotion.pipeline.movers`: more than 1.5
sub-apertures of a degree), so one-degree data never pay for it and report the
acceleration as not estimable (``docs/notes/acceleration.md``: the bound against the
aperture).

**The fit** (:func:`fit_range_acceleration`): the maximum of the matched filter ``|I|``
(:class:`sarmotion.motion.MatchedFilter`) over ``(x, u_r, u_p, alpha)``, ``y`` held,
profiled in ``alpha``: at each ``alpha`` the motion whose range history is nearest the
measured one (least squares over the pulses it was measured on: the ridge of the
likelihood, curved over the tens of m/s of cross-range speed an acceleration moves) is
refined by a Newton ascent of ``|I|^2`` (:func:`sarmotion.core.ascent.newton_ascent`,
analytic derivatives); ``alpha`` is searched on a grid of ``_PROFILE_SPAN`` prior
deviations either side of 0, then by a bounded scalar search between the best point's
neighbours. The standard error
(:func:`acceleration_bound`) is the Cramér–Rao bound of ``(x, u_r, u_p, alpha, |a|)`` at
the fit with the fitted amplitude and the measured noise, factored by QR (the normal
matrix's condition number is past float64's precision), plus the held ``y``'s spread.

Positions in m, speeds in m/s, accelerations in m/s^2, geometry in float64.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import solve_triangular
from scipy.optimize import least_squares, minimize_scalar

from ..core import Acquisition, C, Traces, as_point, as_traces, ground_velocity, range_speed
from ..core.ascent import newton_ascent
from ..core.spectral import phased_row_sums, shift_fast_time
from ..imaging import resolution
from .aperture import central_sub_aperture, ranges_m
from .likelihood import MatchedFilter, PointFit, fit_point_mover

__all__ = [
    "ACCELERATION_PSD",
    "HOLD_COHERENCE",
    "RangeAcceleration",
    "acceleration_bound",
    "acceleration_estimable",
    "acceleration_gradients",
    "fit_range_acceleration",
    "separable_fraction",
    "uniform_start_holds",
]

#: Spectral density ``q`` of the white-noise acceleration a road vehicle is assumed to
#: have before the data (m^2/s^3): accelerations of about 1 m/s^2 sustained over a second,
#: as :class:`sarmotion.tracking.TrackingOptions`' ``acceleration_psd``.
ACCELERATION_PSD = 1.0

#: Unit of ``alpha`` for the tolerance of its search: the change that leaves a quarter
#: radian of phase once ``(x, u_r, u_p)`` follow it (module notes).
_QUARTER_RADIAN = 0.25

#: Newton units of ``(x, u_r, u_p)`` at a fixed ``alpha``: about an eighth of a
#: resolution over a GOTCHA degree (:mod:`sarmotion.motion.likelihood`).
_LOCAL_UNITS = np.array([0.03, 0.0015, 0.09])


def acceleration_gradients(
    antenna_m: ArrayLike,
    slow_times_s: ArrayLike,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    range_acceleration_mps2: float,
    *,
    range_direction: ArrayLike,
    cross_range_direction: ArrayLike,
    range_basis_mps: ArrayLike,
    cross_basis_mps: ArrayLike,
) -> NDArray[np.float64]:
    """Derivatives of the range with respect to ``(x, u_r, u_p, y, alpha)`` (module notes).

    Parameters
    ----------
    antenna_m : (n_pulses, 3) array_like
        Antenna positions (m).
    slow_times_s : (n_pulses,) array_like
        Slow times (s), ``s = 0`` the time of ``position_m``.
    position_m : (3,) array_like
        Position at ``s = 0`` (m).
    velocity_mps : (2,) array_like
        Ground velocity at ``s = 0`` (m/s).
    range_acceleration_mps2 : float
        ``alpha`` (m/s^2).
    range_direction, cross_range_direction : (2,) array_like
        Unit ground-range and cross-range directions ``e_r``, ``e_c``.
    range_basis_mps, cross_basis_mps : (2,) array_like
        ``b_r = ground_velocity(1, 0)`` and ``b_p = ground_velocity(0, 1)``.

    Returns
    -------
    (n_pulses, 5) ndarray
        ``-n_j . e_r``, ``-s_j n_j . b_r``, ``-s_j n_j . b_p``, ``-n_j . e_c`` and
        ``-(s_j^2 / 2) n_j . b_r`` (m per unit of each parameter), ``n_j`` the unit line
        of sight to the antenna.
    """
    ant = np.asarray(antenna_m, dtype=np.float64)
    s = np.asarray(slow_times_s, dtype=np.float64)
    e_r, e_c, b_r, b_p = (
        np.r_[np.asarray(v, dtype=np.float64).reshape(2), 0.0]
        for v in (range_direction, cross_range_direction, range_basis_mps, cross_basis_mps)
    )
    where = _track(as_point(position_m), velocity_mps, range_acceleration_mps2, b_r, s)
    los = ant - where
    n = los / np.linalg.norm(los, axis=1)[:, None]
    nb = n @ b_r
    return np.stack([-(n @ e_r), -s * nb, -s * (n @ b_p), -(n @ e_c), -0.5 * s**2 * nb], axis=1)


def _track(
    position: NDArray[np.float64],
    velocity_mps: ArrayLike,
    alpha: float,
    b_r: NDArray[np.float64],
    s: NDArray[np.float64],
) -> NDArray[np.float64]:
    """``rho + s u + (s^2 / 2) alpha b_r`` at the slow times, shape (n, 3)."""
    v3 = np.r_[np.asarray(velocity_mps, dtype=np.float64).reshape(2), 0.0]
    return position[None, :] + s[:, None] * v3[None, :] + 0.5 * alpha * s[:, None] ** 2 * b_r


def _phase_factor(
    gradients_m: NDArray[np.float64], frequencies_hz: NDArray[np.float64], weights: ArrayLike
) -> NDArray[np.float64]:
    """Upper-triangular ``R`` with ``R^T R = sum w (psi - mean)(psi - mean)^T / sum w``.

    The right side is the Fisher matrix of the range parameters over ``2 SNR``
    (:mod:`sarmotion.motion.bounds`, the phase eliminated), in rad^2 per unit^2. It is
    formed as ``A^T A`` of the weighted, centred phase derivatives ``A`` (one row per
    pulse and frequency) and factored by QR of ``A``, never by inverting ``A^T A``: the
    acceleration shares all but ~1e-8 of its information with the uniform motion, a
    condition number that the normal matrix squares past float64's precision while
    ``R`` keeps it (``1 / R[-1, -1]^2`` is the last parameter's variance with the others
    unknown).
    """
    g = np.asarray(gradients_m, dtype=np.float64)
    k = 4.0 * np.pi * np.asarray(frequencies_hz, dtype=np.float64) / C  # rad per metre
    w = np.asarray(weights, dtype=np.float64) ** 2
    w = w / (g.shape[0] * w.sum())  # every pulse the same spectrum
    psi = k[None, :, None] * g[:, None, :]  # (n_pulses, n_freq, p)
    mean = np.einsum("k,jkp->p", w, psi)
    a = (np.sqrt(w)[None, :, None] * (psi - mean)).reshape(-1, g.shape[1])
    return np.linalg.qr(a, mode="r")


def separable_fraction(
    gradients_m: ArrayLike, frequencies_hz: ArrayLike, weights: ArrayLike
) -> float:
    """Fraction of the last parameter's Fisher information the others do not share.

    ``1 / (J_aa [J^-1]_aa)`` of the parameters' Fisher matrix (the phase eliminated;
    SNR-free): 1 when the last parameter is orthogonal to the others, 0 when the others
    explain it. With :func:`acceleration_gradients` it is the acceleration's
    separability from the uniform motion ``(x, u_r, u_p, y)`` over the aperture (module
    notes).
    """
    g = np.asarray(gradients_m, dtype=np.float64)
    r = _phase_factor(g, np.asarray(frequencies_hz, dtype=np.float64), weights)
    return float(r[-1, -1] ** 2 / np.sum(r[:, -1] ** 2))


def acceleration_bound(
    gradients_m: ArrayLike,
    frequencies_hz: ArrayLike,
    weights: ArrayLike,
    *,
    amplitude: float,
    noise_variance: float,
    cross_range_std_m: float,
) -> NDArray[np.float64]:
    """Error covariance of ``(x, u_r, u_p, alpha, |a|)`` estimated with ``y`` held (module notes).

    Two parts. The Cramér–Rao bound with ``y`` at its true value,
    ``(2 SNR R^T R)^-1`` for ``(x, u_r, u_p, alpha)`` (:func:`_phase_factor`, inverted
    through the triangular factor) and ``sigma_P^2 / (2 n_pulses sum W^2)`` for ``|a|``
    (:mod:`sarmotion.motion.bounds`); plus what a held ``y`` that is ``dy`` off the truth
    adds: the estimate moves by ``beta dy``, ``beta`` the least-squares coefficients of
    ``y``'s phase derivatives on the others' (the parameters' shift that best mimics
    ``dy``), so ``beta beta^T cross_range_std_m^2`` for a ``dy`` of that spread.

    Parameters
    ----------
    gradients_m : (n_pulses, 5) array_like
        :func:`acceleration_gradients`.
    frequencies_hz, weights, amplitude, noise_variance
        As :func:`sarmotion.motion.fisher_information` (``noise_variance``: per
        phase-history sample).
    cross_range_std_m : float
        Spread of the true cross-range coordinate about the held one (m, >= 0).

    Returns
    -------
    (5, 5) ndarray
        Covariance (m, m/s, m/s, m/s^2, amplitude units; squared).
    """
    if not (np.isfinite(amplitude) and amplitude > 0):
        raise ValueError(f"amplitude must be > 0, got {amplitude!r}")
    if not (np.isfinite(noise_variance) and noise_variance > 0):
        raise ValueError(f"noise_variance must be > 0, got {noise_variance!r}")
    if not (np.isfinite(cross_range_std_m) and cross_range_std_m >= 0):
        raise ValueError(f"cross_range_std_m must be >= 0, got {cross_range_std_m!r}")
    g = np.asarray(gradients_m, dtype=np.float64)[:, [0, 1, 2, 4, 3]]  # y last
    w2 = np.asarray(weights, dtype=np.float64) ** 2
    energy = g.shape[0] * float(w2.sum())
    snr = amplitude**2 * energy / noise_variance
    r = _phase_factor(g, np.asarray(frequencies_hz, dtype=np.float64), weights)
    r_inv = solve_triangular(r[:4, :4], np.eye(4))
    beta = r_inv @ r[:4, 4]  # least squares of y's column on the others'
    cov = np.zeros((5, 5))
    cov[:4, :4] = r_inv @ r_inv.T / (2.0 * snr) + cross_range_std_m**2 * np.outer(beta, beta)
    cov[4, 4] = noise_variance / (2.0 * energy)
    return cov


def acceleration_estimable(
    std_mps2: float, duration_s: float, *, acceleration_psd: float = ACCELERATION_PSD
) -> bool:
    """Whether the data tell more of ``alpha`` than the prior: ``std^2 < q / T`` (module notes).

    Parameters
    ----------
    std_mps2 : float
        Cramér–Rao bound of ``alpha`` (m/s^2).
    duration_s : float
        The aperture's duration ``T`` (s).
    acceleration_psd : float
        ``q`` (m^2/s^3).
    """
    return bool(np.isfinite(std_mps2) and std_mps2**2 < acceleration_psd / duration_s)


@dataclass(frozen=True, kw_only=True, eq=False)
class RangeAcceleration:
    """A mover's range acceleration over an aperture (:func:`fit_range_acceleration`).

    Attributes
    ----------
    range_acceleration_mps2 : float
        ``alpha = d u_r / ds`` (m/s^2; module notes).
    std_mps2 : float
        Its standard error (m/s^2): the Cramér–Rao bound at the fitted amplitude and the
        given noise, the uniform motion unknown, plus the spread the held cross-range
        coordinate gives it (:func:`acceleration_bound`).
    estimable : bool
        :func:`acceleration_estimable`: the bound is under the prior's spread.
    prior_std_mps2 : float
        That spread, ``sqrt(q / T)`` (m/s^2).
    amplitude : complex
        ``I / n_pulses`` at the fit (data units).
    uniform_amplitude : complex
        The same at the uniform start (``alpha = 0``).
    separable_fraction : float
        :func:`separable_fraction` at the fit.
    covariance : (5, 5) ndarray
        :func:`acceleration_bound` (``x, u_r, u_p, alpha, |a|``).
    uniform_start_holds : bool
        The uniform start holds the mover over the central degree
        (:func:`uniform_start_holds`); where it does not, the central searches ran.
    start : str
        The range history the kept maximum of the profile started from (module notes):
        ``"uniform"`` (the uniform start's over the whole aperture), ``"central"`` (the
        uniform start's over the central degree) or ``"central search"`` (the central
        searches').
    """

    range_acceleration_mps2: float
    std_mps2: float
    estimable: bool
    prior_std_mps2: float
    amplitude: complex
    uniform_amplitude: complex
    separable_fraction: float
    covariance: NDArray[np.float64]
    uniform_start_holds: bool = True
    start: str = "uniform"


#: Half-width of the profile over ``alpha`` in prior standard deviations ``sqrt(q / T)``:
#: a road vehicle's mean acceleration beyond four of them has a prior probability of 6e-5.
_PROFILE_SPAN = 4.0

#: Points of the profile over ``alpha`` on each side of zero: one prior deviation apart.
#: Each starts from a measured range history (the uniform start's, or the central
#: searches', module notes), so the grid only has to land on the lobe's slope; the
#: bounded search refines between the best point's neighbours
#: (``benchmarks/acceleration_coverage.py`` checks the two together).
_PROFILE_HALF_POINTS = 4

#: Share of the per-pulse terms' power a motion's coherent sum must keep to hold the mover
#: (:func:`uniform_start_holds`): the main lobe's half-power point. A motion that keeps
#: more is on the lobe's slope in every combination of its parameters.
HOLD_COHERENCE = 0.5


def uniform_start_holds(
    data: Traces | ArrayLike,
    positions_m: ArrayLike,
    *,
    acquisition: Acquisition | None = None,
    noise_variance: float,
    coherence: float = HOLD_COHERENCE,
) -> tuple[bool, float]:
    """Whether a motion holds a mover coherently over pulses: its coherent share of their power.

    The matched filter is a sum over pulses, ``I = sum_j z_j``, ``z_j`` one pulse's
    coherent sum over frequency (:class:`sarmotion.motion.MatchedFilter`), with noise of
    variance ``sigma_z^2 = sigma_P^2 / sum W^2`` (``sigma_P^2 = n_samples`` times the noise
    per fast-time sample). Where the motion's range history is the mover's, the ``z_j``
    share one phase and ``|I|^2`` is ``n`` times their power; where it departs by a
    fraction of a wavelength the phases turn and ``|I|^2`` keeps a share of it. The
    share, the noise's expected power taken off both,

        kappa = (|I|^2 - n sigma_z^2) / (n (sum_j |z_j|^2 - n sigma_z^2)),

    is 1 at the mover's motion where its echo is the same in every pulse, and the squared
    mean of its amplitudes over their mean square where it changes in amplitude only (a
    separation that takes part of it in some pulses, a reflectivity that varies with
    aspect: 0.94 for changes of 25 % rms); the motion holds the mover when ``kappa >=
    coherence``. Without power above the noise the test cannot confirm it (``kappa``
    NaN, not held).

    Parameters
    ----------
    data : Traces or (n_pulses, n_samples) array_like
        The traces (the pulses tested).
    positions_m : (n_pulses, 3) array_like
        The motion's positions at those pulses (m).
    acquisition : Acquisition, optional
        Required when ``data`` is an array.
    noise_variance : float
        Noise variance per fast-time sample (data units squared, >= 0).
    coherence : float
        Share required, in (0, 1].

    Returns
    -------
    holds : bool
    kappa : float
        The share (NaN without power above the noise).
    """
    if not (np.isfinite(noise_variance) and noise_variance >= 0):
        raise ValueError(f"noise_variance must be >= 0, got {noise_variance!r}")
    if not (0.0 < coherence <= 1.0):
        raise ValueError(f"coherence must be in (0, 1], got {coherence!r}")
    tr = as_traces(data, acquisition)
    where = np.asarray(positions_m, dtype=np.float64)
    if where.shape != (tr.n_pulses, 3):
        raise ValueError(f"positions_m must have shape ({tr.n_pulses}, 3), got {where.shape}")
    mf = MatchedFilter(tr)
    delays = 2.0 * (np.linalg.norm(mf.antenna - where, axis=1) - mf.ref_range) / C
    z = phased_row_sums(mf.weighted, np.ascontiguousarray(delays), float(mf.freq[0]),
                        mf.freq_step) / mf.norm  # fmt: skip
    n = z.size
    noise = n * tr.n_samples * float(noise_variance) / mf.norm  # n sigma_z^2
    power = float(np.sum(np.abs(z) ** 2)) - noise
    if not power > 0:
        return False, float("nan")
    kappa = (abs(complex(z.sum())) ** 2 - noise) / (n * power)
    return bool(kappa >= coherence), float(kappa)


@dataclass(frozen=True)
class _Start:
    """A measured range history the profile over ``alpha`` starts from at every ``alpha``.

    ``ranges_m`` at the pulses ``pulses``; ``offsets`` a first guess of ``(x, u_r,
    u_p)`` relative to the uniform start.
    """

    pulses: slice
    ranges_m: NDArray[np.float64]
    offsets: NDArray[np.float64]


def _central_search(
    tr: Traces,
    central: slice,
    alphas: NDArray[np.float64],
    *,
    range_speed_mps: float,
    window_mps: float,
) -> tuple[float, PointFit, NDArray[np.float64]]:
    """The central degree's range history, searched at every ``alpha`` (module notes).

    At each ``alpha`` the traces of the central pulses are shifted in range by
    ``+alpha s^2 / 2`` (``s`` the whole aperture's slow time), which takes that much
    range acceleration off every echo, and the uniform search :func:`fit_point_mover`
    runs on them over cross-range speeds ``+-window_mps``, from ``range_speed_mps`` (it
    refines the range speed on ``g`` and over its Doppler span ``+-lambda PRF / 4``). The
    fit of largest ``|I|`` gives the data's range history over those pulses: its own
    range history minus the shift (the shift is known exactly, so the history does not
    depend on how well the shift models an acceleration).

    Returns
    -------
    alpha : float
        The shift's ``alpha`` of the kept fit (m/s^2).
    fit : PointFit
        The fit, on the shifted central traces.
    ranges : (n_central,) ndarray
        The data's range history at the central pulses (m).
    """
    sub = tr.select_pulses(central.start, central.stop)
    s = tr.slow_times_s[central]
    best: tuple[float, PointFit] | None = None
    for a in alphas:
        shifted = shift_fast_time(sub.data, -float(a) * s**2 / C, frequencies_hz=sub.frequencies_hz)
        fit = fit_point_mover(
            sub.with_data(shifted), range_speed_mps, cross_speed_range_mps=(-window_mps, window_mps)
        )
        if best is None or abs(fit.amplitude) > abs(best[1].amplitude):
            best = (float(a), fit)
    assert best is not None
    alpha, fit = best
    ranges = ranges_m(sub, fit.position_m, fit.velocity_mps) - 0.5 * alpha * s**2
    return alpha, fit, ranges


def fit_range_acceleration(
    data: Traces | ArrayLike,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    *,
    acquisition: Acquisition | None = None,
    noise_variance: float,
    cross_range_std_m: float,
    acceleration_psd: float = ACCELERATION_PSD,
) -> RangeAcceleration:
    """Maximum-likelihood ``alpha`` from a uniform estimate, and its bound (module notes).

    Parameters
    ----------
    data : Traces or (n_pulses, n_samples) array_like
        The mover's traces over the whole aperture (others removed).
    position_m : (2,) or (3,) array_like
        The uniform estimate's position at ``s = 0`` (m); its cross-range coordinate is
        held.
    velocity_mps : (2,) array_like
        Its ground velocity (m/s).
    acquisition : Acquisition, optional
        Required when ``data`` is an array.
    noise_variance : float
        Noise variance per fast-time sample (data units squared), for the bound and the
        test of the uniform start (:func:`uniform_start_holds`).
    cross_range_std_m : float
        Spread of the true cross-range coordinate about the held one (m, > 0): e.g. half
        the imaged scene. The bound counts it (:func:`acceleration_bound`).
    acceleration_psd : float
        ``q`` of :func:`acceleration_estimable` (m^2/s^3).

    Returns
    -------
    RangeAcceleration
    """
    tr = as_traces(data, acquisition)
    geom = tr.geometry
    cells = resolution(tr)
    e_r, e_c = np.r_[cells.range_direction, 0.0], np.r_[cells.cross_range_direction, 0.0]
    b_r = np.r_[ground_velocity(1.0, 0.0, geom), 0.0]
    b_p = np.r_[ground_velocity(0.0, 1.0, geom), 0.0]
    s = tr.slow_times_s
    freqs, weights = tr.frequencies_hz, tr.radar.spectral_weights()
    p0 = as_point(position_m, name="position_m")
    v0 = np.r_[np.asarray(velocity_mps, dtype=np.float64).reshape(2), 0.0]
    response = MatchedFilter(tr).response_derivatives()
    # d rho_j / d (x, u_r, u_p) at a fixed alpha, (n, 3, 3): linear in them
    ones = np.ones((s.size, 1))
    jac = np.stack([ones * e_r, s[:, None] * b_r, s[:, None] * b_p], axis=2)

    def where(theta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Positions at the pulses for ``theta = (x, u_r, u_p, alpha)`` (offsets)."""
        v = v0 + theta[1] * b_r + theta[2] * b_p
        return _track(p0 + theta[0] * e_r, v[:2], theta[3], b_r, s)

    def profiled(alpha: float, start: _Start) -> tuple[NDArray[np.float64], complex]:
        """``(x, u_r, u_p)`` maximising ``|I|`` at ``alpha``, and ``I`` there.

        The start: the motion at ``alpha`` whose range history is nearest the start's
        measured one (least squares over its pulses), i.e. the ridge of the likelihood
        followed without linearising it (an acceleration is tens of m/s of cross-range
        speed away, far outside the quadratic region); then the Newton ascent.
        """
        antenna = tr.positions_m[start.pulses]

        def residual(q: NDArray[np.float64]) -> NDArray[np.float64]:
            track = where(np.r_[q, alpha])[start.pulses]
            return np.linalg.norm(antenna - track, axis=1) - start.ranges_m

        q0 = least_squares(residual, start.offsets, x_scale=_LOCAL_UNITS, xtol=1e-10).x
        q, value, _, _ = newton_ascent(
            lambda q: response(where(np.r_[q, alpha]), jac),
            q0, radius=1.0, tol=1e-2, max_iter=30, scale=_LOCAL_UNITS,
        )  # fmt: skip
        return q, value

    def gradients(theta: NDArray[np.float64]) -> NDArray[np.float64]:
        v = v0 + theta[1] * b_r + theta[2] * b_p
        return acceleration_gradients(
            tr.positions_m, s, p0 + theta[0] * e_r, v[:2], theta[3],
            range_direction=e_r[:2], cross_range_direction=e_c[:2],
            range_basis_mps=b_r[:2], cross_basis_mps=b_p[:2],
        )  # fmt: skip

    duration = float(s[-1] - s[0])
    prior_std = float(np.sqrt(acceleration_psd / duration))
    # the grid: _PROFILE_SPAN prior deviations either side of 0, the uniform start in it
    grid = _PROFILE_SPAN * prior_std * np.linspace(-1.0, 1.0, 2 * _PROFILE_HALF_POINTS + 1)
    step = float(grid[1] - grid[0])

    def ascend(start: _Start) -> tuple[float, NDArray[np.float64], complex]:
        """The profile's maximum from ``start``: the grid, then the bounded search."""
        values = [abs(profiled(float(a), start)[1]) for a in grid]
        k = int(np.argmax(values))
        # the maximum between the grid's neighbours of the best point, to a thousandth of
        # the quarter-radian unit of alpha once (x, u_r, u_p) follow it
        g = gradients(np.r_[profiled(float(grid[k]), start)[0], grid[k]])
        unit = _QUARTER_RADIAN / abs(_phase_factor(g[:, [0, 1, 2, 4]], freqs, weights)[-1, -1])
        res = minimize_scalar(
            lambda a: -abs(profiled(float(a), start)[1]),
            bounds=(float(grid[k]) - step, float(grid[k]) + step),
            method="bounded",
            options={"xatol": 1e-3 * unit},
        )
        alpha = float(res.x)
        q, value = profiled(alpha, start)
        if abs(value) < values[k]:  # the bounded search never ends below the grid's best
            alpha = float(grid[k])
            q, value = profiled(alpha, start)
        return alpha, q, value

    def bound(theta: NDArray[np.float64], value: complex) -> NDArray[np.float64]:
        """:func:`acceleration_bound` at ``theta`` with the amplitude ``|value| / n``."""
        return acceleration_bound(
            gradients(theta),
            freqs,
            weights,
            amplitude=max(abs(value) / tr.n_pulses, 1e-300),
            noise_variance=max(tr.n_samples * float(noise_variance), 1e-300),
            cross_range_std_m=cross_range_std_m,
        )

    # start 1: the uniform start's range history over the whole aperture
    uniform_track = where(np.zeros(4))
    everything = slice(0, tr.n_pulses)
    alpha, q, value = ascend(
        _Start(everything, np.linalg.norm(tr.positions_m - uniform_track, axis=1), np.zeros(3))
    )
    cov5 = bound(np.r_[q, alpha], value)
    # start 2: the data's range history over the central degree, the uniform start's where
    # it holds the mover there, else the central searches' (module notes)
    central = central_sub_aperture(tr)
    central_traces = tr.select_pulses(central.start, central.stop)
    holds, _ = uniform_start_holds(
        central_traces, uniform_track[central], noise_variance=max(float(noise_variance), 0.0)
    )
    if holds:
        measured = _Start(central, np.linalg.norm(
            tr.positions_m[central] - uniform_track[central], axis=1), np.zeros(3))  # fmt: skip
    else:
        # each alpha of the grid shifts the curvature a uniform search over +-window
        # reaches by 4 (V - u_t) window / L = 2 grid steps at u_t = 0: every curvature
        # of the grid's span lies in two neighbours' windows, and in at least one for
        # |u_t| up to V / 2 (module notes)
        window = step * geom.range_m / (2.0 * geom.speed_mps)
        _, fit, ranges = _central_search(
            tr, central, grid, range_speed_mps=range_speed(v0[:2], geom), window_mps=window
        )
        # first guess of the offsets: the fit's motion at the whole aperture's s = 0
        t_c = float(s[central][0] - central_traces.slow_times_s[0])
        dv = np.linalg.lstsq(np.stack([b_r, b_p], axis=1), np.r_[fit.velocity_mps, 0.0] - v0,
                             rcond=None)[0]  # fmt: skip
        x_c = float((fit.position_m - t_c * np.r_[fit.velocity_mps, 0.0] - p0) @ e_r)
        measured = _Start(central, ranges, np.r_[x_c, dv])
    a2, q2, value2 = ascend(measured)
    # the second start's maximum replaces the first's where its log-likelihood
    # |I|^2 sum W^2 / (n sigma_P^2) is higher by more than 1/2, the drop one standard
    # error away from a maximum: two ascents that end closer found the same maximum
    start = "uniform"
    gain = (abs(value2) ** 2 - abs(value) ** 2) * float(np.sum(weights**2))
    if gain > 0.5 * tr.n_pulses * tr.n_samples * float(noise_variance):
        alpha, q, value = a2, q2, value2
        cov5 = bound(np.r_[q, alpha], value)
        start = "central" if holds else "central search"
    grads = gradients(np.r_[q, alpha])
    amplitude = value / tr.n_pulses
    std = float(np.sqrt(max(cov5[3, 3], 0.0)))
    return RangeAcceleration(
        range_acceleration_mps2=alpha,
        std_mps2=std,
        estimable=acceleration_estimable(std, duration, acceleration_psd=acceleration_psd),
        prior_std_mps2=prior_std,
        amplitude=complex(amplitude),
        uniform_amplitude=complex(response(uniform_track, jac)[3]) / tr.n_pulses,
        separable_fraction=separable_fraction(grads, freqs, weights),
        covariance=cov5,
        uniform_start_holds=holds,
        start=start,
    )
