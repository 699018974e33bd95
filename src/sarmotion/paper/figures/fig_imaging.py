"""Figures of the imaging sections: traces, images, the straight trace, rotating scatterers."""

from __future__ import annotations

import numpy as np

from ...report.plotting import plot_image, plot_traces, subplots, traces_figure
from ._context import _Context, _fmt, _peak_delay_spread_ns, _peak_delays_s, _Result


def _zoom_panel(ax, data, s, t, ref, title, *, half: int = 4, label: str = "max|D_r|") -> None:
    """``|data|`` in ``2 half + 1`` fast-time samples around its peak, peaks drawn over it.

    The sub-sample peak time of every pulse is the red line.
    """
    a = np.abs(np.asarray(data))
    c = int(np.median(np.argmax(a, axis=1)))
    sl = slice(max(c - half, 0), c + half + 1)
    plot_traces(
        ax,
        np.asarray(data)[:, sl],
        slow_times_s=s,
        fast_times_s=t[sl],
        normalise_by=ref,
        title=title,
        reference_label=label,
    )
    ax.plot(_peak_delays_s(data, t) * 1e9, s, color="tab:red", lw=1.2, label="peak (sub-sample)")
    ax.legend(loc="lower right", fontsize=8)


__all__ = []


# ============================================================================ figures
def _fig_hyperbola(ctx: _Context) -> _Result:
    from ...core import shift_fast_time, travel_time

    sim = ctx.sim("hyperbola")
    tr = sim.traces
    tau_o = travel_time(tr.positions_m, tr.reference_point_m)
    i0 = int(np.argmin(np.abs(tr.slow_times_s)))
    d_r = tr.data
    d_p = shift_fast_time(d_r, -(tau_o - tau_o[i0]), frequencies_hz=tr.frequencies_hz)
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(d_r).max())
    fig, axes = subplots(1, 3, figsize=(15.0, 4.4))
    plot_traces(
        axes[0],
        d_p,
        slow_times_s=s,
        fast_times_s=t,
        normalise_by=ref,
        title="pulse compressed D_p(s,t)",
        reference_label="max|D_r|",
    )
    plot_traces(
        axes[1],
        d_r,
        slow_times_s=s,
        fast_times_s=t,
        normalise_by=ref,
        title="range compressed D_r(s,t')",
        reference_label="max|D_r|",
    )
    before = _peak_delay_spread_ns(d_p, t)
    after = _peak_delay_spread_ns(d_r, t)
    _zoom_panel(axes[2], d_r, s, t, ref, f"D_r zoomed: the peak moves {after:.2f} ns")
    fig.tight_layout()
    h = {"migration_pulse_compressed_ns": before, "migration_range_compressed_ns": after}
    summary = (
        f"peak delay (sub-sample) migrates {_fmt(before, 1)} ns over the aperture before "
        f"range compression, {_fmt(after, 2)} ns after (one sample: {(t[1] - t[0]) * 1e9:.2f} ns)"
    )
    return _Result(
        fig, {"pulse_compressed": d_p, "range_compressed": d_r, "s": s, "t": t}, h, summary
    )


def _fig_image_comp(ctx: _Context) -> _Result:
    from ...imaging import backproject

    sim = ctx.sim("scene1")
    tr = sim.traces
    grid = ctx.grid()
    img = ctx.scene1_image.values
    still = backproject(tr.with_data(sim.stationary), grid).values
    diff = np.abs(img - still).max() / np.abs(still).max()
    streak_db = float(20 * np.log10(diff))
    fig, axes = subplots(1, 2, figsize=(9.6, 4.2))
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
    from ...separation import transform_plus

    sim = ctx.sim("rotscatt")
    tr = sim.traces.with_data(sim.stationary)
    rho = sim.scene.stationary[0].position_m
    aligned = transform_plus(tr, rho).data
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    before = _peak_delay_spread_ns(tr.data, t)
    after = _peak_delay_spread_ns(aligned, t)
    fig, axes = subplots(2, 2, figsize=(10.0, 8.0))
    plot_traces(
        axes[0, 0],
        tr.data,
        slow_times_s=s,
        fast_times_s=t,
        normalise_by=ref,
        title="|D_r(s,t)|",
        reference_label="max|D_r|",
    )
    plot_traces(
        axes[0, 1],
        aligned,
        slow_times_s=s,
        fast_times_s=t,
        normalise_by=ref,
        title="T_+^ρ D_r (exact ρ)",
        reference_label="max|D_r|",
    )
    _zoom_panel(axes[1, 0], tr.data, s, t, ref, f"zoom: the peak moves {before:.2f} ns")
    _zoom_panel(axes[1, 1], aligned, s, t, ref, f"zoom: the peak moves {after:.1e} ns")
    fig.tight_layout()
    col = aligned[:, np.argmax(np.abs(aligned).sum(axis=0))]
    s_dep = float(np.std(col) / np.abs(np.mean(col)))
    h = {
        "migration_before_ns": before,
        "migration_after_ns": after,
        "aligned_column_rel_std": s_dep,
    }
    summary = (
        f"peak (sub-sample) migrates {_fmt(before, 2)} ns before, {after:.1e} ns after T_+ "
        f"(one sample: {(t[1] - t[0]) * 1e9:.2f} ns); aligned "
        f"column varies by {s_dep:.1e} (relative) over s"
    )
    return _Result(fig, {"traces": tr.data, "aligned": aligned, "s": s, "t": t}, h, summary)


def _fig_rot_scatt(ctx: _Context) -> _Result:
    from ...separation import annihilate, transform_plus

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
    fig = traces_figure(
        [
            ("D_r(s,t)", tr.data, False, ref),
            ("T_+^ρ D_r", aligned, False, ref),
            ("Q^ρ D_r", filt, False, float(np.abs(filt).max()), "max|Q^ρ D_r|"),
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
