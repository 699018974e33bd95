"""Shared machinery of the speed objectives: checks, trial velocities, travel-time alignment."""

from __future__ import annotations

import math
from collections.abc import Callable

import numba
import numpy as np
import scipy.fft as sfft
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize_scalar
from threadpoolctl import threadpool_limits

from ..core import C, LookGeometry, Traces, ground_velocity, range_direction_velocity
from ..core.spectral import unit_phasor

__all__ = []


#: Complex samples per chunk of trial velocities (at most 1 MB of complex64, one velocity
#: of a GOTCHA degree): the chunk stays in cache from the modulation through the FFT to
#: the reduction (a larger chunk leaves the cache between the steps).
_CHUNK_ELEMENTS = 1 << 17


#: Most fast-time samples formed by a matrix product with inverse-DFT columns (above, FFT).
_MAX_DFT_COLUMNS = 32


#: Fast-time refinement of the transformed traces (band-limited, by zero padding).
_OVERSAMPLE = 2


#: Sub-sample phases of the shift table behind :meth:`_Aligner.g_values`. Linear
#: interpolation between phases ``1/P`` of a sample apart errs by at most
#: ``(2 pi nu h)^2 / 8`` of a trace's peak modulus, with ``nu = 1 / (2 _OVERSAMPLE)``
#: cycles per sample the band edge and ``h = 1 / P``: 3.0e-4 for ``P = 32`` (-70 dB),
#: below the single-precision spectra's effect on ``g`` at the detector's thresholds.
_SHIFT_PHASES = 16


#: Largest shift table (bytes) :meth:`_Aligner.g_values` builds; building it briefly
#: needs about three times as much. Above (long or finely sampled pulses: 469 GOTCHA
#: pulses of 424 samples take 54 MB, 1000 pulses of 2048 samples 557 MB) ``g`` is formed
#: by one transform per trial in 1 MB chunks, as :meth:`_Aligner.map_chunks` does.
_MAX_TABLE_BYTES = 1 << 27


# =============================================================== validation
def _check_traces(traces: object) -> Traces:
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a sarmotion Traces, got {type(traces).__name__}")
    if traces.n_pulses < 3:
        raise ValueError(f"traces must hold at least 3 pulses, got {traces.n_pulses}")
    return traces


def _speeds(values: ArrayLike, name: str) -> NDArray[np.float64]:
    try:
        u = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of real speeds (m/s), got {values!r}") from None
    u = np.atleast_1d(u)
    if u.ndim != 1 or u.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D array (m/s), got shape {u.shape}")
    if not np.all(np.isfinite(u)):
        raise ValueError(f"{name} must be finite, got {u[~np.isfinite(u)][:3]} among them")
    return u


# =============================================================== resolutions
def _aperture_time_s(traces: Traces) -> float:
    s = traces.slow_times_s
    return float(s[-1] - s[0])


