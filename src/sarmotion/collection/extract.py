"""Each patch's traces, built block by block from a :class:`~sarmotion.core.blocks.PulseBlocks`.

For a block of pulses the phase history ``P(s, f_k)`` is formed once; for each patch

1. **re-reference** to its centre ``rho_p``: ``P(s, f) exp(2i pi f delta_p(s))`` with
   ``delta_p(s) = tau(s, rho_p) - tau(s, rho_o)`` (:func:`sarmotion.core.spectral.delay_phase`,
   carrier included), back to fast time over the data's whole window: a point at
   ``rho`` now peaks at ``tau(s, rho) - tau(s, rho_p)`` with phase ``exp(-i omega_o
   (tau(s, rho) - tau(s, rho_p)))``, exactly the traces the data would be had they been
   compressed to ``rho_p``;
2. **window** in fast time: the patch's ``n_p`` samples about ``t = 0``, cut from the
   inverse transform of the spectrum zero-padded to ``n' =``
   :func:`~sarmotion.collection.plan.window_transform_length` ``(n)`` bins (the same
   traces at the interval ``dt n / n'``; ``n' = n`` where the window is the data's). Their
   spectrum is the same band on the grid ``df_p = n' df / n_p``; the patch's
   :class:`Radar` keeps the carrier and bandwidth. A point's pulse is the data's (the Dirichlet
   kernel of ``n`` bins) cut to the window, where the same point simulated on the patch's
   radar is that of ``n_p`` bins: they agree at the peak and differ by at most
   ``max |p_n(t) - p_{n_p}(t)|`` over the window (a few times ``1 / n_p``, the sidelobe
   level at the window's edge);
3. **resample** in slow time by the patch's ratio ``p / q``: its polyphase FIR
   (:mod:`~sarmotion.collection.resample`) evaluated only at its output pulses, each from
   the ``n_taps / p`` input pulses about it; a point's Doppler in the pass band passes with
   gain within ``10^(-A/20)`` of 1. The output pulses' slow times and antenna positions
   are the trajectory's at their (fractional) places on the pulse axis
   (:func:`~sarmotion.collection.resample.resample_trajectory`).

The rows of step 2 are held only until the last output pulse that needs them is
formed: memory is a block's phase history, plus per patch its filter's span of rows and
its output.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np
from numpy.typing import NDArray

from ..core.blocks import PulseBlocks
from ..core.geometry import travel_time
from ..core.radar import Radar
from ..core.spectral import quarter_turns, to_frequency
from ..core.traces import Traces
from .plan import Patch, window_transform_length
from .resample import phases, resample_trajectory

__all__ = ["patch_radar", "extract_patches", "PatchBuilder", "rereferenced"]


def patch_radar(radar: Radar, n_samples: int, n_transform: int | None = None) -> Radar:
    """The data's radar on ``n_samples`` fast-time samples.

    Of the same interval, or with ``n_transform`` (the padded length of
    :func:`~sarmotion.collection.plan.window_transform_length`) of the interval ``dt n /
    n_transform``: the span ``n_transform df``.
    """
    n_t = radar.n_samples if n_transform is None else int(n_transform)
    if n_samples == radar.n_samples and n_t == radar.n_samples:
        return radar
    return Radar(
        carrier_hz=radar.carrier_hz,
        bandwidth_hz=radar.bandwidth_hz,
        n_samples=int(n_samples),
        frequency_step_hz=radar.frequency_step_hz * n_t / n_samples,
        pulse=radar.pulse,
    )


def rereferenced(
    spectrum: NDArray[np.complexfloating],
    delays_s: NDArray[np.float64],
    frequencies_hz: NDArray[np.float64],
    n_transform: int | None = None,
    *,
    out: NDArray[np.complex64] | None = None,
) -> NDArray[np.complex64]:
    """``spectrum exp(2i pi f delta)`` in single precision, zero-padded to ``n_transform``.

    Step 1 of the module notes in one compiled pass (the phase exactly reduced, as
    :func:`~sarmotion.core.spectral.delay_phase`), written about the centre of
    ``n_transform`` bins (default the spectrum's ``n``): bin ``k`` (baseband ``(k - n //
    2) df``) at ``k - n // 2 + n_transform // 2``, the rest zero, and scaled by
    ``n_transform / n`` so that the padded transform's samples keep a point's amplitude
    (:func:`~sarmotion.collection.plan.window_transform_length`).

    Parameters
    ----------
    spectrum : (n_pulses, n) ndarray
        Phase history of a block of pulses.
    delays_s : (n_pulses,) ndarray
        ``delta_p(s)`` of the pulses (s).
    frequencies_hz : (n,) ndarray
        Absolute frequencies of the bins (Hz).
    n_transform : int, optional
        Bins of the output, ``>= n``.
    out : (n_pulses, n_transform) ndarray of complex64, optional
        Where to write it (a work buffer used again: fresh pages cost more than the pass).

    Returns
    -------
    (n_pulses, n_transform) ndarray of complex64
    """
    n = spectrum.shape[-1]
    n_t = n if n_transform is None else int(n_transform)
    if n_t < n:
        raise ValueError(f"n_transform must be >= the spectrum's {n} bins, got {n_t}")
    shape = (spectrum.shape[0], n_t)
    if out is None:
        out = np.zeros(shape, np.complex64)
    elif out.shape != shape or out.dtype != np.complex64:
        raise ValueError(f"out must be complex64 of shape {shape}, got {out.dtype} {out.shape}")
    else:
        out[:, : n_t // 2 - n // 2] = 0
        out[:, n_t // 2 - n // 2 + n :] = 0
    _rereference(
        np.ascontiguousarray(spectrum, dtype=np.complex128),
        np.ascontiguousarray(delays_s, dtype=np.float64),
        np.ascontiguousarray(frequencies_hz, dtype=np.float64),
        n_t // 2 - n // 2,
        n_t / n,
        out,
    )
    return out


@numba.njit(nogil=True, cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def _rereference(spec, delays, freqs, at, scale, out):  # pragma: no cover - compiled
    """``out[j, at + k] = scale spec[j, k] exp(2i pi freqs[k] delays[j])`` (complex64 out)."""
    n = freqs.size
    turn = np.empty(2 * n)
    for j in range(delays.size):
        dj = delays[j]
        for k in range(n):  # the phasors first: a loop the compiler vectorises
            c = dj * freqs[k]
            cs, sn = quarter_turns(4.0 * (c - math.floor(c)))
            turn[2 * k] = cs
            turn[2 * k + 1] = sn
        for k in range(n):
            z = scale * spec[j, k] * complex(turn[2 * k], turn[2 * k + 1])
            out[j, at + k] = np.complex64(z)


def _window(spectrum: NDArray[np.complex64], lo: int, hi: int) -> NDArray[np.complex64]:
    """Samples ``lo:hi`` of :func:`~sarmotion.core.spectral.to_fast_time` of ``spectrum``.

    One single-precision inverse FFT (the traces are single precision) without the two
    shifts: with ``h = n // 2``, ``to_fast_time(Z)[m] = exp(-2i pi h (m - h) / n)
    ifft(Z)[(m - h) mod n]`` (the input shift ``ifftshift`` is that phase, the output
    shift ``fftshift`` that index).
    """
    from scipy.fft import ifft

    n = spectrum.shape[-1]
    h = n // 2
    raw = ifft(spectrum, axis=-1, overwrite_x=True)
    idx = (np.arange(lo, hi) - h) % n
    phase = np.exp(-2j * np.pi * h * idx.astype(np.float64) / n).astype(np.complex64)
    return raw[:, idx] * phase[None, :]


#: Each thread's work buffer of :meth:`PatchBuilder.add` (one block's padded spectrum).
_WORK = threading.local()


class PatchBuilder:
    """Accumulates one patch's traces from consecutive blocks of pulses.

    Parameters
    ----------
    patch : Patch
        The patch (window, filter, output pulses).
    source : PulseBlocks
        The data's axes.
    """

    def __init__(self, patch: Patch, source: PulseBlocks) -> None:
        self.patch = patch
        n = source.radar.n_samples
        # a window narrower than the data is cut from the padded transform (plan notes)
        self._n_transform = window_transform_length(n) if patch.n_samples < n else n
        self._lo = self._n_transform // 2 - patch.n_samples // 2
        self._hi = self._lo + patch.n_samples
        pos = source.trajectory.positions_m
        self._delays = travel_time(pos, patch.centre_m) - travel_time(pos, source.reference_point_m)
        self._freqs = source.radar.frequencies_hz
        self._half = patch.taps.size // 2
        up = int(patch.interpolation)
        # each output pulse's weights of the input pulses up to its last (resample.phases)
        ph = [w.astype(np.float32)[:, None] for w in phases(patch.taps, up)]
        m = patch.pulses.astype(np.int64) + self._half
        self._weights = [ph[r] for r in (m % up)]
        self._last = m // up  # last input pulse each output needs
        self._rows: NDArray[np.complex64] = np.zeros((0, patch.n_samples), np.complex64)
        self._first = 0  # input pulse of self._rows[0]
        self._out = np.zeros((patch.pulses.size, patch.n_samples), np.complex64)
        self._next = 0  # next output pulse to form
        self._end = 0  # one past the last pulse received

    def add(self, start: int, spectrum: NDArray[np.complexfloating]) -> None:
        """Take the phase history of pulses ``start : start + len(spectrum)``."""
        if start != self._end:
            raise ValueError(f"blocks must be consecutive: expected pulse {self._end}, got {start}")
        stop = start + spectrum.shape[0]
        self._end = stop
        shape = (spectrum.shape[0], self._n_transform)
        work = getattr(_WORK, "buffer", None)
        if work is None or work.shape != shape:
            work = _WORK.buffer = np.zeros(shape, np.complex64)
        rows = _window(
            rereferenced(
                spectrum, self._delays[start:stop], self._freqs, self._n_transform, out=work
            ),
            self._lo,
            self._hi,
        )
        self._rows = np.concatenate([self._rows, rows]) if self._rows.shape[0] else rows
        if self._rows.shape[0] == rows.shape[0]:
            self._first = start
        n_out, last = self.patch.pulses.size, self._last
        # the taps are real; an explicit weighted sum, not a BLAS product: a vector-matrix
        # product per output pulse is too small for BLAS's threads to pay
        while self._next < n_out and last[self._next] < stop:
            w = self._weights[self._next]
            a = int(last[self._next]) - w.shape[0] + 1 - self._first
            self._out[self._next] = (w * self._rows[a : a + w.shape[0]]).sum(axis=0)
            self._next += 1
        if self._next < n_out:
            keep = int(last[self._next]) - self._weights[self._next].shape[0] + 1
        else:
            keep = stop
        drop = min(max(0, keep - self._first), self._rows.shape[0])
        if drop:
            self._rows = self._rows[drop:]
            self._first += drop

    def traces(self, source: PulseBlocks) -> Traces:
        """The patch's traces, once every block was added."""
        if self._next != self.patch.pulses.size:
            raise ValueError(
                f"patch {self.patch.index}: {self.patch.pulses.size - self._next} output "
                "pulse(s) still missing data"
            )
        return make_traces(self.patch, source, self._out, self._n_transform)


