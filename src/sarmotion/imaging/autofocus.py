"""Phase-gradient autofocus (PGA) of the phase history: a slow-time phase error per pulse.

Model
-----
A residual platform-motion error that is the same for every point of the scene is a
phase ``phi(s)`` per pulse: the traces are ``D_r(s, t) exp(i phi(s))``. PGA estimates
``phi`` from the image and corrects the traces, ``D_r(s, t) exp(-i phi(s))``, so that
everything downstream (separation, motion estimation, images) uses corrected data.

The image PGA works on
----------------------
PGA needs an image in which a slow-time phase error is a convolution along one image
axis. It is formed here by backprojection (:func:`~sarmotion.imaging.backproject`) on a
grid whose axes are the look's ground-range direction ``e_r`` and cross-range direction
``e_c`` (:func:`~sarmotion.imaging.resolution`) at the scene centre ``rho_c``; the
traces' geometry is rotated and translated so that this grid is axis-aligned (distances,
hence the image, are unchanged). With ``rho = rho_c + x e_r + y e_c``, a point target
``rho_t = rho_c + x_t e_r + y_t e_c`` of amplitude ``a`` contributes to pixel ``rho``,
through pulse ``j`` (``eq:image``),

    a p(dtau_j(rho) - dtau_j(rho_t)) exp(i omega_o (dtau_j(rho) - dtau_j(rho_t))) exp(i phi_j).

On the range line ``x = x_t`` near the target, ``dtau_j(rho) - dtau_j(rho_t) = -(2/c)
(m_j . e_c) (y - y_t) + O((y - y_t)^2 / L)``, ``m_j`` the unit vector from the target to
the antenna: the envelope ``p`` stays at its peak (the delay change is ``|y - y_t|``
times the angle subtended by the aperture, a small fraction of a range cell over a few
cross-range cells) and the image along the line is

    I(y) = a sum_j exp(i phi_j) exp(i kappa_j (y - y_t)),   kappa_j = -2 k_o (m_j . e_c),

``k_o = omega_o / c``. When the pulses are evenly spaced in look angle (small aperture:
``kappa_j`` linear in ``j``) this is the Fourier series of ``exp(i phi)``: the phase
error convolves every range line with the same kernel, its transform. Conversely the
per-pulse phase history of the target is recovered by the transform back, taken with the
exact delay differences rather than their linearisation,

    G_j = sum_{|y - y_t| <= W/2} I(y) exp(-i omega_o (dtau_j(rho_y) - dtau_j(rho_t)))
        ~ a exp(i phi_j),

``rho_y`` the pixel at ``y`` on the line and ``rho_t`` the sub-pixel peak, smoothed over
pulses by the window's transform. The exact form matters: the linearised phase
``kappa_j (y - y_t)`` leaves the second-order term ``k_o (y - y_t)^2 / R`` (``R`` the
range), a chirp along the line that the window truncates. The truncation puts an even
phase on the pulses near the aperture edges, of order ``k_o (W / 2)^2 / R`` (0.5 rad
for a 10 m window at 10 km), which is the same for every line and so does not average
out: it is a quadratic bias of the estimate even for one isolated, noiseless point.

Iteration
---------
Each iteration: (1) image the current traces; (2) keep the range lines whose brightest
pixel is ``min_contrast_db`` above the line's median intensity (at most ``max_lines``,
brightest first) and centre-shift each on its peak (sub-pixel, by a parabola through
``|I|``); (3) window: the width is 1.5 times the -10 dB width of the centre-shifted
intensity averaged over the lines, at most ``shrink`` times the previous window and at
least ``min_window_cells`` cross-range cells; (4) transform back (``G`` above) and
estimate the phase gradient with the maximum-likelihood kernel
``dphi_j = arg sum_n conj(G_{n,j}) G_{n,j+1}`` (Jakowatz et al., *Spotlight-Mode SAR*,
1996, sect. 4.4; the phase-difference estimator); (5) integrate, remove the mean and the
least-squares linear term in slow time (a linear phase only shifts the image; PGA cannot
observe it), and correct the traces. It stops when the RMS of an iteration's correction
is below ``tol_rad`` (a residual RMS ``sigma`` lowers the peak power by the factor
``exp(-sigma^2)``: 0.01 rad is 4e-4 dB), or after ``max_iter`` iterations. The window
smooths the estimate over pulses (its transform), so components of high order in slow
time are only partly recovered per iteration; clutter in the window biases the estimate
by a fixed amount, so many more iterations than needed drift (stop at the tolerance).

Final estimate
--------------
The iteration's fixed point is not the error. Its estimate at pulse ``j`` is the phase
of the window's smoothing of ``exp(i phi)`` over pulses (``G = M^H I``, ``M`` the
window's model below), and a residual whose image lies outside the window is invisible
to it. The first, wide-window iterations on a large error leave such a residual, mostly
on the pulses at the aperture edges, which the narrower windows that follow cannot see;
it projects onto the quadratic (a mover's cross-range speed, below). So the last step
fits the windows instead of back-transforming them. The window of line ``n``
(``I_n``, its pixels ``y``) is modelled exactly as one point at its sub-pixel peak
``rho_t``,

    I_n(y) = a_n sum_j exp(i omega_o (dtau_j(rho_y) - dtau_j(rho_t)))
             exp(i (phi_j - phi_applied_j + s_nj d_n)),

``phi_applied`` the iteration's correction, ``a_n`` a complex amplitude, ``d_n`` a
cross-range offset of the peak (the parabola's error; ``s_nj = 2 k_o (m_j . e_c)``),
and ``phi`` a Legendre series in slow time of orders 2 to ``L`` (order 0 is ``a_n``,
order 1 the ``d_n``). ``L`` is the highest order the window resolves: the highest
whose linearised image (``i c P_L``) has at least half its energy inside the window.
The fit is least squares over all kept lines (Levenberg-Marquardt, the per-line
unknowns eliminated), from the iteration's estimate projected on the series. A line is
kept while the fit explains its window to the contrast asked of a line: unexplained
energy at most ``10^(-min_contrast_db / 10)`` of the window's (another point or clutter
in the window biases that line's phases by about the square root of that ratio, rad);
lines above it are dropped and the fit repeated. Above order ``L`` the iteration's
estimate is either its own residue (the error has nothing there: the estimate is the
series alone) or part of the error (kept, and the series fitted beneath it); the second
is taken only where it explains more of the kept windows by at least the share of a
point's focused energy that a phase error of ``tol_rad`` RMS moves, ``1 - exp(-tol^2)``,
since below that the windows cannot tell the two apart within the tolerance. Where the
window resolves no order above the linear one, or no line meets the rule, the
iteration's estimate stands (:attr:`AutofocusResult.order` is then 0).

The maximum-likelihood phase-difference kernel is the default; ``kernel="eigenvector"``
takes the phase of the principal right singular vector of ``G`` (lines x pulses), the
maximum-likelihood estimate of ``phi`` under ``G_{n,j} = a_n exp(i phi_j) + noise``
(Jakowatz and Wahl, JOSA A 10, 1993).

When the assumptions hold
-------------------------
- The error is one phase per pulse, the same at every point of the scene: true for an
  uncompensated line-of-sight motion when the scene subtends a small angle from the
  platform (its range and angle variation across the scene is negligible); a range-
  dependent or space-variant error is not modelled.
- Small aperture: the look angle varies little, so ``kappa_j`` is nearly linear in
  ``j``, the range envelope of a target stays within its range cell across a window, and
  one cross-range axis describes the whole aperture (at 4 degrees the keystone of the
  polar support spreads ``kappa_j`` by the fractional bandwidth, which the exact
  delays here absorb at the centre frequency only).
- The image holds dominant point-like scatterers in many range lines, above the clutter
  in the window: their phase histories are the signal, clutter the noise. A scene with
  no bright scatterer is refused.

What is left matters downstream in proportion to its order: a residual linear term is a
shift of the whole scene (unobservable, and removed); a residual quadratic
``c (s / S)^2`` (``S`` the half aperture time) reads, for a mover, as a cross-range
speed error ``c L / (2 k_o (V - u_c) S^2)`` (``V`` the platform speed), which at metres
per second of cross-range-speed resolution per radian can exceed the Cramér–Rao bound
of a bright mover; range position and range speed are not affected to first order.

For a mover, :func:`focus_mover` runs the same iteration on the motion-compensated image
``eq:imagecompu`` around it: the error it estimates includes what the velocity estimate
leaves unfocused, so it is meant for the mover's own traces.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._limits import phase_history_bytes
from .._validation import positive as _positive
from ..core import C, Traces, Trajectory, as_point
from ..core.geometry import _as_velocity
from .backprojection import backproject
from .grid import Image, ImageGrid, default_scene_size_m
from .peaks import parabolic_peak
from .resolution import resolution

__all__ = ["AutofocusResult", "apply_phase_correction", "focus_mover", "pga"]


@dataclass(frozen=True, kw_only=True, eq=False)
class AutofocusResult:
    """Result of :func:`pga`.

    Attributes
    ----------
    traces : Traces
        The corrected traces ``D_r(s, t) exp(-i phi(s))``.
    phase_error_rad : (n_pulses,) ndarray
        The estimated phase error ``phi(s)`` (rad), mean and linear term removed.
    n_iter : int
        Iterations run.
    converged : bool
        Whether the last correction's RMS fell below ``tol_rad``.
    rms_history_rad : (n_iter,) ndarray
        RMS of each iteration's correction (rad).
    window_history_m : (n_iter,) ndarray
        Cross-range window width of each iteration (m).
    lines_history : (n_iter,) ndarray
        Number of range lines used in each iteration.
    tol_rad : float
        The stopping tolerance (rad).
    image : Image or None
        :func:`focus_mover`: the mover's compensated image from the corrected traces.
    order : int
        Highest Legendre order of the final fit (0: no final fit, the iteration's
        estimate stands).
    n_fitted_lines : int
        Range lines the final fit used.
    """

    traces: Traces
    phase_error_rad: NDArray[np.float64]
    n_iter: int
    converged: bool
    rms_history_rad: NDArray[np.float64]
    window_history_m: NDArray[np.float64]
    lines_history: NDArray[np.int64]
    tol_rad: float
    image: Image | None = field(default=None)
    order: int = 0
    n_fitted_lines: int = 0

    def to_dict(self) -> dict:
        """JSON-ready summary (phase error per pulse in rad)."""
        return {
            "method": "pga",
            "n_iter": self.n_iter,
            "converged": self.converged,
            "tol_rad": self.tol_rad,
            "rms_history_rad": self.rms_history_rad.tolist(),
            "window_history_m": self.window_history_m.tolist(),
            "lines_history": self.lines_history.tolist(),
            "phase_error_rms_rad": float(np.sqrt(np.mean(self.phase_error_rad**2))),
            "phase_error_rad": self.phase_error_rad.tolist(),
            "slow_times_s": self.traces.slow_times_s.tolist(),
        }


def apply_phase_correction(traces: Traces, phase_rad: ArrayLike) -> Traces:
    """Traces times ``exp(-i phase(s))``, one phase per pulse (rad).

    Parameters
    ----------
    traces : Traces
        The data.
    phase_rad : (n_pulses,) array_like
        Phase error per pulse (rad) to remove.
    """
    phi = np.asarray(phase_rad, dtype=np.float64)
    if phi.shape != (traces.n_pulses,) or not np.all(np.isfinite(phi)):
        raise ValueError(
            f"phase_rad must be finite with shape ({traces.n_pulses},), got {phi.shape}"
        )
    data = traces.data * np.exp(-1j * phi)[:, None].astype(np.complex128)
    return traces.with_data(data.astype(traces.data.dtype, copy=False))


def _rotated(traces: Traces, centre: NDArray[np.float64], rot: NDArray[np.float64]) -> Traces:
    """The traces with ground coordinates ``rot @ (xy - centre)`` (distances unchanged)."""
    pos = traces.positions_m.copy()
    pos[:, :2] = (pos[:, :2] - centre[None, :2]) @ rot.T
    ref = traces.reference_point_m.copy()
    ref[:2] = rot @ (ref[:2] - centre[:2])
    return Traces(
        data=traces.data,
        trajectory=Trajectory(positions_m=pos, slow_times_s=traces.slow_times_s),
        radar=traces.radar,
        reference_point_m=ref,
        metadata=traces.metadata,
    )


def _bright_lines(
    img: Image, contrast: float, contrast_db: float, max_lines: int
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """Range lines whose brightest pixel is ``contrast`` times their median intensity.

    Returns the chosen lines (brightest first, at most ``max_lines``), every line's peak
    pixel and the lines' intensity ``(n_range_lines, n_cross)``.

    Raises
    ------
    ValueError
        No line qualifies.
    """
    power = np.abs(img.values.T) ** 2  # one row per range line
    peak_idx = np.argmax(power, axis=1)
    peak_pow = power[np.arange(power.shape[0]), peak_idx]
    median = np.median(power, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(median > 0, peak_pow / np.where(median > 0, median, 1.0), np.inf)
    ratio[peak_pow == 0] = 0.0
    chosen = np.nonzero(ratio >= contrast)[0]
    if chosen.size == 0:
        raise ValueError(
            f"no bright scatterer for PGA: no range line of the image has a peak "
            f"{contrast_db:g} dB above its median"
        )
    return chosen[np.argsort(-peak_pow[chosen], kind="stable")][:max_lines], peak_idx, power


@dataclass(frozen=True, eq=False)
class _Windows:
    """The chosen range lines' windows and their exact pulse-to-pixel models.

    Each line ``n`` is centre-shifted on its sub-pixel peak ``rho_t`` (a parabola through
    ``|I|``) and cut to the window's pixels about it that lie in the image (a
    backprojected image is not periodic, so a window is cut at the image's edge, not
    wrapped). The models, ``(n_lines, window, n_pulses)``, are computed a block of lines
    at a time (:meth:`blocks`), each block at most ``block_bytes``: the working bytes the
    read of the phase history held (:func:`~sarmotion._limits.phase_history_bytes`, the
    budget the input was admitted under), whatever the number of lines.

    Attributes
    ----------
    traces : Traces
        The traces the image was formed from (rotated frame).
    velocity : (3,) ndarray
        Compensated velocity of the image (m/s).
    points : (n_lines, 3) ndarray
        Sub-pixel peaks ``rho_t`` (m).
    shifts : (n_lines,) ndarray
        Range line's ``x`` minus the peak's (m).
    dists : (n_lines, window) ndarray
        Window pixels' ``y`` minus the peak's (m).
    mask : (n_lines, window) bool ndarray
        Pixels inside the image.
    pixels : (n_lines, window) complex ndarray
        The window's pixel values (zero where cut).
    slopes : (n_lines, n_pulses) ndarray
        ``2 k_o (m_j . e_y)`` (rad/m): moving ``rho_t`` by ``d`` along ``e_y`` multiplies
        pulse ``j`` of the model by ``exp(i slopes_j d)`` (first order in ``d``).
    block_bytes : int
        Largest block of models (with its temporaries) computed at once.
    cache : list
        The models of all lines, once computed, where they fit in one block.
    """

    traces: Traces
    velocity: NDArray[np.float64]
    points: NDArray[np.float64]
    shifts: NDArray[np.float64]
    dists: NDArray[np.float64]
    mask: NDArray[np.bool_]
    pixels: NDArray[np.complex128]
    slopes: NDArray[np.float64]
    block_bytes: int
    cache: list = field(default_factory=list)

    @classmethod
    def cut(
        cls,
        traces: Traces,
        img: Image,
        chosen: NDArray[np.int64],
        peaks: NDArray[np.int64],
        window: int,
        velocity: NDArray[np.float64],
    ) -> _Windows:
        """The windows of lines ``chosen`` (peaks at cross-range pixels ``peaks``)."""
        grid = img.grid
        dx = grid.x_m[1] - grid.x_m[0]
        dy = grid.y_m[1] - grid.y_m[0]
        ny = grid.y_m.size
        lines = img.values.T  # (n_range_lines, n_cross): one row per range line
        mags = np.abs(img.values)
        half = window // 2
        offsets = np.arange(-half, half + 1)
        points = np.zeros((chosen.size, 3))
        for row, (n, k) in enumerate(zip(chosen, peaks, strict=True)):
            fy, fx = parabolic_peak(mags, int(k), int(n))  # sub-pixel peak along y and x
            points[row, :2] = grid.x_m[0] + fx * dx, grid.y_m[0] + fy * dy
        idx = peaks[:, None] + offsets[None, :]
        mask = (idx >= 0) & (idx < ny)
        idx = np.clip(idx, 0, ny - 1)
        pixels = np.where(mask, lines[chosen[:, None], idx], 0.0)
        rel = traces.positions_m[None, :, :] - (
            points[:, None, :] + traces.slow_times_s[None, :, None] * velocity[None, None, :]
        )
        k_o = 2.0 * np.pi * traces.radar.carrier_hz / C
        # A block: the models and their derivative (complex) and the distances (3 floats).
        per_line = idx.shape[1] * traces.n_pulses * (16 + 16 + 24)
        return cls(
            traces=traces,
            velocity=velocity,
            points=points,
            shifts=grid.x_m[chosen] - points[:, 0],
            dists=grid.y_m[idx] - points[:, 1:2],
            mask=mask,
            pixels=pixels.astype(np.complex128),
            slopes=2.0 * k_o * rel[:, :, 1] / np.linalg.norm(rel, axis=2),
            block_bytes=max(per_line, phase_history_bytes(*traces.data.shape)),
        )

    @property
    def n_lines(self) -> int:
        """Number of lines."""
        return self.points.shape[0]

    def subset(self, keep: NDArray[np.bool_]) -> _Windows:
        """The windows of the lines where ``keep``."""
        return _Windows(
            traces=self.traces,
            velocity=self.velocity,
            points=self.points[keep],
            shifts=self.shifts[keep],
            dists=self.dists[keep],
            mask=self.mask[keep],
            pixels=self.pixels[keep],
            slopes=self.slopes[keep],
            block_bytes=self.block_bytes,
        )

    def models(self, rows: slice) -> NDArray[np.complex128]:
        """``exp(i omega_o (dtau_j(rho_y) - dtau_j(rho_t)))`` of lines ``rows``.

        The window's pixels ``y`` of a point at ``rho_t`` whose pulse ``j`` carries a unit
        phasor, shape ``(n_rows, window, n_pulses)`` (zero rows where the window is cut).
        """
        tr = self.traces
        where = self.points[rows, None, :] + tr.slow_times_s[None, :, None] * self.velocity
        rel = tr.positions_m[None, :, :] - where  # (rows, n_pulses, 3), target to antenna
        r0 = np.linalg.norm(rel, axis=2)
        shifted = np.repeat(rel[:, None, :, :], self.dists.shape[1], axis=1)
        shifted[..., 0] -= self.shifts[rows, None, None]
        shifted[..., 1] -= self.dists[rows, :, None]
        r = np.linalg.norm(shifted, axis=3)
        k_o = 2.0 * np.pi * tr.radar.carrier_hz / C
        out = np.exp(2j * k_o * (r - r0[:, None, :]))
        out[~self.mask[rows]] = 0.0
        return out

    def blocks(self) -> Iterator[tuple[slice, NDArray[np.complex128]]]:
        """``(rows, models(rows))`` over all lines, a block of at most ``block_bytes``.

        Where all lines fit in one block, it is computed once and kept.
        """
        per_line = self.dists.shape[1] * self.traces.n_pulses * (16 + 16 + 24)
        step = max(1, self.block_bytes // per_line)
        if step >= self.n_lines:
            if not self.cache:
                self.cache.append(self.models(slice(0, self.n_lines)))
            yield slice(0, self.n_lines), self.cache[0]
            return
        for first in range(0, self.n_lines, step):
            rows = slice(first, min(first + step, self.n_lines))
            yield rows, self.models(rows)


def _legendre_basis(s: NDArray[np.float64], orders: int) -> NDArray[np.float64]:
    """Legendre ``P_2 .. P_orders`` of slow time mapped onto [-1, 1], shape (n, orders - 1)."""
    x = (s - 0.5 * (s[0] + s[-1])) / (0.5 * (s[-1] - s[0]))
    return np.stack(
        [np.polynomial.legendre.Legendre.basis(order)(x) for order in range(2, orders + 1)], axis=1
    )


def _resolved_orders(lines: _Windows, dy: float) -> int:
    """Highest Legendre order with at least half its linearised image energy in the window.

    A small error ``c P_l(s)`` adds ``i c P_l`` to a point's phase history; its image is
    ``c`` times the transform of ``P_l``, and the window holds the fraction
    ``|M P_l|^2 / (n_period |P_l|^2)`` of it (Parseval: a range line of one period in
    ``y``, ``2 pi / (dkappa dy)`` pixels, holds ``n_period |v|^2`` for pulse weights
    ``v``), ``M`` the window's model of the line with the most pixels. Orders whose image
    lies mostly outside the window are not resolved by it.
    """
    n = int(np.argmax(np.count_nonzero(lines.mask, axis=1)))
    model = lines.models(slice(n, n + 1))[0]
    s = lines.traces.slow_times_s
    dkappa = abs(lines.slopes[n, -1] - lines.slopes[n, 0]) / (s.size - 1)
    n_period = 2.0 * np.pi / (dkappa * dy)
    order = 1
    while order + 1 < s.size:
        p = _legendre_basis(s, order + 1)[:, -1]
        if np.sum(np.abs(model @ p) ** 2) < 0.5 * n_period * np.sum(p**2):
            break
        order += 1
    return order


def _fit_lines(
    lines: _Windows,
    applied: NDArray[np.float64],
    basis: NDArray[np.float64],
    coef: NDArray[np.float64],
    tol_rad: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Least-squares fit of the lines' windows by points with the phase error ``basis @ coef``.

    Model of line ``n`` (window pixels ``I_n``, models ``M_n``, see :class:`_Windows`):
    ``I_n = a_n M_n w_n``, ``w_nj = exp(i ((basis @ coef)_j - applied_j + slopes_nj d_n))``,
    with a complex amplitude ``a_n`` and a cross-range offset ``d_n`` (m) of the sub-pixel
    peak per line, and the common coefficients ``coef``. Levenberg-Marquardt on the
    Gauss-Newton normal equations, the per-line unknowns ``(d_n, a_n)`` eliminated by
    their Schur complement. It stops when a step changes the phase error by less than
    ``tol_rad / 100`` RMS over the pulses (a hundredth of the stopping tolerance of the
    iteration), or after 100 steps.

    Returns
    -------
    coef : (n_basis,) ndarray
        The fitted coefficients (rad).
    misfit : (n_lines,) ndarray
        Each line's unexplained window energy over its window energy.
    """
    pixels, slopes = lines.pixels, lines.slopes
    n_lines, n_basis = lines.n_lines, basis.shape[1]
    energy = np.sum(np.abs(pixels) ** 2, axis=1)

    def phasors(c: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.complex128]:
        return np.exp(1j * ((basis @ c - applied)[None, :] + slopes * d[:, None]))

    def images(w: NDArray[np.complex128]) -> NDArray[np.complex128]:
        v = np.empty_like(pixels)
        for rows, models in lines.blocks():
            v[rows] = np.einsum("nwk,nk->nw", models, w[rows])
        return v

    d = np.zeros(n_lines)
    w = phasors(coef, d)
    v = images(w)
    a = np.sum(np.conj(v) * pixels, axis=1) / np.sum(np.abs(v) ** 2, axis=1)
    r = pixels - a[:, None] * v
    cost = float(np.sum(np.abs(r) ** 2))
    damping = 1e-3
    for _ in range(100):
        hcc = np.zeros((n_basis, n_basis))
        gc = np.zeros(n_basis)
        hcl = np.empty((n_lines, n_basis, 3))
        hll = np.empty((n_lines, 3, 3))
        gl = np.empty((n_lines, 3))
        for rows, models in lines.blocks():
            dv = models * (1j * w[rows])[:, None, :]  # d v / d theta_j
            jc = a[rows, None, None] * np.einsum("nwk,kb->nwb", dv, basis)  # d (a v) / d coef
            jl = np.stack(
                [a[rows, None] * np.einsum("nwk,nk->nw", dv, slopes[rows]), v[rows], 1j * v[rows]],
                axis=2,
            )  # d (a v) / d (d_n, Re a_n, Im a_n)
            hcc += np.einsum("nwb,nwe->be", np.conj(jc), jc).real
            gc += np.einsum("nwb,nw->b", np.conj(jc), r[rows]).real
            hcl[rows] = np.einsum("nwb,nwe->nbe", np.conj(jc), jl).real
            hll[rows] = np.einsum("nwb,nwe->nbe", np.conj(jl), jl).real
            gl[rows] = np.einsum("nwb,nw->nb", np.conj(jl), r[rows]).real
        while True:
            dll = hll + damping * np.einsum("nbb->nb", hll)[:, :, None] * np.eye(3)
            inv = np.linalg.pinv(dll)
            reduced = hcc + damping * np.diag(np.diag(hcc))
            reduced = reduced - np.einsum("nbe,nef,ngf->bg", hcl, inv, hcl)
            rhs = gc - np.einsum("nbe,nef,nf->b", hcl, inv, gl)
            step_c = np.linalg.solve(reduced, rhs)
            step_l = np.einsum("nbe,ne->nb", inv, gl - np.einsum("nbe,b->ne", hcl, step_c))
            c_new = coef + step_c
            d_new = d + step_l[:, 0]
            a_new = a + step_l[:, 1] + 1j * step_l[:, 2]
            w_new = phasors(c_new, d_new)
            v_new = images(w_new)
            r_new = pixels - a_new[:, None] * v_new
            cost_new = float(np.sum(np.abs(r_new) ** 2))
            if cost_new <= cost or damping > 1e8:
                break
            damping *= 10.0
        if cost_new > cost:
            break
        coef, d, a, w, v, r, cost = c_new, d_new, a_new, w_new, v_new, r_new, cost_new
        damping = max(damping / 10.0, 1e-9)
        if np.sqrt(np.mean((basis @ step_c) ** 2)) < 0.01 * tol_rad:
            break
    return coef, np.sum(np.abs(r) ** 2, axis=1) / energy


