"""Predicted ranks for a scene and an aperture, and the fast-time window of windowed RPCA.

:func:`predict_rank` counts the phase-space cells the scene's traces occupy;
:func:`predict_window_ranks` and :func:`predict_window` apply it window by window to
choose the fast-time window of a windowed robust PCA.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._validation import positive as _positive
from ...core import Radar, Trajectory
from .model import DEFAULT_CARRIER_HZ, Model, _check_model, _delays
from .numerical import _kappa

__all__ = ["predict_rank", "predict_window_ranks", "predict_window"]


# ---------------------------------------------------------------------- prediction
def _half_band(bandwidth_hz: float, eps: float, pulse: str) -> float:
    """Angular half-width (rad/s) of the band where ``|p_hat|^2 >= eps`` of its peak."""
    if pulse == "gaussian":
        return bandwidth_hz * _kappa(eps)
    if pulse == "rect":
        _kappa(eps)
        return np.pi * bandwidth_hz
    raise ValueError(f"pulse must be 'gaussian' or 'rect', got {pulse!r}")


def _half_duration(bandwidth_hz: float, eps: float, pulse: str) -> float:
    """Half-width (s) of the support where ``|p(t)|^2 >= eps``."""
    if pulse == "gaussian":
        return _kappa(eps) / bandwidth_hz
    if pulse == "rect":
        return 1.0 / (np.pi * bandwidth_hz * np.sqrt(eps))
    raise ValueError(f"pulse must be 'gaussian' or 'rect', got {pulse!r}")


def _union_components(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lengths of the connected components of the union of intervals ``[lo_i, hi_i]``."""
    if lo.size == 0:
        return np.zeros(0)
    order = np.argsort(lo)
    lo, hi = lo[order], hi[order]
    reach = np.maximum.accumulate(hi)
    start_new = np.concatenate([[True], lo[1:] > reach[:-1]])
    idx = np.flatnonzero(start_new)
    ends = np.concatenate([reach[idx[1:] - 1], [reach[-1]]])
    return ends - lo[idx]