# =============================================================== the kernel
class _Aligner:
    """``T_+^{u, rho}`` of one data set for many trial velocities, in the frequency domain.

    The phase history ``P(s_j, f_k)`` is computed once (complex64). For a chunk of trial
    velocities the delays ``dtau(s_j, rho + s_j u)`` are float64; the phasors
    ``exp(2i pi f_k dtau)`` (``f_k dtau`` up to ~1e4 cycles) are formed compiled from the
    cycles reduced exactly to whole turns every 32 bins and a fixed rotation in between
    (error ~1e-14), and the product with the spectrum is rounded to complex64, written
    straight into the zero-padded FFT buffer (:func:`_modulate`). Single precision after
    the reduction is far below every other error (the data themselves are often
    complex64); float32 *before* the reduction would lose the image. The spectra are
    zero-padded to ``M = 2 n_samples`` and inverse-transformed, one FFT per trial: the
    transformed traces at twice the fast-time sampling of the traces (band-limited
    interpolation; the original samples are every other one), scaled as
    :attr:`Traces.data`. Objectives that read a few fast-time samples only (``g_perp``,
    the likelihood's global search) form those by a matrix product with columns of the
    inverse DFT instead (:meth:`map_chunks`, :meth:`column_basis`).
    """

    def __init__(self, traces: Traces, point_m: NDArray[np.float64]) -> None:
        self.traces = traces
        self.point = point_m
        k = traces.n_samples
        m = _OVERSAMPLE * k
        self.spectrum = (np.fft.ifftshift(traces.phase_history(), axes=-1) * (m / k)).astype(
            np.complex64
        )
        self.freq = np.fft.ifftshift(traces.frequencies_hz)
        # FFT order: non-negative baseband offsets first, the k // 2 negative ones last.
        n_pos = k - k // 2
        self.slots = np.concatenate([np.arange(n_pos), np.arange(m - k // 2, m)])
        self.n_fft = m
        dt = 1.0 / (m * traces.radar.frequency_step_hz)
        self.sample_s = dt
        self._table: NDArray[np.complex64] | None = None
        idx = np.arange(m)
        self.times_s = np.where(idx < m - m // 2, idx, idx - m) * dt
        self.positions = traces.positions_m
        self.slow = traces.slow_times_s
        self.tau_ref = 2.0 * np.linalg.norm(self.positions - traces.reference_point_m, axis=1) / C
        self.chunk = max(1, _CHUNK_ELEMENTS // (traces.n_pulses * m))

    def delays(self, velocities: NDArray[np.float64]) -> NDArray[np.float64]:
        """``dtau(s_j, rho + s_j u_i)`` (s) for ground velocities (n_vel, 2), shape (n_vel, n)."""
        v3 = np.zeros((velocities.shape[0], 3))
        v3[:, :2] = velocities
        diff = self.positions[None, :, :] - self.point[None, None, :]
        diff = diff - self.slow[None, :, None] * v3[:, None, :]
        rng = np.sqrt(np.einsum("vnk,vnk->vn", diff, diff))
        return 2.0 * rng / C - self.tau_ref[None, :]

    def spectra(self, velocities: NDArray[np.float64]) -> NDArray[np.complex64]:
        """Phase-modulated spectra ``P(s, f) exp(2i pi f dtau)``, shape (n_vel, n, n_samples)."""
        delays = np.ascontiguousarray(self.delays(velocities))
        out = np.empty(delays.shape + (self.freq.size,), dtype=np.complex64)
        _modulate(delays, self.freq, self.spectrum, np.arange(self.freq.size), out)
        return out

    def trace_profile(self, velocity_mps: NDArray[np.float64]) -> NDArray[np.float64]:
        """``sum_s |T_+ d(s, t)|`` over the fast time ``t`` (:attr:`times_s`) at one velocity.

        The traces aligned at ``velocity_mps`` ((3,), m/s), transformed back to fast
        time; its maximum is the aligned trace ``g`` takes, shape ``(n_fft,)``.
        """
        spectra = self.spectra(np.asarray(velocity_mps, dtype=np.float64)[None])
        padded = np.zeros(spectra.shape[:2] + (self.n_fft,), dtype=np.complex64)
        padded[..., self.slots] = spectra
        return np.abs(np.fft.ifft(padded, axis=-1)).sum(axis=1)[0]

    def g_values(self, velocities: NDArray[np.float64]) -> NDArray[np.float64]:
        """``g = max_t sum_j |T_+ d(s_j, t)|`` for ground velocities (n_vel, 2), shape (n_vel,).

        The same objective as ``map_chunks(velocities, _g_reduce)`` without a transform
        per trial. Alignment multiplies each pulse's spectrum by ``exp(2i pi f dtau_j)``:
        a carrier phase ``exp(2i pi f_c dtau_j)``, which the modulus removes, times a
        fast-time shift of the pulse's band-limited trace by ``dtau_j``. The traces are
        transformed once, at :data:`_SHIFT_PHASES` sub-sample shifts
        (:meth:`shift_table`); a trial reads each pulse's trace at its shift by linear
        interpolation between the two nearest phases (compiled, trials over the
        threads). Error: at most 1.2e-3 of each trace's peak modulus (see
        :data:`_SHIFT_PHASES`); the fast-time samples are those of the transform. A
        table larger than :data:`_MAX_TABLE_BYTES` is not built: ``g`` then comes from
        one transform per trial (the exact values, in bounded memory).
        """
        if self._table is None and self.table_bytes() > _MAX_TABLE_BYTES:
            return self.map_chunks(velocities, _g_reduce)
        table = self.shift_table()
        shifts = np.ascontiguousarray(self.delays(velocities) / self.sample_s)
        out = np.empty(velocities.shape[0])
        _shifted_sum_abs_max(table, shifts, out)
        return out

    def table_bytes(self) -> int:
        """Size of :meth:`shift_table` (bytes)."""
        return self.traces.n_pulses * (_SHIFT_PHASES + 1) * self.n_fft * 8

    def shift_table(self) -> NDArray[np.complex64]:
        """Band-limited traces at sub-sample shifts, shape (n, P + 1, M), complex64.

        ``table[j, p, m]`` is pulse ``j``'s zero-padded inverse transform (without the
        carrier) at fast-time sample ``m + p / P`` (``P`` = :data:`_SHIFT_PHASES`,
        samples of :attr:`times_s`, circular); the last phase repeats the first one
        sample later, so interpolation never wraps between phases. Built once, on the
        first call (``P`` transforms of the traces).
        """
        if self._table is None:
            phases = _SHIFT_PHASES
            k = self.traces.n_samples
            n, m = self.traces.n_pulses, self.n_fft
            # one transform P times longer: sample m P + p of it is x_j(m + p / P)
            signed = np.where(self.slots < k - k // 2, self.slots, self.slots + (phases - 1) * m)
            padded = np.zeros((n, phases * m), dtype=np.complex64)
            padded[:, signed] = self.spectrum * np.float32(phases)
            fine = sfft.ifft(padded, axis=-1, workers=-1).reshape(n, m, phases)
            table = np.empty((n, phases + 1, m), dtype=np.complex64)
            table[:, :phases] = fine.transpose(0, 2, 1)
            table[:, phases] = np.roll(table[:, 0], -1, axis=-1)
            self._table = table
        return self._table

    def map_chunks(
        self,
        velocities: NDArray[np.float64],
        reduce: Callable[[NDArray[np.complex64]], NDArray[np.float64]],
        *,
        lag: int = 0,
        columns: NDArray[np.intp] | None = None,
    ) -> NDArray[np.float64]:
        """Apply ``reduce`` to the transformed traces of each velocity, chunk by chunk.

        ``reduce`` receives the fast-time traces of a chunk, shape (n_chunk, n', M). With
        ``lag = h > 0`` they are the second differences ``D_s^2`` at step ``h Delta s``,
        ``(x_{j+h} - 2 x_j + x_{j-h}) / (h Delta s)^2`` (per s^2), on the ``n' = n - 2h``
        interior pulses. With ``columns`` (indices into :attr:`times_s`) ``reduce``
        receives only those fast-time samples, shape (n_chunk, n', n_columns). Up to
        :data:`_MAX_DFT_COLUMNS` of them are computed by a matrix product with the
        columns of the inverse DFT instead of the FFT (the same values to float32
        rounding; a few columns cost less than the whole inverse FFT).
        """
        out = np.empty(velocities.shape[0])
        basis = None
        if columns is not None and len(columns) <= _MAX_DFT_COLUMNS:
            basis = self.column_basis(columns)
            # one BLAS thread for the small products (see _columns), set once per call
            with threadpool_limits(limits=1, user_api="blas"):
                self._map(velocities, reduce, lag, columns, basis, out)
        else:
            self._map(velocities, reduce, lag, columns, basis, out)
        return out

    def _map(
        self,
        velocities: NDArray[np.float64],
        reduce: Callable[[NDArray[np.complex64]], NDArray[np.float64]],
        lag: int,
        columns: NDArray[np.intp] | None,
        basis: NDArray[np.complex64] | None,
        out: NDArray[np.float64],
    ) -> None:
        """The chunk loop of :meth:`map_chunks`, results into ``out``."""
        inv_ds2 = np.float32(1.0 / self.traces.trajectory.pulse_interval_s**2)
        padded = None
        for i0 in range(0, velocities.shape[0], self.chunk):
            vel = velocities[i0 : i0 + self.chunk]
            n_out = self.traces.n_pulses - 2 * lag
            if basis is None and (padded is None or padded.shape[0] != vel.shape[0]):
                # zero outside the slots, which every chunk overwrites
                padded = np.zeros((vel.shape[0], n_out, self.n_fft), dtype=np.complex64)
            if lag > 0 or basis is not None:
                x = self.spectra(vel)
                if lag > 0:
                    # D_s^2 acts on slow time only: take it on the spectra, before the FFT.
                    h = lag
                    x = (x[:, 2 * h :] - 2.0 * x[:, h:-h] + x[:, : -2 * h]) * (inv_ds2 / h**2)
                if basis is not None:
                    out[i0 : i0 + self.chunk] = reduce(_columns(x, basis))
                    continue
                padded[..., self.slots] = x
            else:
                delays = np.ascontiguousarray(self.delays(vel))
                _modulate(delays, self.freq, self.spectrum, self.slots, padded)
            y = sfft.ifft(padded, axis=-1, workers=-1)
            out[i0 : i0 + self.chunk] = reduce(y if columns is None else y[..., columns])

    def column_basis(self, columns: NDArray[np.intp]) -> NDArray[np.complex64]:
        """Columns of the zero-padded inverse DFT, shape (n_samples, n_columns).

        ``spectra(v) @ column_basis(c)`` equals ``ifft`` of the padded spectra at the
        fast-time samples ``c`` (indices into :attr:`times_s`); phases in float64.
        """
        c = np.asarray(columns, dtype=np.int64) % self.n_fft
        turns = (self.slots[:, None] * c[None, :]) % self.n_fft / self.n_fft
        return (np.exp(2j * np.pi * turns) / self.n_fft).astype(np.complex64)


def _columns(x: NDArray[np.complex64], basis: NDArray[np.complex64]) -> NDArray[np.complex64]:
    """``x @ basis`` over the last axis as one matrix product.

    Callers limit BLAS to one thread around their loops (``threadpool_limits`` costs
    about as much as a product, so it is set once per loop, not per product): a product
    this small gains nothing from BLAS threads, and on a busy machine their barriers wait
    for descheduled threads (timings in ``docs/notes/motion.md``).
    """
    y = np.ascontiguousarray(x).reshape(-1, x.shape[-1]) @ basis
    return y.reshape(x.shape[:-1] + (basis.shape[1],))


@numba.njit(nogil=True, cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def _modulate(delays, freq, spectrum, slots, out):  # pragma: no cover - compiled
    """``out[v, j, slots[k]] = spectrum[j, k] exp(2i pi freq[k] delays[v, j])``, complex64.

    ``freq`` is two uniform runs (FFT order: the non-negative offsets, then the negative
    ones) of one step. Along each run the phasor advances by the fixed rotation
    ``exp(2i pi delays[v, j] df)``, four interleaved phasors at a time; every 32 bins
    it is re-seeded exactly from the float64 cycles reduced to whole turns
    (:func:`sarmotion.core.spectral.unit_phasor`, error < 1e-14), so the phasors carry
    ~1e-14 of rounding before the product is rounded to single precision.
    """
    n_vel, n = delays.shape
    n_freq = freq.size
    n_pos = n_freq - n_freq // 2
    df = freq[1] - freq[0] if n_pos > 1 else 0.0  # one bin per run: no rotation needed
    for row in range(n_vel * n):
        v = row // n
        j = row - v * n
        d = delays[v, j]
        st = d * df
        r1 = unit_phasor(st - math.floor(st))
        r2 = r1 * r1
        r4 = r2 * r2
        for lo, hi in ((0, n_pos), (n_pos, n_freq)):
            for k0 in range(lo, hi, 32):
                c = d * freq[k0]
                w0 = unit_phasor(c - math.floor(c))
                w1 = w0 * r1
                w2 = w0 * r2
                w3 = w1 * r2
                k1 = min(k0 + 32, hi)
                k = k0
                while k + 4 <= k1:
                    for q, w in ((0, w0), (1, w1), (2, w2), (3, w3)):
                        sp = spectrum[j, k + q]
                        out[v, j, slots[k + q]] = complex(
                            np.float32(w.real * sp.real - w.imag * sp.imag),
                            np.float32(w.real * sp.imag + w.imag * sp.real),
                        )
                    w0 = w0 * r4
                    w1 = w1 * r4
                    w2 = w2 * r4
                    w3 = w3 * r4
                    k += 4
                while k < k1:
                    sp = spectrum[j, k]
                    out[v, j, slots[k]] = complex(
                        np.float32(w0.real * sp.real - w0.imag * sp.imag),
                        np.float32(w0.real * sp.imag + w0.imag * sp.real),
                    )
                    w0 = w0 * r1
                    k += 1


def _basis(geometry: LookGeometry) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Ground velocities of unit range speed and of unit cross-range speed (m/s per m/s)."""
    return ground_velocity(1.0, 0.0, geometry), ground_velocity(0.0, 1.0, geometry)


def _range_trials(
    speeds: NDArray[np.float64], geometry: LookGeometry, cross_range_speed: float | None
) -> NDArray[np.float64]:
    if cross_range_speed is None:
        return speeds[:, None] * range_direction_velocity(1.0, geometry)[None, :]
    e_r, e_p = _basis(geometry)
    return speeds[:, None] * e_r[None, :] + cross_range_speed * e_p[None, :]


def _g_reduce(x: NDArray[np.complex64]) -> NDArray[np.float64]:
    """``max_t sum_j |x[v, j, t]|`` for each ``v`` (compiled; moduli in float64)."""
    return _sum_abs_max(x)


@numba.njit(nogil=True, cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def _sum_abs_max(x):  # pragma: no cover - compiled
    """``max_t sum_j |x[v, j, t]|``, shape (n_vel,), accumulated in float64."""
    n_vel, n, m = x.shape
    out = np.empty(n_vel)
    for v in range(n_vel):
        acc = np.zeros(m)
        for j in range(n):
            for t in range(m):
                z = x[v, j, t]
                re = np.float64(z.real)
                im = np.float64(z.imag)
                acc[t] += math.sqrt(re * re + im * im)
        out[v] = acc.max()
    return out


#: Fewest trials worth a parallel region in :func:`_shifted_sum_abs_max`. A region ends in
#: a barrier; on a busy machine it waits for a descheduled thread, which costs far more
#: than one trial's arithmetic (``docs/notes/motion.md``), so the refinements' single
#: trials run on the calling thread.
_MIN_PARALLEL_TRIALS = 16


def _shifted_sum_abs_max(table, shifts, out):
    """``out[v] = max_m sum_j |x_j(m + shifts[v, j])|`` from the shift table (compiled).

    ``x_j(m + p/P + w/P)`` is ``(1 - w) table[j, p, m] + w table[j, p + 1, m]``
    (``0 <= w < 1``), indices circular in ``m``; single precision throughout (sums of a
    few hundred moduli: rounding ~1e-5 of ``g`` at most, far below the interpolation's
    1.2e-3 bound; ``tests/motion/test_aligned_fast.py`` checks it against float64). Trials
    over the threads when there are at least :data:`_MIN_PARALLEL_TRIALS`.
    """
    if shifts.shape[0] >= _MIN_PARALLEL_TRIALS:
        _shifted_trials_parallel(table, shifts, out)
    else:
        _shifted_trials(table, shifts, out)


@numba.njit(nogil=True, cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def _shifted_trial(table, shifts):  # pragma: no cover - compiled
    """``max_m sum_j |x_j(m + shifts[j])|`` for one trial (see :func:`_shifted_sum_abs_max`)."""
    n, n_phase, m = table.shape
    phases = n_phase - 1
    acc = np.zeros(m, dtype=np.float32)
    for j in range(n):
        fine = shifts[j] * phases
        whole = math.floor(fine)
        w1 = np.float32(fine - whole)
        w0 = np.float32(1.0) - w1
        q = np.int64(whole)
        i = q // phases
        p = q - i * phases
        i = i % m
        a = table[j, p]
        b = table[j, p + 1]
        split = m - i
        for t in range(split):
            z = w0 * a[t + i] + w1 * b[t + i]
            acc[t] += math.sqrt(z.real * z.real + z.imag * z.imag)
        for t in range(split, m):
            z = w0 * a[t - split] + w1 * b[t - split]
            acc[t] += math.sqrt(z.real * z.real + z.imag * z.imag)
    return np.float64(acc.max())


@numba.njit(nogil=True, cache=True)
def _shifted_trials(table, shifts, out):  # pragma: no cover - compiled
    for v in range(shifts.shape[0]):
        out[v] = _shifted_trial(table, shifts[v])


@numba.njit(nogil=True, parallel=True, cache=True)
def _shifted_trials_parallel(table, shifts, out):  # pragma: no cover - compiled
    for v in numba.prange(shifts.shape[0]):
        out[v] = _shifted_trial(table, shifts[v])


def _refine_max(
    func: Callable[[float], float], centre: float, half_width: float, tol: float
) -> tuple[float, float]:
    """Bounded Brent/golden search for the maximum of ``func`` on ``centre +- half_width``."""
    res = minimize_scalar(
        lambda x: -func(x),
        bounds=(centre - half_width, centre + half_width),
        method="bounded",
        options={"xatol": tol},
    )
    x, val = float(res.x), float(-res.fun)
    c_val = func(centre)
    return (x, val) if val >= c_val else (centre, c_val)
