"""Every figure of the paper, regenerated from data, with the numbers behind it.

:func:`build_figures` writes into an output directory, for each figure ``fig:NAME`` of
Borcea, Callaghan & Papanicolaou, "Motion estimation and imaging of complex scenes with
synthetic aperture radar":

* ``fig_NAME.png`` -- the figure (the label with ``:`` replaced by ``_``);
* ``fig_NAME.npz`` -- the arrays plotted in it (axes included);
* ``index.html`` -- every figure beside the paper's caption and one line of what it
  shows numerically.

The headline numbers of each figure (:attr:`FigureRecord.headline`) are measured by the
package's building blocks on the built-in scenes; nothing is typed in. Conventions are
the paper's: traces ``|M|`` normalised by ``max |M|`` of the data they come from, sparse
parts and filtered traces also in dB, slow time ``s`` (s) and fast time ``t`` (ns);
images in dB re their peak with ground axes in m.

``quick=True`` runs the same code paths on reduced sizes (coarser image grids and speed
grids, fewer sweep values, shorter rank apertures), for tests.

This is a report layer: it imports matplotlib (beside :mod:`sarmotion.plotting`, whose
panel functions it uses) and writes files. Progress goes through a callback
``progress(label, done, total)``.
"""

from __future__ import annotations

import html
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
from numpy.typing import NDArray

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from .plotting import plot_image, plot_traces, save_figure  # noqa: E402

__all__ = ["FigureRecord", "FIGURE_LABELS", "CAPTIONS", "build_figures", "figure_filename"]

log = logging.getLogger(__name__)

#: ``progress(label, done, total)`` after each figure.
ProgressCallback = Callable[[str, int, int], None]

#: The paper's captions, LaTeX lightly cleaned (copied from the .tex).
CAPTIONS: dict[str, str] = {
    "fig:hyperbola": "Left: Pulse compressed data D_p(s,t) = f(t - τ(s,ρ)) from a target at "
    "ρ = (0,5,0) m, recorded by a SAR antenna moving at speed V = 70 m/s along a linear "
    "aperture of 400 m, at range L = 10 km from ρ. Right: Range-compressed data D_r(s,t') "
    "with respect to ρ_o = (0,0,0) m.",
    "fig:imageComp": "Left: The image of the complex Scene 1, with twenty stationary targets "
    "and two moving targets. Right: Image of the same stationary scene, and no moving "
    "targets. The effect of the moving targets in the left image amounts to two faint "
    "streaks.",
    "fig:straightTrace": "Left: The trace |D_r(s,t)| from one stationary target. Right: the "
    "traces after the travel time transformation relative to the exact location of the "
    "target. Note that there is no dependence on s after the transformation.",
    "fig:rotScatt": "Left: The traces D_r(s,t) for a scene with one stationary target at "
    "location ρ and a moving one at 28 m/s. Middle: The traces after the travel time "
    "transformation [T_+^ρ D_r](s,t). Right: The filtered traces [Q^{ρ^e} D_r](s,t).",
    "fig:dataDecomp": "Left: The matrix M of the sampled traces from Scene 1. Middle: The "
    "matrix L consisting of the traces from the stationary targets in Scene 1. Right: The "
    "matrix S consisting of the traces from the moving targets in Scene 1.",
    "fig:rpcaEx1": "Separation of traces from the scene in Example 1. From left to right we "
    "show the matrix M of traces, the low rank L, and sparse S components obtained with "
    "robust PCA. Top row: robust PCA applied to the entire data matrix M. Bottom row: "
    "robust PCA applied to a windowed M. In each plot the matrices are normalized by the "
    "largest value of |M|. The sparse components shown in the right column are plotted in "
    "(decibel) dB scale to make the contrast more visible.",
    "fig:rpcaEx2a": "Matrix M of traces from the scene in Example 2.",
    "fig:rpcaEx2b": "Robust PCA separation of traces from a scene with thirty stationary "
    "targets and one moving target. The top row of plots shows the results with robust PCA "
    "applied to the entire data matrix in Figure fig:rpcaEx2a. The low rank and sparse "
    "components are shown on the left and right, respectively. The bottom row of plots "
    "shows the results with robust PCA applied to successive small time windows of the "
    "data. The sparse components shown in the right column are plotted in dB scale to make "
    "the contrast more visible.",
    "fig:annihilScene1": "Annihilation with the filter (eq:OP2) of the stationary target "
    "traces from Scene 1. Top: the matrix of traces. Bottom: the filtered traces. In each "
    "plot we show absolute values normalized by the largest value of |M|. The right column "
    "is the left column plotted in dB scale.",
    "fig:rpca2mov": "Trace separation with robust PCA for Scene 1. The low rank part L is "
    "shown on the left and the sparse part S is shown on the right. In each plot we show "
    "absolute values normalized by the largest value of |M|. The sparse part is plotted in "
    "dB scale.",
    "fig:rotateTrueFilt": "Left: The traces from the two moving targets in Scene 1. Middle "
    "and right: The transformed traces T_+^{u,ρ} D_r(s,t) for the first and second target.",
    "fig:filtComp": "The objective function g(u) using the traces from the entire Scene 1 "
    "(left) and the traces from the moving targets in Scene 1 (right).",
    "fig:rotate2stage": "Top row: The traces after the travel time transformation (eq:TTu+) "
    "at the estimated range speed of one target. Bottom row: The traces after the travel "
    "time transformation (eq:TTu+) with the estimated cross-range correction of the speed. "
    "The right column is a zoom of the left column.",
    "fig:objfxns": "Left: The objective function g. Middle and right: The objective function "
    "g_⊥ for the estimated range speeds of the two targets in Scene 1. The minima of g_⊥ "
    "are the estimates of u_⊥.",
    "fig:rank1": "Comparison of the computed and estimated rank of Y for a single target. "
    "Left: Stationary target at various cross-range positions. Right: Moving target with "
    "various velocities.",
    "fig:convergeRank": "Convergence of the rank of Y normalized by the size (n+1). The blue "
    "line is the computed value and the green line is the asymptotic estimate. The slow "
    "time sampling is fixed, so the longer the aperture is, the larger n.",
    "fig:eigenvals2": "Computed and estimated rank of matrix Y for a scene with two "
    "stationary targets. On the left, one target is fixed at location ρ_1 = (5,5,0) m and "
    "the location of the other varies on the line segment between (-5,0.01,0) m and "
    "(-5,30,0) m. On the right, one target is fixed at location ρ_1 = (0.15,5,0) m and the "
    "location of the other varies on the line segment between (-0.15,0.01,0) m and "
    "(-0.15,30,0) m.",
    "fig:filter10scatt1ord": "Data separation with the annihilation filter for a scene with "
    "ten stationary targets and a moving one. The top row shows the data traces and the "
    "bottom row the trace from the moving target, as separated by the algorithm. The right "
    "column is the left column plotted in dB scale.",
    "fig:filter30scatt1ord": "Data separation with the annihilation filter for a scene with "
    "thirty stationary targets and a moving one. The top row shows the data traces and the "
    "bottom row the trace from the moving target, as separated by the algorithm. The right "
    "column is the left column plotted in dB scale.",
    "fig:motEstscatt": "Error of the estimated target trajectory in a complex scene with ten "
    "stationary targets (left) and thirty stationary targets (right). The motion estimation "
    "is done with the filtered data shown in the bottom row of Figures "
    "fig:filter10scatt1ord and fig:filter30scatt1ord.",
    "fig:rpca2movFinalSep": "Data separation for Scene 1. Left: traces from the stationary "
    "targets. Middle and right: traces from the moving targets.",
    "fig:sepImgs": "Images for Scene 1. Left: image with the traces from the stationary "
    "targets. Middle and right: image with the traces the moving targets.",
}

