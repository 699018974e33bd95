"""Range acceleration over 2-4 degrees: does the Cramér–Rao bound cover the error?

Run::

    python benchmarks/acceleration_coverage.py --draws 40 --uniform 20 --out benchmarks/results

Draws (seeded, ``--seed``): one mover alone in white noise on GOTCHA's circular geometry
(Scene 1's radar and flight), an aperture uniform in [2, 4] degrees, the position uniform
in [-20, 20]^2 m, range and cross-range speeds uniform in [-8, 8] m/s, a per-sample SNR
uniform in [-10, 0] dB (``sarmotion.simulation.add_noise``), and a constant acceleration
``alpha b_r`` along the range direction (``sarmotion.simulation.AcceleratingTarget``,
``alpha = d u_r / ds``) of magnitude uniform in [0.3, 1] m/s^2 and either sign
(``--draws`` of them), or none (``--uniform``).

The chain is the analysis's on a wide aperture, without the separation (no clutter):
the maximum-likelihood fit on the central degree (``fit_point_mover``, cross-range speeds
searched over +-100 m/s: an acceleration looks like ``alpha L / (2 V)`` = 73 s x alpha of
cross-range speed there), its focus on the whole aperture (``refine_on_aperture``), then
``fit_range_acceleration`` with the noise ``noise_variance`` measures on the traces.

Reported per draw: the error over the bound, whether the rule calls it estimable, the
uniform stage's ``|I|`` over the mover's amplitude (below 1 when no uniform motion
matches the central degree: an acceleration towards the radar beyond the curvature
``(V - u_t)^2 / L`` of the uniform range history), the fit's ``|I|`` over it (1 where
the fit is the mover's maximum), whether the step's test found that the uniform start
holds the central degree (``uniform_start_holds``; where it does not, the central
searches run), and the range history the estimate's profile started from (``start``;
module notes of ``sarmotion.motion.acceleration``). Coverage = the fraction
within 3 bounds, over all draws, over the estimable ones, and over those the uniform
stage held (``|I|`` at least half the amplitude) or did not. The median time of the step
is given over all draws and over those whose uniform start held (the step's time for a
uniform mover). Writes ``acceleration_coverage.json`` and ``.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from sarmotion.core import ground_velocity
from sarmotion.motion import (
    central_sub_aperture,
    fit_point_mover,
    fit_range_acceleration,
    noise_variance,
    refine_on_aperture,
)
from sarmotion.simulation import AcceleratingTarget, Scene, add_noise, load_scene, simulate


def draw(rng: np.random.Generator, accelerating: bool) -> dict:
    """One draw's parameters (module notes)."""
    deg = float(rng.uniform(2.0, 4.0))
    magnitude = float(rng.uniform(0.3, 1.0))
    sign = float(rng.choice([-1.0, 1.0]))
    return {
        "aperture_deg": deg,
        "alpha_mps2": sign * magnitude if accelerating else 0.0,
        "position_m": rng.uniform(-20.0, 20.0, 2).tolist(),
        "range_speed_mps": float(rng.uniform(-8.0, 8.0)),
        "cross_range_speed_mps": float(rng.uniform(-8.0, 8.0)),
        "snr_db": float(rng.uniform(-10.0, 0.0)),
        "noise_seed": int(rng.integers(2**31)),
    }


def run_draw(p: dict) -> dict:
    """Simulate, fit, and compare one draw."""
    sc = load_scene("scene1")
    spec = {**sc.trajectory_spec, "aperture_deg": p["aperture_deg"]}
    empty = Scene(name="geometry", targets=(), radar=sc.radar, trajectory_spec=spec,
                  reference_point_m=sc.reference_point_m)  # fmt: skip
    geom = simulate(empty).traces.geometry
    velocity = ground_velocity(p["range_speed_mps"], p["cross_range_speed_mps"], geom)
    mover = AcceleratingTarget(
        position_m=p["position_m"],
        velocity_mps=velocity,
        acceleration_mps2=p["alpha_mps2"] * ground_velocity(1.0, 0.0, geom),
    )
    scene = Scene(name="accelerating", targets=(mover,), radar=sc.radar, trajectory_spec=spec,
                  reference_point_m=sc.reference_point_m)  # fmt: skip
    clean = simulate(scene).traces
    tr = clean.with_data(add_noise(clean.data, snr_db=p["snr_db"], rng=p["noise_seed"]))
    t0 = time.perf_counter()
    central = central_sub_aperture(tr, 1.0)
    sub = tr.select_pulses(central.start, central.stop)
    fit = fit_point_mover(sub, p["range_speed_mps"], cross_speed_range_mps=(-100.0, 100.0))
    focus = refine_on_aperture(tr, fit.position_m, fit.velocity_mps, central=central)
    t1 = time.perf_counter()
    acc = fit_range_acceleration(
        tr,
        focus.position_m,
        focus.velocity_mps,
        noise_variance=noise_variance(tr.data),
        cross_range_std_m=20.0,
    )
    t2 = time.perf_counter()
    err = acc.range_acceleration_mps2 - p["alpha_mps2"]
    return {
        **p,
        "estimate_mps2": acc.range_acceleration_mps2,
        "std_mps2": acc.std_mps2,
        "error_over_bound": err / acc.std_mps2,
        "estimable": acc.estimable,
        "prior_std_mps2": acc.prior_std_mps2,
        "uniform_focus": abs(focus.focus) / tr.n_pulses,
        "amplitude": abs(acc.amplitude),
        "uniform_seconds": t1 - t0,
        "acceleration_seconds": t2 - t1,
        "uniform_start_holds": acc.uniform_start_holds,
        "start": acc.start,
    }


