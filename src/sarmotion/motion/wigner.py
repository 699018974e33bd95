"""The Wigner transform of a signal in slow time and its ridge: instantaneous Doppler per pulse."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["WignerRidge", "wigner_slow_time", "wigner_ridge"]


def _as_channels(signal: ArrayLike) -> NDArray[np.complex128]:
    x = np.asarray(signal)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2 or x.shape[0] < 3:
        raise ValueError(
            f"signal must have shape (n,) or (n, n_channels) with n >= 3, got {np.shape(signal)}"
        )
    if not np.all(np.isfinite(x)):
        raise ValueError("signal contains NaN or infinite values")
    return x.astype(np.complex128, copy=False)


def _check_lag_window(lag_window_pulses: int | None, n: int) -> int:
    if lag_window_pulses is None:
        return n if n % 2 else n - 1
    lw = int(lag_window_pulses)
    if lw != lag_window_pulses or lw < 3 or lw % 2 == 0:
        raise ValueError(
            f"lag_window_pulses must be an odd integer >= 3, got {lag_window_pulses!r}"
        )
    return lw


def _lag_taps(window: str, length: int) -> NDArray[np.float64]:
    """Symmetric lag window of ``length`` taps, all positive (ends of Hann etc. dropped)."""
    if window == "boxcar":
        return np.ones(length)
    from scipy.signal import get_window  # scipy.signal takes ~0.5 s to import: when needed

    try:
        return np.asarray(get_window(window, length + 2, fftbins=False), dtype=np.float64)[1:-1]
    except ValueError as exc:
        raise ValueError(f"window must be a scipy.signal window name, got {window!r}") from exc


def _lag_products(
    x: NDArray[np.complex128], lag_window_pulses: int, window: str
) -> tuple[NDArray[np.complex128], NDArray[np.int64]]:
    """``h_k sum_c x[n + k, c] conj(x[n - k, c])``, shape (n, L), and the lags ``k``."""
    n = x.shape[0]
    half = (lag_window_pulses - 1) // 2
    lags = np.arange(-half, half + 1)
    taps = _lag_taps(window, lag_window_pulses)
    plus = np.arange(n)[:, None] + lags[None, :]
    minus = np.arange(n)[:, None] - lags[None, :]
    valid = (plus >= 0) & (plus < n) & (minus >= 0) & (minus < n)
    prod = np.einsum(
        "nkc,nkc->nk", x[np.clip(plus, 0, n - 1)], np.conj(x[np.clip(minus, 0, n - 1)])
    )
    return np.where(valid, prod * taps[None, :], 0.0), lags


def wigner_slow_time(
    signal: ArrayLike,
    *,
    pulse_interval_s: float,
    lag_window_pulses: int | None = None,
    n_freq: int | None = None,
    window: str = "hann",
    centre_hz: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Discrete pseudo-Wigner(-Ville) transform of a slow-time signal.

    ``W[n, f] = sum_k h_k x[n + k] conj(x[n - k]) exp(-4 i pi (f - f_c) k ds)`` with
    ``f_c = centre_hz``: the sampled ``int x(s + y/2) conj(x(s - y/2)) exp(-2 i pi f y)
    dy`` with lags ``y = 2 k ds``, truncated to the data near the ends and evaluated on
    the band ``|f - f_c| < 1 / (4 ds)`` (aliased modulo ``1 / (2 ds)``). A signal
    ``exp(2 i pi F(s))`` has its ridge at the instantaneous frequency ``F'(s)``.

    Parameters
    ----------
    signal : (n,) or (n, n_channels) array_like
        Complex slow-time signal, one sample per pulse. Several channels (e.g. fast-time
        samples) have their transforms summed.
    pulse_interval_s : float
        Slow-time sampling interval ``ds`` (s).
    lag_window_pulses : int, optional
        Length ``L`` (odd, pulses) of the lag window ``h``; lags ``|k| <= (L - 1) / 2``.
        Default: the whole signal (``n`` or ``n - 1``).
    n_freq : int, optional
        Number of Doppler bins (FFT length, ``>= L``). Default: the power of two
        ``>= 2 L``, at least 256.
    window : str
        Lag window name for :func:`scipy.signal.get_window` (``"hann"``, ``"boxcar"``,
        ...); the zero end taps of Hann-type windows are dropped.
    centre_hz : float
        Centre ``f_c`` of the Doppler axis (Hz).

    Returns
    -------
    W : (n, n_freq) ndarray
        The (real) transform, in signal units squared.
    doppler_hz : (n_freq,) ndarray
        Doppler axis (Hz), increasing, ``f_c + m / (2 n_freq ds)`` for
        ``m = -n_freq/2 .. n_freq/2 - 1``: it spans ``|f - f_c| < 1 / (4 ds)``, half the
        pulse repetition frequency, so only signals whose frequency stays within
        ``1 / (4 ds)`` of ``f_c`` are represented without aliasing.
    """
    x = _as_channels(signal)
    if not (np.isfinite(pulse_interval_s) and pulse_interval_s > 0):
        raise ValueError(f"pulse_interval_s must be positive (s), got {pulse_interval_s!r}")
    n = x.shape[0]
    lw = _check_lag_window(lag_window_pulses, n)
    nf = max(256, int(2 ** np.ceil(np.log2(2 * lw)))) if n_freq is None else int(n_freq)
    if nf < lw:
        raise ValueError(f"n_freq must be >= lag_window_pulses ({lw}), got {n_freq!r}")
    ds = float(pulse_interval_s)
    if centre_hz != 0.0:
        x = x * np.exp(-2j * np.pi * centre_hz * ds * np.arange(n))[:, None]
    r, lags = _lag_products(x, lw, window)
    buf = np.zeros((n, nf), dtype=np.complex128)
    buf[:, lags % nf] = r
    w = np.fft.fftshift(np.fft.fft(buf, axis=1).real, axes=1)
    f = np.fft.fftshift(np.fft.fftfreq(nf, d=2.0 * ds)) + centre_hz
    return w, f