#: Figure labels in the paper's order.
FIGURE_LABELS: tuple[str, ...] = tuple(CAPTIONS)

NU_O = 9.6e9  # carrier of the rank model (Hz), GOTCHA centre
B_RANK = 622e6  # bandwidth of the rank model (Hz), GOTCHA
EPS = 1e-3  # rank threshold on the eigenvalues of Y


def figure_filename(label: str, suffix: str = ".png") -> str:
    """File name of a figure: ``fig:rpcaEx2b`` -> ``fig_rpcaEx2b.png``."""
    return label.replace(":", "_") + suffix


@dataclass(frozen=True, kw_only=True)
class FigureRecord:
    """One regenerated figure.

    Attributes
    ----------
    label : str
        The paper's label, e.g. ``"fig:rpcaEx2b"``.
    png, npz : Path
        The figure and its arrays.
    caption : str
        The paper's caption.
    summary : str
        One line of what the figure shows numerically.
    headline : dict of str to float
        The measured numbers behind :attr:`summary`.
    seconds : float
        Wall-clock time to build it (s).
    """

    label: str
    png: Path
    npz: Path
    caption: str
    summary: str
    headline: dict[str, float] = field(default_factory=dict)
    seconds: float = 0.0


@dataclass
class _Result:
    fig: Any
    arrays: dict[str, Any]
    headline: dict[str, float]
    summary: str


# ============================================================== shared computations
class _Context:
    """Simulations and separations shared by several figures, computed once."""

    def __init__(self, quick: bool) -> None:
        self.quick = quick
        self._sims: dict[str, Any] = {}
        self._rpca: dict[tuple[str, int | None], Any] = {}

    # sizes ------------------------------------------------------------------------
    @property
    def spacing_m(self) -> float:
        return 0.5 if self.quick else 0.25

    @property
    def speed_step_mps(self) -> float:
        return 0.25 if self.quick else 0.05

    def sim(self, name: str) -> Any:
        from .scene import load_scene
        from .simulate import simulate

        if name not in self._sims:
            self._sims[name] = simulate(load_scene(name))
        return self._sims[name]

    def rpca(self, name: str, window: int | None) -> Any:
        """Windowed (``window=None``: chosen from the data) or whole-matrix RPCA."""
        from .separation import separate_rpca

        key = (name, window)
        if key not in self._rpca:
            tr = self.sim(name).traces
            self._rpca[key] = separate_rpca(tr, window=window, tol=1e-4, max_iter=300)
        return self._rpca[key]

    def grid(self, size_m: float = 60.0, centre_m: Sequence[float] = (0.0, 0.0)) -> Any:
        from .imaging import ImageGrid

        return ImageGrid.square(centre_m=centre_m, size_m=size_m, spacing_m=self.spacing_m)

    @cached_property
    def scene1_image(self) -> Any:
        from .imaging import backproject

        return backproject(self.sim("scene1").traces, self.grid())

    @cached_property
    def scene1_analysis(self) -> Any:
        """The paper's pipeline on Scene 1 (RPCA, then one mover at a time)."""
        from .analysis import analyze

        tr = self.sim("scene1").traces
        return analyze(tr, method="rpca", trajectory=False, spacing_m=self.spacing_m)

    @cached_property
    def scene1_moving_traces(self) -> Any:
        sim = self.sim("scene1")
        return sim.traces.with_data(sim.moving)

    @cached_property
    def scene1_g(self) -> dict[str, NDArray[np.float64]]:
        """``g(u)`` on all of Scene 1 and on its moving traces."""
        from .velocity import range_speed_objective

        u = np.arange(-30.0, 30.0 + 1e-9, self.speed_step_mps)
        g_all = range_speed_objective(self.sim("scene1").traces, u)
        g_mov = range_speed_objective(self.scene1_moving_traces, u)
        return {"u_mps": u, "g_all": g_all, "g_moving": g_mov}

    @cached_property
    def scene1_estimates(self) -> list[Any]:
        """Velocity estimates of Scene 1's movers on their traces, at the true positions."""
        from .velocity import estimate_range_speeds, estimate_velocity

        tr = self.scene1_moving_traces
        speeds = estimate_range_speeds(tr, max_movers=2)
        out = []
        for mover in self.sim("scene1").scene.moving:
            from .geometry import range_speed

            u_true = range_speed(mover.velocity_mps, tr.geometry)
            u0 = speeds.speeds_mps[int(np.argmin(np.abs(speeds.speeds_mps - u_true)))]
            out.append(
                estimate_velocity(tr, range_speed_mps=float(u0), position_m=mover.position_m)
            )
        return out


# ================================================================== plotting helpers
def _trace_axes(
    panels: Sequence[tuple[str, NDArray, bool, float]],
    *,
    slow_times_s: NDArray,
    fast_times_s: NDArray,
    ncols: int,
    fast_slice: slice | None = None,
) -> Any:
    """A grid of trace panels ``(title, data, in_db, normalise_by)``."""
    n = len(panels)
    nrows = int(np.ceil(n / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.5 * nrows), squeeze=False)
    sl = fast_slice if fast_slice is not None else slice(None)
    for ax, (title, data, db, ref) in zip(axes.ravel(), panels, strict=False):
        plot_traces(
            ax,
            np.asarray(data)[:, sl],
            slow_times_s=slow_times_s,
            fast_times_s=np.asarray(fast_times_s)[sl],
            normalise_by=ref,
            db=db,
            title=title,
        )
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    fig.tight_layout()
    return fig


def _peak_delay_spread_ns(data: NDArray, fast_times_s: NDArray) -> float:
    """Spread (max - min) over slow time of the fast time of each pulse's peak (ns)."""
    t = np.asarray(fast_times_s)[np.argmax(np.abs(data), axis=1)]
    return float((t.max() - t.min()) * 1e9)


def _rel(a: NDArray, b: NDArray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def _fmt(x: float, nd: int = 2) -> str:
    return f"{x:.{nd}f}"


# ============================================================================ figures
def _fig_hyperbola(ctx: _Context) -> _Result:
    from .geometry import travel_time
    from .spectral import shift_fast_time

    sim = ctx.sim("hyperbola")
    tr = sim.traces
    tau_o = travel_time(tr.positions_m, tr.reference_point_m)
    i0 = int(np.argmin(np.abs(tr.slow_times_s)))
    d_r = tr.data
    d_p = shift_fast_time(d_r, -(tau_o - tau_o[i0]), frequencies_hz=tr.frequencies_hz)
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(d_r).max())
    fig = _trace_axes(
        [
            ("pulse compressed D_p(s,t)", d_p, False, ref),
            ("range compressed D_r(s,t')", d_r, False, ref),
        ],
        slow_times_s=s,
        fast_times_s=t,
        ncols=2,
    )
    before = _peak_delay_spread_ns(d_p, t)
    after = _peak_delay_spread_ns(d_r, t)
    h = {"migration_pulse_compressed_ns": before, "migration_range_compressed_ns": after}
    summary = (
        f"peak delay migrates {_fmt(before, 1)} ns over the aperture before range "
        f"compression, {_fmt(after, 1)} ns after"
    )
    return _Result(
        fig, {"pulse_compressed": d_p, "range_compressed": d_r, "s": s, "t": t}, h, summary
    )


