"""Phase-space (Wigner-transform) motion estimation of a separated mover (paper ``sect:numeric``).

The trajectory errors of the paper's ``fig:motEstscatt`` come from the phase-space
algorithm of its reference ``[sar]`` (Borcea, Callaghan, Papanicolaou, Inverse Problems
28 (2012) 045006): given the target's location at one moment (the aperture centre
``s = 0``) and its separated traces, the motion is estimated over successive short
sub-apertures from the Wigner transform of the data. Only the abstract of ``[sar]`` was
available (segmentation into small apertures, preliminary motion estimation from the data
with the Wigner transform); the algorithm below is derived from first principles in the
Notes.

:func:`wigner_slow_time` is the discrete pseudo-Wigner(-Ville) transform of a slow-time
signal, :func:`wigner_ridge` its ridge (instantaneous Doppler), :func:`estimate_trajectory`
the motion estimation and :func:`trajectory_error` the error ``|rho^e(s) - rho(s)|`` of
``fig:motEstscatt``.

Notes
-----
**Signal along the hypothesised travel time.** A unit point on ``rho(s)`` gives the
baseband trace ``D(s, t) = p(t - dtau(s)) exp(-i w_o dtau(s))``, ``dtau = 2 (R(s) -
R_o(s)) / c``, ``R(s) = |r(s) - rho(s)|`` (see :mod:`sarmotion.core.spectral`). Shifting each
pulse by the delay ``dtau_g(s)`` of a hypothesised path ``rho_g(s)`` (``T_+^{u,rho}``,
carrier phase included) leaves::

    D_g(s, t) = p(t - dtau(s) + dtau_g(s)) exp(-i w_o (dtau(s) - dtau_g(s))),

so that the samples ``g(s) = D_g(s, t_c)`` near the trace (``|t_c| < 1/B``) are a
slow-time signal ``a(s) exp(i phi(s))`` with a slowly varying amplitude and phase
``phi(s) = -(2 w_o / c) (R(s) - R_g(s))``.

**Wigner transform and instantaneous Doppler.** ``W(s, xi) = int g(s + y/2) conj(g(s -
y/2)) exp(-i xi y) dy``. Expanding ``phi(s +- y/2) = phi(s) +- phi'(s) y/2 + phi''(s)
y^2/8 +- O(y^3)``, the quadratic terms cancel in the product, so for a phase that is
quadratic over the lag window ``g(s + y/2) conj(g(s - y/2)) = a(s + y/2) a(s - y/2)
exp(i phi'(s) y)``. With a lag window ``h(y)``, the pseudo-Wigner transform is then
``K(xi - phi'(s))`` with ``K`` the Fourier transform of the real, even, and (for a
positive amplitude) positive ``h(y) a(s + y/2) a(s - y/2)``: it is symmetric about
``xi = phi'(s)`` and largest there, exactly, whatever the (positive) amplitude; an
amplitude that changes sign breaks this. In Hz the ridge is the instantaneous Doppler
``f_D(s) = phi'(s) / (2 pi) = -(2 nu_o / c) (R'(s) - R_g'(s))``, whence the range rate
of the target::

    R'(s) = R_g'(s) - (lambda_o / 2) f_D(s),          lambda_o = c / nu_o.     (1)

**Velocity from range rates.** ``R'(s) = m(s) . (r'(s) - u)`` with ``m = (r - rho) /
|r - rho|`` the unit vector from the target to the antenna. On a sub-aperture ``k``
the target moves on a straight line ``rho(s) = rho(a_k) + (s - a_k) u_k`` with a
horizontal ``u_k``. The level of ``R'`` over the sub-aperture gives the projection
``m . u_k`` of the velocity on the look direction; its slope ``R'' = |P (r' - u)|^2 /
R + m . r''`` (``P = I - m m^T``) gives the component across it, the paper's
observation that the curvature of a trace is set by the speed projected on the plane
orthogonal to ``m_o`` (``sect:ANNIH``). ``u_k`` is the weighted least-squares fit of
(1) over the pulses of the sub-aperture, by Gauss-Newton with the Jacobian::

    dR'/du = -m - (s - a_k) P (r' - u) / R              (horizontal components).

**Marching from the known position.** ``rho(0)`` is known. The central sub-aperture
(around ``s = 0``) is anchored there; each following sub-aperture, outwards in both
directions, is anchored at the knot ``a_k`` between it and its inner neighbour, at the
position given by the neighbour's line. The estimate ``rho^e(s)`` is continuous and
piecewise linear, with ``rho^e(0) = rho(0)``: the trajectory error vanishes at ``s = 0``
and accumulates outwards. In each sub-aperture the hypothesis starts from the inner
neighbour's velocity and is updated by (1) until the velocity changes by less than
``tol_mps``; the final ridge is then close to zero Doppler.

**Discretisation and ambiguity.** With pulses every ``ds`` the pseudo-Wigner transform
with a lag window ``h`` of ``L`` pulses is ``W[n, f] = sum_k h_k g[n + k] conj(g[n - k])
exp(-4 i pi f k ds)`` (lags ``y = 2 k ds``): its Doppler axis is unambiguous only over
``1 / (2 ds)``, i.e. ``|f - f_c| < 1 / (4 ds)``. The centre ``f_c`` is the pulse-pair
(lag-one) mean Doppler, itself unambiguous over ``|f_c| < 1 / (2 ds)``. The hypothesis
must therefore predict the range rate within ``lambda_o / (4 ds)`` (0.52 m/s for
GOTCHA): a Doppler aliased by ``1 / ds`` is a range rate off by ``lambda_o / (2 ds)``
whose range walk then betrays it in fast time (:attr:`TrajectoryEstimate.range_offset_m`
drifts). The first hypothesis comes from the range walk itself, which is unambiguous:
the range speed along the ground look direction that maximises the energy of the
fast-time envelope along the hypothesised travel times (a line integral of
``|D|^2``, coarse to about 0.1 m/s), unless a ``velocity_guess_mps`` is given.

**Fast time.** The Wigner transforms of the ``2 fast_time_halfwidth + 1`` samples
around the trace are summed (an energy-weighted, incoherent combination). The trace is
centred on the maximum of the sub-aperture's fast-time energy profile within
``fast_time_search`` samples of the hypothesised travel time; that offset is kept as a
diagnostic (:attr:`TrajectoryEstimate.range_offset_m`) and is not used as range
information: the algorithm uses the phase only, anchored by ``rho(0)``.

**Annihilation-filtered traces.** The forward difference ``D_s`` of ``eq:DiffOp``
applied in the frame of a stationary point ``rho_p`` maps the mover's trace to ``(x(s +
ds) - x(s)) = 2 i sin(theta/2) x(s + ds/2)`` with ``theta`` its phase increment per
pulse in that frame: pulse ``s`` keeps the mover's phase history but shows it as it was
at ``s + ds/2``, with a slowly varying positive amplitude ``|2 sin(theta/2)|`` (zero
only at blind speeds, ``theta`` a multiple of ``2 pi``) times a constant phase. The
filters of :func:`~sarmotion.separation.annihilate` alternate forward and backward
differences; a backward difference shows the mover as at ``s - ds/2``, so after an even
number ``N`` of filters (odd: half a pulse) whose stationary points have range rates close
to that of ``rho_o`` the separated trace is the mover as at ``s``, not displaced in range
(forward differences alone would shift it by ``N ds R' / 2``: -1.0 m for ``filter10``,
-3.1 m for ``filter30``, ``R' = -13.8`` m/s). The Wigner ridge is insensitive to the
amplitude. With every pulse's stencil complete (the scene simulated ``ceil(N/2)`` pulses
beyond each end of its aperture and cropped) the trajectory errors are 0.015 m
(``filter10``) and 0.023 m (``filter30``): the residues of more filters accumulate. On the
scenes' own 117 pulses the ``ceil(N/2)`` end pulses at each end lack a complete stencil,
keep some stationary energy (-27.2 and -50.2 dB per pulse re the mover) and dominate the
error (0.484 and 0.115 m).

**Defaults** were chosen by measurement on the ``filter10`` and ``filter30`` separated
traces and on the clean ``filter10`` mover with noise at -10 and -20 dB (four seeds):
sub-apertures of 31 pulses (0.46 s) with a 61-pulse Hann lag window and 3 fast-time
samples. Shorter sub-apertures determine the cross-range velocity poorly (the slope of
``R'`` over a sub-aperture of length ``T`` is ``~ 2 (V - u_perp) T / L`` per m/s of
cross-range speed: 5 mm/s for ``T = 0.46`` s), wider fast-time windows add noise.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import (
    C,
    Traces,
    as_point,
    delta_tau,
    look_geometry,
    range_direction_velocity,
    shift_fast_time,
    to_fast_time,
    to_frequency,
)
from ..errors import EstimationError
from .wigner import _check_lag_window, wigner_ridge

#: Fast-time oversampling of the envelope in the coarse range-walk search.
_ENVELOPE_OVERSAMPLING = 4

__all__ = ["TrajectoryEstimate", "estimate_trajectory", "trajectory_error"]


log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True, eq=False)
class TrajectoryEstimate:
    """A mover's trajectory estimated by :func:`estimate_trajectory`.

    The estimate is continuous and piecewise linear: straight on each sub-aperture, with
    ``positions_m`` equal to the given position at ``s = 0``.

    Attributes
    ----------
    slow_times_s : (n_pulses,) ndarray
        Slow times ``s`` (s).
    positions_m : (n_pulses, 3) ndarray
        Estimated positions ``rho^e(s)`` (m).
    position_at_zero_m : (3,) ndarray
        The known position ``rho(0)`` (m) that anchors the estimate.
    sub_aperture_pulses : (n_sub, 2) ndarray of int
        Pulse ranges ``[start, stop)`` of the sub-apertures, in slow-time order.
    knot_times_s : (n_sub, 2) ndarray
        Slow times (s) bounding each straight segment (mid-way between pulses, or the
        aperture ends).
    velocities_mps : (n_sub, 2) ndarray
        Ground velocity ``u_k`` (m/s) of each sub-aperture.
    range_rate_mps : (n_pulses,) ndarray
        Range rate ``R'(s) = d/ds |r(s) - rho(s)|`` (m/s) measured from the Wigner ridge
        (eq. (1) of the module Notes), in the last iteration of each sub-aperture.
    residual_doppler_hz : (n_pulses,) ndarray
        Wigner ridge (Hz) in the frame of the final hypothesis of the last iteration
        (near zero when converged; meaningless where ``ridge_weight`` is small).
    ridge_weight : (n_pulses,) ndarray
        Least-squares weight of each pulse: the ridge curvature, normalised to 1 in
        its sub-aperture.
    range_offset_m : (n_sub,) ndarray
        Range offset (m) of the trace from the hypothesised travel time, from the
        fast-time sample holding its energy (``c t / 2``; one sample is
        ``c / (2 span)``). Near zero for a mover's own traces; the annihilation filter
        shifts it (module Notes).
    initial_velocity_mps : (2,) ndarray
        The first hypothesis (m/s): ``velocity_guess_mps`` or the range-walk estimate.
    n_iter : (n_sub,) ndarray of int
        Iterations used in each sub-aperture.
    converged : (n_sub,) ndarray of bool
        Whether the velocity update fell below ``tol_mps`` within ``max_iter``.
    """

    slow_times_s: NDArray[np.float64]
    positions_m: NDArray[np.float64]
    position_at_zero_m: NDArray[np.float64]
    sub_aperture_pulses: NDArray[np.int64]
    knot_times_s: NDArray[np.float64]
    velocities_mps: NDArray[np.float64]
    range_rate_mps: NDArray[np.float64]
    residual_doppler_hz: NDArray[np.float64]
    ridge_weight: NDArray[np.float64]
    range_offset_m: NDArray[np.float64]
    initial_velocity_mps: NDArray[np.float64]
    n_iter: NDArray[np.int64]
    converged: NDArray[np.bool_]

    @property
    def n_sub_apertures(self) -> int:
        """Number of sub-apertures."""
        return int(self.sub_aperture_pulses.shape[0])


def _sub_apertures(slow_times_s: NDArray[np.float64], size: int) -> list[tuple[int, int]]:
    """Blocks of ``size`` pulses, the first centred on ``s = 0``, short end blocks merged."""
    n = slow_times_s.size
    centre = int(np.argmin(np.abs(slow_times_s)))
    start = min(max(0, centre - size // 2), max(0, n - size))
    blocks = [(start, min(n, start + size))]
    lo = start
    while lo > 0:
        a = max(0, lo - size)
        if 0 < a < size // 2:
            a = 0
        blocks.insert(0, (a, lo))
        lo = a
    hi = blocks[-1][1]
    while hi < n:
        b = min(n, hi + size)
        if n - b < size // 2:
            b = n
        blocks.append((hi, b))
        hi = b
    return blocks


def _range_rate_and_jacobian(
    pos: NDArray, vplat: NDArray, rho: NDArray, u3: NDArray, ds_from_anchor: NDArray
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``R' = m . (r' - u)`` and ``dR'/du`` (horizontal), for ``rho = rho_a + (s - a) u``."""
    d = pos - rho
    rng = np.linalg.norm(d, axis=1)
    m = d / rng[:, None]
    rel = vplat - u3[None, :]
    rate = np.sum(m * rel, axis=1)
    p_rel = rel - rate[:, None] * m  # P (r' - u)
    jac = -m[:, :2] - (ds_from_anchor / rng)[:, None] * p_rel[:, :2]
    return rate, jac