@dataclass(frozen=True, kw_only=True, eq=False)
class WignerRidge:
    """Ridge of a pseudo-Wigner transform, one value per slow-time sample.

    Attributes
    ----------
    doppler_hz : (n,) ndarray
        Instantaneous Doppler ``f_D(s)`` (Hz): the maximiser of ``W[n, f]`` in ``f``.
    peak : (n,) ndarray
        ``W`` at the ridge (signal units squared).
    curvature : (n,) ndarray
        ``-d^2 W / d f^2`` at the ridge (signal units squared per Hz^2); large where the
        ridge is sharp and well determined, zero where no lag is available (the ends).
    centre_hz : float
        Centre of the unambiguous Doppler band ``|f - centre_hz| < 1 / (4 ds)`` (Hz).
    """

    doppler_hz: NDArray[np.float64]
    peak: NDArray[np.float64]
    curvature: NDArray[np.float64]
    centre_hz: float


def wigner_ridge(
    signal: ArrayLike,
    *,
    pulse_interval_s: float,
    lag_window_pulses: int | None = None,
    n_freq: int | None = None,
    window: str = "hann",
    centre_hz: float | None = None,
    n_newton: int = 4,
) -> WignerRidge:
    """Instantaneous Doppler of a slow-time signal: the ridge of its Wigner transform.

    The ridge is located on the FFT grid of :func:`wigner_slow_time` and refined by
    Newton steps on the continuous transform ``W(n, f) = Re sum_k r_k exp(-4 i pi f k
    ds)`` (exact derivatives in ``f``, steps limited to one bin), so its precision is
    not limited by the bin width.

    Parameters
    ----------
    signal : (n,) or (n, n_channels) array_like
        Complex slow-time signal; channels are summed incoherently (their transforms add).
    pulse_interval_s : float
        Slow-time sampling interval ``ds`` (s).
    lag_window_pulses, n_freq, window
        See :func:`wigner_slow_time`.
    centre_hz : float, optional
        Centre of the Doppler search band (Hz). Default: the pulse-pair mean Doppler
        ``arg(sum_n sum_c x[n + 1] conj(x[n])) / (2 pi ds)``, unambiguous in
        ``(-1/(2 ds), 1/(2 ds))``.
    n_newton : int
        Number of Newton refinement steps (``0`` keeps the grid maximum).

    Returns
    -------
    WignerRidge
    """
    x = _as_channels(signal)
    if not (np.isfinite(pulse_interval_s) and pulse_interval_s > 0):
        raise ValueError(f"pulse_interval_s must be positive (s), got {pulse_interval_s!r}")
    if n_newton < 0:
        raise ValueError(f"n_newton must be >= 0, got {n_newton!r}")
    ds = float(pulse_interval_s)
    n = x.shape[0]
    lw = _check_lag_window(lag_window_pulses, n)
    if centre_hz is None:
        fc = float(np.angle(np.sum(x[1:] * np.conj(x[:-1])))) / (2.0 * np.pi * ds)
    else:
        fc = float(centre_hz)
    xd = x * np.exp(-2j * np.pi * fc * ds * np.arange(n))[:, None]
    w, f = wigner_slow_time(
        xd, pulse_interval_s=ds, lag_window_pulses=lw, n_freq=n_freq, window=window
    )
    r, lags = _lag_products(xd, lw, window)
    fd = f[np.argmax(w, axis=1)]
    df = float(f[1] - f[0])
    a = 4.0 * np.pi * ds * lags  # phase (rad) per Hz, for each lag
    for _ in range(n_newton):
        e = r * np.exp(-1j * np.outer(fd, a))
        d1 = np.sum((e * (-1j * a)).real, axis=1)
        d2 = np.sum((e * -(a**2)).real, axis=1)
        concave = d2 < 0
        step = np.where(concave, -d1 / np.where(concave, d2, -1.0), 0.0)
        fd = fd + np.clip(step, -df, df)
    band = 1.0 / (2.0 * ds)
    fd = (fd + band / 2) % band - band / 2
    e = r * np.exp(-1j * np.outer(fd, a))
    return WignerRidge(
        doppler_hz=fd + fc,
        peak=np.sum(e.real, axis=1),
        curvature=np.sum((e * a**2).real, axis=1),
        centre_hz=fc,
    )
