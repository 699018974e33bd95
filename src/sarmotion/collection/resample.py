"""Rational resampling of a patch's traces in slow time.

A patch's traces need ``R = (1 + guard) 2 f_pass`` pulses per second (its band
``|f| <= f_pass`` plus the sampling margin, :mod:`~sarmotion.collection.plan`); the data
may have many more, sized for the whole scene. The traces are resampled by a rational
factor ``p / q`` (up ``p``, down ``q``):

**The rule.** With ``F`` the data's pulse rate: ``p = q = 1`` when ``R >= F``; otherwise
the smallest ``p / q >= R / F`` with ``q <= MAX_DENOMINATOR`` (ties: the smallest ``q``),
in lowest terms. The output rate ``F p / q`` is then at least ``R`` and exceeds it by less
than ``F / (q R)`` of ``R`` (``p / q - R / F < 1 / q``), never more than ``F / (32 R)``
(6 % at ``F / R = 2``). Where ``R / F`` is ``1 / q`` for an integer ``q`` this is the integer
decimation by ``q``.

**The filter.** One Kaiser-window low-pass FIR ``h`` (:func:`design`) on the grid of
``1 / p`` input pulses: pass band ``|f| <= f_pass``, stop band ``|f| >= f_stop = (1 + 2
guard) f_pass``, gain ``p``. Output pulse ``k`` sits at input-pulse position ``u_k = m_k /
p`` (``m_k`` an integer, ``m_{k+1} - m_k = q``) and is ``y_k = sum_j x_j h[m_k - j p +
c]``, ``c = (n_taps - 1) / 2``: the ``n_taps / p`` input pulses about it, weighted by one
of the filter's ``p`` phases (a polyphase filter, ``scipy.signal.upfirdn``'s sum
evaluated only at the kept outputs). Components beyond ``f_pass`` up to ``f_stop`` alias,
at the output rate ``>= 2 (1 + guard) f_pass``, to beyond ``f_pass``: outside the band.

**The error bound.** For traces whose slow-time spectrum lies in the pass band, ``y_k``
differs from the band-limited signal at ``u_k`` by at most ``10^(-A/20)`` of each
component's amplitude (pass-band ripple), and a component in the stop band leaves at
most ``10^(-A/20)`` of its own (stop-band attenuation ``A``: ``stopband_db``, 60 dB by
default). Each output uses one of the filter's ``p`` phases, whose response to
``exp(2i pi f j / F)`` is ``(1 / p) sum_{i < p} H(f + i F)`` (``H`` the filter's); the
design is checked on every phase (:func:`phase_errors`) and its attenuation raised until
both hold, so the bound holds by construction, not by Kaiser's approximate formulae.

**Movers aliased in the data.** The data hold a component at Doppler ``D`` (relative to
the patch's centre, after re-referencing) at ``D - k F``, its alias in ``[-F/2, F/2)``. On
the data's own pulses, and on every ``q``-th of them, the two agree; between pulses they
do not: the resampled traces carry the alias's Doppler with the true range migration,
which no point target has (a mover of range speed ``v`` is shifted by ``2 v / lambda``: at
X-band and ``F = 313`` Hz every mover above 2.3 m/s is aliased). A mover the patch keeps
(its aliased Doppler in the pass band) is unaliased, ``k = 0``, when ``|D| < F - f_pass``.
So the rational ratio is taken only where every mover of the speed range starting in the
region has ``|D| < F - f_pass`` (:func:`aliased_doppler_hz`); elsewhere the plan keeps the
integer decimation ``q = floor(F / R)`` (``p = 1``), which is exact for aliased movers too.

**The output pulses' axes.** Slow time at ``u_k`` is the input's, linear between pulses
(exact for a uniform pulse rate, the premise of any slow-time filter); the antenna's
position is the cubic spline through the input positions over slow time (float64; its
error ``5 h^4 max|r''''| / 384``, ``h`` the pulse interval, is below a nanometre for an
airborne platform), the exact input positions where ``u_k`` is an integer.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from numpy.typing import NDArray

from ..core.geometry import Trajectory

__all__ = [
    "MAX_DENOMINATOR",
    "slow_time_ratio",
    "aliased_doppler_hz",
    "design",
    "phase_errors",
    "output_grid",
    "phases",
    "resample_trajectory",
]

#: Largest down factor ``q`` of the slow-time ratio ``p / q`` (module notes).
MAX_DENOMINATOR = 32


def slow_time_ratio(prf_hz: float, rate_hz: float) -> tuple[int, int]:
    """``(p, q)``: the smallest ratio ``p / q >= rate / prf`` with ``q <= MAX_DENOMINATOR``.

    Parameters
    ----------
    prf_hz : float
        The data's pulse rate ``F`` (Hz).
    rate_hz : float
        The pulse rate the traces need, ``R`` (Hz).

    Returns
    -------
    (int, int)
        Up and down factors in lowest terms; ``(1, 1)`` when ``R >= F``.
    """
    if not (prf_hz > 0.0 and rate_hz > 0.0):
        raise ValueError(f"pulse rates must be positive, got {prf_hz} and {rate_hz} Hz")
    target = rate_hz / prf_hz
    if target >= 1.0:
        return 1, 1
    best = Fraction(1, 1)
    for q in range(1, MAX_DENOMINATOR + 1):
        r = Fraction(math.ceil(q * target), q)
        if r < best:
            best = r
    return best.numerator, best.denominator


def aliased_doppler_hz(
    positions_m: NDArray[np.float64],
    slow_times_s: NDArray[np.float64],
    centre_m: NDArray[np.float64],
    points_m: NDArray[np.float64],
    velocities_mps: NDArray[np.float64],
    frequencies_hz: tuple[float, float],
) -> float:
    """Largest Doppler of a mover relative to a patch's centre, unaliased (Hz).

    ``max |f d/ds [tau(s, x + s u) - tau(s, rho_p)]|`` over the pulses, ``f`` the band's
    ends, ``x`` the points (the region's corners) and ``u`` the ground velocities (and
    rest). A rational ratio (``p > 1``) keeps a component only where this is below ``F -
    f_pass`` (module notes).

    Parameters
    ----------
    positions_m : (n, 3) ndarray
        Antenna positions (m).
    slow_times_s : (n,) ndarray
        Their slow times (s).
    centre_m : (3,) ndarray
        The patch's centre (m).
    points_m : (k, 3) ndarray
        Mover start points (m).
    velocities_mps : (v, 2) ndarray
        Ground velocities (m/s).
    frequencies_hz : (float, float)
        The band's ends (Hz).
    """
    from ..core.geometry import travel_time

    s = np.asarray(slow_times_s, dtype=np.float64)
    ref = travel_time(positions_m, centre_m)
    vel = np.vstack([np.zeros((1, 2)), np.asarray(velocities_mps, dtype=np.float64)])
    worst = 0.0
    for x in np.atleast_2d(points_m):
        for u in vel:
            where = x[None, :] + s[:, None] * np.r_[u, 0.0][None, :]
            rate = np.gradient(travel_time(positions_m, where) - ref, s)
            worst = max(worst, float(np.max(np.abs(rate))) * max(abs(f) for f in frequencies_hz))
    return worst


def design(
    up: int, passband_hz: float, prf_hz: float, stopband_db: float, *, guard: float
) -> NDArray[np.float64]:
    """The resampling filter on the grid of ``1 / up`` input pulses.

    Kaiser window (:func:`scipy.signal.firwin`) for a transition from ``f_pass`` to
    ``f_stop = (1 + 2 guard) f_pass`` at the rate ``up F``, odd length, gain ``up`` at
    0 Hz. Its attenuation starts at ``A`` (:func:`scipy.signal.kaiserord`, whose formulae
    are approximate) and is raised by the shortfall until every phase meets the bound
    ``10^(-A/20)`` (:func:`phase_errors`). With ``up = 1`` and ``f_stop`` at or above the
    Nyquist rate ``F / 2``: ``[1.0]`` (the band is the data's).

    Parameters
    ----------
    up : int
        Up factor ``p``.
    passband_hz, prf_hz : float
        ``f_pass`` and ``F`` (Hz).
    stopband_db : float
        ``A`` (dB).
    guard : float
        The band guard.

    Returns
    -------
    (n_taps,) ndarray of float64
    """
    from scipy.signal import firwin, kaiserord

    stop = (1.0 + 2.0 * guard) * passband_hz
    if up == 1 and stop >= 0.5 * prf_hz:
        return np.ones(1)
    fs = up * prf_hz
    bound = 10.0 ** (-stopband_db / 20.0)
    atten = stopband_db
    for _ in range(8):
        n_taps, beta = kaiserord(atten, (stop - passband_hz) / (0.5 * fs))
        n_taps += 1 - n_taps % 2  # odd: a whole-sample delay
        h = firwin(n_taps, 0.5 * (stop + passband_hz), window=("kaiser", beta), fs=fs) * up
        worst = max(phase_errors(h, up, passband_hz, stop, prf_hz))
        if worst <= bound:
            break
        atten += 20.0 * math.log10(worst / bound) + 0.5
    return h


def phase_errors(
    taps: NDArray[np.float64], up: int, passband_hz: float, stop_hz: float, prf_hz: float
) -> tuple[float, float]:
    """Worst pass-band deviation and stop-band gain of the filter's phases.

    For each phase (an output at fraction ``r / up`` between input pulses) the response
    ``G(f) = sum_j w_j exp(2i pi f (j - u) / F)`` to ``exp(2i pi f j / F)``: ``max |G -
    1|`` over ``|f| <= f_pass`` and ``max |G|`` over ``f_stop <= |f| <= F - f_stop`` (``|G|``
    is ``F``-periodic, so that is the whole stop band), on a grid of 64 points per
    ``F / n_weights`` (a ripple's width).

    Returns
    -------
    (float, float)
        Pass-band deviation and stop-band gain (amplitude ratios).
    """
    c = taps.size // 2
    ws = phases(np.asarray(taps, dtype=np.float64), up)
    n_max = max(w.size for w in ws)
    m = 1 << max(12, int(math.ceil(math.log2(64 * n_max))))
    f = np.fft.fftfreq(m, d=1.0 / prf_hz)  # Hz, the DFT's grid on [-F/2, F/2)
    af = np.abs(f)
    passband = af <= passband_hz
    stopband = (af >= stop_hz) & (af <= prf_hz - stop_hz)
    dev = gain = 0.0
    for r, w in enumerate(ws):
        # weights of pulses j_hi - L + 1 .. j_hi; u = j_hi + (r - c) / up
        d0 = (1 - w.size) - (r - c) / up  # (j - u) of the first weight
        g = m * np.fft.ifft(w, m) * np.exp(2j * np.pi * f * d0 / prf_hz)
        if passband.any():
            dev = max(dev, float(np.max(np.abs(g[passband] - 1.0))))
        if stopband.any():
            gain = max(gain, float(np.max(np.abs(g[stopband]))))
    return dev, gain


def output_grid(n_pulses: int, up: int, down: int, n_taps: int) -> NDArray[np.int64]:
    """Grid indices ``m_k`` of the output pulses (input pulse ``j`` at ``m = j up``).

    Every ``down``-th grid point whose filter support ``[m - c, m + c]`` (``c = (n_taps -
    1) / 2``) lies within the input pulses ``0 .. n_pulses - 1``, placed symmetrically in
    the aperture. Empty when none fits.
    """
    c = n_taps // 2
    usable = (n_pulses - 1) * up - 2 * c + 1
    if usable <= 0:
        return np.zeros(0, dtype=np.int64)
    count = (usable - 1) // down + 1
    first = c + (usable - 1 - (count - 1) * down) // 2
    return first + down * np.arange(count, dtype=np.int64)


def phases(taps: NDArray[np.float64], up: int) -> list[NDArray[np.float64]]:
    """The filter's ``up`` phases as weights of consecutive input pulses.

    For an output at grid index ``m`` with ``r = (m + c) mod up``, the weights of the
    input pulses ``j_hi - len + 1 .. j_hi``, ``j_hi = (m + c - r) / up``, are
    ``phases(taps, up)[r]`` (``taps[m - j up + c]``, ascending ``j``).
    """
    return [np.ascontiguousarray(taps[r::up][::-1]) for r in range(up)]


def resample_trajectory(trajectory: Trajectory, grid: NDArray[np.int64], up: int) -> Trajectory:
    """The antenna at the output pulses ``u_k = grid_k / up`` (module notes).

    Parameters
    ----------
    trajectory : Trajectory
        The data's trajectory (``n_pulses`` pulses).
    grid : (n_out,) ndarray of int
        Output grid indices (:func:`output_grid`).
    up : int
        Up factor ``p``.

    Returns
    -------
    Trajectory
        ``n_out`` pulses: slow times linear in ``u`` between input pulses, positions from
        the cubic spline over slow time (exact at whole ``u``).
    """
    grid = np.asarray(grid, dtype=np.int64)
    if up == 1:
        return Trajectory(
            positions_m=trajectory.positions_m[grid], slow_times_s=trajectory.slow_times_s[grid]
        )
    from scipy.interpolate import CubicSpline

    s_in = trajectory.slow_times_s
    whole, frac = np.divmod(grid, up)
    nxt = np.minimum(whole + 1, s_in.size - 1)
    s = s_in[whole] + (frac / up) * (s_in[nxt] - s_in[whole])
    pos = CubicSpline(s_in, trajectory.positions_m, axis=0)(s)
    on = frac == 0
    pos[on] = trajectory.positions_m[whole[on]]
    s[on] = s_in[whole[on]]
    return Trajectory(positions_m=pos, slow_times_s=s)
