"""The whole aperture, coherently: a fixed track's uniform motion refined on its echo.

**What it adds.** The wide-aspect fit (:mod:`sarmotion.tracking.wide_aspect`) joins the
looks' range histories, each measured on its own sub-aperture: their phases are not
compared. Once that fit fixes the position, the mover's echo over the whole track can be
focused as one: the maximum-likelihood fit of the analysis over a degree
(:mod:`sarmotion.motion.likelihood`), now over every pulse from the track's first
sub-aperture to its last. Its statistic is the matched filter
``I(theta) = sum_jk P_jk W_k exp(+i psi_jk(theta)) / sum_k W_k^2`` of the data (clutter
included: over tens of degrees a stationary point does not focus at a mover's motion,
and what it leaves is counted in the noise below), ``theta = (x, y, ux, uy)`` at the
fit's reference time ``t_0``.

**The search.** The wide-aspect fit's covariance bounds where to look: along each of
its principal axes ``v_i`` the grid spans ``+-3`` standard deviations in steps of
``pi / (max_j s_j - min_j s_j)``, ``s_j = (4 pi / lambda) dR_j/dv_i`` the phase rate of
pulse ``j`` (the mainlobe of ``|I|`` along ``v_i`` is about twice that wide), at least
3 and at most :data:`_MAX_STEPS` points an axis; the best point is polished by
Nelder-Mead on ``|I|`` in those step units.

**Its bound.** The Cramér–Rao bound of ``theta`` for a point of unknown complex amplitude
``a`` in white noise of variance ``sigma^2`` per phase-history sample is the inverse of
``J = (2 |a|^2 / sigma^2) [sum_jk W_k^2 q_jk q_jk^T - (sum W^2 q)(sum W^2 q)^T /
sum W^2]``, ``q_jk = (4 pi f_k / c) grad R_j`` (the amplitude's phase is a nuisance; its
term removes the mean phase slope). ``a = I / n_pulses`` at the fit; ``sigma^2`` is the
interference the matched filter sees at random motions about the fit
(:func:`sarmotion.motion.likelihood.matched_filter_noise_variance`), clutter residue
included.

**Errors above the bound.** The bound counts the interference as white; a stationary
point's sidelobes are not, and along the family, where over ten degrees the likelihood
is nearly flat, they move the maximum far beyond it (a simulated 10 degree pass, 6
unit points at 20 dB: 0.62 m off at a bound of 0.04 m). As the wide-aspect fit does
with its looks, the error is measured on the data: at the fit, each sub-aperture's
matched filter ``I_k`` should have the whole's phase, within its noise
``var(arg I_k) = var(I_k) / (2 |I_k|^2)``; the bound's standard deviations are
multiplied by ``f = sqrt(max(1, sum_k arg(I_k / I)^2 / var(arg I_k) / chi2_q(K - 5)))``,
``K - 5`` the degrees of freedom the state and the common phase leave and ``chi2_q`` the
chi-square quantile at the complement of
:data:`~sarmotion.tracking.wide_aspect.FACTOR_CONFIDENCE` (the variance's upper 95 %
limit). On the pass above ``f`` was 27 (the error 0.67 of the scaled deviation); with
no point, 2.4 (0.76); at 30 degrees with the points 8.0 (0.9), without 1.2 (1.4). With
fewer than 6 sub-apertures the factor is not measured and no covariance is given.

**Whether the echo is coherent.** The bound holds for a mover that is uniform to a
fraction of a wavelength over the track. The data say whether it is: with ``I_k`` the
matched filter of the fit over sub-aperture ``k``'s pulses, the coherence ``|sum_k I_k|
/ sum_k |I_k|`` is 1 when their phases agree and about ``1 / sqrt(K)`` when they are
random. The echo is taken as coherent when the coherence is at least
:data:`COHERENCE_FLOOR`, the value a quadratic phase error of ``pi / 2`` at the track's
ends leaves (Fresnel's ``C(1)``: the focusing criterion of the fit's coherence margin,
:mod:`sarmotion.tracking.wide_aspect`); below it the refinement is reported but the
wide-aspect fit stands.

Cost: the track's pulses are weighted and stored frequency-major (about three times
their traces' size as complex128, held while the fit runs: 0.9 GB for a whole 360
degree GOTCHA-like pass of 424 samples at 117 pulses a degree); 1 s over 30 degrees,
4 s over 90 (``benchmarks/wide_aspect.py --coherent``).

Times in s, positions in m, velocities in m/s.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize
from scipy.stats import chi2

from ..core import C, Traces
from ..motion.likelihood import MatchedFilter, matched_filter_noise_variance
from .wide_aspect import FACTOR_CONFIDENCE, PositionFit

__all__ = ["COHERENCE_FLOOR", "CoherentFit", "refine_coherently"]

#: Coherence below which the echo is not coherent over the track (module notes):
#: Fresnel's C(1) = int_0^1 cos(pi x^2 / 2) dx, a quadratic phase error of pi/2 at the ends.
COHERENCE_FLOOR = 0.7799

#: Most grid points along one principal axis of the search (module notes).
_MAX_STEPS = 9


@dataclass(frozen=True, kw_only=True, eq=False)
class CoherentFit:
    """A track's uniform motion focused over its whole aperture (module notes).

    Attributes
    ----------
    time_s : float
        Reference time ``t_0`` of the state (s): the wide-aspect fit's.
    state : (4,) ndarray
        ``(x, y, ux, uy)`` at ``time_s`` (m, m/s).
    covariance : (4, 4) ndarray
        Its covariance: the bound times :attr:`error_factor` squared (m^2, m^2/s,
        m^2/s^2; module notes); NaN when the factor cannot be measured.
    bound_covariance : (4, 4) ndarray
        The Cramér–Rao bound (same units).
    amplitude : complex
        The fitted reflectivity ``I / n_pulses`` (data units).
    coherence : float
        ``|sum_k I_k| / sum_k |I_k|`` over the track's sub-apertures.
    coherent : bool
        ``coherence >= COHERENCE_FLOOR``: the bound applies.
    n_pulses : int
        Pulses focused.
    snr_db : float
        ``|I|^2`` over its noise variance at the fit (dB).
    shift_m : float
        Distance of the refined position from the wide-aspect fit's at ``time_s`` (m).
    error_factor : float
        The a posteriori factor of the bound's standard deviations, from the scatter of
        the sub-apertures' phases (module notes); NaN with fewer than 6 sub-apertures.
    n_sub_apertures : int
        Sub-apertures whose matched filters the coherence and the factor compare.
    """

    time_s: float
    state: NDArray[np.float64]
    covariance: NDArray[np.float64]
    bound_covariance: NDArray[np.float64]
    amplitude: complex
    coherence: float
    coherent: bool
    n_pulses: int
    snr_db: float
    shift_m: float
    error_factor: float
    n_sub_apertures: int

    def at(self, time_s: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """State ``(x, y, ux, uy)`` and :attr:`covariance` at ``time_s`` (uniform motion)."""
        f = np.eye(4)
        f[0, 2] = f[1, 3] = float(time_s) - self.time_s
        return f @ self.state, f @ self.covariance @ f.T

    @property
    def position_std_m(self) -> float:
        """Largest standard deviation of the position at :attr:`time_s` (m; NaN unmeasured)."""
        cov = self.covariance[:2, :2]
        if not np.all(np.isfinite(cov)):
            return float("nan")
        return float(np.sqrt(max(0.0, np.linalg.eigvalsh(cov)[-1])))

    @property
    def position_bound_m(self) -> float:
        """Largest standard deviation of the position from the bound alone (m)."""
        cov = self.bound_covariance[:2, :2]
        return float(np.sqrt(max(0.0, np.linalg.eigvalsh(cov)[-1])))

    @property
    def velocity_std_mps(self) -> float:
        """Largest standard deviation of the velocity (m/s; NaN unmeasured)."""
        cov = self.covariance[2:, 2:]
        if not np.all(np.isfinite(cov)):
            return float("nan")
        return float(np.sqrt(max(0.0, np.linalg.eigvalsh(cov)[-1])))


def refine_coherently(
    traces: Traces,
    fit: PositionFit,
    sub_apertures: Sequence[slice],
    *,
    height_m: float = 0.0,
) -> CoherentFit:
    """Focus a track's echo over all its pulses, from its wide-aspect fit (module notes).

    Parameters
    ----------
    traces : Traces
        The whole acquisition (slow time ``s = 0`` at its centre).
    fit : PositionFit
        The track's wide-aspect fit (its covariance bounds the search).
    sub_apertures : sequence of slice
        The pulses of the track's sub-apertures, in time order: the data focused are
        those from the first one's start to the last one's stop; each one's matched
        filter enters the coherence.
    height_m : float
        The mover's height (m).

    Returns
    -------
    CoherentFit
    """
    if not sub_apertures:
        raise ValueError("a coherent refinement needs at least one sub-aperture")
    start = min(sl.start for sl in sub_apertures)
    stop = max(sl.stop for sl in sub_apertures)
    data = traces.select_pulses(start, stop)
    # select_pulses re-centres slow time: its s = 0 is `offset` in the acquisition's
    offset = float(traces.slow_times_s[start] - data.slow_times_s[0])
    mf = MatchedFilter(data)
    lam = float(traces.radar.wavelength_m)
    t0 = float(fit.time_s)
    antenna = data.positions_m
    times = data.slow_times_s + offset - t0  # from t_0, s

    def at_data_zero(states: NDArray[np.float64]) -> NDArray[np.float64]:
        """Positions at the data's ``s = 0`` (m, with the height) of ``(k, 4)`` states."""
        p = states[:, :2] - (t0 - offset) * states[:, 2:]
        return np.column_stack([p, np.full(len(states), height_m)])

    def rows(state: NDArray[np.float64]) -> NDArray[np.complex128]:
        return mf.pulse_responses(at_data_zero(state[None])[0], state[2:])

    def grad_range(state: NDArray[np.float64]) -> NDArray[np.float64]:
        p = state[:2] + times[:, None] * state[2:]
        d = np.column_stack([p, np.full(times.size, height_m)]) - antenna
        g = d[:, :2] / np.linalg.norm(d, axis=1)[:, None]
        return np.column_stack([g, times[:, None] * g])  # dR_j / d(x, y, ux, uy)

    # the grid along the fit's principal axes, steps from the phase rates
    x0 = np.asarray(fit.state, dtype=np.float64)
    w, v = np.linalg.eigh(0.5 * (fit.covariance + fit.covariance.T))
    rates = (4.0 * np.pi / lam) * grad_range(x0) @ v  # (n_pulses, 4) rad per unit
    steps = np.pi / np.maximum(np.ptp(rates, axis=0), 1e-300)
    reach = 3.0 * np.sqrt(np.maximum(w, 0.0))  # 3 deviations along each axis
    halves = np.clip(np.ceil(reach / steps), 1, _MAX_STEPS // 2).astype(int)
    spans = [
        np.linspace(-1.0, 1.0, 2 * h + 1) * min(r, h * st)
        for h, r, st in zip(halves, reach, steps, strict=True)
    ]
    mesh = np.stack(np.meshgrid(*spans, indexing="ij"), axis=-1).reshape(-1, 4)
    candidates = x0[None, :] + mesh @ v.T
    values = np.abs(mf.responses(at_data_zero(candidates), candidates[:, 2:]))
    best = candidates[int(np.argmax(values))]

    def objective(z: NDArray[np.float64]) -> float:
        return -float(abs(rows(best + v @ (z * steps)).sum()))

    opt = minimize(
        objective, np.zeros(4), method="Nelder-Mead",
        options={"xatol": 1e-3, "fatol": 1e-9 * max(-objective(np.zeros(4)), 1e-300),
                 "initial_simplex": np.vstack([np.zeros(4), 0.25 * np.eye(4)]), "maxiter": 2000},
    )  # fmt: skip
    state = best + v @ (opt.x * steps)
    per_pulse = rows(state)
    value = complex(per_pulse.sum())
    amplitude = value / data.n_pulses

    # interference the matched filter sees about the fit, per phase-history sample
    p_s0 = at_data_zero(state[None])[0]
    sigma2 = (
        matched_filter_noise_variance(
            data, half_size_m=max(5.0 * fit.position_std_m, 20.0), centre_m=p_s0,
            velocity_mps=state[2:],
        )
        * data.n_samples
    )  # fmt: skip

    # Cramér-Rao bound, the amplitude's phase a nuisance
    weights = data.radar.spectral_weights() ** 2  # W_k^2
    g = grad_range(state)
    kf = 4.0 * np.pi * data.frequencies_hz / C  # rad per m, per frequency
    sum_w_k2 = float(np.sum(weights * kf**2))
    sum_w_k = float(np.sum(weights * kf))
    total_w = float(np.sum(weights)) * data.n_pulses
    first = sum_w_k * g.sum(axis=0)
    info = sum_w_k2 * (g.T @ g) - np.outer(first, first) / total_w
    info *= 2.0 * abs(amplitude) ** 2 / max(sigma2, 1e-300)
    covariance = np.linalg.pinv(0.5 * (info + info.T))

    parts = np.array([per_pulse[sl.start - start : sl.stop - start].sum() for sl in sub_apertures])
    coherence = float(abs(parts.sum()) / max(float(np.sum(np.abs(parts))), 1e-300))
    noise_i = sigma2 * data.n_pulses / mf.norm  # variance of I
    # phases of the sub-apertures' I_k about the whole's: their scatter against noise
    sizes = np.array([sl.stop - sl.start for sl in sub_apertures], dtype=np.float64)
    phase_var = sigma2 * sizes / mf.norm / np.maximum(2.0 * np.abs(parts) ** 2, 1e-300)
    phases = np.angle(parts * np.conj(value))
    nu = len(sub_apertures) - 5  # the state's 4 and the common phase
    ratio = float(np.sum(phases**2 / phase_var))
    factor = (
        float(np.sqrt(max(1.0, ratio / chi2.ppf(1.0 - FACTOR_CONFIDENCE, nu))))
        if nu >= 1
        else float("nan")
    )
    bound = 0.5 * (covariance + covariance.T)
    return CoherentFit(
        time_s=t0,
        state=state,
        covariance=bound * factor**2,
        bound_covariance=bound,
        amplitude=amplitude,
        coherence=coherence,
        coherent=bool(coherence >= COHERENCE_FLOOR),
        n_pulses=int(data.n_pulses),
        snr_db=float(10.0 * np.log10(max(abs(value) ** 2, 1e-300) / max(noise_i, 1e-300))),
        shift_m=float(np.hypot(*(state[:2] - x0[:2]))),
        error_factor=factor,
        n_sub_apertures=len(sub_apertures),
    )
