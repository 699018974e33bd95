"""Emitted waveform, pulse compression and range compression (paper ``sect:compress``).

The antenna emits ``f(t) = cos(omega_o t) f_B(t)`` (``eq:signal``) with a linear
frequency-modulated chirp ``f_B``. Pulse compression correlates the echoes with the
emitted signal (a matched filter, computed by FFT), giving echoes of the compressed pulse
``f_p`` of duration ``~1/B``. Range compression (``eq:rangecompress``) shifts the fast
time by the travel time to a reference point. Everything here is complex baseband; the
paper's real passband pulse ``cos(omega_o t) exp(-B^2 t^2 / 2)`` (``eq:compPulse``) is
:func:`passband_gaussian_pulse`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import shift_fast_time

__all__ = [
    "lfm_chirp",
    "matched_filter",
    "passband_gaussian_pulse",
    "baseband_gaussian_pulse",
    "range_compress",
]


def lfm_chirp(t_s: ArrayLike, *, bandwidth_hz: float, duration_s: float) -> NDArray[np.complex128]:
    """Baseband linear-FM chirp ``exp(i pi (B/T) t^2)`` on ``|t| <= T/2``, zero outside.

    Parameters
    ----------
    t_s : (n,) array_like
        Times (s), centred on the chirp.
    bandwidth_hz : float
        Swept bandwidth ``B`` (Hz).
    duration_s : float
        Chirp length ``T`` (s); the time-bandwidth product ``B T`` should be >> 1.

    Returns
    -------
    (n,) ndarray
        Complex baseband chirp.
    """
    if not (bandwidth_hz > 0 and duration_s > 0):
        raise ValueError(
            f"bandwidth_hz and duration_s must be positive, got {bandwidth_hz!r}, {duration_s!r}"
        )
    t = np.asarray(t_s, dtype=np.float64)
    rate = bandwidth_hz / duration_s
    return np.where(np.abs(t) <= 0.5 * duration_s, np.exp(1j * np.pi * rate * t * t), 0.0)


def matched_filter(
    echoes: ArrayLike, reference: ArrayLike, *, axis: int = -1
) -> NDArray[np.complex128]:
    """Pulse compression: correlate ``echoes`` with ``reference`` by FFT.

    Computes ``D_p(t) = sum_t' D(t') conj(f(t' - t))`` (the paper's matched filter) for
    every lag, with zero padding so that the correlation is linear, not circular.

    Parameters
    ----------
    echoes : (..., n) array_like
        Received signals sampled on a uniform grid.
    reference : (m,) array_like
        Emitted waveform on the same sampling interval, sample 0 at its start.
    axis : int
        Fast-time axis of ``echoes``.

    Returns
    -------
    (..., n) ndarray
        Compressed echoes; output sample ``k`` is lag ``k`` (an echo delayed by ``k``
        samples relative to the reference start peaks at ``k``).
    """
    d = np.moveaxis(np.asarray(echoes, dtype=np.complex128), axis, -1)
    ref = np.asarray(reference, dtype=np.complex128)
    if ref.ndim != 1:
        raise ValueError(f"reference must be 1-D, got shape {ref.shape}")
    n = d.shape[-1]
    nfft = int(2 ** np.ceil(np.log2(n + ref.size)))
    spec = np.fft.fft(d, nfft, axis=-1) * np.conj(np.fft.fft(ref, nfft))
    out = np.fft.ifft(spec, axis=-1)[..., :n]
    return np.moveaxis(out, -1, axis)


def passband_gaussian_pulse(
    t_s: ArrayLike, *, carrier_hz: float, bandwidth_hz: float
) -> NDArray[np.float64]:
    """The paper's real compressed pulse ``cos(omega_o t) exp(-B^2 t^2 / 2)`` (``eq:compPulse``).

    Parameters
    ----------
    t_s : array_like
        Times (s).
    carrier_hz : float
        ``nu_o = omega_o / (2 pi)`` (Hz).
    bandwidth_hz : float
        ``B`` (Hz) as written in the paper's formula.
    """
    t = np.asarray(t_s, dtype=np.float64)
    return np.cos(2 * np.pi * carrier_hz * t) * np.exp(-(bandwidth_hz**2) * t * t / 2.0)


def baseband_gaussian_pulse(t_s: ArrayLike, *, bandwidth_hz: float) -> NDArray[np.float64]:
    """Complex-baseband envelope ``exp(-B^2 t^2 / 2)`` of :func:`passband_gaussian_pulse`."""
    t = np.asarray(t_s, dtype=np.float64)
    return np.exp(-(bandwidth_hz**2) * t * t / 2.0)


def range_compress(
    pulse_compressed: ArrayLike,
    reference_delays_s: ArrayLike,
    *,
    frequencies_hz: ArrayLike,
) -> NDArray[np.complex128]:
    """Range compression ``D_r(s, t) = D_p(s, t + tau(s, rho_o))`` (``eq:rangecompress``).

    Parameters
    ----------
    pulse_compressed : (n_pulses, n_samples) array_like
        Pulse-compressed baseband echoes on a fast-time axis whose ``t = 0`` is the same
        for every pulse.
    reference_delays_s : (n_pulses,) array_like
        ``tau(s, rho_o)`` minus that common origin (s).
    frequencies_hz : (n_samples,) array_like
        Absolute frequencies of the spectrum bins (Hz).

    Returns
    -------
    (n_pulses, n_samples) ndarray
        Range-compressed traces (circular shift over the fast-time window).
    """
    return shift_fast_time(pulse_compressed, reference_delays_s, frequencies_hz=frequencies_hz)
