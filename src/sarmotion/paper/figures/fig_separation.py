"""Figures of the separation sections: robust PCA, annihilation filters, their combination."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...report.plotting import plot_traces, subplots, traces_figure
from ._context import EPS, _Context, _fmt, _peak_delay_spread_ns, _rel, _Result, _scr_db

__all__ = []


def _fig_data_decomp(ctx: _Context) -> _Result:
    from ..rank import numerical_rank

    sim = ctx.sim("scene1")
    tr = sim.traces
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    fig = traces_figure(
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
    fig = traces_figure(panels, slow_times_s=s, fast_times_s=t, ncols=3 if with_m else 2)
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
    from ..rank import numerical_rank

    sim = ctx.sim("example2")
    tr = sim.traces
    s, t = tr.slow_times_s, tr.fast_times_s
    fig = traces_figure(
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


def _fig_annihil_scene1(ctx: _Context) -> _Result:
    from ...separation import (
        annihilate,
        mover_trace_coverage,
        separate_annihilation,
        stationary_candidates,
    )

    sim = ctx.sim("scene1")
    tr = sim.traces
    img = ctx.scene1_image
    cand = stationary_candidates(img.values, x_m=img.grid.x_m, y_m=img.grid.y_m, traces=tr)
    sep = separate_annihilation(tr, cand)
    pts = sep.stationary_points_m
    q_l = annihilate(tr.with_data(sim.stationary), pts).data if len(pts) else sim.stationary
    q_s = annihilate(tr.with_data(sim.moving), pts).data if len(pts) else sim.moving
    cov = mover_trace_coverage(sep.moving, tr, sim.scene.moving)
    scr = _scr_db(sep.moving, q_s)
    # per pulse, re the largest per-pulse energy of Q S_true (dB)
    e_s = np.sum(np.abs(q_s) ** 2, axis=1)
    e_l = np.sum(np.abs(q_l) ** 2, axis=1)
    mover_db = 10 * np.log10(np.maximum(e_s, 1e-300) / e_s.max())
    still_db = 10 * np.log10(np.maximum(e_l, 1e-300) / e_s.max())
    exact = annihilate(tr, [p.position_m for p in sim.scene.stationary]).data
    cov_exact = mover_trace_coverage(exact, tr, sim.scene.moving)
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    refq = float(np.abs(sep.moving).max())
    fig = traces_figure(
        [
            ("M", tr.data, False, ref),
            ("M, dB", tr.data, True, ref),
            ("Q M", sep.moving, False, refq, "max|Q M|"),
            ("Q M, dB", sep.moving, True, refq, "max|Q M|"),
        ],
        slow_times_s=s,
        fast_times_s=t,
        ncols=2,
    )
    h = {
        "mover_trace_coverage": cov,
        "signal_to_clutter_db": scr,
        "min_pulse_mover_db": float(mover_db.min()),
        "max_pulse_stationary_db": float(still_db.max()),
        "pulses_movers_within_40db": float(np.mean(mover_db >= -40.0)),
        "n_filters": float(len(pts)),
        "n_candidates": float(len(cand)),
        "mover_trace_coverage_exact_locations": cov_exact,
    }
    summary = (
        f"annihilation ({len(pts)} filters from the image) keeps {100 * cov:.0f} % of the "
        f"movers' traces ({100 * cov_exact:.0f} % with the 20 exact locations), "
        f"signal-to-clutter {_fmt(scr, 1)} dB; per pulse the movers stay >= "
        f"{_fmt(mover_db.min(), 1)} dB and the stationary residue <= {_fmt(still_db.max(), 1)} dB "
        "re the largest per-pulse mover energy"
    )
    arrays = {
        "M": tr.data,
        "QM": sep.moving,
        "points_m": pts,
        "pulse_mover_db": mover_db,
        "pulse_stationary_db": still_db,
        "s": s,
        "t": t,
    }
    return _Result(fig, arrays, h, summary)


def _fig_rpca2mov(ctx: _Context) -> _Result:
    from ...separation import mover_trace_coverage, separation_quality

    sim = ctx.sim("scene1")
    tr = sim.traces
    sep = ctx.scene1_analysis.separation
    cov = mover_trace_coverage(sep.moving, tr, sim.scene.moving)
    q = separation_quality(sep, true_stationary=sim.stationary, true_moving=sim.moving)
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    fig = traces_figure(
        [("L (low rank)", sep.stationary, False, ref), ("S (sparse), dB", sep.moving, True, ref)],
        slow_times_s=s,
        fast_times_s=t,
        ncols=2,
    )
    h = {
        "mover_trace_coverage": cov,
        "signal_to_clutter_db": _scr_db(sep.moving, sim.moving),
        "rel_error_S": float(q["relative_error_moving"]),
    }
    summary = (
        f"windowed RPCA keeps {100 * cov:.0f} % of the movers' traces, signal-to-clutter "
        f"{_fmt(h['signal_to_clutter_db'], 1)} dB, "
        f"||S-S_true||/||S_true|| = {_fmt(h['rel_error_S'])}"
    )
    return _Result(fig, {"L": sep.stationary, "S": sep.moving, "s": s, "t": t}, h, summary)


def _fig_rotate_true_filt(ctx: _Context) -> _Result:
    from ...separation import transform_plus

    sim = ctx.sim("scene1")
    tr = ctx.scene1_moving_traces
    s, t = tr.slow_times_s, tr.fast_times_s
    ref = float(np.abs(tr.data).max())
    panels = [("moving traces S", tr.data, False, ref, "max|S|")]
    arrays: dict[str, Any] = {"moving": tr.data, "s": s, "t": t}
    h: dict[str, float] = {}
    parts = []
    for k, mover in enumerate(sim.scene.moving, start=1):
        al = transform_plus(tr, mover.position_m, velocity_mps=mover.velocity_mps).data
        panels.append((f"T_+^(u,ρ) S for mover {k}", al, False, ref, "max|S|"))
        arrays[f"aligned_{k}"] = al
        own = transform_plus(
            tr.with_data(_own_trace(ctx, k)), mover.position_m, velocity_mps=mover.velocity_mps
        ).data
        h[f"mover{k}_migration_after_ns"] = _peak_delay_spread_ns(own, t)
        h[f"mover{k}_migration_before_ns"] = _peak_delay_spread_ns(_own_trace(ctx, k), t)
        before = h[f"mover{k}_migration_before_ns"]
        after = h[f"mover{k}_migration_after_ns"]
        parts.append(f"{_fmt(before, 0)} -> {_fmt(after, 1)} ns")
    fig = traces_figure(panels, slow_times_s=s, fast_times_s=t, ncols=3)
    summary = "trace migration over the aperture, movers 1 and 2: " + ", ".join(parts)
    return _Result(fig, arrays, h, summary)


def _own_trace(ctx: _Context, k: int) -> NDArray:
    """The simulated trace of Scene 1's k-th mover alone (1-based)."""
    from ...core import to_fast_time
    from ...simulation import simulate_phase_history

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
    from ...core import range_speed

    sim = ctx.sim("scene1")
    geom = sim.traces.geometry
    gg = ctx.scene1_g
    u, g_all, g_mov = gg["u_mps"], gg["g_all"], gg["g_moving"]
    true_u = sorted(range_speed(m.velocity_mps, geom) for m in sim.scene.moving)
    peak_all = float(u[np.argmax(g_all)])
    peaks = np.sort(_local_maxima(u, g_mov, 2))
    fig, axes = subplots(1, 2, figsize=(9.6, 3.6))
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
    from ...core import ground_velocity, range_direction_velocity
    from ...motion import cross_range_objective
    from ...separation import transform_plus

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
    fig, axes = subplots(2, 2, figsize=(8.4, 7.0))
    for row, (data, tag) in enumerate(
        ((stage1, f"u^e = {u_e:.2f} m/s"), (stage2, f"+ u_perp^e = {up_e:.2f} m/s"))
    ):
        plot_traces(
            axes[row, 0],
            data,
            slow_times_s=s,
            fast_times_s=t,
            normalise_by=ref,
            title=tag,
            reference_label="max|D_1|",
        )
        plot_traces(
            axes[row, 1],
            data.real[:, zoom],
            slow_times_s=s,
            fast_times_s=t[zoom],
            normalise_by=ref,
            title="zoom, |Re| (carrier phase)",
            reference_label="max|D_1|",
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