def _circle_components(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lengths of the components of the union of arcs ``[lo_i, hi_i]`` on a circle of ``2 pi``."""
    two_pi = 2.0 * np.pi
    if lo.size == 0:
        return np.zeros(0)
    if np.any(hi - lo >= two_pi):
        return np.array([two_pi])
    start = np.mod(lo, two_pi)
    end = start + (hi - lo)
    order = np.argsort(start)
    start, end = start[order], end[order]
    reach = np.maximum.accumulate(end)
    idx = np.flatnonzero(np.concatenate([[True], start[1:] > reach[:-1]]))
    c_lo = start[idx]
    c_hi = np.concatenate([reach[idx[1:] - 1], [reach[-1]]])
    # Only the last component can pass 2 pi; it swallows the first ones it reaches.
    last_lo, last_hi = c_lo[-1], c_hi[-1]
    i = 0
    while i < c_lo.size - 1 and last_hi - two_pi >= c_lo[i]:
        last_hi = max(last_hi, c_hi[i] + two_pi)
        i += 1
    lengths = np.concatenate([c_hi[i:-1] - c_lo[i:-1], [last_hi - last_lo]])
    return np.array([two_pi]) if lengths.max() >= two_pi else lengths


class _ScenePhaseSpace:
    """Per-target Doppler arcs and delay intervals of a scene over an aperture."""

    def __init__(
        self,
        targets: Sequence[Any],
        trajectory: Trajectory,
        reference_point_m: ArrayLike,
        *,
        carrier_hz: float,
        bandwidth_hz: float,
        eps: float,
        model: str,
        pulse: str,
    ) -> None:
        _check_model(model)
        nu = _positive(carrier_hz, "carrier_hz")
        bw = _positive(bandwidth_hz, "bandwidth_hz")
        omega = _half_band(bw, eps, pulse)
        if omega >= 2 * np.pi * nu:
            raise ValueError("the pulse band must lie below the carrier (bandwidth_hz too large)")
        dtau, _ = _delays(targets, trajectory, reference_point_m)
        s = trajectory.slow_times_s
        n = trajectory.n_pulses
        ds = trajectory.pulse_interval_s
        rate = np.gradient(dtau, s, axis=1)
        w0 = 2.0 * np.pi * nu
        # theta = ds * (w0 + omega') * rate(s), omega' in [-omega, omega]: bilinear hull.
        corners = ds * np.stack(
            [
                (w0 - omega) * rate.min(axis=1),
                (w0 - omega) * rate.max(axis=1),
                (w0 + omega) * rate.min(axis=1),
                (w0 + omega) * rate.max(axis=1),
            ]
        )
        half_cell = np.pi / n  # half a slow-time frequency resolution cell 2 pi / n
        self.theta_lo = corners.min(axis=0) - half_cell
        self.theta_hi = corners.max(axis=0) + half_cell
        self.delay_lo = dtau.min(axis=1)
        self.delay_hi = dtau.max(axis=1)
        self.omega = omega
        self.n = n
        self.sides = 2 if model == "passband" else 1

    def count(
        self,
        mask: NDArray[np.bool_] | None = None,
        *,
        delays: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    ) -> float:
        """Phase-space count of the selected targets (see :func:`predict_rank` Notes).

        ``delays`` overrides the delay intervals ``(lo, hi)`` (s) of the fast-time count,
        e.g. clipped to a window.
        """
        sel = np.ones(self.theta_lo.size, bool) if mask is None else mask
        if not np.any(sel):
            return 0.0
        lo, hi = self.theta_lo[sel], self.theta_hi[sel]
        if self.sides == 2:
            lo, hi = np.concatenate([lo, -hi]), np.concatenate([hi, -lo])
        doppler = float(np.sum(np.ceil(self.n * _circle_components(lo, hi) / (2 * np.pi) - 1e-9)))
        dlo, dhi = (self.delay_lo[sel], self.delay_hi[sel]) if delays is None else delays
        half_cell = 0.5 * np.pi / self.omega  # half a delay cell pi / omega
        cells = self.omega * _union_components(dlo - half_cell, dhi + half_cell) / np.pi
        delay = self.sides * float(np.sum(np.ceil(cells - 1e-9)))
        return float(min(self.n, doppler, delay))


def _sub_trajectory(trajectory: Trajectory, n_pulses: int | None) -> Trajectory:
    if n_pulses is None:
        return trajectory
    if not (isinstance(n_pulses, (int, np.integer)) and 2 <= n_pulses <= trajectory.n_pulses):
        raise ValueError(
            f"n_pulses must be an integer in [2, {trajectory.n_pulses}], got {n_pulses!r}"
        )
    start = (trajectory.n_pulses - int(n_pulses)) // 2
    return trajectory.sub_aperture(start, start + int(n_pulses))


def predict_rank(
    targets: Sequence[Any],
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    *,
    n_pulses: int | None = None,
    bandwidth_hz: float,
    carrier_hz: float = DEFAULT_CARRIER_HZ,
    eps: float = 1e-3,
    model: Model = "baseband",
    pulse: Literal["gaussian", "rect"] = "gaussian",
) -> int:
    """Predicted numerical rank of the traces of a scene over an aperture.

    Parameters
    ----------
    targets : sequence
        Targets as accepted by :func:`passband_traces` (equal reflectivities assumed).
    trajectory : Trajectory
        Antenna positions and slow times.
    reference_point_m : (3,) array_like
        Reference point ``rho_o`` (m).
    n_pulses : int, optional
        Use the central ``n_pulses`` pulses of ``trajectory`` (a sub-aperture); default all.
    bandwidth_hz : float
        ``B`` (Hz).
    carrier_hz : float
        ``nu_o`` (Hz); default the GOTCHA carrier.
    eps : float
        Relative threshold in (0, 1) on the eigenvalues of ``Y`` (as in
        :func:`numerical_rank`).
    model : {"baseband", "passband"}
        Complex-baseband traces (the library's data) or the paper's real traces.
    pulse : {"gaussian", "rect"}
        Compressed-pulse spectrum (:class:`~sarmotion.core.radar.Radar` ``pulse``).

    Returns
    -------
    int
        Predicted rank, between 1 and the number of pulses.

    Notes
    -----
    Target ``q`` with delay ``dtau_q(s)`` (exact, over the aperture) is a 2-D signal whose
    phase-space support is counted two ways, each an approximate upper bound on the rank
    (Landau-Pollak-Slepian time-frequency counts; the Szegő count ``eq:RANK_AS`` is the
    first one for a single straight trace):

    * slow time: the trace's carrier and pulse band ``w_o + [-Omega, Omega]`` is seen in
      slow time at ``theta = ds (w_o + omega) dtau_q'(s)``; each target covers an arc
      ``Theta_q`` (the hull over the aperture, so curved traces count their Doppler
      sweep), widened by half a resolution cell ``pi / n`` on each side (``n`` pulses).
      The count is ``n |C| / (2 pi)``, rounded up, summed over the connected components
      ``C`` of ``U_q Theta_q`` on the circle (passband: with the mirror arcs
      ``-Theta_q``). For one straight trace this is ``n`` times the Szegő fraction
      (``eq:AS_RANK`` or its baseband form) plus one per bump, rounded up.
    * fast time: the delays ``U_q [min dtau_q, max dtau_q]`` (each interval widened by
      half a delay cell ``pi / (2 Omega)``) carry ``Omega |C| / pi`` band-limited degrees
      of freedom per connected component ``C``, rounded up (twice for passband).

    ``Omega`` is the angular half-width where ``|p_hat|^2 >= eps`` of its peak:
    ``B sqrt(log 1/eps)`` (Gaussian) or ``pi B`` (rect). The prediction is
    ``min(n, slow-time count, fast-time count)``, at least 1.

    Compared with the sum of per-target Szegő ranks (an upper bound by subadditivity),
    the union counts once the Doppler shared by targets of equal cross range and motion,
    and the fast-time count the delays shared by targets in the same range cell. The
    latter is where the paper's two-target argument fails: with ``B |beta| <~ 1``
    (``eq:beta``) the interaction terms of ``eq:covar2`` lower the rank by about the
    rank of the slower target, at every aperture tested (1 to 16 degrees), so the rank
    is close to that of the faster-migrating target, not to the sum given by the
    Toeplitz part ``eq:seqc``; for ``B |beta| >> 1`` the Toeplitz part is exact.
    Reflectivities are ignored, as in the paper's equal-reflectivity model (a target
    with ``|sigma|^2`` below ``eps`` times the strongest would not count numerically).
    """
    traj = _sub_trajectory(trajectory, n_pulses)
    ps = _ScenePhaseSpace(
        targets,
        traj,
        reference_point_m,
        carrier_hz=carrier_hz,
        bandwidth_hz=bandwidth_hz,
        eps=eps,
        model=model,
        pulse=pulse,
    )
    return int(max(1, np.ceil(ps.count() - 1e-9)))


def _window_starts(n_samples: int, window_samples: int) -> list[int]:
    hop = max(1, int(np.ceil(window_samples / 2)))
    starts = list(range(0, n_samples - window_samples + 1, hop))
    if starts[-1] != n_samples - window_samples:
        starts.append(n_samples - window_samples)
    return starts


class _WindowPredictor:
    """Predicted rank of the stationary traces in fast-time windows of a radar."""

    def __init__(
        self,
        stationary_positions_m: ArrayLike,
        trajectory: Trajectory,
        reference_point_m: ArrayLike,
        radar: Radar,
        eps: float,
    ) -> None:
        pos = np.asarray(stationary_positions_m, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] not in (2, 3) or pos.shape[0] == 0:
            raise ValueError(
                f"stationary_positions_m must have shape (n_targets, 2 or 3), got {pos.shape}"
            )
        if not isinstance(radar, Radar):
            raise TypeError(f"radar must be a Radar, got {type(radar).__name__}")
        self.ps = _ScenePhaseSpace(
            list(pos),
            trajectory,
            reference_point_m,
            carrier_hz=radar.carrier_hz,
            bandwidth_hz=radar.bandwidth_hz,
            eps=eps,
            model="baseband",
            pulse=radar.pulse,
        )
        self.n_samples = radar.n_samples
        self.dt = radar.sample_interval_s
        self.period = self.n_samples * self.dt
        self.half = _half_duration(radar.bandwidth_hz, eps, radar.pulse)
        # Delay intervals folded into the circular fast-time window [t0, t0 + period).
        self.t0 = float(radar.fast_times_s[0]) - 0.5 * self.dt
        mid = 0.5 * (self.ps.delay_lo + self.ps.delay_hi)
        shift = -np.floor((mid - self.t0) / self.period) * self.period
        self.d_lo = self.ps.delay_lo + shift
        self.d_hi = self.ps.delay_hi + shift

    def ranks(self, window_samples: int) -> NDArray[np.int64]:
        w = int(window_samples)
        out = []
        for k in _window_starts(self.n_samples, w):
            a, b = self.t0 + k * self.dt, self.t0 + (k + w) * self.dt
            lo, hi, inside = [], [], np.zeros(self.d_lo.size, bool)
            for sh in (-self.period, 0.0, self.period):
                hit = (self.d_lo + sh - self.half < b) & (self.d_hi + sh + self.half > a)
                inside |= hit
                lo.append(np.clip(self.d_lo[hit] + sh, a, b))
                hi.append(np.clip(self.d_hi[hit] + sh, a, b))
            r = 0.0
            if np.any(inside):
                r = self.ps.count(inside, delays=(np.concatenate(lo), np.concatenate(hi)))
            out.append(int(min(np.ceil(r - 1e-9), w)))
        return np.array(out, dtype=np.int64)


def predict_window_ranks(
    stationary_positions_m: ArrayLike,
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    radar: Radar,
    *,
    window_samples: int,
    eps: float = 1e-3,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Predicted rank of the stationary traces in each fast-time window.

    Windows of ``window_samples`` samples tile the fast-time axis of ``radar`` with hop
    ``ceil(window_samples / 2)``, the last one ending at the last sample. A target is in
    a window when its delay interval over the aperture, widened by the pulse
    half-duration where ``|p|^2 >= eps`` (``sqrt(log 1/eps) / B`` Gaussian,
    ``1 / (pi B sqrt(eps))`` rect), meets the window (circularly, as the simulator wraps
    fast time). The rank is :func:`predict_rank`'s phase-space count (baseband model) of
    those targets, with the fast-time count on their delays clipped to the window,
    capped at ``window_samples``.

    Parameters
    ----------
    stationary_positions_m : (n_targets, 2) or (n_targets, 3) array_like
        Stationary target positions (m).
    trajectory : Trajectory
        Antenna positions and slow times.
    reference_point_m : (3,) array_like
        Reference point ``rho_o`` (m).
    radar : Radar
        Carrier, bandwidth, pulse shape, ``n_samples`` and ``dt``.
    window_samples : int
        Window length ``W`` (samples), ``1 <= W <= n_samples``.
    eps : float
        Relative rank threshold in (0, 1).

    Returns
    -------
    starts : (n_windows,) ndarray of int
        First sample of each window.
    ranks : (n_windows,) ndarray of int
        Predicted rank in each window.
    """
    if not (isinstance(window_samples, (int, np.integer)) and 1 <= window_samples):
        raise ValueError(f"window_samples must be a positive integer, got {window_samples!r}")
    if window_samples > radar.n_samples:
        raise ValueError(
            f"window_samples ({window_samples}) exceeds radar.n_samples ({radar.n_samples})"
        )
    wp = _WindowPredictor(stationary_positions_m, trajectory, reference_point_m, radar, eps)
    starts = np.array(_window_starts(radar.n_samples, int(window_samples)), dtype=np.int64)
    return starts, wp.ranks(int(window_samples))


def predict_window(
    stationary_positions_m: ArrayLike,
    trajectory: Trajectory,
    reference_point_m: ArrayLike,
    radar: Radar,
    *,
    max_rank_fraction: float = 0.1,
    relative_to: Literal["pulses", "min"] = "pulses",
    eps: float = 1e-3,
) -> int:
    """Fast-time window length (samples) for a windowed robust PCA.

    Rule: windows of ``W`` samples tile fast time at hop ``ceil(W / 2)``
    (:func:`predict_window_ranks`); ``W`` is acceptable when the predicted rank ``r`` of
    the stationary traces in every window satisfies

    * ``relative_to="pulses"`` (default): ``max r(W) <= max_rank_fraction * n_pulses``
      -- the stationary part is low rank with respect to the slow-time dimension;
    * ``relative_to="min"``: ``max r(W) <= max_rank_fraction * min(n_pulses, W)`` -- the
      robust-PCA recovery condition on the smaller dimension of the ``n_pulses x W``
      window (stricter for ``W < n_pulses``).

    The largest acceptable ``W`` between one pulse length (``2 x`` the half-duration
    where ``|p|^2 >= eps``) and ``n_samples`` is returned; if none is acceptable, the
    ``W`` with the smallest worst-case ratio (ties: the longest), the best the scene
    allows. Short windows always satisfy the first form since a window of ``W`` samples
    holds at most ``~ W B dt sqrt(log 1/eps) / pi + 1`` degrees of freedom; under the
    second form the ratio is roughly the number of stationary targets per fast-time
    sample, which windowing cannot lower once ``W < n_pulses``.

    Parameters
    ----------
    stationary_positions_m : (n_targets, 2) or (n_targets, 3) array_like
        Positions of the (known or imaged) stationary targets (m).
    trajectory : Trajectory
        Antenna positions and slow times of the data.
    reference_point_m : (3,) array_like
        Reference point ``rho_o`` (m).
    radar : Radar
        Carrier, bandwidth, pulse shape and fast-time sampling ``dt`` of the data.
    max_rank_fraction : float
        Admissible rank as a fraction of ``n_pulses`` (or ``min(n_pulses, W)``), in (0, 1].
    relative_to : {"pulses", "min"}
        Which dimension the admissible rank refers to.
    eps : float
        Relative rank threshold in (0, 1).

    Returns
    -------
    int
        Window length ``W`` in fast-time samples.
    """
    if not (0.0 < max_rank_fraction <= 1.0):
        raise ValueError(f"max_rank_fraction must be in (0, 1], got {max_rank_fraction!r}")
    if relative_to not in ("pulses", "min"):
        raise ValueError(f"relative_to must be 'pulses' or 'min', got {relative_to!r}")
    wp = _WindowPredictor(stationary_positions_m, trajectory, reference_point_m, radar, eps)
    n = trajectory.n_pulses
    n_samp = wp.n_samples
    w_min = max(1, min(n_samp, int(np.ceil(2 * wp.half / wp.dt))))
    chosen, best_w, best_ratio = None, w_min, np.inf
    for w in range(w_min, n_samp + 1):
        ratio = float(wp.ranks(w).max()) / (n if relative_to == "pulses" else min(n, w))
        if ratio <= max_rank_fraction:
            chosen = w
        if ratio <= best_ratio:
            best_w, best_ratio = w, ratio
    return int(chosen if chosen is not None else best_w)