def _fig_image_comp(ctx: _Context) -> _Result:
    from .imaging import backproject

    sim = ctx.sim("scene1")
    tr = sim.traces
    grid = ctx.grid()
    img = ctx.scene1_image.values
    still = backproject(tr.with_data(sim.stationary), grid).values
    diff = np.abs(img - still).max() / np.abs(still).max()
    streak_db = float(20 * np.log10(diff))
    fig, axes = plt.subplots(1, 2, figsize=(9.6, 4.2))
    ref = float(np.abs(still).max())
    for ax, (title, v) in zip(
        axes, [("Scene 1", img), ("stationary targets only", still)], strict=True
    ):
        plot_image(ax, v, x_m=grid.x_m, y_m=grid.y_m, reference=ref, title=title)
    fig.tight_layout()
    h = {"mover_streak_db": streak_db}
    summary = (
        f"the movers add at most {_fmt(streak_db, 1)} dB (re the brightest stationary "
        "target) to the image: faint streaks"
    )
    return _Result(
        fig, {"image": img, "stationary_image": still, "x": grid.x_m, "y": grid.y_m}, h, summary
    )


def _fig_straight_trace(ctx: _Context) -> _Result:
    from .transforms import transform_plus

    sim = ctx.sim("rotscatt")
    tr = sim.traces.with_data(sim.stationary)
    rho = sim.scene.stationary[0].position_m
    aligned = transform_plus(tr, rho).data
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    fig = _trace_axes(
        [("|D_r(s,t)|", tr.data, False, ref), ("T_+^ρ D_r (exact ρ)", aligned, False, ref)],
        slow_times_s=s,
        fast_times_s=t,
        ncols=2,
    )
    before = _peak_delay_spread_ns(tr.data, t)
    after = _peak_delay_spread_ns(aligned, t)
    col = aligned[:, np.argmax(np.abs(aligned).sum(axis=0))]
    s_dep = float(np.std(col) / np.abs(np.mean(col)))
    h = {
        "migration_before_ns": before,
        "migration_after_ns": after,
        "aligned_column_rel_std": s_dep,
    }
    summary = (
        f"trace migrates {_fmt(before, 1)} ns before, {_fmt(after, 1)} ns after T_+; aligned "
        f"column varies by {s_dep:.1e} (relative) over s"
    )
    return _Result(fig, {"traces": tr.data, "aligned": aligned, "s": s, "t": t}, h, summary)


def _fig_rot_scatt(ctx: _Context) -> _Result:
    from .transforms import annihilate, transform_plus

    sim = ctx.sim("rotscatt")
    tr = sim.traces
    rho = sim.scene.stationary[0].position_m
    aligned = transform_plus(tr, rho).data
    filt = annihilate(tr, rho).data
    q_still = annihilate(tr.with_data(sim.stationary), rho).data
    q_mov = annihilate(tr.with_data(sim.moving), rho).data
    removed_db = float(
        10 * np.log10(np.vdot(q_still, q_still).real / np.vdot(sim.stationary, sim.stationary).real)
    )
    kept_db = float(
        10 * np.log10(np.vdot(q_mov, q_mov).real / np.vdot(sim.moving, sim.moving).real)
    )
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    fig = _trace_axes(
        [
            ("D_r(s,t)", tr.data, False, ref),
            ("T_+^ρ D_r", aligned, False, ref),
            ("Q^ρ D_r (re its max)", filt, False, float(np.abs(filt).max())),
        ],
        slow_times_s=s,
        fast_times_s=t,
        ncols=3,
    )
    h = {"stationary_energy_after_Q_db": removed_db, "mover_energy_after_Q_db": kept_db}
    summary = (
        f"Q^ρ leaves {_fmt(removed_db, 0)} dB of the stationary trace's energy and "
        f"{_fmt(kept_db, 1)} dB of the mover's"
    )
    return _Result(
        fig, {"traces": tr.data, "aligned": aligned, "filtered": filt, "s": s, "t": t}, h, summary
    )


def _fig_data_decomp(ctx: _Context) -> _Result:
    from .rank import numerical_rank

    sim = ctx.sim("scene1")
    tr = sim.traces
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    fig = _trace_axes(
        [
            ("M", tr.data, False, ref),
            ("L (stationary)", sim.stationary, False, ref),
            ("S (moving)", sim.moving, False, ref),
        ],
        slow_times_s=s,
        fast_times_s=t,
        ncols=3,
    )
    r_l = numerical_rank(sim.stationary, eps=EPS)
    r_s = numerical_rank(sim.moving, eps=EPS)
    a = np.abs(sim.moving)
    fill = float(np.mean(a >= 0.1 * a.max()))
    h = {
        "rank_L": float(r_l),
        "rank_S": float(r_s),
        "n_pulses": float(tr.n_pulses),
        "S_fill_fraction": fill,
    }
    summary = (
        f"rank (eps=1e-3 on Y) of L = {r_l}, of S = {r_s} (of {tr.n_pulses}); S is "
        f"{100 * fill:.1f} % filled (>= -20 dB)"
    )
    return _Result(
        fig, {"M": tr.data, "L": sim.stationary, "S": sim.moving, "s": s, "t": t}, h, summary
    )


def _rpca_compare(ctx: _Context, name: str, *, with_m: bool) -> _Result:
    sim = ctx.sim(name)
    tr = sim.traces
    whole = ctx.rpca(name, tr.n_samples)
    win = ctx.rpca(name, None)
    e_whole = _rel(whole.moving, sim.moving)
    e_win = _rel(win.moving, sim.moving)
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    w = win.info["windows"][0]
    panels = []
    for tag, sep in (("whole M", whole), (f"windows of {w[1] - w[0]} samples", win)):
        if with_m:
            panels.append((f"M ({tag})", tr.data, False, ref))
        panels.append((f"L ({tag})", sep.stationary, False, ref))
        panels.append((f"S ({tag}), dB", sep.moving, True, ref))
    fig = _trace_axes(panels, slow_times_s=s, fast_times_s=t, ncols=3 if with_m else 2)
    h = {
        "rel_error_S_windowed": e_win,
        "rel_error_S_whole": e_whole,
        "rel_error_L_windowed": _rel(win.stationary, sim.stationary),
        "rel_error_L_whole": _rel(whole.stationary, sim.stationary),
        "window_samples": float(w[1] - w[0]),
    }
    summary = (
        f"windowed RPCA: ||S-S_true||/||S_true|| = {_fmt(e_win)} vs {_fmt(e_whole)} whole-matrix"
    )
    arrays = {
        "M": tr.data,
        "L_whole": whole.stationary,
        "S_whole": whole.moving,
        "L_windowed": win.stationary,
        "S_windowed": win.moving,
        "s": s,
        "t": t,
    }
    return _Result(fig, arrays, h, summary)


