"""Travel-time transformations and slow-time annihilators (paper ``sect:ANNIH``).

``T_+^{rho}`` (``eq:TT+``) maps the traces to the coordinates ``(s, t + dtau(s, rho))``
so that the trace of a stationary target at ``rho`` no longer depends on ``s``;
``T_+^{u,rho}`` (``eq:TTu+``) does the same for a target moving on ``rho + s u``.
Both are implemented as phase modulations of the phase history (``eq:FFT``, see
:func:`sarmotion.core.spectral.shift_fast_time`) with the carrier phase carried exactly, so
``T_- T_+`` is the identity to machine precision.

The annihilators act along slow time in the transformed frame: the paper's difference
``D_s`` (``eq:DiffOp``), its second difference ``D_s^2`` (used in ``eq:OBJ2``),
Savitzky-Golay smoothed derivatives for noisy data, and the projection that removes the
slow-time mean (an annihilator of ``s``-independent traces that leaves the other traces
in their own units, so that a separated ``S`` can be compared with the truth).

Composed differences and the ends of the aperture
-------------------------------------------------
``N`` composed two-point differences have an ``N + 1``-pulse stencil, so near the ends of
a finite aperture some pulses have no complete stencil (on Scene 1 the preliminary image
gives ``N = 100`` filters for 117 pulses). :func:`annihilate` therefore

* **alternates** forward and backward differences (filter ``k`` forward for even ``k``,
  backward for odd ``k``): the composition neither delays the traces (forward
  differences alone move them half a pulse each, 50 pulses for 100 filters) nor piles
  every incomplete stencil onto the last pulses; and
* at the one pulse where a difference has no neighbour (the last pulse of a forward
  difference, the first of a backward one) extrapolates the neighbouring rows
  quadratically (``3 d_{n-2} - 3 d_{n-3} + d_{n-4}``) in the frame of ``rho_o`` (the scene
  centre), where the traces near the centre vary slowly, instead of repeating the last
  difference in the filter's own frame, where the trace of any other target ``j`` turns
  by the phase of ``dtau_j - dtau_k`` from one pulse to the next. Like every other row it
  is a combination of differences, exactly zero on traces that do not depend on ``s`` in
  the filter's frame.

Of the end rows considered (forward differences only; alternated differences with the
last difference repeated in the filter's frame or in the frame of ``rho_o``, or
extrapolated in the frame of ``rho_o``), the last keeps the stationary residue lowest and
the movers' energy highest on every pulse, on Scene 1 and on seeded random scenes with
its movers (``tests/separation/test_transforms.py``; the table in ``docs/notes/separation.md``).
What remains is the end of the aperture, not the filter: ``N`` composed
differences on ``n`` pulses have only ``n - N`` complete stencils, and no choice of end
rows makes the others exact.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import (
    Acquisition,
    Traces,
    as_point,
    delay_phase,
    delta_tau,
    shift_fast_time,
    target_positions,
    to_fast_time,
    to_frequency,
)

__all__ = [
    "Annihilator",
    "travel_time_delays",
    "transform_plus",
    "transform_minus",
    "slow_time_difference",
    "annihilate",
]

Annihilator = Literal["difference", "difference2", "savgol", "mean"]


def travel_time_delays(
    traces: Acquisition | Traces, point_m: ArrayLike, *, velocity_mps: ArrayLike | None = None
) -> NDArray[np.float64]:
    """``dtau(s, rho + s u) = tau(s, rho + s u) - tau(s, rho_o)`` for every pulse (s).

    Parameters
    ----------
    traces : Acquisition or Traces
        Supplies the antenna positions, slow times and ``rho_o``.
    point_m : (2,) or (3,) array_like
        ``rho`` at ``s = 0`` (m).
    velocity_mps : (2,) array_like, optional
        Ground velocity ``u`` (m/s); ``None`` for a stationary point.

    Returns
    -------
    (n_pulses,) ndarray
        Delays (s).
    """
    rho = as_point(point_m, name="point_m")
    if velocity_mps is None:
        pts = rho
    else:
        pts = target_positions(rho, velocity_mps, traces.slow_times_s)
    return delta_tau(traces.positions_m, pts, traces.reference_point_m)


def transform_plus(
    traces: Traces, point_m: ArrayLike, *, velocity_mps: ArrayLike | None = None
) -> Traces:
    """``T_+^{rho}`` (``eq:TT+``) or ``T_+^{u,rho}`` (``eq:TTu+``).

    Computes ``D(s, t + dtau(s, rho + s u))``.

    Returns
    -------
    Traces
        Transformed traces (same axes); a target on ``rho + s u`` sits at ``t = 0`` with
        phase independent of ``s``.
    """
    delays = travel_time_delays(traces, point_m, velocity_mps=velocity_mps)
    return traces.with_data(
        shift_fast_time(traces.data, delays, frequencies_hz=traces.frequencies_hz)
    )


def transform_minus(
    traces: Traces, point_m: ArrayLike, *, velocity_mps: ArrayLike | None = None
) -> Traces:
    """``T_-^{rho}`` / ``T_-^{u,rho}``: the inverse of :func:`transform_plus`."""
    delays = travel_time_delays(traces, point_m, velocity_mps=velocity_mps)
    return traces.with_data(
        shift_fast_time(traces.data, -delays, frequencies_hz=traces.frequencies_hz)
    )


def slow_time_difference(
    data: ArrayLike,
    *,
    pulse_interval_s: float,
    kind: Annihilator = "difference",
    window: int = 7,
    direction: Literal["forward", "backward"] = "forward",
) -> NDArray[np.complex128]:
    """Annihilator along slow time (axis 0), shape preserved.

    Parameters
    ----------
    data : (n_pulses, n_samples) array_like
        Traces in a transformed frame.
    pulse_interval_s : float
        ``Delta s`` (s).
    kind : {"difference", "difference2", "savgol", "mean"}
        ``"difference"``: ``D_s`` of ``eq:DiffOp``, ``(x_{j+1} - x_j) / Delta s`` (forward;
        the last row is the difference of the last two pulses) or, with
        ``direction="backward"``, ``(x_j - x_{j-1}) / Delta s`` (the first row is the
        difference of the first two pulses). ``"difference2"``: ``D_s^2``,
        ``(x_{j+1} - 2 x_j + x_{j-1}) / Delta s^2`` (edge rows repeat their neighbour).
        ``"savgol"``: first derivative by a quadratic Savitzky-Golay filter over
        ``window`` pulses, a smoothed ``D_s`` for noisy data. ``"mean"``: ``x - mean_s x``,
        the orthogonal projection removing ``s``-independent traces (dimensionless).
    window : int
        Savitzky-Golay window length (odd, pulses).
    direction : {"forward", "backward"}
        Direction of ``"difference"`` (the other kinds ignore it).

    Returns
    -------
    (n_pulses, n_samples) ndarray
        Filtered traces; every kind maps an ``s``-independent trace to exactly zero.
    """
    x = np.asarray(data)
    if x.ndim != 2 or x.shape[0] < 3:
        raise ValueError(f"data must have shape (n_pulses >= 3, n_samples), got {x.shape}")
    if not pulse_interval_s > 0:
        raise ValueError(f"pulse_interval_s must be positive, got {pulse_interval_s!r}")
    ds = float(pulse_interval_s)
    if direction not in ("forward", "backward"):
        raise ValueError(f"direction must be 'forward' or 'backward', got {direction!r}")
    if kind == "difference":
        d = np.empty(x.shape, dtype=np.result_type(x.dtype, np.complex64))
        if direction == "forward":
            d[:-1] = (x[1:] - x[:-1]) / ds
            d[-1] = d[-2]
        else:
            d[1:] = (x[1:] - x[:-1]) / ds
            d[0] = d[1]
        return d
    if kind == "difference2":
        d = np.empty(x.shape, dtype=np.result_type(x.dtype, np.complex64))
        d[1:-1] = (x[2:] - 2 * x[1:-1] + x[:-2]) / ds**2
        d[0] = d[1]
        d[-1] = d[-2]
        return d
    if kind == "savgol":
        if window % 2 == 0 or window < 3 or window > x.shape[0]:
            raise ValueError(f"window must be odd, >= 3 and <= n_pulses, got {window}")
        from scipy.signal import savgol_filter  # ~0.5 s to import: only when needed

        re = savgol_filter(x.real, window, 2, deriv=1, delta=ds, axis=0, mode="interp")
        im = savgol_filter(x.imag, window, 2, deriv=1, delta=ds, axis=0, mode="interp")
        return re + 1j * im
    if kind == "mean":
        return x - x.mean(axis=0, keepdims=True)
    raise ValueError(f"kind must be 'difference', 'difference2', 'savgol' or 'mean', got {kind!r}")


def annihilate(
    traces: Traces,
    points_m: ArrayLike,
    *,
    velocities_mps: ArrayLike | None = None,
    kind: Annihilator = "difference",
    window: int = 7,
) -> Traces:
    """Annihilation filters ``Q^{rho}`` (``eq:OP1``) and ``Q^{u,rho}`` (``eq:OPu1``).

    Several filters compose as ``Q = Q^{rho_N} ... Q^{rho_1}`` (``eq:OP2``). With
    ``kind="difference"`` the filters alternate forward and backward differences and the
    end row of each is registered in the frame of ``rho_o`` (the module docstring says
    why, and what it measures): every row of every filter is a difference of two pulses,
    exact on traces that do not depend on ``s`` in the filter's frame.

    The travel-time shifts are diagonal in the phase history and the annihilator acts on
    slow time only, so ``Q`` is applied entirely in the frequency domain: one transform in
    and one out, whatever the number of filters. The differences are taken per pulse
    (``Delta s`` times ``D_s``): the constant ``1/Delta s`` of ``eq:DiffOp`` only rescales,
    and ``N`` composed filters would otherwise scale the data by ``Delta s^-N``.

    Composition works because ``D_s`` maps the trace of another target ``j``, shifted by
    a slowly varying ``dtau_j - dtau_k`` in the frame of ``k``, to approximately
    ``A f_p'`` with a nearly constant annihilation factor ``A`` (``eq:T2``, ``eq:T3``): a
    trace that the next filter can still annihilate. The ``"mean"`` projection does not
    have that property (it leaves a ghost of target ``j`` in the frame of ``k``) and is
    meant for a single filter.

    Parameters
    ----------
    traces : Traces
        Input traces.
    points_m : (2,) or (3,) or (n_filters, 2|3) array_like
        Estimated locations ``rho^e_k`` at ``s = 0`` (m), applied in order.
    velocities_mps : (2,) or (n_filters, 2) array_like, optional
        Estimated ground velocities ``u^e_k`` (m/s); ``None`` for stationary points.
    kind, window
        The slow-time annihilator, see :func:`slow_time_difference`.

    Returns
    -------
    Traces
        Filtered traces.
    """
    pts = np.atleast_2d(np.asarray(points_m, dtype=np.float64))
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise ValueError(f"points_m must have shape (n_filters, 2 or 3), got {np.shape(points_m)}")
    vels: list[ArrayLike | None]
    if velocities_mps is None:
        vels = [None] * len(pts)
    else:
        v = np.atleast_2d(np.asarray(velocities_mps, dtype=np.float64))
        if v.shape != (len(pts), 2):
            raise ValueError(
                f"velocities_mps must have shape ({len(pts)}, 2), got {np.shape(velocities_mps)}"
            )
        vels = list(v)
    f = traces.frequencies_hz
    spectrum = to_frequency(traces.data)
    for k, (p, v) in enumerate(zip(pts, vels, strict=True)):
        phase = delay_phase(travel_time_delays(traces, p, velocity_mps=v), f)
        forward = k % 2 == 0
        spectrum = slow_time_difference(
            spectrum * phase,
            pulse_interval_s=1.0,
            kind=kind,
            window=window,
            direction="forward" if forward else "backward",
        ) * np.conj(phase)
        if kind == "difference" and len(spectrum) >= 4:
            # the end row: quadratic extrapolation, in the frame of rho_o, of its neighbours
            if forward:
                spectrum[-1] = 3 * spectrum[-2] - 3 * spectrum[-3] + spectrum[-4]
            else:
                spectrum[0] = 3 * spectrum[1] - 3 * spectrum[2] + spectrum[3]
    return traces.with_data(to_fast_time(spectrum))
