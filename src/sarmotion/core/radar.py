"""Radar parameters: carrier, bandwidth, fast-time sampling and compressed-pulse shape."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from .constants import C

__all__ = ["Radar", "PulseShape"]

PulseShape = Literal["rect", "gaussian"]

#: GOTCHA X-band: 424 frequencies from 9.288 GHz in steps of 1.4713 MHz (least-squares fit
#: of the float32 grid stored in the pass-1 files).
GOTCHA_START_HZ = 9.28808072e9
GOTCHA_STEP_HZ = 1.47130106e6
GOTCHA_N_FREQUENCIES = 424


@dataclass(frozen=True, kw_only=True)
class Radar:
    """Radar waveform and sampling, all in SI units.

    The complex-baseband traces have ``n_samples`` fast-time samples at interval
    ``dt = 1 / (n_samples * frequency_step_hz)``; their spectrum is the frequency grid
    ``f_k = carrier_hz + (k - n_samples // 2) * frequency_step_hz``, ``k = 0..n_samples-1``
    (the deramped phase-history grid of real data). The carrier is thus the frequency of
    bin ``n_samples // 2``.

    Parameters
    ----------
    carrier_hz : float
        Carrier frequency ``nu_o = omega_o / (2 pi)`` (Hz).
    bandwidth_hz : float
        Bandwidth ``B`` (Hz) of the compressed pulse.
    n_samples : int
        Number of fast-time samples (= number of frequencies).
    frequency_step_hz : float
        Frequency sampling step (Hz); ``1 / frequency_step_hz`` is the fast-time window (s).
    pulse : {"rect", "gaussian"}
        Compressed-pulse spectrum: ``"rect"`` is flat over ``[-B/2, B/2]`` (a deramped
        chirp, as in real data: a sinc pulse); ``"gaussian"`` is the paper's
        ``exp(-B^2 t^2 / 2)`` envelope (``eq:compPulse``).
    """

    carrier_hz: float = GOTCHA_START_HZ + (GOTCHA_N_FREQUENCIES // 2) * GOTCHA_STEP_HZ
    bandwidth_hz: float = GOTCHA_N_FREQUENCIES * GOTCHA_STEP_HZ
    n_samples: int = GOTCHA_N_FREQUENCIES
    frequency_step_hz: float = GOTCHA_STEP_HZ
    pulse: PulseShape = "rect"

    def __post_init__(self) -> None:
        for name in ("carrier_hz", "bandwidth_hz", "frequency_step_hz"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number (Hz), got {v!r}")
        if not (isinstance(self.n_samples, (int, np.integer)) and self.n_samples >= 2):
            raise ValueError(f"n_samples must be an integer >= 2, got {self.n_samples!r}")
        if self.pulse not in ("rect", "gaussian"):
            raise ValueError(f"pulse must be 'rect' or 'gaussian', got {self.pulse!r}")
        if self.bandwidth_hz >= self.carrier_hz:
            raise ValueError(
                f"bandwidth_hz ({self.bandwidth_hz}) must be below carrier_hz ({self.carrier_hz})"
            )
        if self.pulse == "rect" and self.bandwidth_hz > self.span_hz * (1 + 1e-9):
            raise ValueError(
                f"bandwidth_hz ({self.bandwidth_hz:g}) exceeds the sampled span "
                f"n_samples * frequency_step_hz = {self.span_hz:g} Hz"
            )

    @property
    def span_hz(self) -> float:
        """Sampled frequency span ``n_samples * frequency_step_hz`` (Hz)."""
        return self.n_samples * self.frequency_step_hz

    @property
    def sample_interval_s(self) -> float:
        """Fast-time sampling interval ``dt`` (s)."""
        return 1.0 / self.span_hz

    @property
    def wavelength_m(self) -> float:
        """Central wavelength ``lambda_o = c / nu_o`` (m)."""
        return C / self.carrier_hz

    @property
    def range_resolution_m(self) -> float:
        """Slant-range resolution ``c / (2B)`` (m)."""
        return C / (2.0 * self.bandwidth_hz)

    @property
    def frequencies_hz(self) -> NDArray[np.float64]:
        """Absolute frequencies of the spectrum bins, shape (n_samples,), increasing (Hz)."""
        k = np.arange(self.n_samples, dtype=np.float64) - self.n_samples // 2
        return self.carrier_hz + k * self.frequency_step_hz

    @property
    def fast_times_s(self) -> NDArray[np.float64]:
        """Fast-time axis, shape (n_samples,), with ``t = 0`` at index ``n_samples // 2`` (s)."""
        k = np.arange(self.n_samples, dtype=np.float64) - self.n_samples // 2
        return k * self.sample_interval_s

    def spectral_weights(self) -> NDArray[np.float64]:
        """Compressed-pulse spectrum on :attr:`frequencies_hz`, peak-normalised, shape (n,).

        ``"rect"``: 1 within ``|f - nu_o| <= B/2``, else 0. ``"gaussian"``: the Fourier
        transform of ``exp(-B^2 t^2 / 2)``, i.e. ``exp(-(2 pi (f - nu_o))^2 / (2 B^2))``,
        normalised so that the pulse peaks at 1 in fast time.
        """
        df = self.frequencies_hz - self.carrier_hz
        if self.pulse == "rect":
            w = (np.abs(df) <= 0.5 * self.bandwidth_hz * (1 + 1e-12)).astype(np.float64)
        else:
            w = np.exp(-((2 * np.pi * df) ** 2) / (2.0 * self.bandwidth_hz**2))
        return w * (self.n_samples / w.sum())