def _fig_rpca_ex1(ctx: _Context) -> _Result:
    return _rpca_compare(ctx, "example1", with_m=True)


def _fig_rpca_ex2a(ctx: _Context) -> _Result:
    from .rank import numerical_rank

    sim = ctx.sim("example2")
    tr = sim.traces
    s, t = tr.slow_times_s, tr.fast_times_s
    fig = _trace_axes(
        [("M (Example 2)", tr.data, False, float(np.abs(tr.data).max()))],
        slow_times_s=s,
        fast_times_s=t,
        ncols=1,
    )
    r_l = numerical_rank(sim.stationary, eps=EPS)
    r_l1 = numerical_rank(ctx.sim("example1").stationary, eps=EPS)
    h = {
        "rank_L_example2": float(r_l),
        "rank_L_example1": float(r_l1),
        "n_pulses": float(tr.n_pulses),
    }
    summary = (
        f"the 30 stationary traces have rank {r_l} of {tr.n_pulses} (Example 1's seven: "
        f"{r_l1}): not low rank as a whole"
    )
    return _Result(fig, {"M": tr.data, "s": s, "t": t}, h, summary)


def _fig_rpca_ex2b(ctx: _Context) -> _Result:
    return _rpca_compare(ctx, "example2", with_m=False)


def _scr_db(moving: NDArray, stationary_part: NDArray) -> float:
    return float(
        10 * np.log10(np.vdot(moving, moving).real / np.vdot(stationary_part, stationary_part).real)
    )


def _fig_annihil_scene1(ctx: _Context) -> _Result:
    from .separation import mover_trace_coverage, separate_annihilation, stationary_candidates
    from .transforms import annihilate

    sim = ctx.sim("scene1")
    tr = sim.traces
    img = ctx.scene1_image
    cand = stationary_candidates(img.values, x_m=img.grid.x_m, y_m=img.grid.y_m, traces=tr)
    sep = separate_annihilation(tr, cand)
    pts = sep.stationary_points_m
    q_l = annihilate(tr.with_data(sim.stationary), pts).data if len(pts) else sim.stationary
    q_s = annihilate(tr.with_data(sim.moving), pts).data if len(pts) else sim.moving
    cov = mover_trace_coverage(sep.moving, tr, sim.scene.moving)
    scr = _scr_db(q_s, q_l)
    exact = annihilate(tr, [p.position_m for p in sim.scene.stationary]).data
    cov_exact = mover_trace_coverage(exact, tr, sim.scene.moving)
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    refq = float(np.abs(sep.moving).max())
    fig = _trace_axes(
        [
            ("M", tr.data, False, ref),
            ("M, dB", tr.data, True, ref),
            ("Q M (re its max)", sep.moving, False, refq),
            ("Q M, dB (re its max)", sep.moving, True, refq),
        ],
        slow_times_s=s,
        fast_times_s=t,
        ncols=2,
    )
    h = {
        "mover_trace_coverage": cov,
        "signal_to_clutter_db": scr,
        "n_filters": float(len(pts)),
        "n_candidates": float(len(cand)),
        "mover_trace_coverage_exact_locations": cov_exact,
    }
    summary = (
        f"annihilation ({len(pts)} filters from the image) keeps {100 * cov:.0f} % of the "
        f"movers' traces ({100 * cov_exact:.0f} % with the 20 exact locations), "
        f"signal-to-clutter {_fmt(scr, 1)} dB"
    )
    return _Result(
        fig, {"M": tr.data, "QM": sep.moving, "points_m": pts, "s": s, "t": t}, h, summary
    )


def _fig_rpca2mov(ctx: _Context) -> _Result:
    from .separation import mover_trace_coverage, separation_quality

    sim = ctx.sim("scene1")
    tr = sim.traces
    sep = ctx.scene1_analysis.separation
    cov = mover_trace_coverage(sep.moving, tr, sim.scene.moving)
    q = separation_quality(sep, true_stationary=sim.stationary, true_moving=sim.moving)
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    fig = _trace_axes(
        [("L (low rank)", sep.stationary, False, ref), ("S (sparse), dB", sep.moving, True, ref)],
        slow_times_s=s,
        fast_times_s=t,
        ncols=2,
    )
    h = {
        "mover_trace_coverage": cov,
        "signal_to_clutter_db": float(q["signal_to_clutter_db"]),
        "rel_error_S": float(q["relative_error_moving"]),
    }
    summary = (
        f"windowed RPCA keeps {100 * cov:.0f} % of the movers' traces, signal-to-clutter "
        f"{_fmt(h['signal_to_clutter_db'], 1)} dB, "
        f"||S-S_true||/||S_true|| = {_fmt(h['rel_error_S'])}"
    )
    return _Result(fig, {"L": sep.stationary, "S": sep.moving, "s": s, "t": t}, h, summary)


def _fig_rotate_true_filt(ctx: _Context) -> _Result:
    from .transforms import transform_plus

    sim = ctx.sim("scene1")
    tr = ctx.scene1_moving_traces
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    panels = [("moving traces", tr.data, False, ref)]
    arrays: dict[str, Any] = {"moving": tr.data, "s": s, "t": t}
    h: dict[str, float] = {}
    parts = []
    for k, mover in enumerate(sim.scene.moving, start=1):
        al = transform_plus(tr, mover.position_m, velocity_mps=mover.velocity_mps).data
        panels.append((f"T_+^(u,ρ) for mover {k}", al, False, ref))
        arrays[f"aligned_{k}"] = al
        own = transform_plus(
            tr.with_data(_own_trace(ctx, k)), mover.position_m, velocity_mps=mover.velocity_mps
        ).data
        h[f"mover{k}_migration_after_ns"] = _peak_delay_spread_ns(own, t)
        h[f"mover{k}_migration_before_ns"] = _peak_delay_spread_ns(_own_trace(ctx, k), t)
        before = h[f"mover{k}_migration_before_ns"]
        after = h[f"mover{k}_migration_after_ns"]
        parts.append(f"{_fmt(before, 0)} -> {_fmt(after, 1)} ns")
    fig = _trace_axes(panels, slow_times_s=s, fast_times_s=t, ncols=3)
    summary = "trace migration over the aperture, movers 1 and 2: " + ", ".join(parts)
    return _Result(fig, arrays, h, summary)


def _own_trace(ctx: _Context, k: int) -> NDArray:
    """The simulated trace of Scene 1's k-th mover alone (1-based)."""
    from .simulate import simulate_phase_history
    from .spectral import to_fast_time

    key = f"_own_{k}"
    if not hasattr(ctx, key):
        sim = ctx.sim("scene1")
        tr = sim.traces
        mover = sim.scene.moving[k - 1]
        ph = simulate_phase_history([mover], tr.trajectory, tr.radar, tr.reference_point_m)
        setattr(ctx, key, to_fast_time(ph))
    return getattr(ctx, key)


def _local_maxima(u: NDArray, g: NDArray, n: int) -> NDArray:
    idx = [i for i in range(1, len(g) - 1) if g[i] >= g[i - 1] and g[i] > g[i + 1]]
    idx = sorted(idx, key=lambda i: -g[i])[:n]
    return np.array([u[i] for i in idx])


