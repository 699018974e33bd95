"""Coherent detection: the generalized likelihood ratio of a point mover, in two stages.

**Why.** The ``g(u)`` statistic (:mod:`sarmotion.motion.detector`) sums *magnitudes*
along a mover's aligned trace: over ``n`` pulses its peak gains about ``sqrt(n)`` over
the noise, where a coherent sum gains ``n``. The maximum-likelihood fit
(:func:`sarmotion.motion.fit_point_mover`) is the coherent matched filter ``I(theta)``;
for a point mover of unknown complex amplitude in circular white Gaussian noise the
generalized likelihood ratio (GLR) of "mover at ``theta``" against "noise alone",
maximised over the amplitude, is ``|I(theta)|^2 / var(I)`` (:mod:`.likelihood`).

**Statistic.** For a candidate fitted at ``theta^`` (its ``|I|`` maximised over range
position, range speed and cross-range speed by the fit's own search),

    Lambda = 10 log10( |I(theta^)|^2 / sigma_I^2 )   (dB),

``sigma_I^2 = sigma^2 n_samples n_pulses / sum_k W_k^2`` the variance of ``I`` under the
interference, ``sigma^2`` its per-fast-time-sample level as the matched filter sees it
in the candidate's neighbourhood (:func:`sarmotion.motion.matched_filter_noise_variance`,
the robust ``median |I|^2 / ln 2`` of draws around the fit, :data:`NOISE_NEIGHBOURHOOD`):
positions within 4 ground-range cells, range speeds within 5 Doppler resolutions and
cross-range speeds within 3 cross-range-speed resolutions. A mover's main lobe is one
resolution wide in each, so most draws fall off it and the median ignores the rest; the
leakage of stationary clutter that a separation leaves in ``S`` (the response of many
stationary targets to a moving signature) is broad in the parameters and raises the
level there as much as at the candidate: a constant-false-alarm-rate normalisation. The
level is taken on the data minus the candidate's fitted model: its own side lobes in the
neighbourhood, a fixed fraction of its peak, would otherwise cap ``Lambda`` of a strong
mover at the peak-to-side-lobe ratio. At one fixed ``theta`` in white noise ``|I|^2 /
sigma_I^2`` is exponential with mean 1 (chi-square with two degrees of freedom over
two): ``P(Lambda > t) = exp(-10^(t / 10))``. Maximised over the search it is the largest
of many such cells, whose tail in dB is lighter than exponential.

**Two stages.** (1) the ``g(u)`` screen: every candidate of ``g(u)`` beyond the
stationary band and narrower than the shape test allows (as the ``g(u)`` detector) whose
statistic reaches the *per-candidate* ``SCREEN_PROBABILITY`` point of the ``g(u)``
null, ``t_0 + s ln(p_0 / p)`` of :data:`sarmotion.motion.NULL_TAIL` (its 90 % quantile
``t_0`` for ``p = 0.1``), goes to stage 2: a weak mover's ``g`` peak need only clear the
floor's own fluctuations; (2) the fit, and ``Lambda`` against its own threshold.

**Null and threshold.** ``Lambda`` of every screened candidate is measured on scenes
without movers, the way ``benchmarks/detector_null.py`` measures the ``g(u)`` null
(``--detector coherent``: the real GOTCHA degrees one at a time and together, simulated
point clutter at 0-30 dB SNR, each through the analysis's own separation and screen).
Only the candidates that the focus test does not explain as a stationary point count
(:func:`sarmotion.motion.stationary_explanation`; the others are not declared whatever
their ``Lambda``). Above its 90 % quantile ``t_0`` the tail is modelled as exponential
in dB, ``P(Lambda > t) = p_0 exp(-(t - t_0) / s)`` (``p_0 = 0.1``, ``s`` the mean excess
over ``t_0``, the maximum-likelihood scale of an exponential), fitted on the heaviest
population: :data:`COHERENT_NULL_TAIL`. The heaviest is simulated point clutter
separated by robust PCA, whose tail holds the leakage of stationary clutter into ``S``
at range speeds just beyond the stationary band (the response of several stationary
targets to a moving signature, which a single stationary point does not explain): it
is this leakage, not the noise, that sets the threshold. With ``N`` screened candidates
in a scene the per-scene false-alarm rate ``alpha`` is met by
:func:`coherent_threshold_db` ``= t_0 + s ln(p_0 N / alpha)`` (the union bound). The
table is ``benchmarks/results/detector_null_coherent.md``.

**Clairvoyant bound.** The matched filter at a mover's *true* parameters on data whose
clutter is removed exactly is a single test of a known ``theta``: its null is the
exponential above, and the per-scene rate ``alpha`` is met by ``Lambda >= 10 log10(ln(1 /
alpha))`` (:func:`clairvoyant_threshold_db`, 6.6 dB for 1 %). No detector that searches
can do better. One that knows the clutter but searches the mover's parameters tests the
largest ``Lambda`` of ``N`` independent cells, whose null passes ``ln(N / alpha)``
(:func:`searching_threshold_db`; ``N`` measured by :func:`effective_cells`): the
look-elsewhere penalty between the two bounds. ``benchmarks/coherent_detection.py``
compares the two detectors with both bounds (figures in ``docs/notes/detector.md``).

Positions in m, speeds in m/s, statistics in dB.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..core import Acquisition, C, Traces, as_traces
from ..imaging import resolution
from .detector import NULL_TAIL
from .likelihood import MatchedFilter, matched_filter_noise_variance, point_model
from .speed_resolution import cross_range_speed_resolution

__all__ = [
    "COHERENT_NULL_TAIL",
    "SCREEN_PROBABILITY",
    "clairvoyant_threshold_db",
    "coherent_false_alarm_probability",
    "coherent_statistic_db",
    "coherent_threshold_db",
    "effective_cells",
    "matched_filter_variance",
    "neighbourhood_noise",
    "screen_threshold_db",
    "searching_threshold_db",
]

#: Per-candidate probability with which a ``g(u)`` null candidate passes the screen:
#: the 90 % point of the ``g(u)`` null (``NULL_TAIL["t0_db"]``).
SCREEN_PROBABILITY = 0.1

#: The neighbourhood of a fit where the interference level is drawn, in resolutions:
#: positions within this many ground-range cells (half side of a square), range speeds
#: within this many Doppler resolutions ``lambda / (2 T)`` and cross-range speeds within
#: this many cross-range-speed resolutions of the fit's own (module notes).
NOISE_NEIGHBOURHOOD = {"cells": 4.0, "doppler": 5.0, "cross_range_speed": 3.0}

#: Exponential tail of ``Lambda`` (dB) of screened null candidates above its 90 %
#: quantile (module notes; ``benchmarks/detector_null.py --detector coherent``): the
#: heaviest measured population.
COHERENT_NULL_TAIL = {"t0_db": 14.89, "scale_db": 4.09, "p0": 0.10}


def screen_threshold_db(probability: float = SCREEN_PROBABILITY) -> float:
    """``g(u)`` statistic (dB) a null candidate reaches with ``probability`` (per candidate).

    ``t_0 + s ln(p_0 / p)`` of the measured ``g(u)`` tail :data:`NULL_TAIL`, valid for
    ``p <= p_0``.
    """
    if not 0.0 < probability <= NULL_TAIL["p0"]:
        raise ValueError(f"probability must be in (0, {NULL_TAIL['p0']}], got {probability!r}")
    t = NULL_TAIL
    return float(t["t0_db"] + t["scale_db"] * np.log(t["p0"] / probability))


def coherent_threshold_db(false_alarm_rate: float, n_candidates: int) -> float:
    """Threshold on ``Lambda`` (dB) for a per-scene false-alarm rate over ``N`` candidates.

    ``t_0 + s ln(p_0 N / alpha)`` with :data:`COHERENT_NULL_TAIL`.
    """
    if not 0.0 < false_alarm_rate < 1.0:
        raise ValueError(f"false_alarm_rate must be in (0, 1), got {false_alarm_rate!r}")
    t = COHERENT_NULL_TAIL
    n = max(int(n_candidates), 1)
    return float(t["t0_db"] + t["scale_db"] * np.log(t["p0"] * n / false_alarm_rate))


def coherent_false_alarm_probability(statistic_db: float, n_candidates: int) -> float:
    """Per-scene probability that ``N`` null candidates reach ``statistic_db`` (union bound)."""
    t = COHERENT_NULL_TAIL
    n = max(int(n_candidates), 1)
    excess = (float(statistic_db) - t["t0_db"]) / t["scale_db"]
    return float(min(1.0, n * t["p0"] * np.exp(-excess)))


def clairvoyant_threshold_db(false_alarm_rate: float) -> float:
    """``Lambda`` (dB) that a single test at known parameters passes with ``alpha`` under noise.

    ``|I|^2 / sigma_I^2`` is exponential with mean 1: ``10 log10(ln(1 / alpha))``.
    """
    if not 0.0 < false_alarm_rate < 1.0:
        raise ValueError(f"false_alarm_rate must be in (0, 1), got {false_alarm_rate!r}")
    return float(10.0 * np.log10(np.log(1.0 / false_alarm_rate)))


def searching_threshold_db(false_alarm_rate: float, n_cells: float) -> float:
    """``Lambda`` (dB) the largest of ``N`` independent cells passes with ``alpha`` under noise.

    Each cell's ``|I|^2 / sigma_I^2`` is exponential with mean 1, so ``P(max <= t) = (1 -
    exp(-t))^N`` and ``t = -ln(1 - (1 - alpha)^(1 / N))``, about ``ln(N / alpha)``;
    ``N = 1`` is :func:`clairvoyant_threshold_db`. ``N`` need not be whole (cells of a
    correlated search, :func:`effective_cells`).
    """
    if not 0.0 < false_alarm_rate < 1.0:
        raise ValueError(f"false_alarm_rate must be in (0, 1), got {false_alarm_rate!r}")
    if not n_cells >= 1.0:
        raise ValueError(f"n_cells must be >= 1, got {n_cells!r}")
    t = -np.log(-np.expm1(np.log1p(-false_alarm_rate) / float(n_cells)))
    return float(10.0 * np.log10(t))


def effective_cells(maxima: ArrayLike) -> float:
    """Number ``N`` of independent unit-exponential cells whose largest value the samples are.

    The maximum-likelihood ``N`` of ``P(max <= t) = (1 - exp(-t))^N`` from ``k`` sampled
    maxima ``t_i`` (linear, not dB): the log-likelihood ``k ln N + (N - 1) sum ln(1 -
    exp(-t_i)) + const`` peaks at ``N = -k / sum ln(1 - exp(-t_i))``. Its relative
    standard deviation is ``1 / sqrt(k)`` (``-N ln(1 - exp(-t))`` is unit exponential).
    """
    t = np.asarray(maxima, dtype=np.float64).ravel()
    if t.size == 0 or not np.all(t > 0):
        raise ValueError("maxima must be a non-empty array of positive values")
    return float(-t.size / np.sum(np.log(-np.expm1(-t))))


def matched_filter_variance(acquisition: Acquisition | Traces, noise_variance: float) -> float:
    """``sigma_I^2 = sigma^2 n_samples n_pulses / sum_k W_k^2`` (data units squared).

    The variance of ``I`` (:class:`MatchedFilter`) for circular white noise of
    ``noise_variance`` per fast-time sample: the phase history is the unnormalised DFT of
    the traces (``n_samples sigma^2`` per bin) and ``I`` sums ``n_pulses`` rows weighted
    by ``W_k / sum W_k^2``.
    """
    w = acquisition.radar.spectral_weights()
    return float(noise_variance * acquisition.n_samples * acquisition.n_pulses / np.sum(w**2))


def coherent_statistic_db(
    data: Traces | ArrayLike,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    *,
    acquisition: Acquisition | None = None,
    value: complex | None = None,
    noise_variance: float | None = None,
) -> float:
    """``Lambda = 10 log10(|I|^2 / sigma_I^2)`` of a fit (dB; module notes).

    Parameters
    ----------
    data : Traces or (n_pulses, n_samples) array_like
        The traces the candidate was fitted on.
    position_m : (3,) array_like
        Fitted position at ``s = 0`` (m).
    velocity_mps : (2,) array_like
        Fitted ground velocity (m/s).
    acquisition : Acquisition, optional
        Required when ``data`` is an array.
    value : complex, optional
        ``I`` at the fit (data units times ``n_pulses``); computed when not given.
    noise_variance : float, optional
        Per-fast-time-sample interference level (data units squared); default the
        matched filter's level in the fit's neighbourhood (:func:`neighbourhood_noise`)
        on ``data`` minus the candidate's fitted model (:func:`point_model` at amplitude
        ``I / n_pulses``), so that a strong mover's own side lobes do not count as
        interference.

    Returns
    -------
    float
    """
    tr = as_traces(data, acquisition)
    pos = np.asarray(position_m, dtype=np.float64).reshape(3)
    vel = np.asarray(velocity_mps, dtype=np.float64).reshape(2)
    if value is None:
        value = complex(MatchedFilter(tr).responses(pos[None], vel[None])[0])
    if noise_variance is None:  # the interference there, the candidate's own model removed
        model = point_model(tr.acquisition, pos, vel, value / tr.n_pulses)
        noise_variance = neighbourhood_noise(tr.with_data(tr.data - model), pos, vel)
    var = matched_filter_variance(tr.acquisition, float(noise_variance))
    return float(10.0 * np.log10(max(abs(value) ** 2, 1e-300) / max(var, 1e-300)))


def neighbourhood_noise(
    data: Traces | ArrayLike,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    *,
    acquisition: Acquisition | None = None,
) -> float:
    """Interference level around a fit, per fast-time sample (data units squared).

    :func:`sarmotion.motion.matched_filter_noise_variance` drawn in the neighbourhood
    :data:`NOISE_NEIGHBOURHOOD` of ``(position_m, velocity_mps)`` (module notes), its
    extent in the resolutions of ``data``: the ground-range cell, the Doppler resolution
    ``lambda / (2 T) = c / (2 nu_o n_pulses ds)`` of the range speed and
    :func:`sarmotion.motion.cross_range_speed_resolution`.
    """
    tr = as_traces(data, acquisition)
    nb = NOISE_NEIGHBOURHOOD
    ds = float(np.median(np.diff(tr.slow_times_s)))
    doppler = C / (2.0 * tr.radar.carrier_hz * tr.n_pulses * ds)
    return matched_filter_noise_variance(
        tr,
        half_size_m=nb["cells"] * resolution(tr).ground_range_m,
        centre_m=np.asarray(position_m, dtype=np.float64).reshape(3),
        velocity_mps=velocity_mps,
        speed_spread_mps=(
            nb["doppler"] * doppler,
            nb["cross_range_speed"] * cross_range_speed_resolution(tr),
        ),
    )
