"""Fast-time <-> frequency transforms and exact fast-time shifts of baseband traces.

Convention (shared by simulation, real data and every operator): a trace sample
``D(s, t)`` is complex baseband, and its spectrum on the absolute frequencies
``f_k = nu_o + nu_k`` is the deramped phase history ``P(s, f_k)``. A point at
differential delay ``dtau`` contributes ``P = exp(-2i pi f_k dtau)``, i.e.
``D(t) = p(t - dtau) exp(-i omega_o dtau)`` with a real pulse ``p`` peaking at 1.

A shift of the *passband* signal by ``delta`` (``D(s, t) -> D(s, t + delta(s))``, the
paper's ``eq:FFT``) is, on baseband data, the product of the phase history with
``exp(+2i pi f_k delta)``: the carrier phase is carried exactly, so opposite shifts
cancel to machine precision.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "to_frequency",
    "to_fast_time",
    "delay_phase",
    "phased_row_sums",
    "FrequencyPlanes",
    "shift_fast_time",
]


def to_frequency(traces: ArrayLike, *, axis: int = -1) -> NDArray[np.complexfloating]:
    """Spectrum (phase history) of fast-time traces, bins in increasing frequency.

    Parameters
    ----------
    traces : (..., n_samples) array_like
        Traces with ``t = 0`` at index ``n_samples // 2``.
    axis : int
        Fast-time axis.

    Returns
    -------
    ndarray
        Same shape; bin ``k`` is frequency ``nu_o + (k - n // 2) df``.
    """
    x = np.asarray(traces)
    return np.fft.fftshift(np.fft.fft(np.fft.ifftshift(x, axes=axis), axis=axis), axes=axis)


def to_fast_time(spectrum: ArrayLike, *, axis: int = -1) -> NDArray[np.complexfloating]:
    """Inverse of :func:`to_frequency`: fast-time traces from a phase history.

    A unit point reflector (``P = exp(-2i pi f dtau)`` on a flat spectrum) gives a pulse
    of peak modulus 1 at ``t = dtau``.
    """
    x = np.asarray(spectrum)
    return np.fft.fftshift(np.fft.ifft(np.fft.ifftshift(x, axes=axis), axis=axis), axes=axis)


def delay_phase(delays_s: ArrayLike, frequencies_hz: ArrayLike) -> NDArray[np.complex128]:
    """``exp(2i pi f_k delta_j)`` for every pulse ``j`` and frequency ``k``.

    The phase reaches ~1e4 cycles (``f ~ 1e10`` Hz, ``delta ~ 1e-6`` s): it is formed in
    float64 and reduced to whole cycles exactly before the exponential.

    Parameters
    ----------
    delays_s : (n_pulses,) array_like
        Delays ``delta(s)`` (s).
    frequencies_hz : (n_freq,) array_like
        Absolute frequencies (Hz).

    Returns
    -------
    (n_pulses, n_freq) ndarray
        Unit phasors; multiplying a phase history by them shifts its traces by
        ``+delta`` (``D(s, t) -> D(s, t + delta(s))``), carrier included.
    """
    d = np.ascontiguousarray(delays_s, dtype=np.float64)
    f = np.ascontiguousarray(frequencies_hz, dtype=np.float64)
    out = np.empty((d.size, f.size), dtype=np.complex128)
    _delay_phase(d.reshape(-1), f.reshape(-1), out.view(np.float64))
    return out.reshape(np.shape(delays_s) + np.shape(frequencies_hz))


# exp(2i pi c) for c = delta f (float64): c is reduced exactly to quarter cycles,
# t = 4 c - k, k = rint(4 c), |t| <= 1/2, and exp(2i pi c) = i^k exp(i pi t / 2) with
# minimax polynomials for cos and sin of pi t / 2 (error < 1e-14, exact at t = 0; np.exp
# of the reduced phase agrees to 1e-14). Compiled and vectorised, it avoids numpy's complex
# exp, which made delay_phase the largest single cost of analyze (tests/core/test_spectral_fast.py
# checks the values; the profile is in docs/notes/motion.md).
_S = (1.57079632679489, -0.6459640975043288, 0.07969262615641214, -0.0046817525994714984,
      0.00016042930460199835, -3.5564543255214174e-06)  # fmt: skip
_C = (1.0, -1.2337005501361604, 0.2536695079002106, -0.02086348074043811,
      0.0009192599906072516, -2.5200275027694737e-05, 4.657112551982875e-07)  # fmt: skip


@numba.njit(cache=True, fastmath={"nsz", "arcp", "contract", "afn"}, inline="always")
def quarter_turns(t: float) -> tuple[float, float]:
    """``(cos, sin)`` of ``pi t / 2`` (compiled code, float64, error < 1e-14).

    ``t`` is folded exactly to ``x = t - k``, ``k = rint(t)``, ``|x| <= 1/2`` (Sterbenz),
    then ``exp(i pi t / 2) = i^k exp(i pi x / 2)`` from the polynomials above; exact at
    ``t = 0``. The one shared phase routine of the compiled kernels (backprojection, FFBP,
    the frequency sums).
    """
    k = np.rint(t)
    x = t - k
    z = x * x
    s = x * (_S[0] + z * (_S[1] + z * (_S[2] + z * (_S[3] + z * (_S[4] + z * _S[5])))))
    co = _C[0] + z * (_C[1] + z * (_C[2] + z * (_C[3] + z * (_C[4] + z * (_C[5] + z * _C[6])))))
    q = np.int64(k)
    swap = (q & 1) != 0
    cs = s if swap else co
    sn = co if swap else s
    cs = -cs if ((q + 1) & 2) != 0 else cs
    sn = -sn if (q & 2) != 0 else sn
    return cs, sn


@numba.njit(nogil=True, cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def unit_phasor(c: float) -> complex:
    """``exp(2i pi c)`` with ``c`` reduced exactly (compiled code; error < 1e-14)."""
    cs, sn = quarter_turns(4.0 * c)
    return complex(cs, sn)


@numba.njit(nogil=True, cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def _delay_phase(delays, freqs, out):  # pragma: no cover - compiled
    """``out[j, k] = exp(2i pi delays[j] freqs[k])``; ``out`` is the float64 (re, im) view."""
    for j in range(delays.size):
        dj = delays[j]
        for k in range(freqs.size):
            c = dj * freqs[k]
            cs, sn = quarter_turns(4.0 * (c - math.floor(c)))
            out[j, 2 * k] = cs
            out[j, 2 * k + 1] = sn


@numba.njit(nogil=True, cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def phased_row_sums(values, delays, f_first, f_step):  # pragma: no cover - compiled
    """``sum_k values[j, k] exp(2i pi delays[j] (f_first + k f_step))`` for every row ``j``.

    The phasors of a row advance by a fixed rotation ``exp(2i pi delays[j] f_step)``; the
    product is re-seeded exactly (:func:`unit_phasor`) every 32 terms, which keeps the
    rounding below ~1e-14 of the row's sum of moduli. Four interleaved phasors and
    partial sums (terms ``k = 4i + q``) break the dependency chain of the rotation: 1.6x
    faster than one phasor on 117 x 424 rows, the same sums to ~1e-16 of their moduli.
    Compiled code and callers.
    """
    n_rows, n = values.shape
    out = np.empty(n_rows, dtype=np.complex128)
    for j in range(n_rows):
        dj = delays[j]
        step = dj * f_step
        r1 = unit_phasor(step - math.floor(step))
        r2 = r1 * r1
        r4 = r2 * r2
        a0 = 0j
        a1 = 0j
        a2 = 0j
        a3 = 0j
        for k0 in range(0, n, 32):
            c = dj * (f_first + f_step * k0)
            w0 = unit_phasor(c - math.floor(c))
            w1 = w0 * r1
            w2 = w0 * r2
            w3 = w1 * r2
            k1 = min(k0 + 32, n)
            k = k0
            while k + 4 <= k1:
                a0 += values[j, k] * w0
                a1 += values[j, k + 1] * w1
                a2 += values[j, k + 2] * w2
                a3 += values[j, k + 3] * w3
                w0 *= r4
                w1 *= r4
                w2 *= r4
                w3 *= r4
                k += 4
            while k < k1:
                a0 += values[j, k] * w0
                w0 *= r1
                k += 1
        out[j] = (a0 + a1) + (a2 + a3)
    return out


class FrequencyPlanes:
    """Rows of a phase history stored frequency-major, for many :func:`phased_row_sums`.

    ``re[k, j]``, ``im[k, j]`` are the real and imaginary parts of ``values[j, k]``
    (float64, C order): the compiled sums then run over the rows in SIMD lanes, 3x
    faster than :func:`phased_row_sums` on 117-469 x 424 GOTCHA phase histories, with
    the same sums to ~1e-16 of the rows' sums of moduli. Worth it when the same rows are
    summed at many delays (a location or focus search); building it is one pass over
    the values.

    Parameters
    ----------
    values : (n_rows, n_freq) array_like
        Complex rows (e.g. ``traces.phase_history()``).
    """

    def __init__(self, values: ArrayLike) -> None:
        v = np.asarray(values)
        if v.ndim != 2:
            raise ValueError(f"values must have shape (n_rows, n_freq), got {v.shape}")
        self.shape = v.shape
        self.re = np.ascontiguousarray(v.real.T, dtype=np.float64)
        self.im = np.ascontiguousarray(v.imag.T, dtype=np.float64)

    def sums(
        self, delays: ArrayLike, f_first: float, f_step: float, rows: slice = slice(None)
    ) -> NDArray[np.complex128]:
        """:func:`phased_row_sums` of the rows ``rows`` at their ``delays`` (s)."""
        start, stop, step = rows.indices(self.shape[0])
        if step != 1:
            raise ValueError(f"rows must be a contiguous slice, got {rows!r}")
        d = np.ascontiguousarray(delays, dtype=np.float64)
        if d.shape != (stop - start,):
            raise ValueError(f"delays must have shape ({stop - start},), got {d.shape}")
        return _plane_sums(
            self.re[:, start:stop], self.im[:, start:stop], d, float(f_first), float(f_step)
        )

    def sums_and_derivatives(
        self, delays: ArrayLike, f_first: float, f_step: float, rows: slice = slice(None)
    ) -> tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.complex128]]:
        """Row sums ``A_j(d_j)`` and their first two derivatives in the delay.

        ``A_j(d) = sum_k values[j, k] exp(2i pi f_k d)``; returns ``A_j``,
        ``dA_j/dd = sum_k (2i pi f_k) values[j, k] exp(...)`` (per s) and
        ``d2A_j/dd2 = -sum_k (2 pi f_k)^2 values[j, k] exp(...)`` (per s^2), each of
        shape (n_rows,), in one pass over the planes (the phasors as in :meth:`sums`);
        only the rows ``rows`` (a contiguous slice) when given.
        """
        start, stop, step = rows.indices(self.shape[0])
        if step != 1:
            raise ValueError(f"rows must be a contiguous slice, got {rows!r}")
        d = np.ascontiguousarray(delays, dtype=np.float64)
        if d.shape != (stop - start,):
            raise ValueError(f"delays must have shape ({stop - start},), got {d.shape}")
        out = np.empty((3, stop - start), dtype=np.complex128)
        re, im = self.re[:, start:stop], self.im[:, start:stop]
        _plane_sums_derivatives(re, im, d, float(f_first), float(f_step), out)
        return out[0], out[1], out[2]


@numba.njit(cache=True, inline="always")
def _unit_phasors(delays, frequency, out_re, out_im):  # pragma: no cover - compiled
    """``exp(2i pi frequency delays[j])`` per row, cycles reduced exactly (:func:`unit_phasor`)."""
    for j in range(delays.size):
        c = delays[j] * frequency
        w = unit_phasor(c - math.floor(c))
        out_re[j] = w.real
        out_im[j] = w.imag


@numba.njit(nogil=True, cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def _plane_sums_derivatives(re, im, delays, f_first, f_step, out):  # pragma: no cover
    """:func:`_plane_sums` with the ``f``- and ``f^2``-weighted sums (derivatives in delay).

    The weights are taken about the band centre ``f_c``: with ``f = f_c + e``,
    ``sum f^m x = sum (f_c + e)^m x``, expanded so that every accumulator stays of the
    order of the plain sum.
    """
    n_freq, n_rows = re.shape
    f_c = f_first + 0.5 * f_step * (n_freq - 1)
    acc = np.zeros((6, n_rows))
    w_r = np.empty(n_rows)
    w_i = np.empty(n_rows)
    r_r = np.empty(n_rows)
    r_i = np.empty(n_rows)
    _unit_phasors(delays, f_step, r_r, r_i)
    for k0 in range(0, n_freq, 32):
        _unit_phasors(delays, f_first + f_step * k0, w_r, w_i)
        for k in range(k0, min(k0 + 32, n_freq)):
            e1 = f_first + f_step * k - f_c
            e2 = e1 * e1
            for j in range(n_rows):
                a = re[k, j]
                b = im[k, j]
                x = w_r[j]
                y = w_i[j]
                tr = a * x - b * y
                ti = a * y + b * x
                acc[0, j] += tr
                acc[1, j] += ti
                acc[2, j] += e1 * tr
                acc[3, j] += e1 * ti
                acc[4, j] += e2 * tr
                acc[5, j] += e2 * ti
                w_r[j] = x * r_r[j] - y * r_i[j]
                w_i[j] = x * r_i[j] + y * r_r[j]
    two_pi = 2.0 * math.pi
    for j in range(n_rows):
        s0 = complex(acc[0, j], acc[1, j])
        s1 = complex(acc[2, j], acc[3, j])
        s2 = complex(acc[4, j], acc[5, j])
        out[0, j] = s0
        out[1, j] = 1j * two_pi * (f_c * s0 + s1)
        out[2, j] = -(two_pi**2) * (f_c * f_c * s0 + 2.0 * f_c * s1 + s2)


@numba.njit(nogil=True, cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def _plane_sums(re, im, delays, f_first, f_step):  # pragma: no cover - compiled
    """:func:`phased_row_sums` of frequency-major planes, the rows in the inner loop.

    Each row's phasor is re-seeded exactly (:func:`unit_phasor`) every 32 frequencies
    and advanced by its fixed rotation in between, as in :func:`phased_row_sums`.
    """
    n_freq, n_rows = re.shape
    acc_r = np.zeros(n_rows)
    acc_i = np.zeros(n_rows)
    w_r = np.empty(n_rows)
    w_i = np.empty(n_rows)
    r_r = np.empty(n_rows)
    r_i = np.empty(n_rows)
    _unit_phasors(delays, f_step, r_r, r_i)
    for k0 in range(0, n_freq, 32):
        _unit_phasors(delays, f_first + f_step * k0, w_r, w_i)
        for k in range(k0, min(k0 + 32, n_freq)):
            for j in range(n_rows):
                a = re[k, j]
                b = im[k, j]
                x = w_r[j]
                y = w_i[j]
                acc_r[j] += a * x - b * y
                acc_i[j] += a * y + b * x
                w_r[j] = x * r_r[j] - y * r_i[j]
                w_i[j] = x * r_i[j] + y * r_r[j]
    out = np.empty(n_rows, dtype=np.complex128)
    for j in range(n_rows):
        out[j] = complex(acc_r[j], acc_i[j])
    return out


def shift_fast_time(
    traces: ArrayLike,
    delays_s: ArrayLike,
    *,
    frequencies_hz: ArrayLike,
) -> NDArray[np.complex128]:
    """Return ``D(s, t + delta(s))`` for baseband traces, carrier phase included.

    Implemented as the phase modulation ``P(s, f) exp(2i pi f delta(s))`` of the phase
    history (``eq:FFT``); the shift is circular over the fast-time window.

    Parameters
    ----------
    traces : (n_pulses, n_samples) array_like
        Complex baseband traces.
    delays_s : (n_pulses,) array_like
        Shift ``delta(s)`` per pulse (s).
    frequencies_hz : (n_samples,) array_like
        Absolute frequencies of the spectrum bins (Hz), from ``Radar.frequencies_hz``.

    Returns
    -------
    (n_pulses, n_samples) ndarray
        Shifted traces, complex128.
    """
    d = np.asarray(traces)
    delta = np.asarray(delays_s, dtype=np.float64)
    f = np.asarray(frequencies_hz, dtype=np.float64)
    if d.ndim != 2:
        raise ValueError(f"traces must have shape (n_pulses, n_samples), got {d.shape}")
    if delta.shape != (d.shape[0],):
        raise ValueError(f"delays_s must have shape ({d.shape[0]},), got {delta.shape}")
    if f.shape != (d.shape[1],):
        raise ValueError(f"frequencies_hz must have shape ({d.shape[1]},), got {f.shape}")
    return to_fast_time(to_frequency(d) * delay_phase(delta, f))