def _fig_filt_comp(ctx: _Context) -> _Result:
    from .geometry import range_speed

    sim = ctx.sim("scene1")
    geom = sim.traces.geometry
    gg = ctx.scene1_g
    u, g_all, g_mov = gg["u_mps"], gg["g_all"], gg["g_moving"]
    true_u = sorted(range_speed(m.velocity_mps, geom) for m in sim.scene.moving)
    peak_all = float(u[np.argmax(g_all)])
    peaks = np.sort(_local_maxima(u, g_mov, 2))
    fig, axes = plt.subplots(1, 2, figsize=(9.6, 3.6))
    for ax, g, title in (
        (axes[0], g_all, "all traces of Scene 1"),
        (axes[1], g_mov, "moving traces"),
    ):
        ax.plot(u, g / g.max())
        for tu in true_u:
            ax.axvline(tu, color="tab:red", ls=":", lw=1)
        ax.set_xlabel("range speed u (m/s)")
        ax.set_ylabel("g(u) / max g")
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    h = {
        "peak_all_mps": peak_all,
        "peak_moving_1_mps": float(peaks[0]),
        "peak_moving_2_mps": float(peaks[1]),
        "true_range_speed_1_mps": float(true_u[0]),
        "true_range_speed_2_mps": float(true_u[1]),
    }
    summary = (
        f"g on all traces peaks at u = {_fmt(peak_all)} m/s; on the moving traces at "
        f"{_fmt(peaks[0])} and {_fmt(peaks[1])} m/s (true {_fmt(true_u[0])}, {_fmt(true_u[1])})"
    )
    return _Result(fig, {"u": u, "g_all": g_all, "g_moving": g_mov}, h, summary)