def coverage(rows: list[dict]) -> dict:
    """Fraction of ``rows`` within 3 bounds, and how many."""
    n = len(rows)
    inside = sum(abs(r["error_over_bound"]) <= 3.0 for r in rows)
    return {"n": n, "within_3_bounds": inside, "fraction": inside / n if n else float("nan")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=40)
    ap.add_argument("--uniform", type=int, default=20)
    ap.add_argument("--seed", type=int, default=20261126)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    params = [draw(rng, True) for _ in range(args.draws)]
    params += [draw(rng, False) for _ in range(args.uniform)]
    rows = []
    for k, p in enumerate(params):
        rows.append(run_draw(p))
        r = rows[-1]
        print(
            f"{k:3d} {r['aperture_deg']:.2f} deg alpha {r['alpha_mps2']:+.3f} est "
            f"{r['estimate_mps2']:+.3f} +- {r['std_mps2']:.3f} ({r['error_over_bound']:+.2f}) "
            f"estimable {r['estimable']} focus {r['uniform_focus']:.3f} "
            f"holds {r['uniform_start_holds']} start {r['start']} "
            f"{r['acceleration_seconds']:.1f} s",
            flush=True,
        )
    acc = [r for r in rows if r["alpha_mps2"] != 0.0]
    uni = [r for r in rows if r["alpha_mps2"] == 0.0]
    held = [r for r in acc if r["uniform_focus"] >= 0.5]
    lost = [r for r in acc if r["uniform_focus"] < 0.5]
    seconds = [r["acceleration_seconds"] for r in rows]
    seconds_held = [r["acceleration_seconds"] for r in rows if r["uniform_start_holds"]]
    summary = {
        "seed": args.seed,
        "accelerating_all": coverage(acc),
        "accelerating_estimable": coverage([r for r in acc if r["estimable"]]),
        "accelerating_held_by_uniform_stage": coverage(held),
        "accelerating_held_and_estimable": coverage([r for r in held if r["estimable"]]),
        "accelerating_not_held_by_uniform_stage": coverage(lost),
        "uniform_all": coverage(uni),
        "uniform_estimable": coverage([r for r in uni if r["estimable"]]),
        "acceleration_seconds_median": float(np.median(seconds)),
        "acceleration_seconds_median_start_held": (
            float(np.median(seconds_held)) if seconds_held else float("nan")
        ),
        "central_searches_run": sum(not r["uniform_start_holds"] for r in rows),
        "estimates_from_central_history": sum(r["start"] != "uniform" for r in rows),
        "load_average": os.getloadavg(),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "acceleration_coverage.json").write_text(
        json.dumps({"summary": summary, "draws": rows}, indent=1)
    )
    lines = [
        "# Range acceleration: coverage of the Cramér–Rao bound",
        "",
        f"`python benchmarks/acceleration_coverage.py --draws {args.draws} --uniform "
        f"{args.uniform} --seed {args.seed}` (module notes of the script for the draws).",
        "",
        "| population | draws | within 3 bounds | fraction |",
        "|---|---|---|---|",
    ]
    for key, c in summary.items():
        if isinstance(c, dict):
            lines.append(f"| {key} | {c['n']} | {c['within_3_bounds']} | {c['fraction']:.3f} |")
    lines += [
        "",
        f"Median time of the acceleration step: {summary['acceleration_seconds_median']:.2f} s "
        f"over all draws, {summary['acceleration_seconds_median_start_held']:.2f} s over those "
        f"whose uniform start held (load average {summary['load_average'][0]:.1f} on the "
        "machine that ran it). Central searches run on "
        f"{summary['central_searches_run']} of {len(rows)} draws; the estimate came from the "
        f"central degree's range history on {summary['estimates_from_central_history']}.",
        "",
        "| aperture (deg) | alpha (m/s^2) | estimate | bound | error / bound | estimable | "
        "uniform |I| / amplitude | fit |I| / amplitude | uniform start holds | start |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['aperture_deg']:.2f} | {r['alpha_mps2']:+.3f} | {r['estimate_mps2']:+.3f} | "
            f"{r['std_mps2']:.3f} | {r['error_over_bound']:+.2f} | {r['estimable']} | "
            f"{r['uniform_focus']:.3f} | {r['amplitude']:.3f} | {r['uniform_start_holds']} | "
            f"{r['start']} |"
        )
    (args.out / "acceleration_coverage.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
