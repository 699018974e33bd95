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

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["to_frequency", "to_fast_time", "delay_phase", "shift_fast_time"]


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
    cycles = np.multiply.outer(
        np.asarray(delays_s, dtype=np.float64), np.asarray(frequencies_hz, dtype=np.float64)
    )
    cycles -= np.round(cycles)
    return np.exp(2j * np.pi * cycles)


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