def _coarse_range_speed(
    traces: Traces, rho0: NDArray[np.float64], *, max_range_speed_mps: float, search: int
) -> NDArray[np.float64]:
    """Ground velocity along ``b_o`` whose range walk holds the most envelope energy."""
    q = _ENVELOPE_OVERSAMPLING
    s = traces.slow_times_s
    pos = traces.positions_m
    ref = traces.reference_point_m
    f = traces.frequencies_hz
    base = delta_tau(pos, rho0, ref)
    spec = to_frequency(shift_fast_time(traces.data, base, frequencies_hz=f))
    ns = traces.n_samples
    pad = np.zeros((traces.n_pulses, q * ns), dtype=np.complex128)
    pad[:, (q * ns) // 2 - ns // 2 : (q * ns) // 2 - ns // 2 + ns] = spec
    env = np.abs(to_fast_time(pad)) ** 2  # fine step dt / q, t = 0 at q ns // 2
    dt_fine = traces.radar.sample_interval_s / q
    geo = look_geometry(traces.trajectory, rho0)
    step = 0.1
    speeds = np.arange(-max_range_speed_mps, max_range_speed_mps + step / 2, step)
    offsets = np.arange(-q * search, q * search + 1)
    rows = np.arange(traces.n_pulses)[:, None]

    def line_energy(ur: float) -> float:
        v = range_direction_velocity(ur, geo)
        pts = rho0[None, :] + s[:, None] * np.array([v[0], v[1], 0.0])[None, :]
        shift = np.rint((delta_tau(pos, pts, ref) - base) / dt_fine).astype(np.int64)
        idx = np.clip((q * ns) // 2 + shift[:, None] + offsets[None, :], 0, q * ns - 1)
        return float(env[rows, idx].sum(axis=0).max())

    energy = np.array([line_energy(u) for u in speeds])
    j = int(np.argmax(energy))
    ur = float(speeds[j])
    if 0 < j < speeds.size - 1:
        y0, y1, y2 = energy[j - 1 : j + 2]
        den = y0 - 2.0 * y1 + y2
        if den < 0:
            ur += 0.5 * step * (y0 - y2) / den
    return range_direction_velocity(ur, geo)


def estimate_trajectory(
    traces: Traces,
    position_m: ArrayLike,
    *,
    velocity_guess_mps: ArrayLike | None = None,
    sub_aperture_pulses: int = 31,
    lag_window_pulses: int | None = None,
    fast_time_halfwidth: int = 1,
    fast_time_search: int = 24,
    window: str = "hann",
    max_iter: int = 6,
    tol_mps: float = 1e-3,
    max_range_speed_mps: float = 40.0,
) -> TrajectoryEstimate:
    """Estimate a mover's trajectory from its traces and its position at ``s = 0``.

    The phase-space algorithm derived in the module Notes: on successive sub-apertures,
    marching outwards from ``s = 0``, the traces are shifted to a hypothesised straight
    path, the Wigner ridge of the samples along it gives the range rate, and the range
    rates give the sub-aperture's ground velocity; positions follow by integration from
    the known ``rho(0)``.

    Parameters
    ----------
    traces : Traces
        The mover's (separated) traces; remnants of other targets may remain.
    position_m : (2,) or (3,) array_like
        The mover's position ``rho(0)`` at ``s = 0`` (m).
    velocity_guess_mps : (2,) array_like, optional
        First hypothesis for the ground velocity (m/s); its range speed must be right
        within ``lambda_o / (4 ds)``. Default: the range-walk search.
    sub_aperture_pulses : int
        Pulses per sub-aperture (``>= 5``); the end sub-apertures absorb remainders
        shorter than half this.
    lag_window_pulses : int, optional
        Wigner lag window (odd, pulses). Default: ``2 sub_aperture_pulses - 1``, so that
        the ridge at the edge of a sub-aperture still sees its whole length.
    fast_time_halfwidth : int
        The Wigner transforms of ``2 fast_time_halfwidth + 1`` fast-time samples around
        the trace are summed.
    fast_time_search : int
        The trace is looked for within this many fast-time samples of the hypothesised
        travel time (also the range of the range-walk search).
    window : str
        Wigner lag window, see :func:`wigner_slow_time`.
    max_iter : int
        Maximum number of hypothesis updates per sub-aperture.
    tol_mps : float
        Stopping rule: ``|u_k^(i+1) - u_k^(i)| < tol_mps`` (m/s).
    max_range_speed_mps : float
        Range-walk search interval ``|u . m_o| <= max_range_speed_mps`` (m/s).

    Returns
    -------
    TrajectoryEstimate
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces, got {type(traces).__name__}")
    rho0 = as_point(position_m, name="position_m")
    size, lw, hw, search = _check_trajectory_options(
        traces,
        sub_aperture_pulses=sub_aperture_pulses,
        lag_window_pulses=lag_window_pulses,
        fast_time_halfwidth=fast_time_halfwidth,
        fast_time_search=fast_time_search,
        max_iter=max_iter,
        tol_mps=tol_mps,
        max_range_speed_mps=max_range_speed_mps,
    )
    if velocity_guess_mps is None:
        u_init = _coarse_range_speed(
            traces, rho0, max_range_speed_mps=max_range_speed_mps, search=search
        )
    else:
        u_init = np.asarray(velocity_guess_mps, dtype=np.float64)
        if u_init.shape != (2,) or not np.all(np.isfinite(u_init)):
            raise ValueError(
                "velocity_guess_mps must be a finite (2,) ground velocity (m/s), "
                f"got {velocity_guess_mps!r}"
            )
    log.debug("initial velocity %s m/s", u_init)
    march = _March(
        traces,
        size=size,
        lag_window=lw,
        halfwidth=hw,
        search=search,
        window=window,
        max_iter=max_iter,
        tol_mps=tol_mps,
    )
    march.run(rho0, u_init)
    if not march.converged.all():
        log.warning(
            "trajectory estimate: %d of %d sub-apertures did not converge",
            int((~march.converged).sum()),
            march.converged.size,
        )
    return TrajectoryEstimate(
        slow_times_s=march.s.copy(),
        positions_m=march.positions,
        position_at_zero_m=rho0,
        sub_aperture_pulses=np.array(march.blocks, dtype=np.int64),
        knot_times_s=march.knots,
        velocities_mps=march.velocities,
        range_rate_mps=march.rate,
        residual_doppler_hz=march.residual,
        ridge_weight=march.weight,
        range_offset_m=march.offset,
        initial_velocity_mps=np.asarray(u_init, dtype=np.float64),
        n_iter=march.n_iter,
        converged=march.converged,
    )


def _check_trajectory_options(
    traces: Traces,
    *,
    sub_aperture_pulses: int,
    lag_window_pulses: int | None,
    fast_time_halfwidth: int,
    fast_time_search: int,
    max_iter: int,
    tol_mps: float,
    max_range_speed_mps: float,
) -> tuple[int, int, int, int]:
    """Validate the options of :func:`estimate_trajectory`: ``(size, lag, halfwidth, search)``."""
    n = traces.n_pulses
    size = int(sub_aperture_pulses)
    if size != sub_aperture_pulses or not 5 <= size <= n:
        # a valid option that these traces are too short for: no estimate, not bad input
        too_short = size == sub_aperture_pulses and size >= 5
        raise (EstimationError if too_short else ValueError)(
            f"sub_aperture_pulses must be an integer in [5, {n}], got {sub_aperture_pulses!r}"
        )
    lw = 2 * size - 1 if lag_window_pulses is None else _check_lag_window(lag_window_pulses, n)
    hw = int(fast_time_halfwidth)
    search = int(fast_time_search)
    if hw < 0 or hw != fast_time_halfwidth:
        raise ValueError(
            f"fast_time_halfwidth must be an integer >= 0, got {fast_time_halfwidth!r}"
        )
    if search < hw or search != fast_time_search or traces.n_samples // 2 - search - hw < 0:
        # a valid option whose search runs past the end of the traces' fast-time window
        past_edge = search >= hw and search == fast_time_search
        raise (EstimationError if past_edge else ValueError)(
            f"fast_time_search must be an integer in [{hw}, {traces.n_samples // 2 - hw}], "
            f"got {fast_time_search!r}"
        )
    if max_iter < 1:
        raise ValueError(f"max_iter must be >= 1, got {max_iter!r}")
    if not tol_mps > 0:
        raise ValueError(f"tol_mps must be positive (m/s), got {tol_mps!r}")
    if not max_range_speed_mps > 0:
        raise ValueError(f"max_range_speed_mps must be positive (m/s), got {max_range_speed_mps!r}")
    return size, lw, hw, search


class _March:
    """The sub-aperture march of :func:`estimate_trajectory`, outwards from ``s = 0``.

    Holds the geometry of the traces and fills, sub-aperture by sub-aperture, the
    positions, range rates, residual Dopplers and ridge weights per pulse, and the
    velocity, range offset, iteration count and convergence per sub-aperture.
    """

    def __init__(
        self,
        traces: Traces,
        *,
        size: int,
        lag_window: int,
        halfwidth: int,
        search: int,
        window: str,
        max_iter: int,
        tol_mps: float,
    ) -> None:
        self.traces = traces
        self.lw, self.hw, self.search, self.window = lag_window, halfwidth, search, window
        self.max_iter, self.tol_mps = max_iter, tol_mps
        n = traces.n_pulses
        self.s = s = traces.slow_times_s
        self.pos = traces.positions_m
        self.vplat = np.gradient(self.pos, s, axis=0)
        self.half_lambda = 0.5 * C / traces.radar.carrier_hz
        self.c0 = traces.n_samples // 2
        self.margin = (lag_window - 1) // 2
        self.blocks = _sub_apertures(s, size)
        self.knots = np.array(
            [
                [
                    s[0] if i0 == 0 else 0.5 * (s[i0 - 1] + s[i0]),
                    s[-1] if i1 == n else 0.5 * (s[i1 - 1] + s[i1]),
                ]
                for i0, i1 in self.blocks
            ]
        )
        nb = len(self.blocks)
        self.positions = np.zeros((n, 3))
        self.rate = np.zeros(n)
        self.residual = np.zeros(n)
        self.weight = np.zeros(n)
        self.velocities = np.zeros((nb, 2))
        self.offset = np.zeros(nb)
        self.n_iter = np.zeros(nb, dtype=np.int64)
        self.converged = np.zeros(nb, dtype=bool)

    def run(self, rho0: NDArray[np.float64], u_init: NDArray[np.float64]) -> None:
        """Solve the central sub-aperture from ``rho(0)``, then march outwards both ways."""
        s, blocks, knots, vel = self.s, self.blocks, self.knots, self.velocities
        centre = next(k for k, (i0, i1) in enumerate(blocks) if i0 <= np.argmin(np.abs(s)) < i1)
        self.solve(centre, 0.0, rho0, u_init)
        for k in range(centre + 1, len(blocks)):  # outwards, s > 0
            a, inner = knots[k, 0], blocks[k - 1][1] - 1
            anchor = self.positions[inner] + (a - s[inner]) * np.append(vel[k - 1], 0.0)
            self.solve(k, a, anchor, vel[k - 1])
        for k in range(centre - 1, -1, -1):  # outwards, s < 0
            a, inner = knots[k, 1], blocks[k + 1][0]
            anchor = self.positions[inner] + (a - s[inner]) * np.append(vel[k + 1], 0.0)
            self.solve(k, a, anchor, vel[k + 1])

    def solve(
        self, k: int, anchor_s: float, anchor_m: NDArray[np.float64], u_start: NDArray
    ) -> None:
        """Iterate sub-aperture ``k``'s velocity from ``u_start``; store its results."""
        i0, i1 = self.blocks[k]
        u = np.array(u_start, dtype=np.float64)
        it, done = 0, False
        while it < self.max_iter:
            it += 1
            measured, fd, wts, tc = self._measure(k, anchor_s, anchor_m, u)
            u_new = self._fit_velocity(k, anchor_s, anchor_m, u, measured, wts)
            done = bool(np.linalg.norm(u_new - u) < self.tol_mps)
            u = u_new
            if done:
                break
        u3 = np.array([u[0], u[1], 0.0])
        self.positions[i0:i1] = anchor_m[None, :] + (self.s[i0:i1, None] - anchor_s) * u3[None, :]
        self.rate[i0:i1] = measured
        self.residual[i0:i1] = fd
        self.weight[i0:i1] = wts
        self.velocities[k] = u
        self.offset[k] = 0.5 * C * (tc - self.c0) * self.traces.radar.sample_interval_s
        self.n_iter[k] = it
        self.converged[k] = done

    def _measure(
        self, k: int, anchor_s: float, anchor_m: NDArray[np.float64], u: NDArray[np.float64]
    ) -> tuple[NDArray, NDArray, NDArray, int]:
        """Range rates measured on the Wigner ridge along the hypothesised path.

        Returns the measured range rates (m/s), the ridge Doppler (Hz) and weights of
        the sub-aperture's pulses, and the fast-time sample of the trace.
        """
        tr, s, pos, c0, hw, search = self.traces, self.s, self.pos, self.c0, self.hw, self.search
        n = tr.n_pulses
        i0, i1 = self.blocks[k]
        e0, e1 = max(0, i0 - self.margin), min(n, i1 + self.margin)
        own = slice(i0 - e0, i1 - e0)
        u3 = np.array([u[0], u[1], 0.0])
        path = anchor_m[None, :] + (s[e0:e1, None] - anchor_s) * u3[None, :]
        shifted = shift_fast_time(
            tr.data[e0:e1],
            delta_tau(pos[e0:e1], path, tr.reference_point_m),
            frequencies_hz=tr.frequencies_hz,
        )
        profile = np.sum(np.abs(shifted[own, c0 - search - hw : c0 + search + hw + 1]) ** 2, axis=0)
        box = np.convolve(profile, np.ones(2 * hw + 1), mode="valid")
        tc = c0 - search + int(np.argmax(box))
        ridge = wigner_ridge(
            shifted[:, tc - hw : tc + hw + 1],
            pulse_interval_s=tr.trajectory.pulse_interval_s,
            lag_window_pulses=self.lw,
            window=self.window,
        )
        fd = ridge.doppler_hz[own]
        wts = np.clip(ridge.curvature[own], 0.0, None)
        wts = wts / wts.max() if wts.max() > 0 else np.ones_like(wts)
        guess_rate, _ = _range_rate_and_jacobian(
            pos[i0:i1], self.vplat[i0:i1], path[own], u3, s[i0:i1] - anchor_s
        )
        return guess_rate - self.half_lambda * fd, fd, wts, tc

    def _fit_velocity(
        self,
        k: int,
        anchor_s: float,
        anchor_m: NDArray[np.float64],
        u: NDArray[np.float64],
        measured: NDArray[np.float64],
        wts: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Three weighted Gauss-Newton steps on ``u`` for the measured range rates."""
        i0, i1 = self.blocks[k]
        s, sw = self.s, np.sqrt(wts)
        u_new = u.copy()
        for _ in range(3):
            un3 = np.array([u_new[0], u_new[1], 0.0])
            p = anchor_m[None, :] + (s[i0:i1, None] - anchor_s) * un3[None, :]
            model, jac = _range_rate_and_jacobian(
                self.pos[i0:i1], self.vplat[i0:i1], p, un3, s[i0:i1] - anchor_s
            )
            step, *_ = np.linalg.lstsq(jac * sw[:, None], (measured - model) * sw, rcond=None)
            u_new = u_new + step
        return u_new


def trajectory_error(
    estimate: TrajectoryEstimate, true_position_m: ArrayLike, true_velocity_mps: ArrayLike
) -> NDArray[np.float64]:
    """Trajectory error ``|rho^e(s) - rho(s)|`` (m) against a straight true path.

    Parameters
    ----------
    estimate : TrajectoryEstimate
        The estimate.
    true_position_m : (2,) or (3,) array_like
        True position ``rho(0)`` (m).
    true_velocity_mps : (2,) array_like
        True ground velocity ``u`` (m/s); ``rho(s) = rho(0) + s u`` (``eq:MOD9``).

    Returns
    -------
    (n_pulses,) ndarray
        Error (m) at each slow time of ``estimate``.
    """
    if not isinstance(estimate, TrajectoryEstimate):
        raise TypeError(f"estimate must be a TrajectoryEstimate, got {type(estimate).__name__}")
    rho = as_point(true_position_m, name="true_position_m")
    v = np.asarray(true_velocity_mps, dtype=np.float64)
    if v.shape != (2,) or not np.all(np.isfinite(v)):
        raise ValueError(
            "true_velocity_mps must be a finite (2,) ground velocity (m/s), "
            f"got {true_velocity_mps!r}"
        )
    truth = rho[None, :] + estimate.slow_times_s[:, None] * np.array([v[0], v[1], 0.0])[None, :]
    return np.linalg.norm(estimate.positions_m - truth, axis=1)
