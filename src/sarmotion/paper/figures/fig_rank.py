"""Figures of the rank analysis of the trace matrix (``sect:rank``)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...report.plotting import subplots
from ._context import B_RANK, EPS, NU_O, _Context, _Result

__all__ = []


# --------------------------------------------------------------------------- rank
def _linfit(x: NDArray, y: NDArray) -> tuple[float, float]:
    slope, icpt = np.polyfit(x, y, 1)
    resid = y - (slope * x + icpt)
    r2 = 1.0 - np.sum(resid**2) / max(np.sum((y - y.mean()) ** 2), 1e-300)
    return float(slope), float(r2)


def _fig_rank1(ctx: _Context) -> _Result:
    from ...core import Trajectory, look_geometry, range_direction_velocity
    from ..rank import alpha, numerical_rank, passband_traces, szego_rank_fraction

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
    fig, axes = subplots(1, 2, figsize=(9.6, 3.6))
    axes[0].plot(offsets, e_off, "b-", label="Szegő estimate")
    axes[0].plot(offsets, r_off, "g.-", label="computed")
    axes[0].set_xlabel("cross-range offset (m)")
    axes[0].set_title(f"stationary target, n+1 = {traj_s.n_pulses}", fontsize=9)
    axes[1].plot(speeds, e_u, "b-", label="Szegő estimate")
    axes[1].plot(speeds, r_u, "g.-", label="computed")
    axes[1].set_xlabel("range speed (m/s)")
    axes[1].set_title(f"moving target at ρ_o, n+1 = {traj_m.n_pulses}", fontsize=9)
    for ax, n1 in zip(axes, (traj_s.n_pulses, traj_m.n_pulses), strict=True):
        ax.set_ylabel(f"rank of Y (of n+1 = {n1})")
        ax.legend(fontsize=8)
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
        "n_plus_1_offset": float(traj_s.n_pulses),
        "n_plus_1_speed": float(traj_m.n_pulses),
    }
    summary = (
        f"rank slope {so:.2f}/m (Szegő {h['slope_offset_szego_per_m']:.2f}) with offset, "
        f"{su:.1f} per m/s (Szegő {h['slope_speed_szego_per_mps']:.1f}) with range speed; "
        f"mover at {speeds[-1]:g} m/s rank {r_u[-1]} vs stationary (10 m) {r_still10} "
        f"(left: 4° aperture, n+1 = {traj_s.n_pulses} pulses; right and the comparison: 1°, "
        f"n+1 = {traj_m.n_pulses})"
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
    from ...core import Trajectory, look_geometry
    from ..rank import alpha_j, numerical_rank, passband_traces, szego_rank_fraction

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
    fig, ax = subplots(figsize=(5.4, 3.8))
    ax.plot(n1, frac, "b.-", label="computed rank/(n+1)")
    ax.plot(n1, est, "g-", label="Szegő estimate")
    ax.set_xlabel("n + 1 (pulses)")
    ax.set_ylabel("rank(Y) / (n+1)")
    ax.set_title("stationary target 50 m off in cross range", fontsize=9)
    ax.legend(fontsize=8)
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
    from ...core import LookGeometry, Trajectory, look_geometry
    from ..rank import (
        alpha_j,
        beta,
        numerical_rank,
        passband_traces,
        symbol_rank_fraction,
    )

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
    fig, axes = subplots(1, 2, figsize=(9.6, 3.6))
    arrays: dict[str, Any] = {"y_m": ys}
    h: dict[str, float] = {"n_plus_1": float(traj.n_pulses)}
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
        axes[k].set_ylabel(f"rank of Y (of n+1 = {traj.n_pulses})")
        axes[k].set_title(
            f"ρ_1 = ({x:g}, 5, 0) m, n+1 = {traj.n_pulses}; B|β| = {b_flat:.2f} (flat), "
            f"{b_geo:.2f} (3-D)",
            fontsize=8,
        )
        axes[k].legend(fontsize=8)
    fig.tight_layout()
    summary = (
        f"B|β| = {h['B_beta_flat_left']:.2f} (flat convention; {h['B_beta_3d_left']:.2f} in 3-D "
        f"GOTCHA) on the left, {h['B_beta_flat_right']:.2f} on the right; max |computed - "
        f"Szegő| = {h['max_abs_computed_minus_szego_left']:.0f} and "
        f"{h['max_abs_computed_minus_szego_right']:.0f} (4° aperture, n+1 = {traj.n_pulses} "
        "pulses)"
    )
    return _Result(fig, arrays, h, summary)
