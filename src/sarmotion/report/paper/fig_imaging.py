"""Figures of the imaging sections: traces, images, the straight trace, rotating scatterers."""

from __future__ import annotations

import numpy as np

from ..plotting import plot_image, subplots, traces_figure
from ._context import _Context, _fmt, _peak_delay_spread_ns, _Result

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
    fig = traces_figure(
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
    fig = traces_figure(
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
