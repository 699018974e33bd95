"""Maximum-likelihood position and velocity of point movers (the matched filter).

For a point mover ``a W_k exp(-i psi_jk(theta))`` in complex white Gaussian noise
(:mod:`sarmotion.motion.bounds`) the log-likelihood maximised over the complex amplitude
is ``|<P, m(theta)>|^2 / ||m(theta)||^2``; ``||m||`` does not depend on ``theta``, so the
maximum-likelihood ``theta`` maximises the modulus of the *matched filter*

    I(theta) = sum_jk P_jk W_k exp(+i psi_jk(theta)) / sum_k W_k^2,

the coherent motion-compensated point response (``eq:imagecompu`` evaluated exactly,
weighted by the pulse spectrum); ``I = a n_pulses`` for a noise-free mover at
``theta``, and the amplitude estimate is ``I / n_pulses``.

``theta`` is ``(x, u_r, u_p)``: ground-range offset of the position at ``s = 0``, range
speed and cross-range speed, with the cross-range coordinate of the position held (the
data of about a degree fix a mover's range history, not where it is along its
cross-range family, :mod:`sarmotion.motion.aperture`). The search
(:func:`fit_point_mover`) is

1. **global** in the cross-range speed: every ``u_p`` of a grid of half a
   cross-range-speed resolution over the whole searched interval; at each, the traces
   are aligned by ``T_+`` at ``(u_r^0, u_p)`` (``eq:TTu+``, :class:`._aligned._Aligner`)
   on the reference point, and the matched filter is profiled over the ground-range
   offset (fast time of the aligned traces, a window around the trace of the ``g(u)``
   peak) and over a residual range speed ``+- lambda PRF / 4`` (a Doppler FFT over slow
   time, padded four times): the linear phase ``exp(i 4 pi du s / lambda)`` that a
   range-speed error leaves on the aligned trace;
2. **local**: a loose Nelder–Mead on the exact ``|I(theta)|``, then a Newton ascent of
   ``|I|^2`` (analytic derivatives, :mod:`sarmotion.core.ascent`), from each of the
   profile's largest lobes. A point of the search is a range history aligned on the
   reference point; the start is the motion on the fit's (the reference point's) cross
   range with the same range history (:func:`_model_start`): off the reference point
   the same ground velocity has another range rate, by several Doppler resolutions for
   a fast mover tens of metres away, and a start that far off climbs to another lobe of
   lower likelihood metres per second away in cross-range speed. The fit of largest
   ``|I|`` is kept and checked against the profile's maximum (``|I|`` of an approximate
   signature at a point of the search: a fit more than ``_PROFILE_TOLERANCE`` below it
   gives way to that point's motion where its ``|I|`` is larger). A maximum on another
   lobe within ``NEAR_EQUAL_LOBES`` of the fit's ``|I|`` makes the fit
   :attr:`PointFit.ambiguous`.

:func:`duplicate_fits` finds fits that repeat another's range history (one mover fitted
twice).

:func:`refine_jointly` re-fits every mover with the others' fitted models subtracted
from the data, a few rounds (the alternating maximisation of the joint likelihood).

On real clutter the global search finds the cross-range speed where ``g_perp``
(``eq:OBJ2``) can land on a side maximum, and in white noise the fit reaches the
Cramér–Rao bound (``tests/motion/test_movers_detection.py``; figures in ``docs/notes/motion.md``).
Positions in m, speeds in m/s, geometry in float64.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.fft as sfft
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, minimize
from threadpoolctl import threadpool_limits

from ..core import (
    Acquisition,
    C,
    Traces,
    as_point,
    as_traces,
    cross_range_speed,
    ground_velocity,
    range_direction_velocity,
    range_speed,
    to_fast_time,
)
from ..core.ascent import ResponseDerivatives, newton_ascent
from ..core.spectral import FrequencyPlanes, phased_row_sums
from ..imaging import resolution
from ._aligned import _Aligner, _columns, _refine_max
from .aperture import ranges_m
from .speed_resolution import cross_range_speed_resolution, range_speed_resolution

__all__ = [
    "MatchedFilter",
    "NEAR_EQUAL_LOBES",
    "PointFit",
    "fit_point_mover",
    "fit_point_mover_at",
    "duplicate_fits",
    "point_model",
    "refine_jointly",
    "refit_movers",
    "noise_variance",
    "matched_filter_noise_variance",
]

#: Pulse-frequency products in one chunk of parameter sets in :meth:`MatchedFilter.responses`.
_CHUNK = 1 << 21

#: Units of the Newton ascent in :func:`_local_fit`: about an eighth of a resolution in
#: range position (m), range speed and cross-range speed (m/s) on a GOTCHA degree.
_LOCAL_UNITS = np.array([0.03, 0.0015, 0.09])

#: Lobes of the global profile (its largest local maxima, a cross-range-speed resolution
#: apart) from which :func:`fit_point_mover` starts local fits.
_PROFILE_LOBES = 3

#: Largest relative shortfall of the chosen fit's ``|I|`` below the profile's maximum.
#: The profile correlates the data with an approximation of the signature of the search
#: point's range history, in the units of ``|I|`` (its residual range speed is
#: compensated by its phase at the carrier only); the first local fit starts at the
#: exact signature of that range history (:func:`_model_start`) and an ascent never
#: ends below its start. A fit further below the profile's maximum than the two
#: signatures' difference can explain is replaced by that start where the start's
#: ``|I|`` is larger. The tolerance: noise between the two signatures (a relative
#: deviation of ``|I|`` of ``1 / sqrt(2 SNR)``, 5 % at a matched-filter SNR of 23 dB).
_PROFILE_TOLERANCE = 0.05

#: ``|I|`` ratio of two maxima on different lobes (cross-range speeds more than a
#: resolution apart) at or above which the likelihood is reported ambiguous
#: (:attr:`PointFit.ambiguous`): 0.9 in ``|I|`` is 0.9 dB, within the noise of ``|I|^2``
#: at an SNR of the matched filter below ~20 dB (its relative deviation is
#: ``2 / sqrt(2 SNR)``), where the larger maximum may not be the true one.
NEAR_EQUAL_LOBES = 0.9


class MatchedFilter:
    """``I(theta)`` of one data set for batches of positions and velocities.

    Parameters
    ----------
    data : Traces or (n_pulses, n_samples) array_like
        The traces filtered (e.g. the moving residual).
    acquisition : Acquisition, optional
        Their acquisition (geometry, frequencies, reference point, pulse spectrum);
        required when ``data`` is an array.
    """

    def __init__(self, data: Traces | ArrayLike, *, acquisition: Acquisition | None = None) -> None:
        d = as_traces(data, acquisition)
        traces = d.acquisition
        w = traces.radar.spectral_weights()
        self.weighted = np.ascontiguousarray(d.phase_history() * w[None, :], dtype=np.complex128)
        self.norm = float(np.sum(w**2))
        self.antenna = traces.positions_m
        self.slow = traces.slow_times_s
        self.freq = traces.frequencies_hz
        self.freq_step = float(traces.radar.frequency_step_hz)
        self.ref_range = np.linalg.norm(self.antenna - traces.reference_point_m, axis=1)
        self._planes: FrequencyPlanes | None = None

    def planes(self) -> FrequencyPlanes:
        """The weighted phase history stored frequency-major, built on first use.

        Building it costs about two row sums over the data; each sum on it then costs
        0.4 of :func:`~sarmotion.core.spectral.phased_row_sums` (0.65 against 1.55 ms on
        1187 x 406 traces), so a search of many evaluations builds it first.
        """
        if self._planes is None:
            self._planes = FrequencyPlanes(self.weighted)
        return self._planes

    def response_derivatives(self) -> ResponseDerivatives:
        """``|I|^2`` with its gradient and Hessian in linear parameters (Newton fits)."""
        return ResponseDerivatives(
            self.planes(),
            self.antenna,
            2.0 * self.ref_range / C,
            float(self.freq[0]),
            self.freq_step,
            1.0 / self.norm,
        )

    def _delays(self, pos: NDArray[np.float64], vel: NDArray[np.float64]) -> NDArray[np.float64]:
        """``(k, n_pulses)`` two-way delays (s) from the reference point's, float64."""
        v3 = np.concatenate([vel, np.zeros((vel.shape[0], 1))], axis=1)
        where = pos[:, None, :] + self.slow[None, :, None] * v3[:, None]
        rng = np.linalg.norm(self.antenna[None] - where, axis=2)
        return np.ascontiguousarray(2.0 * (rng - self.ref_range[None]) / C)

    def pulse_responses(
        self, position_m: ArrayLike, velocity_mps: ArrayLike
    ) -> NDArray[np.complex128]:
        """Each pulse's term of ``I`` at one position (m, ``s = 0``) and ground velocity.

        Returns
        -------
        (n_pulses,) ndarray
            Complex; their sum is :meth:`responses` at the same point (on :meth:`planes`).
        """
        pos = np.asarray(position_m, dtype=np.float64).reshape(1, 3)
        vel = np.asarray(velocity_mps, dtype=np.float64).reshape(1, 2)
        d = self._delays(pos, vel)[0]
        return self.planes().sums(d, float(self.freq[0]), self.freq_step) / self.norm

    def responses(
        self, positions_m: ArrayLike, velocities_mps: ArrayLike
    ) -> NDArray[np.complex128]:
        """``I`` at ``(k, 3)`` positions (m, ``s = 0``) and ``(k, 2)`` ground velocities (m/s).

        The delays are float64; the sum over frequencies runs compiled with phasors
        advancing by a fixed rotation (:func:`sarmotion.core.spectral.phased_row_sums`,
        re-seeded exactly every 32 bins): the same values as forming
        ``exp(2i pi f dtau)`` to ~1e-14 of ``sum |P W|`` (tested against that direct
        form), without a complex exponential per term. Once :meth:`planes` is built
        (or for two or more points, which build it) the sums run on it, the rows in
        SIMD lanes: the same sums to ~1e-16 of ``sum |P W|``.

        Returns
        -------
        (k,) ndarray
            Complex; ``a n_pulses`` for a mover of reflectivity ``a`` at the parameters.
        """
        pos = np.atleast_2d(np.asarray(positions_m, dtype=np.float64))
        vel = np.atleast_2d(np.asarray(velocities_mps, dtype=np.float64))
        out = np.empty(pos.shape[0], dtype=np.complex128)
        step = max(1, _CHUNK // self.weighted.size)
        f0 = float(self.freq[0])
        planes = self.planes() if self._planes is not None or pos.shape[0] > 1 else None
        for i0 in range(0, pos.shape[0], step):
            delays = self._delays(pos[i0 : i0 + step], vel[i0 : i0 + step])
            for i, d in enumerate(delays):
                if planes is not None:
                    out[i0 + i] = planes.sums(d, f0, self.freq_step).sum()
                else:
                    out[i0 + i] = phased_row_sums(self.weighted, d, f0, self.freq_step).sum()
        return out / self.norm


@dataclass(frozen=True, kw_only=True, eq=False)
class PointFit:
    """One mover's maximum-likelihood fit (:func:`fit_point_mover`).

    A part of the analysis's mover record, not an alternative to it:
    :class:`~sarmotion.pipeline.Mover` holds two (``separated_fit`` and ``fit``) beside
    the detection evidence, ``g_perp``, the whole-aperture focus, bounds, traces and image.
    This holds the fit alone, with the global cross-range search and the lobe ambiguity.

    Attributes
    ----------
    position_m : (3,) ndarray
        Position at ``s = 0`` (m); its cross-range coordinate is the one held.
    range_speed_mps, cross_range_speed_mps : float
        ``u_r``, ``u_p`` (m/s).
    velocity_mps : (2,) ndarray
        Ground velocity (m/s).
    amplitude : complex
        ``I / n_pulses``: the reflectivity estimate (data units).
    grid_mps, profile : (n_grid,) ndarray
        The global search: cross-range speeds and ``max |I|`` over range and range speed
        at each (data units times ``n_pulses``), for plotting beside ``g_perp``.
    lobe_ratio : float
        ``|I|`` of the best local maximum on another lobe (cross-range speed more than a
        resolution away) over the fit's ``|I|``; 0 when no other lobe was fitted.
    other_cross_range_speed_mps : float or None
        That maximum's cross-range speed (m/s).
    ambiguous : bool
        The likelihood has two near-equal maxima: ``lobe_ratio >= NEAR_EQUAL_LOBES``.
    """

    position_m: NDArray[np.float64]
    range_speed_mps: float
    cross_range_speed_mps: float
    velocity_mps: NDArray[np.float64]
    amplitude: complex
    grid_mps: NDArray[np.float64]
    profile: NDArray[np.float64]
    lobe_ratio: float = 0.0
    other_cross_range_speed_mps: float | None = None
    ambiguous: bool = False


@dataclass(frozen=True)
class _Profile:
    """The global search over cross-range speed (:func:`_global_cross_search`).

    ``values[i]``: ``max |I|`` over the window's ground-range offsets and the residual
    range speeds at the cross-range speed ``grid[i]``; ``residual_mps[i]`` and
    ``delay_s[i]``: where that maximum is (residual range speed, m/s, and the aligned
    trace's fast-time delay, s).
    """

    grid: NDArray[np.float64]
    values: NDArray[np.float64]
    residual_mps: NDArray[np.float64]
    delay_s: NDArray[np.float64]

    def peaks(self, separation: int, count: int) -> list[int]:
        """Indices of the profile's ``count`` largest local maxima, ``separation`` apart.

        Largest first; a maximum within ``separation`` grid steps of a larger one is
        the same lobe's shoulder and is not listed.
        """
        order = np.argsort(-self.values, kind="stable")
        out: list[int] = []
        for i in order:
            if len(out) == count:
                break
            lo, hi = max(0, i - 1), min(self.values.size, i + 2)
            if self.values[i] < self.values[lo:hi].max():
                continue  # not a local maximum
            if all(abs(int(i) - j) > separation for j in out):
                out.append(int(i))
        return out


def _global_cross_search(
    d: Traces,
    range_speed_mps: float,
    grid: NDArray[np.float64],
    centre_s: float | None = None,
) -> _Profile:
    """Profile of ``max |I|`` over range and residual range speed for each ``u_p`` of ``grid``.

    The range window is centred on the aligned trace of the ``g(u)`` peak (the fast-time
    sample where ``sum_s |T_+ d|`` peaks at ``u_r``), or on ``centre_s`` (s, a sample of
    the aligned traces' fast time) where given.

    The profile is in the units of ``|I|`` (``a n_pulses`` for a mover of reflectivity
    ``a`` at the parameters): the aligned traces are scaled as :attr:`Traces.data`, whose
    point response peaks at ``mean(W)`` (1, :meth:`sarmotion.core.Radar.spectral_weights`).
    The residual range speed is compensated by its phase at the carrier: a lower bound
    of ``|I|`` at the motion of the same range history, not ``|I|`` itself.
    """
    al = _Aligner(d, d.reference_point_m)
    geom = d.geometry
    # fast-time window: the aligned trace of the g(u) peak, +- 12 samples (1.4 m at GOTCHA)
    if centre_s is None:
        centre = int(np.argmax(al.trace_profile(range_direction_velocity(range_speed_mps, geom))))
    else:
        centre = int(np.argmin(np.abs(al.times_s - centre_s)))
    cols = (centre + np.arange(-12, 13)) % al.n_fft
    basis = al.column_basis(cols)
    n = d.n_pulses
    n_dop = 1 << int(np.ceil(np.log2(4 * n)))
    profile = np.empty(grid.size)
    where = np.empty((grid.size, 2), dtype=int)
    with threadpool_limits(limits=1, user_api="blas"):  # small products: one thread
        for i0 in range(0, grid.size, 8):
            vel = np.array([ground_velocity(range_speed_mps, up, geom) for up in grid[i0 : i0 + 8]])
            # the window's fast-time samples only: inverse-DFT columns instead of the FFT
            aligned = _columns(al.spectra(vel), basis)
            dop = np.abs(sfft.fft(aligned, n=n_dop, axis=1, workers=-1)).reshape(vel.shape[0], -1)
            k = dop.argmax(axis=1)
            profile[i0 : i0 + 8] = dop[np.arange(vel.shape[0]), k]
            where[i0 : i0 + 8] = np.stack(np.unravel_index(k, (n_dop, cols.size)), axis=1)
    kd, it = where[:, 0], where[:, 1]
    ds = float(np.median(np.diff(d.slow_times_s)))
    doppler_hz = np.where(kd < n_dop // 2, kd, kd - n_dop) / (n_dop * ds)
    du = doppler_hz * C / (2.0 * d.radar.carrier_hz)
    mean_w = float(np.mean(d.radar.spectral_weights()))
    return _Profile(
        grid=np.asarray(grid, dtype=np.float64),
        values=profile / mean_w,
        residual_mps=du,
        delay_s=al.times_s[cols[it]].astype(np.float64),
    )


def _model_start(
    traces: Traces, delay_s: float, range_speed_mps: float, cross_range_speed_mps: float
) -> tuple[NDArray[np.float64], float, float]:
    """The matched filter's parameters of a point of the global search.

    The search aligns the traces on the reference point: its point ``(delay, u_r, u_p)``
    is the range history ``|r(s) - rho_o - s u| + c delay / 2`` (``u`` the ground velocity
    of ``(u_r, u_p)``). The matched filter's parameters hold the position on the
    reference point's cross range, ``rho_o + x e_r``: the motion there with the same
    range history has other speeds. Off the reference point the line of sight's
    elevation differs (a ground velocity's range rate scales with its cosine: 28 m/s
    at 40 m of ground range on GOTCHA is 0.04 m/s, five Doppler resolutions of a
    degree), and so does the curvature of a circular flight's range history. The three
    numbers of the range history over a straight sub-aperture (range, rate, curvature,
    :mod:`sarmotion.motion.aperture`) fix ``(x, u_r, u_p)``: they are fitted by least
    squares on the ranges at every pulse.

    Returns
    -------
    position : (3,) ndarray
        ``rho_o + x e_r`` (m).
    range_speed_mps, cross_range_speed_mps : float
    """
    geom = traces.geometry
    cells = resolution(traces)
    e_r = np.r_[cells.range_direction, 0.0]
    ref = traces.reference_point_m
    g_r, g_p = ground_velocity(1.0, 0.0, geom), ground_velocity(0.0, 1.0, geom)
    target = (
        ranges_m(traces, ref, range_speed_mps * g_r + cross_range_speed_mps * g_p)
        + 0.5 * C * delay_s
    )
    x0 = -0.5 * C * delay_s / np.cos(cells.elevation_rad)

    def residual(q: NDArray[np.float64]) -> NDArray[np.float64]:
        v = (range_speed_mps + q[1]) * g_r + (cross_range_speed_mps + q[2]) * g_p
        return ranges_m(traces, ref + (x0 + q[0]) * e_r, v) - target

    q = least_squares(residual, np.zeros(3), x_scale=np.array([0.1, 0.01, 0.1]), xtol=1e-12).x
    return (
        ref + (x0 + q[0]) * e_r,
        range_speed_mps + float(q[1]),
        cross_range_speed_mps + float(q[2]),
    )


def _local_fit(
    traces: Acquisition | Traces,
    mf: MatchedFilter,
    position_m: NDArray[np.float64],
    range_speed_mps: float,
    cross_range_speed_mps: float,
) -> tuple[NDArray[np.float64], float, float, complex]:
    """Local maximum of ``|I|`` over ``(x, u_r, u_p)``, the cross-range coordinate held.

    Two steps. Nelder-Mead to a loose tolerance finds the lobe: initial steps of 3 cm of
    range, 0.01 m/s of range speed (about half the Doppler resolution ``lambda / (2 T)``
    of a GOTCHA degree) and 0.15 m/s of cross-range speed (a fifth of its resolution),
    stopped when the simplex is within 1e-3 (m, m/s) and ``|I|`` within 1e-6 of itself.
    A Newton ascent (analytic derivatives, :mod:`sarmotion.core.ascent`) then converges
    on that lobe, in units of about an eighth of a resolution (3 cm, 0.0015 m/s, 0.09
    m/s), to a gaining step under 1e-3 of one. The simplex matters: where the start is
    not on the main lobe's concave part (the likelihood is indefinite there) the
    gradient can lead along a ridge to a lower maximum metres per second away in
    cross-range speed, while the simplex's exploratory steps find the lobe the tight
    Nelder-Mead finds, in a fraction of its evaluations (``tests/motion/test_likelihood_fit.py``;
    figures in ``docs/notes/motion.md``).
    """
    geom = traces.geometry
    e_r = np.r_[resolution(traces).range_direction, 0.0]
    g_r = np.r_[ground_velocity(1.0, 0.0, geom), 0.0]
    g_p = np.r_[ground_velocity(0.0, 1.0, geom), 0.0]
    v0 = np.r_[ground_velocity(range_speed_mps, cross_range_speed_mps, geom), 0.0]
    s = mf.slow

    def unpack(q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return position_m + q[0] * e_r, (v0 + q[1] * g_r + q[2] * g_p)[:2]

    def cost(q: NDArray[np.float64]) -> float:
        p, v = unpack(q)
        return -float(abs(mf.responses(p[None], v[None])[0]))

    mf.planes()  # the simplex's evaluations and the ascent's run on it
    q0 = np.zeros(3)
    start = cost(q0)
    res = minimize(
        cost,
        q0,
        method="Nelder-Mead",
        options={
            "initial_simplex": np.vstack([q0, np.diag([0.03, 0.01, 0.15])]),
            "xatol": 1e-3,
            "fatol": 1e-6 * max(1e-300, -start),
            "maxiter": 800,
        },
    )
    q1 = res.x if res.fun <= start else q0
    evaluate = mf.response_derivatives().on_track(s, position_m, v0, e_r, (g_r, g_p))
    q, value, _, _ = newton_ascent(
        evaluate, q1, radius=1.0, tol=1e-3, max_iter=100, scale=_LOCAL_UNITS
    )
    p = position_m + q[0] * e_r
    return p, range_speed_mps + float(q[1]), cross_range_speed_mps + float(q[2]), complex(value)


def fit_point_mover(
    data: Traces | ArrayLike,
    range_speed_mps: float,
    *,
    acquisition: Acquisition | None = None,
    cross_speed_range_mps: tuple[float, float] = (-30.0, 30.0),
    step_mps: float | None = None,
    trace_delay_s: float | None = None,
) -> PointFit:
    """Maximum-likelihood ``(x, u_r, u_p)`` of one mover near a ``g(u)`` peak (module notes).

    Parameters
    ----------
    data : Traces or (n_pulses, n_samples) array_like
        Traces holding the mover, stationary targets and other movers removed.
    range_speed_mps : float
        The ``g(u)`` peak (m/s); refined on ``g`` within half a range-speed resolution
        first, then by the Doppler search within ``+- lambda PRF / 4``.
    acquisition : Acquisition, optional
        Acquisition of about a degree (its ``s = 0`` is the time of the position);
        required when ``data`` is an array.
    cross_speed_range_mps : (float, float)
        The cross-range speeds searched globally (m/s).
    step_mps : float, optional
        Grid step of the global search (m/s); default half of
        :func:`cross_range_speed_resolution` (0.37 m/s for a GOTCHA degree).
    trace_delay_s : float, optional
        Fast-time delay (s) of the aligned trace on which the global search centres its
        range window; default the ``g(u)`` peak's own (the strongest trace at that
        speed). Another trace of the same range speed: a second mover beside a stronger
        echo there (:func:`sarmotion.motion.aligned_trace`).

    Returns
    -------
    PointFit
        Its position is on the reference point's cross range; ``ambiguous``,
        ``lobe_ratio`` and ``other_cross_range_speed_mps`` say whether another lobe of
        the likelihood came near its maximum.
    """
    tr = as_traces(data, acquisition)
    res_u = range_speed_resolution(tr)
    al = _Aligner(tr, tr.reference_point_m)

    def g(u: float) -> float:
        return float(al.g_values(range_direction_velocity(u, tr.geometry)[None])[0])

    u0, _ = _refine_max(g, float(range_speed_mps), 0.5 * res_u, 1e-3)
    lo, hi = cross_speed_range_mps
    res_c = cross_range_speed_resolution(tr)
    step = 0.5 * res_c if step_mps is None else float(step_mps)
    grid = lo + step * np.arange(int(np.floor((hi - lo) / step)) + 1)
    search = _global_cross_search(tr, u0, grid, trace_delay_s)
    mf = MatchedFilter(tr)
    # Local maxima one Doppler resolution apart in range speed trade it against metres
    # per second of cross-range speed (one degree of aperture): from the profile's
    # largest maximum the local fit starts at its range speed and one resolution either
    # side; from the next lobes' maxima at their own range speed.
    doppler_mps = C / (
        2.0 * tr.radar.carrier_hz * tr.n_pulses * np.median(np.diff(tr.slow_times_s))
    )
    lobe_steps = max(1, int(np.ceil(res_c / step)))
    peaks = search.peaks(lobe_steps, _PROFILE_LOBES)
    fits = []
    for rank, i in enumerate(peaks):
        start, ur0, up0 = _model_start(
            tr, search.delay_s[i], u0 + search.residual_mps[i], float(grid[i])
        )
        for k in (0, -1, 1) if rank == 0 else (0,):
            fits.append(_local_fit(tr, mf, start, ur0 + k * doppler_mps, up0))
    pos, ur, up, value = max(fits, key=lambda f: abs(f[3]))
    # The check against the profile (_PROFILE_TOLERANCE): a fit far below the profile's
    # maximum gives way to the motion of that maximum's range history, if higher.
    best = peaks[0]
    if abs(value) < (1.0 - _PROFILE_TOLERANCE) * search.values[best]:
        p0, ur0, up0 = _model_start(
            tr, search.delay_s[best], u0 + search.residual_mps[best], float(grid[best])
        )
        v0 = complex(mf.responses(p0[None], ground_velocity(ur0, up0, tr.geometry)[None])[0])
        if abs(v0) > abs(value):
            pos, ur, up, value = p0, ur0, up0, v0
    others = [f for f in fits if abs(f[2] - up) > res_c]
    other = max(others, key=lambda f: abs(f[3])) if others else None
    ratio = abs(other[3]) / max(abs(value), 1e-300) if other is not None else 0.0
    return PointFit(
        position_m=pos,
        range_speed_mps=ur,
        cross_range_speed_mps=up,
        velocity_mps=ground_velocity(ur, up, tr.geometry),
        amplitude=value / tr.n_pulses,
        grid_mps=grid,
        profile=search.values,
        lobe_ratio=float(ratio),
        other_cross_range_speed_mps=None if other is None else float(other[2]),
        ambiguous=bool(ratio >= NEAR_EQUAL_LOBES),
    )


def fit_point_mover_at(
    data: Traces | ArrayLike,
    delay_s: float,
    range_speed_mps: float,
    cross_range_speed_mps: float,
    *,
    acquisition: Acquisition | None = None,
    profile_resolutions: float = 3.0,
) -> PointFit:
    """Maximum-likelihood ``(x, u_r, u_p)`` of one mover from a point of its range history.

    The start is the motion whose range history is ``|r(s) - rho_o - s u| + c delay / 2``
    (``u`` the ground velocity of ``(range_speed_mps, cross_range_speed_mps)``, the
    position on the reference point's cross range, :func:`_model_start`), refined on its
    lobe as in :func:`fit_point_mover` (:func:`_local_fit`). For a candidate that a
    search over cross-range speeds has already placed (the defocus bank,
    :mod:`sarmotion.motion.defocus`): no global search, only its profile within
    ``profile_resolutions`` cross-range-speed resolutions of the fit, for the record.

    Parameters
    ----------
    data : Traces or (n_pulses, n_samples) array_like
        Traces holding the mover.
    delay_s : float
        Fast time of its trace at ``s = 0`` relative to the motion's (s).
    range_speed_mps, cross_range_speed_mps : float
        ``u_r``, ``u_p`` of the start (m/s).
    acquisition : Acquisition, optional
        Required when ``data`` is an array.
    profile_resolutions : float
        Half-width of the recorded profile (cross-range-speed resolutions).

    Returns
    -------
    PointFit
        Its position on the reference point's cross range; ``lobe_ratio`` 0 (no other
        lobe was fitted).
    """
    tr = as_traces(data, acquisition)
    start, ur0, up0 = _model_start(
        tr, float(delay_s), float(range_speed_mps), float(cross_range_speed_mps)
    )
    pos, ur, up, value = _local_fit(tr, MatchedFilter(tr), start, ur0, up0)
    res_c = cross_range_speed_resolution(tr)
    k = int(np.ceil(2.0 * profile_resolutions))
    grid = up + 0.5 * res_c * np.arange(-k, k + 1)
    search = _global_cross_search(tr, ur, grid)
    return PointFit(
        position_m=pos,
        range_speed_mps=ur,
        cross_range_speed_mps=up,
        velocity_mps=ground_velocity(ur, up, tr.geometry),
        amplitude=value / tr.n_pulses,
        grid_mps=grid,
        profile=search.values,
    )


#: A weaker fit is a stronger one's echo when its amplitude is at most this many times
#: what that echo makes at the weaker's point model (:func:`duplicate_fits`): half its
#: amplitude or more can be the echo.
ECHO_MARGIN = 2.0


def duplicate_fits(traces: Acquisition | Traces, fits: Sequence[PointFit]) -> list[int]:
    """Indices of the fits that repeat a stronger one: the same range history, or its echo.

    Two point movers whose ranges ``|r(s) - rho - s u|`` differ by less than a
    slant-range resolution ``c / (2 B)`` at every pulse of ``traces`` are within one
    resolution cell of each other all along the aperture: their traces are one trace
    to ``g(u)`` and to the separation, and what the point model leaves of a mover
    fitted on a side lobe (whose range history differs from the main lobe's by a few
    wavelengths of curvature) follows that trace, so a second fit of it is the same
    mover. A weaker fit ``k`` is also the stronger ``j``'s when ``j``'s echo can make
    half its amplitude or more: ``|a_k| <= ECHO_MARGIN |a_j| |<m_j, m_k>| / <m_k, m_k>``,
    ``m`` the unit point models (:func:`point_model`): what ``j``'s echo gives the
    least-squares amplitude of ``k``'s model, phases included. At a range-speed alias of
    ``j`` (range rates ``lambda PRF / 2`` apart, the same range at ``s = 0``) the two
    models' phases agree at every pulse and only their envelopes part, a cell in
    ``(c / 2B) / |u_k - u_j|`` of slow time: a strong mover's fit at its alias there
    reads a few percent of its amplitude, a second fit the subtraction of the first
    leaves to ``g(u)``. Movers of other range rates turn against each other in phase
    and read little of each other. Of each group the fit of largest ``|amplitude|`` is
    kept.

    Parameters
    ----------
    traces : Traces
        The (sub-)aperture the fits were made on (``s = 0`` their time).
    fits : sequence of PointFit

    Returns
    -------
    list of int
        The indices to drop, ascending.
    """
    cell = 0.5 * C / traces.radar.bandwidth_hz
    order = sorted(range(len(fits)), key=lambda k: -abs(fits[k].amplitude))
    histories = [ranges_m(traces, f.position_m, f.velocity_mps) for f in fits]
    models: dict[int, NDArray[np.complex128]] = {}

    def model(k: int) -> NDArray[np.complex128]:
        if k not in models:
            models[k] = point_model(traces, fits[k].position_m, fits[k].velocity_mps, 1.0).ravel()
        return models[k]

    def echo(j: int, k: int) -> float:
        """``|a_j| |<m_j, m_k>| / <m_k, m_k>``: what ``j``'s echo reads in ``k``'s model."""
        mk = model(k)
        norm = float(np.vdot(mk, mk).real)
        return abs(fits[j].amplitude) * abs(np.vdot(mk, model(j))) / norm if norm > 0 else 0.0

    kept: list[int] = []
    drop: list[int] = []
    for k in order:
        if any(np.max(np.abs(histories[k] - histories[j])) < cell for j in kept) or any(
            abs(fits[k].amplitude) <= ECHO_MARGIN * echo(j, k) for j in kept
        ):
            drop.append(k)
        else:
            kept.append(k)
    return sorted(drop)


def point_model(
    traces: Acquisition | Traces, position_m: ArrayLike, velocity_mps: ArrayLike, amplitude: complex
) -> NDArray[np.complex128]:
    """Traces of one point mover on the acquisition ``traces`` (``eq:MOD1``).

    Returns
    -------
    (n_pulses, n_samples) ndarray
        ``a W_k exp(-i psi_jk)`` brought to fast time (data units).
    """
    rho = as_point(position_m, name="position_m")
    v3 = np.r_[np.asarray(velocity_mps, dtype=np.float64).reshape(2), 0.0]
    where = rho[None, :] + traces.slow_times_s[:, None] * v3[None, :]
    rng = np.linalg.norm(traces.positions_m - where, axis=1)
    ref = np.linalg.norm(traces.positions_m - traces.reference_point_m, axis=1)
    cycles = (2.0 * (rng - ref) / C)[:, None] * traces.frequencies_hz[None, :]
    cycles -= np.rint(cycles)
    ph = (
        complex(amplitude) * traces.radar.spectral_weights()[None, :] * np.exp(-2j * np.pi * cycles)
    )
    return to_fast_time(ph)


def refine_jointly(
    data: Traces | ArrayLike,
    fits: Sequence[PointFit],
    *,
    acquisition: Acquisition | None = None,
    rounds: int = 2,
) -> list[PointFit]:
    """Re-fit every mover locally on ``data`` minus the other movers' models, ``rounds`` times.

    The alternating (coordinate-wise) maximisation of the joint likelihood of several
    point movers (:func:`refit_movers` on the data the fits were made on); one mover is
    returned unchanged. ``acquisition`` is required when ``data`` is an array.
    """
    if len(fits) < 2:
        return list(fits)
    return refit_movers(data, fits, acquisition=acquisition, rounds=rounds)


def noise_variance(residual: ArrayLike) -> float:
    """Robust per-sample variance of circular complex noise: ``median(|r|^2) / ln 2``.

    ``|r|^2`` of circular complex Gaussian noise of variance ``sigma^2`` is exponential
    with median ``sigma^2 ln 2``; the median ignores the few samples of bright residue.
    """
    r = np.asarray(residual)
    return float(np.median(np.abs(r) ** 2) / np.log(2.0))


def matched_filter_noise_variance(
    data: Traces | ArrayLike,
    *,
    acquisition: Acquisition | None = None,
    half_size_m: float,
    speed_range_mps: tuple[float, float] = (-30.0, 30.0),
    centre_m: ArrayLike | None = None,
    velocity_mps: ArrayLike | None = None,
    speed_spread_mps: tuple[float, float] = (2.0, 5.0),
    n_draws: int = 256,
    seed: int = 0,
) -> float:
    """Per-sample noise variance as the matched filter sees it (data units squared).

    ``I`` at ``n_draws`` random positions (within ``half_size_m`` of ``centre_m``, default
    the reference point) and velocities (range and cross-range speeds uniform over
    ``speed_range_mps``, or within ``speed_spread_mps`` of those of ``velocity_mps``):
    away from every target ``I`` is the interference projected on a mover's signature,
    of variance ``sigma_P^2 n_pulses / sum_k W_k^2`` for white noise of ``sigma_P^2`` per
    phase-history sample. Its robust level ``median(|I|^2) / ln 2`` (a draw that hits a
    target does not count) gives ``sigma_P^2``, returned per fast-time sample
    (``/ n_samples``). Unlike the median of the residual samples it counts the residue
    of stationary clutter, which RPCA leaves sparse (most samples exactly zero); drawn
    around a mover it measures the interference where that mover is. ``acquisition`` is
    required when ``data`` is an array.
    """
    traces = as_traces(data, acquisition)
    gen = np.random.default_rng(seed)
    geom = traces.geometry
    centre = traces.reference_point_m if centre_m is None else as_point(centre_m, name="centre_m")
    offsets = gen.uniform(-half_size_m, half_size_m, (n_draws, 2))
    pos = centre[None, :] + np.c_[offsets, np.zeros(n_draws)]
    if velocity_mps is None:
        lo, hi = speed_range_mps
        speeds = gen.uniform(lo, hi, (n_draws, 2))
    else:
        v = np.asarray(velocity_mps, dtype=np.float64).reshape(2)
        ur, up = range_speed(v, geom), cross_range_speed(v, geom)
        spread = np.asarray(speed_spread_mps, dtype=np.float64)
        speeds = np.array([ur, up])[None, :] + gen.uniform(-1.0, 1.0, (n_draws, 2)) * spread
    vel = np.array([ground_velocity(a, b, geom) for a, b in speeds])
    mf = MatchedFilter(traces)
    level = float(np.median(np.abs(mf.responses(pos, vel)) ** 2) / np.log(2.0))
    return level * mf.norm / traces.n_pulses / traces.n_samples


def refit_movers(
    data: Traces | ArrayLike,
    fits: Sequence[PointFit],
    *,
    acquisition: Acquisition | None = None,
    rounds: int = 1,
) -> list[PointFit]:
    """Re-fit every mover locally on ``data`` minus the other movers' models.

    Unlike :func:`refine_jointly` a single mover is re-fitted too: ``data`` is not the
    one the fits were made on (e.g. the traces with a new stationary estimate removed,
    :mod:`sarmotion.pipeline.refit`). The other movers' models use the amplitudes of
    ``fits``; each re-fitted mover's amplitude is the matched filter on ``data`` at its
    new parameters. ``rounds`` sweeps (the alternating maximisation of the joint
    likelihood). ``acquisition`` is required when ``data`` is an array.
    """
    given = as_traces(data, acquisition)
    traces, d = given.acquisition, given.data
    out = list(fits)
    models = [point_model(traces, f.position_m, f.velocity_mps, f.amplitude) for f in out]
    for _ in range(int(rounds)):
        for k, f in enumerate(out):
            others = sum((m for j, m in enumerate(models) if j != k), np.zeros_like(d))
            mf = MatchedFilter(d - others, acquisition=traces)
            pos, ur, up, value = _local_fit(
                traces, mf, f.position_m, f.range_speed_mps, f.cross_range_speed_mps
            )
            vel = ground_velocity(ur, up, traces.geometry)
            out[k] = replace(
                f,
                position_m=pos,
                range_speed_mps=ur,
                cross_range_speed_mps=up,
                velocity_mps=vel,
                amplitude=value / traces.n_pulses,
            )
            models[k] = point_model(traces, pos, vel, out[k].amplitude)
    return out