def make_traces(
    patch: Patch, source: PulseBlocks, data: NDArray, n_transform: int | None = None
) -> Traces:
    """:class:`Traces` of a patch from its output rows (cut from a transform of that length)."""
    trajectory = resample_trajectory(source.trajectory, patch.pulses, patch.interpolation)
    meta = dict(source.metadata)
    meta.update(patch=patch.index, patch_core_m=list(patch.core_m))
    return Traces(
        data=data,
        trajectory=trajectory,
        radar=patch_radar(source.radar, patch.n_samples, n_transform),
        reference_point_m=patch.centre_m,
        metadata=meta,
    )


def extract_patches(
    source: PulseBlocks,
    patches: Sequence[Patch],
    *,
    block_pulses: int = 256,
    progress: Callable[[str, int, int], object] | None = None,
) -> list[Traces]:
    """Traces of every patch, reading ``source`` once, block by block.

    Each block's patches are built in threads, one per core (:func:`PatchBuilder.add` is
    independent per patch).

    Parameters
    ----------
    source : PulseBlocks
        The data.
    patches : sequence of Patch
        Patches of :func:`~sarmotion.collection.plan_patches`.
    block_pulses : int
        Pulses per block.
    progress : callable, optional
        ``progress("patch traces", pulses_read, n_pulses)``.

    Returns
    -------
    list of Traces
        One per patch, in order.
    """
    builders = [PatchBuilder(p, source) for p in patches]
    threads = min(len(builders), _cores())
    with ThreadPoolExecutor(max_workers=max(1, threads)) as pool:
        for start, stop, block in source.blocks(block_pulses):
            spectrum = to_frequency(np.asarray(block, dtype=np.complex128))
            # the patches are independent; their compiled pass and transform release the GIL
            for _ in pool.map(lambda b, s=start, z=spectrum: b.add(s, z), builders):
                pass
            if progress is not None:
                progress("patch traces", stop, source.n_pulses)
    return [b.traces(source) for b in builders]


def _cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1