def _fig_rotate2stage(ctx: _Context) -> _Result:
    from .geometry import ground_velocity, range_direction_velocity
    from .transforms import transform_plus
    from .velocity import cross_range_objective

    sim = ctx.sim("scene1")
    tr = sim.traces.with_data(_own_trace(ctx, 1))
    mover = sim.scene.moving[0]
    est = ctx.scene1_estimates[0]
    geom = tr.geometry
    u_e, up_e = est.range_speed_mps, est.cross_range_speed_mps
    stage1 = transform_plus(
        tr, mover.position_m, velocity_mps=range_direction_velocity(u_e, geom)
    ).data
    stage2 = transform_plus(
        tr, mover.position_m, velocity_mps=ground_velocity(u_e, up_e, geom)
    ).data
    gp = cross_range_objective(tr, [0.0, up_e], range_speed_mps=u_e, position_m=mover.position_m)
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    m = tr.n_samples
    zoom = slice(m // 2 - 12, m // 2 + 13)
    fig, axes = plt.subplots(2, 2, figsize=(8.4, 7.0))
    for row, (data, tag) in enumerate(
        ((stage1, f"u^e = {u_e:.2f} m/s"), (stage2, f"+ u_perp^e = {up_e:.2f} m/s"))
    ):
        plot_traces(axes[row, 0], data, slow_times_s=s, fast_times_s=t, normalise_by=ref, title=tag)
        plot_traces(
            axes[row, 1],
            data.real[:, zoom],
            slow_times_s=s,
            fast_times_s=t[zoom],
            normalise_by=ref,
            title="zoom, |Re| (carrier phase)",
        )
    fig.tight_layout()
    h = {
        "range_speed_mps": float(u_e),
        "cross_range_speed_mps": float(up_e),
        "g_perp_ratio": float(gp[1] / gp[0]),
    }
    summary = (
        f"mover 1: the cross-range correction (u_perp^e = {_fmt(up_e)} m/s) lowers the "
        f"slow-time curvature sum_|D_s^2| to {gp[1] / gp[0]:.1e} of its value at u_perp = 0"
    )
    return _Result(fig, {"stage1": stage1, "stage2": stage2, "s": s, "t": t}, h, summary)


def _fig_objfxns(ctx: _Context) -> _Result:
    from .geometry import cross_range_speed
    from .velocity import cross_range_objective

    sim = ctx.sim("scene1")
    tr = ctx.scene1_moving_traces
    geom = tr.geometry
    gg = ctx.scene1_g
    step = 0.5 if ctx.quick else 0.1
    up = np.arange(-30.0, 30.0 + 1e-9, step)
    fig, axes = plt.subplots(1, 3, figsize=(12.6, 3.6))
    axes[0].plot(gg["u_mps"], gg["g_moving"] / gg["g_moving"].max())
    axes[0].set_xlabel("range speed u (m/s)")
    axes[0].set_ylabel("g(u) / max g")
    axes[0].set_title("g on the moving traces", fontsize=9)
    arrays: dict[str, Any] = {"u": gg["u_mps"], "g": gg["g_moving"], "u_perp": up}
    h: dict[str, float] = {}
    parts = []
    for k, (mover, est) in enumerate(
        zip(sim.scene.moving, ctx.scene1_estimates, strict=True), start=1
    ):
        gp = cross_range_objective(
            tr, up, range_speed_mps=est.range_speed_mps, position_m=mover.position_m
        )
        arrays[f"g_perp_{k}"] = gp
        true_up = cross_range_speed(mover.velocity_mps, geom)
        argmin = float(up[np.argmin(gp)])
        h[f"g_perp_min_{k}_mps"] = argmin
        h[f"estimate_{k}_mps"] = float(est.cross_range_speed_mps)
        h[f"true_u_perp_{k}_mps"] = float(true_up)
        ax = axes[k]
        ax.plot(up, gp / gp.max())
        ax.axvline(true_up, color="tab:red", ls=":", lw=1, label="true u_perp")
        ax.set_xlabel("cross-range speed u_perp (m/s)")
        ax.set_ylabel("g_perp / max")
        ax.set_title(f"g_perp at u^e = {est.range_speed_mps:.2f} m/s (mover {k})", fontsize=9)
        ax.legend(fontsize=7)
        parts.append(f"{_fmt(argmin, 1)} vs {_fmt(true_up, 1)}")
    fig.tight_layout()
    summary = "g_perp minima vs true u_perp (m/s): " + "; ".join(parts)
    return _Result(fig, arrays, h, summary)


# --------------------------------------------------------------------------- rank
def _linfit(x: NDArray, y: NDArray) -> tuple[float, float]:
    slope, icpt = np.polyfit(x, y, 1)
    resid = y - (slope * x + icpt)
    r2 = 1.0 - np.sum(resid**2) / max(np.sum((y - y.mean()) ** 2), 1e-300)
    return float(slope), float(r2)


def _fig_rank1(ctx: _Context) -> _Result:
    from .geometry import Trajectory, look_geometry, range_direction_velocity
    from .rank import alpha, numerical_rank, passband_traces, szego_rank_fraction

    kw = {"carrier_hz": NU_O, "bandwidth_hz": B_RANK}
    origin = np.zeros(3)
    traj_s = Trajectory.circular(aperture_deg=4.0)
    traj_m = Trajectory.circular(aperture_deg=1.0)
    offsets = np.linspace(10.0, 60.0, 4 if ctx.quick else 11)
    speeds = np.linspace(0.5, 5.0, 4 if ctx.quick else 10)
    gs, gm = look_geometry(traj_s, origin), look_geometry(traj_m, origin)
    r_off, e_off, r_u, e_u = [], [], [], []
    for y in offsets:
        p = (0.0, float(y), 0.0)
        r_off.append(numerical_rank(passband_traces([p], traj_s, origin, **kw), eps=EPS))
        frac = szego_rank_fraction(
            alpha(p, np.zeros(3), gs), bandwidth_hz=B_RANK, pulse_interval_s=traj_s.pulse_interval_s
        )
        e_off.append(traj_s.n_pulses * frac)
    for u in speeds:
        v = np.r_[range_direction_velocity(float(u), gm), 0.0]
        r_u.append(numerical_rank(passband_traces([(origin, v)], traj_m, origin, **kw), eps=EPS))
        frac = szego_rank_fraction(
            alpha(origin, v, gm), bandwidth_hz=B_RANK, pulse_interval_s=traj_m.pulse_interval_s
        )
        e_u.append(traj_m.n_pulses * frac)
    r_off, e_off, r_u, e_u = map(np.asarray, (r_off, e_off, r_u, e_u))
    r_still10 = numerical_rank(passband_traces([(0.0, 10.0, 0.0)], traj_m, origin, **kw), eps=EPS)
    fig, axes = plt.subplots(1, 2, figsize=(9.6, 3.6))
    axes[0].plot(offsets, e_off, "b-", label="Szegő estimate")
    axes[0].plot(offsets, r_off, "g.-", label="computed")
    axes[0].set_xlabel("cross-range offset (m)")
    axes[0].set_title(f"stationary target, n+1 = {traj_s.n_pulses}", fontsize=9)
    axes[1].plot(speeds, e_u, "b-", label="Szegő estimate")
    axes[1].plot(speeds, r_u, "g.-", label="computed")
    axes[1].set_xlabel("range speed (m/s)")
    axes[1].set_title(f"moving target at ρ_o, n+1 = {traj_m.n_pulses}", fontsize=9)
    for ax in axes:
        ax.set_ylabel("rank of Y")
        ax.legend(fontsize=7)
    fig.tight_layout()
    so, r2o = _linfit(offsets, r_off)
    su, r2u = _linfit(speeds, r_u)
    h = {
        "slope_offset_per_m": so,
        "slope_offset_szego_per_m": _linfit(offsets, e_off)[0],
        "r2_offset": r2o,
        "slope_speed_per_mps": su,
        "slope_speed_szego_per_mps": _linfit(speeds, e_u)[0],
        "r2_speed": r2u,
        "rank_mover_max_speed": float(r_u[-1]),
        "rank_stationary_10m_1deg": float(r_still10),
    }
    summary = (
        f"rank slope {so:.2f}/m (Szegő {h['slope_offset_szego_per_m']:.2f}) with offset, "
        f"{su:.1f} per m/s (Szegő {h['slope_speed_szego_per_mps']:.1f}) with range speed; "
        f"mover at {speeds[-1]:g} m/s rank {r_u[-1]} vs stationary (10 m) {r_still10}"
    )
    arrays = {
        "offsets_m": offsets,
        "rank_offset": r_off,
        "szego_offset": e_off,
        "speeds_mps": speeds,
        "rank_speed": r_u,
        "szego_speed": e_u,
    }
    return _Result(fig, arrays, h, summary)


def _fig_converge_rank(ctx: _Context) -> _Result:
    from .geometry import Trajectory, look_geometry
    from .rank import alpha_j, numerical_rank, passband_traces, szego_rank_fraction

    kw = {"carrier_hz": NU_O, "bandwidth_hz": B_RANK}
    origin = np.zeros(3)
    p = (0.0, 50.0, 0.0)
    degs = np.array([1.0, 2.0, 4.0, 8.0] if ctx.quick else [1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0])
    n1, frac, est = [], [], []
    for d in degs:
        traj = Trajectory.circular(aperture_deg=float(d))
        a = alpha_j(p, look_geometry(traj, origin))
        r = numerical_rank(passband_traces([p], traj, origin, **kw), eps=EPS)
        n1.append(traj.n_pulses)
        frac.append(r / traj.n_pulses)
        est.append(
            szego_rank_fraction(a, bandwidth_hz=B_RANK, pulse_interval_s=traj.pulse_interval_s)
        )
    n1, frac, est = map(np.asarray, (n1, frac, est))
    fig, ax = plt.subplots(figsize=(5.4, 3.8))
    ax.plot(n1, frac, "b.-", label="computed rank/(n+1)")
    ax.plot(n1, est, "g-", label="Szegő estimate")
    ax.set_xlabel("n + 1 (pulses)")
    ax.set_ylabel("rank(Y) / (n+1)")
    ax.set_title("stationary target 50 m off in cross range", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    ratio = frac / est
    h = {
        "ratio_smallest_n": float(ratio[0]),
        "ratio_largest_n": float(ratio[-1]),
        "largest_n_plus_1": float(n1[-1]),
    }
    summary = (
        f"computed/Szegő rank ratio {ratio[0]:.2f} at n+1 = {n1[0]} -> {ratio[-1]:.2f} at "
        f"n+1 = {n1[-1]}"
    )
    return _Result(
        fig, {"n_plus_1": n1, "rank_fraction": frac, "szego": est, "aperture_deg": degs}, h, summary
    )


def _fig_eigenvals2(ctx: _Context) -> _Result:
    from .geometry import LookGeometry, Trajectory, look_geometry
    from .rank import alpha_j, beta, numerical_rank, passband_traces, symbol_rank_fraction

    kw = {"carrier_hz": NU_O, "bandwidth_hz": B_RANK}
    origin = np.zeros(3)
    traj = Trajectory.circular(aperture_deg=4.0)
    geom = look_geometry(traj, origin)
    flat = LookGeometry(
        m_o=np.array([1.0, 0.0, 0.0]),
        tangent=geom.tangent,
        range_m=geom.range_m,
        speed_mps=geom.speed_mps,
        reference_point_m=origin,
    )
    ys = np.linspace(0.01, 30.0, 4 if ctx.quick else 31)
    fig, axes = plt.subplots(1, 2, figsize=(9.6, 3.6))
    arrays: dict[str, Any] = {"y_m": ys}
    h: dict[str, float] = {}
    for k, x in enumerate((5.0, 0.15)):
        rho1 = (x, 5.0, 0.0)
        comp, est = [], []
        for y in ys:
            rho2 = (-x, float(y), 0.0)
            comp.append(numerical_rank(passband_traces([rho1, rho2], traj, origin, **kw), eps=EPS))
            a = [alpha_j(rho1, geom), alpha_j(rho2, geom)]
            est.append(
                traj.n_pulses
                * symbol_rank_fraction(
                    a, pulse_interval_s=traj.pulse_interval_s, n_theta=2**18, **kw
                )
            )
        comp, est = np.asarray(comp), np.asarray(est)
        arrays[f"computed_{k}"], arrays[f"szego_{k}"] = comp, est
        b_flat = B_RANK * abs(beta(rho1, (-x, 12.0, 0.0), flat))
        b_geo = B_RANK * abs(beta(rho1, (-x, 12.0, 0.0), geom))
        tag = "left" if k == 0 else "right"
        h[f"B_beta_flat_{tag}"] = float(b_flat)
        h[f"B_beta_3d_{tag}"] = float(b_geo)
        h[f"max_abs_computed_minus_szego_{tag}"] = float(np.max(np.abs(comp - est)))
        axes[k].plot(ys, est, "b-", label="Szegő estimate (eq:seqc)")
        axes[k].plot(ys, comp, "g.-", label="computed")
        axes[k].set_xlabel("y of the second target (m)")
        axes[k].set_ylabel("rank of Y")
        axes[k].set_title(
            f"ρ_1 = ({x:g}, 5, 0) m; B|β| = {b_flat:.2f} (flat), {b_geo:.2f} (3-D)", fontsize=8
        )
        axes[k].legend(fontsize=7)
    fig.tight_layout()
    summary = (
        f"B|β| = {h['B_beta_flat_left']:.2f} (flat convention; {h['B_beta_3d_left']:.2f} in 3-D "
        f"GOTCHA) on the left, {h['B_beta_flat_right']:.2f} on the right; max |computed - "
        f"Szegő| = {h['max_abs_computed_minus_szego_left']:.0f} and "
        f"{h['max_abs_computed_minus_szego_right']:.0f}"
    )
    return _Result(fig, arrays, h, summary)


# -------------------------------------------------------------- annihilation, motion
def _annihilated(ctx: _Context, name: str) -> tuple[Any, Any]:
    from .transforms import annihilate

    key = f"_annih_{name}"
    if not hasattr(ctx, key):
        sim = ctx.sim(name)
        pts = [t.position_m for t in sim.scene.stationary]
        setattr(ctx, key, (sim, annihilate(sim.traces, pts)))
    return getattr(ctx, key)


def _fig_filter(ctx: _Context, name: str) -> _Result:
    from .separation import mover_trace_coverage
    from .transforms import annihilate

    sim, filt = _annihilated(ctx, name)
    tr = sim.traces
    pts = [t.position_m for t in sim.scene.stationary]
    q_l = annihilate(tr.with_data(sim.stationary), pts).data
    q_s = annihilate(tr.with_data(sim.moving), pts).data
    cov = mover_trace_coverage(filt.data, tr, sim.scene.moving)
    scr = _scr_db(q_s, q_l)
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    refq = float(np.abs(filt.data).max())
    fig = _trace_axes(
        [
            ("M", tr.data, False, ref),
            ("M, dB", tr.data, True, ref),
            ("Q M (re its max)", filt.data, False, refq),
            ("Q M, dB (re its max)", filt.data, True, refq),
        ],
        slow_times_s=s,
        fast_times_s=t,
        ncols=2,
    )
    h = {"mover_trace_coverage": cov, "signal_to_clutter_db": scr, "n_filters": float(len(pts))}
    summary = (
        f"{len(pts)} exact filters: signal-to-clutter {_fmt(scr, 1)} dB, "
        f"{100 * cov:.0f} % of the mover's trace kept"
    )
    return _Result(fig, {"M": tr.data, "QM": filt.data, "s": s, "t": t}, h, summary)


def _fig_filter10(ctx: _Context) -> _Result:
    return _fig_filter(ctx, "filter10")


def _fig_filter30(ctx: _Context) -> _Result:
    return _fig_filter(ctx, "filter30")


def _fig_mot_est(ctx: _Context) -> _Result:
    from .phase_space import estimate_trajectory, trajectory_error

    fig, axes = plt.subplots(1, 2, figsize=(9.6, 3.6))
    arrays: dict[str, Any] = {}
    h: dict[str, float] = {}
    for ax, name in zip(axes, ("filter10", "filter30"), strict=True):
        sim, filt = _annihilated(ctx, name)
        mover = sim.scene.moving[0]
        est = estimate_trajectory(filt, mover.position_m)
        err = trajectory_error(est, mover.position_m, mover.velocity_mps)
        arrays[f"s_{name}"] = est.slow_times_s
        arrays[f"error_{name}"] = err
        h[f"max_error_{name}_m"] = float(err.max())
        h[f"rms_error_{name}_m"] = float(np.sqrt(np.mean(err**2)))
        ax.plot(est.slow_times_s, err)
        ax.set_xlabel("slow time s (s)")
        ax.set_ylabel("|ρ^e(s) - ρ(s)| (m)")
        ax.set_title(f"{name[6:]} stationary targets", fontsize=9)
    fig.tight_layout()
    summary = (
        f"max trajectory error {h['max_error_filter10_m']:.3f} m (ten stationary) vs "
        f"{h['max_error_filter30_m']:.3f} m (thirty)"
    )
    return _Result(fig, arrays, h, summary)


# ----------------------------------------------------------- mover-by-mover (Scene 1)
def _fig_final_sep(ctx: _Context) -> _Result:
    sim = ctx.sim("scene1")
    tr = sim.traces
    res = ctx.scene1_analysis
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    panels = [("stationary (L)", res.separation.stationary, False, ref)]
    arrays: dict[str, Any] = {"L": res.separation.stationary, "s": s, "t": t}
    h: dict[str, float] = {}
    for k, m in enumerate(res.movers[:2], start=1):
        panels.append((f"mover {k}, dB", m.traces, True, ref))
        arrays[f"mover_{k}"] = m.traces
        own = _own_trace(ctx, _match(ctx, m))
        h[f"mover{k}_rel_error"] = _rel(m.traces, own)
    fig = _trace_axes(panels, slow_times_s=s, fast_times_s=t, ncols=3)
    h["n_movers"] = float(len(res.movers))
    summary = f"{len(res.movers)} movers separated; ||D_q - D_q,true||/||D_q,true|| = " + ", ".join(
        _fmt(h[f"mover{k}_rel_error"]) for k in range(1, min(len(res.movers), 2) + 1)
    )
    return _Result(fig, arrays, h, summary)


def _match(ctx: _Context, mover_result: Any) -> int:
    """1-based index of the true Scene 1 mover nearest in velocity."""
    truth = ctx.sim("scene1").scene.moving
    d = [np.linalg.norm(mover_result.velocity_mps - t.velocity_mps) for t in truth]
    return int(np.argmin(d)) + 1


def _fig_sep_imgs(ctx: _Context) -> _Result:
    sim = ctx.sim("scene1")
    tr = sim.traces
    res = ctx.scene1_analysis
    from .imaging import resolution

    cells = resolution(tr)
    rng_cell, cross_cell = cells.ground_range_m, cells.cross_range_m
    geom = tr.geometry
    e_r = geom.ground_m_o / np.linalg.norm(geom.ground_m_o)
    e_c = np.array([-e_r[1], e_r[0]])
    n_mov = min(len(res.movers), 2)
    fig, axes = plt.subplots(1, 1 + n_mov, figsize=(4.8 * (1 + n_mov), 4.2), squeeze=False)
    img = res.stationary_image
    truth_still = [tuple(p.position_m[:2]) for p in sim.scene.stationary]
    plot_image(
        axes[0, 0],
        img.values,
        x_m=img.grid.x_m,
        y_m=img.grid.y_m,
        title="stationary traces",
        markers=truth_still,
    )
    found = np.array([p.position_m for p in res.stationary]) if res.stationary else None
    errs, inside = [], 0
    for p in truth_still:
        if found is None:
            break
        d = found - np.asarray(p)
        i = int(np.argmin(np.linalg.norm(d, axis=1)))
        errs.append(float(np.linalg.norm(d[i])))
        inside += abs(d[i] @ e_r) <= rng_cell and abs(d[i] @ e_c) <= cross_cell
    h: dict[str, float] = {
        "stationary_within_cell": float(inside),
        "n_stationary": float(len(truth_still)),
        "stationary_median_peak_error_m": float(np.median(errs)) if errs else float("nan"),
        "stationary_max_peak_error_m": float(max(errs)) if errs else float("nan"),
        "range_cell_m": rng_cell,
        "cross_range_cell_m": cross_cell,
    }
    arrays: dict[str, Any] = {"stationary_image": img.values, "x": img.grid.x_m, "y": img.grid.y_m}
    parts = []
    for k, m in enumerate(res.movers[:2], start=1):
        truth = sim.scene.moving[_match(ctx, m) - 1]
        mi = m.image
        plot_image(
            axes[0, k],
            mi.values,
            x_m=mi.grid.x_m,
            y_m=mi.grid.y_m,
            title=f"mover {k}, u^e = ({m.velocity_mps[0]:.1f}, {m.velocity_mps[1]:.1f}) m/s",
            markers=[tuple(truth.position_m[:2])],
        )
        d = np.asarray(m.image_peak_m) - truth.position_m[:2]
        h[f"mover{k}_peak_range_error_m"] = float(d @ e_r)
        h[f"mover{k}_peak_cross_range_error_m"] = float(d @ e_c)
        arrays[f"mover_{k}_image"] = mi.values
        arrays[f"mover_{k}_x"], arrays[f"mover_{k}_y"] = mi.grid.x_m, mi.grid.y_m
        parts.append(
            f"mover {k} peak off by {abs(d @ e_r):.2f} m range, {abs(d @ e_c):.2f} m cross range"
        )
    fig.tight_layout()
    summary = (
        f"{inside} of {len(truth_still)} stationary targets peak within a resolution cell "
        f"(median error {h['stationary_median_peak_error_m']:.2f} m); "
        + "; ".join(parts)
        + f" (cells {rng_cell:.2f} x {cross_cell:.2f} m)"
    )
    return _Result(fig, arrays, h, summary)


_BUILDERS: dict[str, Callable[[_Context], _Result]] = {
    "fig:hyperbola": _fig_hyperbola,
    "fig:imageComp": _fig_image_comp,
    "fig:straightTrace": _fig_straight_trace,
    "fig:rotScatt": _fig_rot_scatt,
    "fig:dataDecomp": _fig_data_decomp,
    "fig:rpcaEx1": _fig_rpca_ex1,
    "fig:rpcaEx2a": _fig_rpca_ex2a,
    "fig:rpcaEx2b": _fig_rpca_ex2b,
    "fig:annihilScene1": _fig_annihil_scene1,
    "fig:rpca2mov": _fig_rpca2mov,
    "fig:rotateTrueFilt": _fig_rotate_true_filt,
    "fig:filtComp": _fig_filt_comp,
    "fig:rotate2stage": _fig_rotate2stage,
    "fig:objfxns": _fig_objfxns,
    "fig:rank1": _fig_rank1,
    "fig:convergeRank": _fig_converge_rank,
    "fig:eigenvals2": _fig_eigenvals2,
    "fig:filter10scatt1ord": _fig_filter10,
    "fig:filter30scatt1ord": _fig_filter30,
    "fig:motEstscatt": _fig_mot_est,
    "fig:rpca2movFinalSep": _fig_final_sep,
    "fig:sepImgs": _fig_sep_imgs,
}


# ============================================================================ driver
def _for_npz(value: Any) -> NDArray:
    """Arrays as stored: complex traces and images as complex64 (plotting precision)."""
    a = np.asarray(value)
    return a.astype(np.complex64) if a.dtype == np.complex128 else a


def _write_index(out: Path, records: Sequence[FigureRecord], quick: bool) -> Path:
    rows = []
    for r in records:
        rows.append(
            f'<section id="{html.escape(r.label)}"><h2>{html.escape(r.label)}</h2>\n'
            f'<div class="row"><a href="{r.png.name}"><img src="{r.png.name}" '
            f'alt="{html.escape(r.label)}"></a>\n<div class="text"><p class="caption">'
            f'<b>Paper:</b> {html.escape(r.caption)}</p>\n<p class="measured"><b>Measured:</b> '
            f'{html.escape(r.summary)}</p>\n<p class="files"><a href="{r.npz.name}">'
            f"{r.npz.name}</a> &middot; built in {r.seconds:.1f} s</p></div></div></section>"
        )
    page = (
        '<!DOCTYPE html>\n<html><head><meta charset="utf-8"><title>The paper, reproduced'
        "</title>\n<style>body{font-family:sans-serif;max-width:1400px;margin:auto}"
        ".row{display:flex;gap:1.5em;align-items:flex-start}.row img{max-width:820px}"
        ".text{max-width:520px}.measured{color:#05a}</style></head><body>\n"
        "<h1>Motion estimation and imaging of complex scenes with SAR: figures reproduced"
        "</h1>\n"
        f"<p>{len(records)} figures{' (quick, reduced sizes)' if quick else ''}, generated by "
        "<code>sarmotion.paper.build_figures</code>.</p>\n" + "\n".join(rows) + "\n</body></html>\n"
    )
    path = out / "index.html"
    path.write_text(page, encoding="utf-8")
    return path


def build_figures(
    out_dir: str | Path,
    *,
    only: str | Sequence[str] | None = None,
    quick: bool = False,
    progress: ProgressCallback | None = None,
) -> list[FigureRecord]:
    """Regenerate the paper's figures with data.

    Parameters
    ----------
    out_dir : str or Path
        Output directory (created). Receives ``fig_NAME.png`` and ``fig_NAME.npz`` per
        figure ``fig:NAME`` and ``index.html``.
    only : str or sequence of str, optional
        Build only these labels (``"fig:rpcaEx2b"``; the ``fig:`` prefix may be left out).
    quick : bool
        Reduced sizes (coarser grids, fewer sweep values), same code paths; for tests.
    progress : callable, optional
        ``progress(label, done, total)`` after each figure.

    Returns
    -------
    list of FigureRecord
        In the paper's order.
    """
    if only is None:
        labels = list(FIGURE_LABELS)
    else:
        wanted = [only] if isinstance(only, str) else list(only)
        labels = []
        for w in wanted:
            lab = w if w.startswith("fig:") else f"fig:{w}"
            if lab not in _BUILDERS:
                raise ValueError(
                    f"only must name figures among {', '.join(FIGURE_LABELS)}; got {w!r}"
                )
            labels.append(lab)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ctx = _Context(quick)
    records = []
    for i, lab in enumerate(labels, start=1):
        t0 = time.perf_counter()
        res = _BUILDERS[lab](ctx)
        png = save_figure(res.fig, out / figure_filename(lab))
        npz = out / figure_filename(lab, ".npz")
        np.savez_compressed(npz, **{k: _for_npz(v) for k, v in res.arrays.items()})
        dt = time.perf_counter() - t0
        rec = FigureRecord(
            label=lab,
            png=png,
            npz=npz,
            caption=CAPTIONS[lab],
            summary=res.summary,
            headline={k: float(v) for k, v in res.headline.items()},
            seconds=dt,
        )
        records.append(rec)
        log.info("%s (%.1f s): %s", lab, dt, res.summary)
        if progress is not None:
            progress(lab, i, len(labels))
    _write_index(out, records, quick)
    return records
