r"""Movers whose traces look stationary, found by their defocus over a cross-range-speed bank.

**Why.** ``g(u)`` (:mod:`~sarmotion.motion.detector`) finds a mover by the range speed of
its trace and leaves the stationary band untested: the range speeds of the imaged
scene's own stationary points, where their residue lies. A mover whose apparent range
speed falls in that band, whose image lands inside the scene (most movers of a large
collection, whose patches tile the whole unambiguous scene), has to first order the
range history of a stationary point of the scene: the separation takes its echo for
stationary and it is listed as a string of stationary points along cross range. What
tells it apart is the second order: its cross-range speed ``u_p`` changes the curvature
of its range history, a quadratic phase over the aperture that the stationary image
does not focus.

**The bank.** For each cross-range speed ``w`` of a grid, the data are aligned to a point
at the reference moving at ``w`` with no range speed, ``D(s, t) -> D(s, t + delta_w(s))``
with ``delta_w(s) = 2 (|x(s) - rho_ref - s v_w| - |x(s) - rho_ref|) / c`` (carrier
included, :func:`~sarmotion.core.delay_phase`), and transformed over slow time. A target
whose range history is the hypothesis' up to a range offset and a range rate becomes a
peak at its fast time ``t`` and Doppler ``f``: focused where ``w`` is its cross-range
speed, smeared elsewhere; its apparent range speed (the ``g(u)`` sense, relative to the
reference) is ``u = u_w - lambda_c f / 2``, ``u_w`` the hypothesis' own at ``s = 0``.
``w = 0`` is the stationary range-Doppler image. Adjacent hypotheses' quadratic phases
differ by ``pi / 2`` at the aperture's edges (:func:`edge_phase_rad`): a mover between
two is seen with at most ``pi / 4`` of quadratic phase, a loss of
``|mean_x exp(i pi x^2 / 4)|`` over ``x in [-1, 1]``, 0.24 dB. The hypotheses are about
the reference; a stationary point elsewhere in the scene has a range curvature of its
own, mostly from its range offset ``x`` (on a circular flight about ``x Omega^2``,
``Omega`` the turn rate: at the edges of GOTCHA apertures, for 50 m of range, 0.53 rad
over a degree and four times that over two, two of that bank's steps; 0.002 rad for 50
m of cross range over a degree). Each fast-time row's own is removed before the
transform (:func:`row_phases`: the stationary point on the ground-range line through
the reference at that row's range), so the stationary points of every row focus at
``w = 0`` and ``w`` is a cross-range speed relative to them; what remains is the cross
range's share, under a tenth of a step over the analysed scenes. Range migration within
the band is neglected (the band is the scene's own range rates: a few resolution cells
over the aperture at most), except in the smear test below.

**Screen.** Interference in a cell is taken as complex Gaussian, ``|X|^2`` exponential
with mean ``p``: the noise, estimated per hypothesis as ``median |X|^2 / ln 2`` over the
cells searched (targets barely move a median), or, where larger, the mean power of the
cell's range bin over its Doppler cells beyond a guard of a focused point's main lobe
either side (cell-averaging: the smears and side lobes of the stationary points in that
bin, which at a moving hypothesis add with unrelated phases; the guard keeps the cell's
own target out). Over ``N`` cells and hypotheses such a cell exceeds ``p ln(N / alpha)`` with
probability at most ``alpha`` (the union bound, as
:func:`~sarmotion.separation.noise_only`). A candidate is
a cell of some ``w != 0`` that reaches it, is a local maximum in fast time, Doppler and
``w``, and is brighter than a stationary point's smear could make it: a stationary
point of value ``X_0(t', f')`` reads ``|X_0(t', f')| H_w(f - f')`` in hypothesis ``w``
(``H_w`` the transform of the quadratic phase between the two hypotheses), and the cell
must exceed the largest such, over the range bins a stationary point of the band
crosses during the aperture (``band T``) and one more either side, by
``SMEAR_MARGIN_DB``: 6.02 dB, what two smears of equal size reach in phase (the model
takes each stationary point alone). Candidates are ranked by their statistic, power over
interference, and keep their power (of one target's cells at several ``w``, the most
powerful is where it focuses best). The screen does not decide: the mover stage fits
each candidate by maximum likelihood and tests it against the stationary scene
(:mod:`sarmotion.pipeline.defocused`).

Times in s, speeds in m/s, phases in rad; geometry in float64.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
import scipy.fft as sfft
from numpy.typing import NDArray

from ..core import Traces, delay_phase, ground_velocity, to_fast_time, to_frequency
from ..core.constants import C
from ..core.geometry import range_direction_velocity
from .aperture import ranges_m
from .speed_resolution import range_speed_resolution

__all__ = [
    "DefocusCandidate",
    "DefocusScan",
    "ECHO_LOBE",
    "EDGE_PHASE_STEP_RAD",
    "SMEAR_MARGIN_DB",
    "cross_speed_bank",
    "defocus_scan",
    "echo_peak_power",
    "echo_residue",
    "edge_phase_rad",
    "hypothesis_delays_s",
    "keystone_spectrum",
    "row_phases",
    "screen_cells",
]

#: Quadratic phase (rad, at the aperture's edges) between adjacent hypotheses of the bank.
EDGE_PHASE_STEP_RAD = 0.5 * np.pi

#: Least margin of a candidate over the brightest stationary smear at its cell (dB):
#: two equal smears in phase, ``20 log10 2``.
SMEAR_MARGIN_DB = float(20.0 * np.log10(2.0))

#: The cells of a model's own echo (:func:`echo_residue`): where its power is at least this
#: share of its peak, ``(1/2)^2``, its main lobe at half amplitude.
ECHO_LOBE = 0.25


@dataclass(frozen=True, kw_only=True)
class DefocusCandidate:
    """One cell of the bank that passed the screen (:func:`defocus_scan`).

    Attributes
    ----------
    range_speed_mps : float
        Apparent range speed of its trace relative to the reference (the ``g(u)`` sense).
    cross_range_speed_mps : float
        The hypothesis ``w`` that focuses it best.
    delay_s : float
        Fast time of its trace at ``s = 0`` relative to the reference's (s).
    statistic_db : float
        ``10 log10(|X|^2 / p)``: its power over its interference level (dB, module notes).
    leak_db : float
        Its amplitude over the brightest stationary smear at its cell (dB, > 0).
    power : float
        ``|X|^2`` at its cell (data units squared): the statistic times the cell's
        interference level. Of one echo's cells (one target seen at several ``w``) the
        most powerful is the hypothesis that focuses it best.
    """

    range_speed_mps: float
    cross_range_speed_mps: float
    delay_s: float
    statistic_db: float
    leak_db: float
    power: float


@dataclass(frozen=True, kw_only=True, eq=False)
class DefocusScan:
    """What :func:`defocus_scan` found.

    Attributes
    ----------
    candidates : tuple of DefocusCandidate
        By decreasing ``statistic_db``, at most ``max_candidates``.
    n_beyond : int
        Candidates that passed but were beyond ``max_candidates`` (not returned).
    threshold_db : float
        ``10 log10 ln(N / alpha)``: the statistic a noise cell reaches with probability
        at most ``alpha`` over the ``N`` cells and hypotheses (dB).
    n_cells : int
        ``N``.
    speeds_mps : (n_w,) ndarray
        The bank's cross-range speeds (m/s), 0 included.
    """

    candidates: tuple[DefocusCandidate, ...]
    n_beyond: int
    threshold_db: float
    n_cells: int
    speeds_mps: NDArray[np.float64]

    def p_value(self, statistic_db: float) -> float:
        """Union-bound probability that noise alone reaches ``statistic_db`` in some cell."""
        return float(min(1.0, self.n_cells * np.exp(-(10.0 ** (statistic_db / 10.0)))))


def _guarded_mean(power: NDArray, cols: NDArray[np.int64], guard: int) -> NDArray[np.float64]:
    """Mean of ``power`` (rows, n) along each row beyond ``+-guard`` cells of each of ``cols``.

    Circular in the second axis (Doppler); shape ``(rows, cols.size)``. For the bank's
    float32 maps the compiled :func:`_guarded_mean_f32` gives the same values bit for bit
    (a row's running sum in float32, as ``np.cumsum`` forms it, read only at the columns
    asked for); this form is the reference it is tested against.
    """
    n = power.shape[1]
    c = np.concatenate([np.zeros((power.shape[0], 1)), np.cumsum(power, axis=1)], axis=1)
    total = c[:, -1:]
    lo = cols - guard
    hi = cols + guard + 1
    inside = np.zeros((power.shape[0], cols.size))
    for shift in (-n, 0, n):  # the window may wrap around
        a = np.clip(lo + shift, 0, n)
        b = np.clip(hi + shift, 0, n)
        inside += c[:, b] - c[:, a]
    return (total - inside) / max(n - (2 * guard + 1), 1)


@numba.njit(nogil=True, cache=True)
def _guarded_mean_f32(power, cols, guard, out):  # pragma: no cover - compiled
    """:func:`_guarded_mean` of float32 ``power`` into ``out`` (rows, cols.size), float64.

    The same arithmetic in the same order: each row's running sum accumulated in float32
    (``np.cumsum``'s), its values taken to float64, the window's three circular pieces
    added to zero in turn, ``(total - inside) / max(n - (2 guard + 1), 1)``.
    """
    n_rows, n = power.shape
    run = np.empty(n + 1, dtype=np.float64)
    denom = np.float64(max(n - (2 * guard + 1), 1))
    for r in range(n_rows):
        acc = np.float32(0.0)
        run[0] = 0.0
        for i in range(n):
            acc = np.float32(acc + power[r, i])
            run[i + 1] = np.float64(acc)
        total = run[n]
        for q in range(cols.size):
            inside = 0.0
            for shift in (-n, 0, n):
                a = min(max(cols[q] - guard + shift, 0), n)
                b = min(max(cols[q] + guard + 1 + shift, 0), n)
                inside += run[b] - run[a]
            out[r, q] = (total - inside) / denom


@numba.njit(nogil=True, cache=True)
def _power_f32(values, out):  # pragma: no cover - compiled
    """``out = |values|^2`` in float32, ``re^2 + im^2`` formed in float64."""
    n_rows, n = values.shape
    for r in range(n_rows):
        for i in range(n):
            z = values[r, i]
            out[r, i] = np.float32(z.real * z.real + z.imag * z.imag)


def _local_peaks(
    maps: NDArray, cols: NDArray[np.int64], k: int, rows: NDArray, js: NDArray
) -> NDArray[np.bool_]:
    """Whether cells ``(k, rows, cols[js])`` of ``maps`` are maxima of their neighbourhoods.

    The neighbourhood is 3 x 3 x 3 cells over (hypothesis, range row, searched Doppler
    column ``cols``), edges repeated (``scipy.ndimage.maximum_filter``'s ``"nearest"``):
    the same answer as filtering the whole bank, evaluated only at the cells asked about
    (those over the screen's level, a few of tens of millions).
    """
    n_w, n_r = maps.shape[0], maps.shape[1]
    here = maps[k, rows, cols[js]]
    best = np.full(here.shape, -np.inf, dtype=maps.dtype)
    for dk in (-1, 0, 1):
        kk = min(max(k + dk, 0), n_w - 1)
        for dr in (-1, 0, 1):
            rr = np.clip(rows + dr, 0, n_r - 1)
            for dj in (-1, 0, 1):
                jj = cols[np.clip(js + dj, 0, cols.size - 1)]
                np.maximum(best, maps[kk, rr, jj], out=best)
    return here >= best


def hypothesis_delays_s(traces: Traces, cross_range_speed_mps: float) -> NDArray[np.float64]:
    """``delta_w(s)`` (s), shape ``(n_pulses,)``: a point at the reference moving at ``w``.

    ``2 (|x(s) - rho_ref - s v_w| - |x(s) - rho_ref|) / c`` with ``v_w`` the ground velocity
    of zero range speed and cross-range speed ``w`` (:func:`~sarmotion.core.ground_velocity`).
    """
    ref = traces.reference_point_m
    v = ground_velocity(0.0, float(cross_range_speed_mps), traces.geometry)
    return 2.0 * (ranges_m(traces, ref, v) - ranges_m(traces, ref, np.zeros(2))) / C


def row_phases(traces: Traces, rows: NDArray[np.int64]) -> NDArray[np.complex128]:
    """Each fast-time row's own stationary phase, removed: shape ``(n_pulses, rows.size)``.

    Row ``t`` holds, at ``s = 0``, the echoes of the points at slant range ``c t / 2``
    beyond the reference's; the one on the ground along the look's ground-range
    direction, ``p_t = rho_ref - (c t / 2) b_o / |b_o|^2``
    (:func:`~sarmotion.core.range_direction_velocity`), has the delays
    ``delta_t(s) = 2 (|x(s) - p_t| - |x(s) - rho_ref|) / c``. Their part beyond a
    straight line in ``s`` (least squares), ``delta_t^nl``, is the range curvature that
    the hypotheses, which are about the reference, do not hold (module notes); these
    phasors ``exp(2i pi f_c delta_t^nl(s))`` (the carrier's part of
    :func:`~sarmotion.core.delay_phase`) remove it from an aligned row, so that every
    row's stationary points on that line focus at ``w = 0``. The straight line stays: a
    cell's Doppler keeps its meaning, the range rate relative to the reference.
    ``delta_t^nl`` is millimetres, its envelope's migration is not corrected.
    """
    t = np.asarray(traces.fast_times_s, dtype=np.float64)[np.asarray(rows, dtype=np.int64)]
    ref = np.asarray(traces.reference_point_m, dtype=np.float64)
    along = np.r_[range_direction_velocity(1.0, traces.geometry), 0.0]  # range up 1 m per m
    points = ref[None, :] - (0.5 * C * t)[:, None] * along[None, :]  # (rows, 3)
    x = np.asarray(traces.positions_m, dtype=np.float64)  # (n_pulses, 3)
    r_ref = np.linalg.norm(x - ref, axis=1)
    delays = 2.0 * (np.linalg.norm(x[:, None, :] - points[None, :, :], axis=2) - r_ref[:, None]) / C
    s = np.asarray(traces.slow_times_s, dtype=np.float64)
    basis = np.stack([np.ones_like(s), s - s.mean()], axis=1)
    line = basis @ np.linalg.lstsq(basis, delays, rcond=None)[0]
    return np.exp(2j * np.pi * traces.radar.carrier_hz * (delays - line))


def edge_phase_rad(traces: Traces, cross_range_speed_mps: float) -> float:
    """Quadratic phase (rad) of ``delta_w`` at the aperture's edges, ``|a| (T / 2)^2``.

    ``a`` the quadratic coefficient of the least-squares fit of ``2 pi f_c delta_w(s)``
    by a parabola in ``s``, ``T`` the aperture's duration.
    """
    s = traces.slow_times_s
    phase = (
        2.0 * np.pi * traces.radar.carrier_hz * hypothesis_delays_s(traces, cross_range_speed_mps)
    )
    a = np.polyfit(s - s.mean(), phase, 2)[0]
    return float(abs(a) * (0.5 * np.ptp(s)) ** 2)


def cross_speed_bank(
    traces: Traces, max_speed_mps: float, *, within_mps: float | None = None
) -> NDArray[np.float64]:
    """The bank's cross-range speeds (m/s): 0 and steps of ``EDGE_PHASE_STEP_RAD`` to ``max``.

    The edge phase is linear in ``w`` over the speeds of ground movers (``2 V w`` against
    ``V^2`` in the curvature); its slope is taken at 1 m/s. ``within_mps``: only the
    steps with ``|w| <= within_mps`` (m/s).
    """
    per_mps = edge_phase_rad(traces, 1.0)
    if not per_mps > 0.0:
        raise ValueError("the aperture has no quadratic phase to focus: it is too short")
    step = EDGE_PHASE_STEP_RAD / per_mps
    top = float(max_speed_mps) if within_mps is None else min(float(max_speed_mps), within_mps)
    n = int(np.floor(top / step))
    return step * np.arange(-n, n + 1, dtype=np.float64)


def screen_cells(
    traces: Traces, speeds_mps: NDArray, *, band_mps: float, half_span_s: float
) -> int:
    """Independent cells a bank tests (the union bound's ``N``, :func:`defocus_scan`).

    Range resolutions within ``|t| <= half_span_s`` (s) times Doppler resolutions
    ``lambda / (2 T)`` within ``|u| <= band_mps`` (m/s) times the moving hypotheses of
    ``speeds_mps`` (m/s; ``w = 0`` is not tested).
    """
    n_p = traces.n_pulses
    prf = 1.0 / float(np.median(np.diff(traces.slow_times_s)))
    lam = C / traces.radar.carrier_hz
    range_cells = max(1.0, 2.0 * half_span_s * traces.radar.bandwidth_hz)
    dop_cells = max(1.0, 2.0 * band_mps / (0.5 * lam * prf / n_p))
    moving = int(np.count_nonzero(np.asarray(speeds_mps) != 0.0))
    return int(np.ceil(range_cells * dop_cells * moving))


def _doppler_cells(n_pulses: int) -> int:
    """Doppler cells of the bank: twice oversampled, a power of two."""
    return int(2 ** np.ceil(np.log2(2 * n_pulses)))


def _doppler_speeds(traces: Traces, n_dop: int) -> NDArray[np.float64]:
    """``lambda f / 2`` (m/s) of the ``n_dop`` Doppler cells ``f``, in FFT order.

    A cell of hypothesis ``w`` reads the apparent range speed ``u_w - lambda f / 2``.
    """
    prf = 1.0 / float(np.median(np.diff(traces.slow_times_s)))
    return 0.5 * traces.radar.wavelength_m * np.fft.fftfreq(n_dop, d=1.0 / prf)


def _hypothesis_rate(traces: Traces, delays_s: NDArray) -> float:
    """``u_w`` (m/s): a hypothesis' own range rate, the slope of ``c delays_s / 2``."""
    return 0.5 * C * float(np.polyfit(traces.slow_times_s, delays_s, 1)[0])


def _hypothesis_values(
    traces: Traces, spectrum: NDArray, delays_s: NDArray, rows: NDArray, n_dop: int
) -> tuple[float, NDArray[np.complex128]]:
    """One hypothesis of the bank: ``(u_w, X)``, the values of shape ``(n_dop, rows)``.

    ``spectrum`` (the data over frequency) aligned by ``delays_s`` (carrier included),
    back to fast time at ``rows``, each row's own stationary curvature removed
    (:func:`row_phases`), transformed over slow time on ``n_dop`` cells;
    ``u_w`` (m/s) the hypothesis' own range rate (:func:`_hypothesis_rate`).
    """
    u_w = _hypothesis_rate(traces, delays_s)
    aligned = to_fast_time(spectrum * delay_phase(delays_s, traces.frequencies_hz))[:, rows]
    return u_w, np.fft.fft(aligned * row_phases(traces, rows), n=n_dop, axis=0)


def _hypothesis_power(
    traces: Traces, spectrum: NDArray, delays_s: NDArray, rows: NDArray, n_dop: int
) -> tuple[float, NDArray[np.float64]]:
    """One hypothesis of the bank: ``(u_w, |X|^2)`` (:func:`_hypothesis_values`)."""
    u_w, values = _hypothesis_values(traces, spectrum, delays_s, rows, n_dop)
    return u_w, np.abs(values) ** 2


#: Half-width of the keystone's interpolating kernel (pulses either side): a Lanczos
#: kernel ``sinc(x) sinc(x / h)``, ``|x| < h``.
KEYSTONE_HALF_TAPS = 8


@numba.njit(nogil=True, cache=True)
def _keystone_kernel(spectrum, index, out):  # pragma: no cover - compiled
    """``out[j, k] = sum_m L(index[j, k] - m) spectrum[m, k]``, ``L`` the Lanczos kernel."""
    n_p, n_f = spectrum.shape
    h = KEYSTONE_HALF_TAPS
    for j in range(n_p):
        for k in range(n_f):
            x = index[j, k]
            if x < 0.0 or x > n_p - 1:
                out[j, k] = 0.0
                continue
            i0 = int(np.floor(x))
            acc = 0.0 + 0.0j
            for m in range(max(i0 - h + 1, 0), min(i0 + h + 1, n_p)):
                d = x - m
                if d == 0.0:
                    w = 1.0
                else:
                    a = np.pi * d
                    w = np.sin(a) / a * np.sin(a / h) / (a / h)
                acc += w * spectrum[m, k]
            out[j, k] = acc


def keystone_spectrum(
    spectrum: NDArray, slow_times_s: NDArray, frequencies_hz: NDArray, carrier_hz: float
) -> NDArray[np.complex128]:
    """The data over frequency with each frequency's slow time scaled by ``f_c / f``.

    ``D_k(f, s) = D(f, s f_c / f)``, by band-limited interpolation over the pulses
    (:data:`KEYSTONE_HALF_TAPS`; zero where ``s f_c / f`` is beyond the first or last
    pulse). A target of range ``r_0 + u s`` has the phase ``exp(-4i pi f (r_0 + u s) / c)``
    over frequency ``f``: its range moves by ``u T`` over the aperture. Keystoned, its
    linear term is ``f_c u s`` at every frequency: it stays in its fast-time cell,
    whatever ``u`` (the keystone transform). The slow-time samples must hold the
    Doppler unaliased (the data referenced within the scene, as the analysis does).

    Parameters
    ----------
    spectrum : (n_pulses, n_freq) ndarray
        The data over frequency.
    slow_times_s : (n_pulses,) ndarray
        Pulse times (s), increasing.
    frequencies_hz : (n_freq,) ndarray
        Absolute frequencies of the columns (Hz).
    carrier_hz : float
        ``f_c`` (Hz).

    Returns
    -------
    (n_pulses, n_freq) ndarray
    """
    s = np.asarray(slow_times_s, dtype=np.float64)
    f = np.asarray(frequencies_hz, dtype=np.float64)
    source = s[:, None] * (float(carrier_hz) / f)[None, :]
    index = np.interp(source.ravel(), s, np.arange(s.size, dtype=np.float64), left=-1.0, right=-1.0)
    out = np.empty(np.shape(spectrum), dtype=np.complex128)
    _keystone_kernel(
        np.ascontiguousarray(spectrum, dtype=np.complex128), index.reshape(source.shape), out
    )
    return out


class _Bank:
    """The bank's transforms of one set of traces: ``|X|^2`` of a hypothesis, (rows, n_dop).

    The same values as :func:`_hypothesis_power` (to float32's rounding of ``|X|^2``,
    formed as ``re^2 + im^2`` rather than ``|X|`` squared), in the screen's layout
    and with less work per hypothesis: the data's spectrum is held in the transforms'
    own order (``ifftshift``, once), so a hypothesis needs no reordering copies of the
    whole array; only the searched fast-time rows are kept after the inverse transform;
    and the slow-time transform runs along the last axis of the rows (contiguous), its
    power written straight into the bank's map. With ``keystone`` the spectrum is first
    keystoned (:func:`keystone_spectrum`): the transforms of the wide search, whose stationary
    points cross several fast-time cells over the aperture.
    """

    def __init__(
        self, traces: Traces, rows: NDArray[np.int64], n_dop: int, *, keystone: bool = False
    ) -> None:
        m = traces.n_samples
        # to_frequency(x) = fftshift(fft(ifftshift(x))): its ifftshift is fft(ifftshift(x))
        self.spectrum = np.fft.fft(np.fft.ifftshift(np.asarray(traces.data), axes=-1), axis=-1)
        self.frequencies_hz = np.fft.ifftshift(traces.frequencies_hz)
        if keystone:
            self.spectrum = keystone_spectrum(
                self.spectrum, traces.slow_times_s, self.frequencies_hz, traces.radar.carrier_hz
            )
        # to_fast_time(y)[:, r] = ifft(ifftshift(y))[:, (r - m // 2) % m] (fftshift's roll)
        self.rows = (np.asarray(rows) - m // 2) % m
        self.phases = row_phases(traces, rows)  # (n_pulses, rows)
        self.n_pulses = traces.n_pulses
        # the slow-time transform's input, zero-padded to n_dop (pulses first, then zeros)
        self._padded = np.zeros((len(rows), n_dop), dtype=np.complex128)

    def power(self, delays_s: NDArray, *, out: NDArray[np.float32]) -> None:
        """``|X|^2`` of the hypothesis of ``delays_s`` into ``out`` (rows, n_dop)."""
        shifted = self.spectrum * delay_phase(delays_s, self.frequencies_hz)
        aligned = np.fft.ifft(shifted, axis=-1)[:, self.rows]
        aligned *= self.phases
        padded = self._padded
        padded[:, : self.n_pulses] = aligned.T
        padded[:, self.n_pulses :] = 0.0
        # scipy's pocketfft, in place: numpy's values, bit for bit, in two thirds the time
        values = sfft.fft(padded, axis=-1, overwrite_x=True)
        _power_f32(values, out)


def defocus_scan(
    traces: Traces,
    *,
    max_speed_mps: float,
    band_mps: float,
    half_span_s: float,
    false_alarm_rate: float,
    max_candidates: int = 8,
    threshold_db: float | None = None,
    within_mps: float | None = None,
    cells_tested: int | None = None,
    keystone: bool = False,
) -> DefocusScan:
    """Cells of the cross-range-speed bank that noise and stationary smears cannot explain.

    Parameters
    ----------
    traces : Traces
        The data of about a degree, stationary targets included (their smears are tested
        against, not removed).
    max_speed_mps : float
        Largest cross-range speed of the bank (m/s).
    band_mps : float
        Apparent range speeds searched: ``|u| <= band_mps`` (m/s; the stationary band
        ``g(u)`` leaves untested).
    half_span_s : float
        Fast times searched: ``|t| <= half_span_s`` (s), the scene's range span.
    false_alarm_rate : float
        ``alpha`` of the union bound, in (0, 1).
    max_candidates : int
        At most this many are returned, the most powerful first; the others are counted.
    threshold_db : float, optional
        The screen's level over the interference (dB), overriding that of
        ``false_alarm_rate`` (to measure the candidates' null below it).
    within_mps : float, optional
        Only the bank's hypotheses ``|w| <= within_mps`` (m/s): a longer aperture's search
        under a shorter one's first step (:mod:`~sarmotion.pipeline.defocused`).
    cells_tested : int, optional
        The union bound's ``N``: this bank's cells and those of the banks tested beside
        it at the same ``false_alarm_rate`` (:func:`screen_cells`); default this bank's.
    keystone : bool
        Keystone the data first (:func:`keystone_spectrum`): each stationary point stays
        in its fast-time cell over the aperture, which the screen's smear model takes
        (the wide search, over which they cross several).

    Returns
    -------
    DefocusScan
    """
    if not 0.0 < false_alarm_rate < 1.0:
        raise ValueError(f"false_alarm_rate must be in (0, 1), got {false_alarm_rate!r}")
    speeds = cross_speed_bank(traces, max_speed_mps, within_mps=within_mps)
    n_p = traces.n_pulses
    n_dop = _doppler_cells(n_p)
    prf = 1.0 / float(np.median(np.diff(traces.slow_times_s)))
    doppler = np.fft.fftfreq(n_dop, d=1.0 / prf)
    t = traces.fast_times_s
    rows = np.flatnonzero(np.abs(t) <= half_span_s)
    bank = _Bank(traces, rows, n_dop, keystone=keystone)
    u_w = np.empty(speeds.size)
    maps = np.empty((speeds.size, rows.size, n_dop), dtype=np.float32)
    smears = np.empty((speeds.size, n_dop), dtype=np.float64)
    still = hypothesis_delays_s(traces, 0.0)  # hypothesis 0: the stationary point
    for k, w in enumerate(speeds):
        delays = hypothesis_delays_s(traces, w)
        u_w[k] = _hypothesis_rate(traces, delays)
        bank.power(delays, out=maps[k])
        smears[k] = _smear(traces, delays, still, n_dop)
    # the Doppler of each cell in each hypothesis, as an apparent range speed
    speed_of = u_w[:, None] - _doppler_speeds(traces, n_dop)[None, :]
    searched = np.abs(speed_of) <= band_mps  # (n_w, n_dop)
    zero = int(np.argmin(np.abs(speeds)))
    moving = np.ones(speeds.size, bool)
    moving[zero] = False
    n_cells = screen_cells(traces, speeds, band_mps=band_mps, half_span_s=half_span_s)
    if cells_tested is not None:
        n_cells = max(n_cells, int(cells_tested))
    level = np.log(n_cells / false_alarm_rate)
    if threshold_db is not None:
        level = 10.0 ** (float(threshold_db) / 10.0)
    noise = np.empty(speeds.size)
    for k in range(speeds.size):
        sel = maps[k][:, searched[k]]
        noise[k] = float(np.median(sel)) / np.log(2.0) if sel.size else np.inf
    stationary = np.sqrt(maps[zero])  # |X_0|, (rows, n_dop)
    # a stationary point of the band migrates by up to band * T in range over the
    # aperture: its smear is sought over the rows it crosses, and one more either side
    reach = _smear_reach(traces, band_mps)
    found: list[DefocusCandidate] = []
    # a focused point's main lobe, null to null, in Doppler cells (either side)
    guard = 2 * int(np.ceil(n_dop / n_p))
    # the searched Doppler columns and one either side, in increasing Doppler (contiguous)
    order = np.argsort(doppler, kind="stable")
    wanted = np.convolve(searched.any(axis=0)[order], np.ones(3), mode="same") > 0
    cols = order[wanted]
    for k in np.flatnonzero(moving):
        if not np.isfinite(noise[k]) or noise[k] <= 0:
            continue
        mk = maps[k][:, cols]
        # the interference of a cell: the noise, or the mean power of its range bin over
        # the Doppler cells beyond its guard if larger (cell-averaging, module notes)
        mean = np.empty((rows.size, cols.size))
        _guarded_mean_f32(maps[k], cols, guard, mean)
        floor = np.maximum(noise[k], mean)
        over = np.nonzero((mk >= level * floor) & searched[k][cols][None, :])
        peak = _local_peaks(maps, cols, int(k), over[0], over[1])
        for r, j in zip(over[0][peak], over[1][peak], strict=True):
            f = int(cols[j])
            amp = float(np.sqrt(maps[k, r, f]))
            lo, hi = max(0, r - reach), min(rows.size, r + reach + 1)
            shifts = (f - np.arange(n_dop)) % n_dop
            leak = float(np.max(stationary[lo:hi] * smears[k][shifts][None, :]))
            if amp <= leak * 10.0 ** (SMEAR_MARGIN_DB / 20.0):
                continue
            found.append(
                DefocusCandidate(
                    range_speed_mps=float(speed_of[k, f]),
                    cross_range_speed_mps=float(speeds[k]),
                    delay_s=float(t[rows[r]]),
                    statistic_db=float(10.0 * np.log10(maps[k, r, f] / floor[r, j])),
                    leak_db=float(20.0 * np.log10(amp / max(leak, 1e-300))),
                    power=float(maps[k, r, f]),
                )
            )
    found.sort(key=lambda c: -c.statistic_db)
    return DefocusScan(
        candidates=tuple(found[:max_candidates]),
        n_beyond=max(0, len(found) - max_candidates),
        threshold_db=float(10.0 * np.log10(level)),
        n_cells=n_cells,
        speeds_mps=speeds,
    )


def _smear(traces: Traces, delays_s: NDArray, still_s: NDArray, n_dop: int) -> NDArray:
    """``|H_w|``, shape ``(n_dop,)``: a stationary point's smear in the hypothesis of ``delays_s``.

    The transform over slow time of its phase relative to hypothesis 0 (``still_s``),
    over the pulses: 1 at its peak when the two hypotheses are the same.
    """
    smear = np.exp(2j * np.pi * traces.radar.carrier_hz * (delays_s - still_s))
    return np.abs(np.fft.fft(smear, n=n_dop)) / traces.n_pulses


def _smear_reach(traces: Traces, band_mps: float) -> int:
    """Range rows a stationary point of the band crosses during the aperture, plus one."""
    dt = float(np.median(np.diff(traces.fast_times_s)))
    return 1 + int(np.ceil(2.0 * band_mps * float(np.ptp(traces.slow_times_s)) / C / dt))


def _echo_extent(
    traces: Traces, candidate: DefocusCandidate
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64], int]:
    """``(rows, cols, delays_s, n_dop)``: the cells of ``candidate``'s echo in its hypothesis.

    The bank's cells of hypothesis ``w = candidate.cross_range_speed_mps``
    (:func:`defocus_scan`, same Doppler oversampling) within two range cells of its delay
    (fast-time rows) and two range-speed resolutions of its range speed (Doppler
    columns): the extent of one echo (the mover stage's grouping,
    :func:`~sarmotion.pipeline.defocused.distinct_echoes`). Either may be empty.
    """
    rows = np.flatnonzero(
        np.abs(traces.fast_times_s - candidate.delay_s) <= 2.0 / traces.radar.bandwidth_hz
    )
    n_dop = _doppler_cells(traces.n_pulses)
    delays = hypothesis_delays_s(traces, candidate.cross_range_speed_mps)
    speed = _hypothesis_rate(traces, delays) - _doppler_speeds(traces, n_dop)
    res = range_speed_resolution(traces)
    cols = np.flatnonzero(np.abs(speed - candidate.range_speed_mps) <= 2.0 * res)
    return rows, cols, delays, n_dop


def _echo_values(traces: Traces, extent: tuple, spectrum: NDArray) -> NDArray:
    """``X`` over an echo's extent (:func:`_echo_extent`'s tuple), ``(cols, rows)``.

    ``spectrum``: the data over frequency (:func:`~sarmotion.core.to_frequency`).
    """
    rows, cols, delays, n_dop = extent
    if rows.size == 0 or cols.size == 0:
        return np.zeros((cols.size, rows.size), dtype=np.complex128)
    return _hypothesis_values(traces, spectrum, delays, rows, n_dop)[1][cols]


def _smear_bound(
    traces: Traces,
    extent: tuple,
    spectrum: NDArray,
    band_mps: float,
    cells: tuple[NDArray[np.int64], NDArray[np.int64]],
) -> NDArray[np.float64]:
    """Largest stationary smear at some cells of an echo, shape ``(k,)``.

    ``extent``: the echo's (:func:`_echo_extent`); ``cells``: (column, row) indices into
    its ``(cols, rows)``. As the screen's (:func:`defocus_scan`): ``max |X_0(t', f')|
    |H_w(f - f')|`` over the Doppler cells ``f'`` of the stationary image ``X_0`` of the
    data (``spectrum``, over frequency) and over the range rows a stationary point of the
    band ``|u| <= band_mps`` crosses, and one more either side.
    """
    rows, cols, delays, n_dop = extent
    ci, ri = (np.asarray(a, dtype=np.int64) for a in cells)
    if ci.size == 0:
        return np.zeros(0)
    reach = _smear_reach(traces, band_mps)
    lo, hi = (
        max(0, int(rows[ri].min()) - reach),
        min(traces.n_samples, int(rows[ri].max()) + reach + 1),
    )
    near = np.arange(lo, hi)
    still = hypothesis_delays_s(traces, 0.0)
    a0 = np.abs(_hypothesis_values(traces, spectrum, still, near, n_dop)[1])
    smear = _smear(traces, delays, still, n_dop)
    out = np.empty(ci.size)
    for k in range(ci.size):
        h = smear[(cols[ci[k]] - np.arange(n_dop)) % n_dop]  # (n_dop,)
        js = np.abs(near - rows[ri[k]]) <= reach
        out[k] = float(np.max(h[:, None] * a0[:, js]))
    return out


def echo_peak_power(
    traces: Traces, candidate: DefocusCandidate, data: NDArray | None = None
) -> float:
    """Largest ``|X|^2`` of ``candidate``'s echo in its own hypothesis (data units squared).

    Over the extent of one echo (:func:`_echo_values`). ``data`` (``traces``' shape)
    replaces ``traces.data`` when given.
    """
    d = traces.data if data is None else data
    values = _echo_values(traces, _echo_extent(traces, candidate), to_frequency(d))
    return float(np.max(np.abs(values) ** 2)) if values.size else 0.0


def echo_residue(
    traces: Traces, candidate: DefocusCandidate, model: NDArray, band_mps: float
) -> float:
    """What ``model`` leaves of ``candidate``'s echo: peak power after over before (ratio).

    After: the largest ``|X(D - M)|^2`` over the cells of the echo's extent
    (:func:`_echo_extent`: two range cells, two range-speed resolutions) that are the
    model's own echo (its main lobe, where the model's power is at least ``ECHO_LOBE``
    of its largest: half amplitude) or that no stationary point's smear explains
    (``|X(D - M)|`` over the largest smear there by the screen's ``SMEAR_MARGIN_DB``, the
    smears of the stationary image of ``D`` over the band ``|u| <= band_mps``, m/s, as
    :func:`defocus_scan` takes them). Before: the largest ``|X(D)|^2`` of the main lobe.
    The extent groups one target's cells over the bank's hypotheses; within one
    hypothesis it also spans the echoes of stationary points a few cross-range cells away
    (a range-speed resolution is the range migration's, many Doppler cells), nearly
    focused in a hypothesis near ``w = 0``: not the model's to remove, and explained by
    their smears. ``X(D - M) = X(D) - X(M)``. ``model`` has ``traces``' shape; a model
    with no power in the extent gives ``inf`` (it describes no echo of the candidate).
    """
    extent = _echo_extent(traces, candidate)
    spectrum = to_frequency(traces.data)
    x_d = _echo_values(traces, extent, spectrum)
    x_m = _echo_values(traces, extent, to_frequency(model))
    p_m = np.abs(x_m) ** 2
    if p_m.size == 0 or not p_m.max() > 0.0:
        return float("inf")
    lobe = p_m >= ECHO_LOBE * p_m.max()
    left = np.abs(x_d - x_m)
    before = float(np.max(np.abs(x_d[lobe]) ** 2))
    after = float(np.max(left[lobe]))
    # only the cells brighter than the lobe's residue can raise it: their smears decide
    ci, ri = np.nonzero(~lobe & (left > after))
    if ci.size:
        margin = 10.0 ** (SMEAR_MARGIN_DB / 20.0)
        bound = _smear_bound(traces, extent, spectrum, band_mps, (ci, ri))
        unexplained = left[ci, ri] > margin * bound
        if unexplained.any():
            after = max(after, float(np.max(left[ci, ri][unexplained])))
    return after**2 / before if before > 0.0 else float("inf")