def _remove_linear(phi: NDArray[np.float64], s: NDArray[np.float64]) -> NDArray[np.float64]:
    """``phi`` minus its least-squares line in ``s`` (mean and slope)."""
    a = np.stack([np.ones_like(s), s - s.mean()], axis=1)
    coef, *_ = np.linalg.lstsq(a, phi, rcond=None)
    return phi - a @ coef


def _window_width(power: NDArray[np.float64], peaks: NDArray[np.int64]) -> int:
    """1.5 times the -10 dB width (pixels) of the centre-shifted mean intensity."""
    n = power.shape[1]
    shifted = np.stack([np.roll(p, n // 2 - k) for p, k in zip(power, peaks, strict=True)])
    avg = shifted.mean(axis=0)
    above = avg >= 0.1 * avg[n // 2]
    lo = n // 2
    while lo > 0 and above[lo - 1]:
        lo -= 1
    hi = n // 2
    while hi < n - 1 and above[hi + 1]:
        hi += 1
    return int(math.ceil(1.5 * (hi - lo + 1)))


def _final_estimate(
    work: Traces,
    grid: ImageGrid,
    applied: NDArray[np.float64],
    window: int,
    velocity: NDArray[np.float64],
    *,
    contrast: float,
    contrast_db: float,
    max_lines: int,
    tol_rad: float,
) -> tuple[NDArray[np.float64], int, int] | None:
    """The final estimate: the lines' windows fitted with the window's exact model.

    ``work`` are the traces corrected by ``applied`` (rad per pulse). The phase error is
    the Legendre series of the orders the final window resolves
    (:func:`_resolved_orders`), fitted by :func:`_fit_lines` to the bright lines'
    windows (:func:`_bright_lines`, :class:`_Windows`) of the image of ``work``;
    or, where that explains the windows better by the tolerance's share (module
    docstring), ``applied`` above those orders plus the series fitted beneath it.
    A line is kept while the fit explains its window to the contrast asked of a line,
    misfit <= ``1 / contrast``: what else lies in its window (another point, clutter)
    then stands at least as far below the point as a line's median below its peak.
    Lines above it are dropped and the fit repeated until every kept line meets it.

    Returns
    -------
    tuple or None
        ``(phase_error_rad, order, n_lines)``: the fitted phase error per pulse (rad),
        the highest order and the lines fitted; None where the window resolves no order
        above the linear one or no line meets the misfit rule (the iteration's estimate
        then stands).
    """
    img = backproject(work, grid, velocity_mps=None if not np.any(velocity) else velocity[:2])
    try:
        chosen, peak_idx, _ = _bright_lines(img, contrast, contrast_db, max_lines)
    except ValueError:
        return None
    lines = _Windows.cut(work, img, chosen, peak_idx[chosen], window, velocity)
    s = work.slow_times_s
    order = _resolved_orders(lines, grid.y_m[1] - grid.y_m[0])
    if order < 2:
        return None
    basis = _legendre_basis(s, order)
    low = np.hstack([np.stack([np.ones_like(s), s - s.mean()], axis=1), basis])
    start = np.linalg.lstsq(low, applied, rcond=None)[0]
    resolved, coef = low @ start, start[2:]  # the iteration's estimate up to order L
    energy = np.sum(np.abs(lines.pixels) ** 2, axis=1)
    keep = np.ones(chosen.size, dtype=bool)
    while keep.any():
        kept = lines.subset(keep)
        fitted, misfit = _fit_lines(kept, applied, basis, coef, tol_rad)
        bad = misfit > 1.0 / contrast
        if not bad.any():
            # Above order L the iteration's estimate is either its own residue (the
            # error has nothing there: the series alone) or the error's (kept, the
            # series fitted below it). The second is taken only where it explains more
            # of the windows by at least the share of a point's focused energy that a
            # phase error of tol_rad RMS moves, 1 - exp(-tol_rad^2): else the windows
            # cannot tell them apart within the tolerance, and the smaller stands.
            above, misfit_above = _fit_lines(kept, resolved, basis, coef, tol_rad)
            gain = np.sum((misfit - misfit_above) * energy[keep])
            if gain > -np.expm1(-(tol_rad**2)) * np.sum(energy[keep]):
                return applied - resolved + basis @ above, order, int(keep.sum())
            return basis @ fitted, order, int(keep.sum())
        coef = fitted
        keep[np.nonzero(keep)[0][bad]] = False
    return None


def pga(
    traces: Traces,
    *,
    centre_m: ArrayLike | None = None,
    velocity_mps: ArrayLike | None = None,
    size_m: float | None = None,
    oversampling: float = 2.0,
    max_iter: int = 10,
    tol_rad: float = 0.01,
    min_contrast_db: float = 20.0,
    max_lines: int = 200,
    min_window_cells: float = 8.0,
    shrink: float = 0.8,
    kernel: str = "ml",
) -> AutofocusResult:
    """Phase-gradient autofocus of the traces (module docstring).

    Parameters
    ----------
    traces : Traces
        The data.
    centre_m : (2,) or (3,) array_like, optional
        Centre of the PGA image (m); default the reference point.
    velocity_mps : (2,) array_like, optional
        Compensated ground velocity (m/s) of the image (``eq:imagecompu``).
    size_m : float, optional
        Side of the square PGA image, along range and cross range (m); default
        :func:`~sarmotion.imaging.default_scene_size_m`.
    oversampling : float
        Pixels per resolution cell along each axis (>= 1).
    max_iter : int
        Most iterations, ``1 <= max_iter <= n_pulses``.
    tol_rad : float
        Stop when the RMS of an iteration's correction is below this (rad).
    min_contrast_db : float
        A range line is used when its brightest pixel's intensity is this many dB above
        the line's median (> 0).
    max_lines : int
        Most range lines used per iteration (the highest contrast first).
    min_window_cells : float
        Narrowest window (cross-range resolution cells, >= 2).
    shrink : float
        Largest ratio of a window to the previous one, ``0 < shrink <= 1``.
    kernel : {"ml", "eigenvector"}
        Phase estimator: phase differences (``"ml"``) or the principal singular vector.

    Returns
    -------
    AutofocusResult

    Raises
    ------
    ValueError
        Bad parameters, or no range line holds a bright scatterer.
    """
    if not isinstance(traces, Traces):
        raise TypeError(f"traces must be a Traces object, got {type(traces).__name__}")
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)):
        raise TypeError(f"max_iter must be an integer, got {type(max_iter).__name__}")
    if not 1 <= max_iter <= traces.n_pulses:
        raise ValueError(
            f"max_iter must be between 1 and the number of pulses ({traces.n_pulses}), "
            f"got {max_iter}"
        )
    tol = _positive(tol_rad, "tol_rad", unit="rad")
    contrast = 10.0 ** (_positive(min_contrast_db, "min_contrast_db", unit="dB") / 10.0)
    over = _positive(oversampling, "oversampling")
    if over < 1.0:
        raise ValueError(f"oversampling must be >= 1, got {oversampling!r}")
    if not (isinstance(max_lines, (int, np.integer)) and max_lines >= 1):
        raise ValueError(f"max_lines must be a positive integer, got {max_lines!r}")
    if not (math.isfinite(min_window_cells) and min_window_cells >= 2):
        raise ValueError(f"min_window_cells must be >= 2, got {min_window_cells!r}")
    if not (math.isfinite(shrink) and 0 < shrink <= 1):
        raise ValueError(f"shrink must be in (0, 1], got {shrink!r}")
    if kernel not in ("ml", "eigenvector"):
        raise ValueError(f"kernel must be 'ml' or 'eigenvector', got {kernel!r}")
    centre = traces.reference_point_m if centre_m is None else as_point(centre_m, name="centre_m")
    centre = np.array([centre[0], centre[1], 0.0])
    vel = np.zeros(3) if velocity_mps is None else _as_velocity(velocity_mps, name="velocity_mps")
    size = default_scene_size_m(traces) if size_m is None else _positive(size_m, "size_m", unit="m")

    res = resolution(traces, point_m=centre)
    rot = np.stack([res.range_direction, res.cross_range_direction])  # rows: e_r, e_c
    vel_rot = np.array([*(rot @ vel[:2]), 0.0])
    dx = res.ground_range_m / over
    dy = res.cross_range_m / over
    nx = max(8, int(round(size / dx)))
    ny = max(16, int(round(size / dy)))
    grid = ImageGrid(x_m=(np.arange(nx) - nx // 2) * dx, y_m=(np.arange(ny) - ny // 2) * dy)
    min_window = int(math.ceil(min_window_cells * over))
    s = traces.slow_times_s

    work = _rotated(traces, centre, rot)
    phi_total = np.zeros(traces.n_pulses)
    rms_hist: list[float] = []
    win_hist: list[float] = []
    line_hist: list[int] = []
    window = ny
    converged = False
    for _ in range(max_iter):
        img = backproject(work, grid, velocity_mps=None if velocity_mps is None else vel_rot[:2])
        chosen, peak_idx, power = _bright_lines(img, contrast, min_contrast_db, max_lines)
        window = max(min_window, min(_window_width(power[chosen], peak_idx[chosen]),
                                     int(shrink * window), ny))  # fmt: skip
        lines = _Windows.cut(work, img, chosen, peak_idx[chosen], window, vel_rot)
        g = np.empty((chosen.size, traces.n_pulses), dtype=np.complex128)
        for rows, models in lines.blocks():
            g[rows] = np.einsum("nwk,nw->nk", np.conj(models), lines.pixels[rows])
        if kernel == "eigenvector":
            _, _, vh = np.linalg.svd(g, full_matrices=False)
            raw = np.unwrap(np.angle(vh[0]))
        else:
            dphi = np.angle(np.sum(np.conj(g[:, :-1]) * g[:, 1:], axis=0))
            raw = np.concatenate([[0.0], np.cumsum(dphi)])
        phi = _remove_linear(raw, s)
        phi_total += phi
        work = apply_phase_correction(work, phi)
        rms = float(np.sqrt(np.mean(phi**2)))
        rms_hist.append(rms)
        win_hist.append(window * dy)
        line_hist.append(int(chosen.size))
        if rms < tol:
            converged = True
            break
    final = _final_estimate(
        work, grid, phi_total, window, vel_rot, contrast=contrast, contrast_db=min_contrast_db,
        max_lines=max_lines, tol_rad=tol,
    )  # fmt: skip
    order, n_fitted = 0, 0
    if final is not None:
        phi_total, order, n_fitted = final
    phi_total = _remove_linear(phi_total, s)
    meta = {
        "autofocus": "pga",
        "pga_iterations": len(rms_hist),
        "pga_converged": converged,
        "pga_phase_error_rms_rad": float(np.sqrt(np.mean(phi_total**2))),
    }
    corrected = apply_phase_correction(traces, phi_total)
    corrected = corrected.with_data(corrected.data, **meta)
    return AutofocusResult(
        traces=corrected,
        phase_error_rad=phi_total,
        n_iter=len(rms_hist),
        converged=converged,
        rms_history_rad=np.array(rms_hist),
        window_history_m=np.array(win_hist),
        lines_history=np.array(line_hist, dtype=np.int64),
        tol_rad=tol,
        order=order,
        n_fitted_lines=n_fitted,
    )


def focus_mover(
    traces: Traces,
    position_m: ArrayLike,
    velocity_mps: ArrayLike,
    *,
    grid: ImageGrid | None = None,
    size_m: float | None = None,
    **options,
) -> AutofocusResult:
    """PGA on a mover's motion-compensated image, and that image refocused.

    Parameters
    ----------
    traces : Traces
        The mover's traces (e.g. the moving part of a separation).
    position_m : (2,) or (3,) array_like
        The mover's position at ``s = 0`` (m): the centre of the PGA image.
    velocity_mps : (2,) array_like
        Its ground velocity (m/s), compensated (``eq:imagecompu``).
    grid : ImageGrid, optional
        Grid of the returned image; default a ``size_m`` square around ``position_m``
        with quarter-cell pixels.
    size_m : float, optional
        Side of the PGA image (m); default 64 cross-range cells, so that a defocus of up
        to +-16 cells leaves most of each range line to the background (the median of
        the contrast test).
    **options
        Passed to :func:`pga` (``max_iter``, ``tol_rad``, ...).

    Returns
    -------
    AutofocusResult
        With :attr:`~AutofocusResult.image` the compensated image of the corrected
        traces on ``grid``.
    """
    p = as_point(position_m, name="position_m")
    res = resolution(traces, point_m=p)
    if size_m is None:
        size_m = 64.0 * res.cross_range_m
    result = pga(traces, centre_m=p, velocity_mps=velocity_mps, size_m=size_m, **options)
    if grid is None:
        step = 0.25 * min(res.ground_range_m, res.cross_range_m)
        grid = ImageGrid.square(centre_m=p[:2], size_m=size_m, spacing_m=step)
    img = backproject(result.traces, grid, velocity_mps=velocity_mps)
    return AutofocusResult(
        traces=result.traces,
        phase_error_rad=result.phase_error_rad,
        n_iter=result.n_iter,
        converged=result.converged,
        rms_history_rad=result.rms_history_rad,
        window_history_m=result.window_history_m,
        lines_history=result.lines_history,
        tol_rad=result.tol_rad,
        image=img,
        order=result.order,
        n_fitted_lines=result.n_fitted_lines,
    )
