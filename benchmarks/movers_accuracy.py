"""Accuracy of mover detection and estimation: seeded Monte Carlo, the analysis and a baseline.

Regenerate the table and figures (a few minutes on 2 cores)::

    python benchmarks/movers_accuracy.py --out benchmarks/results

``--quick`` runs one scene in six (a smoke test). The analysis also searches its
stationary band (``AnalysisOptions.defocus_search``, the default) unless
``--no-defocus-search`` (``results/movers_accuracy_defocus.md`` compares the two). Every
scene is one degree of aperture
(117 pulses), seeded from ``--seed`` (default 2026; the detector's null tail was measured
on other seeds, see ``sarmotion.motion.detector``). Scenes:

``clutter``  random point clutter, 10-80 unit targets, white noise at 0/10/20/30 dB SNR
             (``add_noise``), 1-2 movers of range speed 1-10 m/s, reflectivity -20..0 dB;
             even seeds separated by the combined method, odd by RPCA (as GOTCHA-format
             files of simulated scenes are);
``real``     a real GOTCHA degree (all four in turn) with 2 injected movers at
             4-24 dB below the median per-pulse peak of the data;
``slow``     2 movers of range speed 0.5-3 m/s, alternately in a real degree and in clutter;
``pairs``    2 movers with range speeds within 0.5 m/s, alternately real and clutter;
``null``     the four real degrees one at a time and together (central degree), and
             simulated clutter without movers.

For each scene, in the same run: the analysis (``sarmotion.pipeline.detect`` and
``estimate_movers``, default options, as ``analyze`` calls them: its movers' final refit
on the data minus a stationary estimate made without them,
``sarmotion.pipeline.refit``; their fits on the separated traces before the refit are
scored too) and the *baseline*: ``g(u)`` on all traces (no separation), the same local-floor
statistic and threshold (same false-alarm rate), no shape or stationary test; for each
peak the cross-range speed maximising the focus of the motion-compensated response (the
same global search and local polish, ``fit_point_mover`` on the data), no joint
refinement.

Scoring: an estimate is matched to the true mover minimising
``(du / 0.27)^2 + (dx / 0.34)^2`` (range speed, range position) within 1.1 m/s and 3 m;
unmatched estimates are false movers. Per regime the table gives P_d, false movers per
scene and the RMSEs on each method's own movers and on the movers both found (the common
set: the only like-for-like comparison of accuracy), beside the bound the analysis reports.
Errors are taken after sliding the estimate along
its own cross-range family to the truth's cross-range coordinate
(``sarmotion.motion.family_member``), where the bound is defined. ``strength`` is the
mover's reflectivity over the median per-pulse peak ``|M|`` of the data (dB).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import dataclass, field
from multiprocessing import Pool
from pathlib import Path

import numpy as np

GOTCHA = Path(
    os.environ.get(
        "SARMOTION_GOTCHA_DIR", Path(__file__).resolve().parents[2] / "shared" / "data" / "gotcha"
    )
)


# =================================================================== scenes
@dataclass
class Spec:
    kind: str
    seed: int
    params: dict = field(default_factory=dict)


def scene_specs(seed: int, quick: bool) -> list[Spec]:
    specs: list[Spec] = []
    for i in range(30):
        specs.append(Spec("clutter", seed + i))
    for i, att in enumerate([4, 8, 12, 14, 16, 18, 20, 24] * 4):
        specs.append(Spec("real", seed + 100 + i, {"degree": i % 4, "attenuation_db": att}))
    for i in range(16):
        specs.append(Spec("slow", seed + 200 + i, {"real": i % 2 == 0, "degree": i % 4}))
    for i in range(12):
        specs.append(Spec("pairs", seed + 300 + i, {"real": i % 2 == 0, "degree": i % 4}))
    for d in range(5):
        specs.append(Spec("null_real", seed + 400 + d, {"degree": d}))
    for i in range(10):
        specs.append(Spec("null_sim", seed + 500 + i))
    return specs[::6] if quick else specs


def _gotcha(degree: int):
    from sarmotion.io import read_gotcha

    files = sorted(GOTCHA.glob("data_3dsar_pass1_az00*_HH.mat"))
    return read_gotcha(files[degree : degree + 1] if degree < 4 else files)


def _clutter(rng: np.random.Generator, movers: list, snr_db: float | None = None):
    """Random point clutter of 10-80 unit targets with noise, and the given movers.

    Returns the traces, the scene's info and the noise-free traces of the clutter alone
    (the true ``L``, for a detector that knows it: ``benchmarks/coherent_detection.py``).
    """
    from sarmotion.simulation import random_scene, simulate

    n = int(rng.integers(10, 81))
    snr = float(rng.choice([0.0, 10.0, 20.0, 30.0])) if snr_db is None else snr_db
    scene = random_scene(n_stationary=n, rng=rng)
    sim = simulate(scene, snr_db=snr, rng=rng)
    from sarmotion.simulation import inject

    tr = inject(sim.traces, movers) if movers else sim.traces
    return tr, {"n_stationary": n, "snr_db": snr}, sim.stationary


def _mover(rng, geom, u_range, amp, *, u=None, up_range=(-10.0, 10.0), min_up=0.0):
    from sarmotion.core import ground_velocity
    from sarmotion.simulation import PointTarget

    ur = rng.uniform(*u_range) * rng.choice([-1.0, 1.0]) if u is None else u
    up = rng.uniform(*up_range)
    while abs(up) < min_up:
        up = rng.uniform(*up_range)
    pos = rng.uniform(-20.0, 20.0, 2)
    phase = np.exp(2j * np.pi * rng.random())
    return PointTarget(
        position_m=pos, velocity_mps=ground_velocity(ur, up, geom), reflectivity=amp * phase
    )


def make_scene(spec: Spec, *, with_clutter: bool = False):
    """(traces, movers, method, info) of a spec.

    ``with_clutter``: a fifth element, the noise-free traces of the simulated clutter
    (``None`` for a real degree).
    """
    out = _make_scene(spec)
    return out if with_clutter else out[:4]


def _make_scene(spec: Spec):
    """(traces, movers, method, info, clutter or None) of a spec."""
    from sarmotion.simulation import inject

    rng = np.random.default_rng(spec.seed)
    p = spec.params
    template = _gotcha(0)
    geom = template.geometry
    if spec.kind == "clutter":
        amps = 10 ** (rng.uniform(-20, 0, 2) / 20)
        movers = [_mover(rng, geom, (1.0, 10.0), a) for a in amps[: int(rng.integers(1, 3))]]
        tr, info, clutter = _clutter(rng, movers)
        return tr, movers, "combined" if spec.seed % 2 == 0 else "rpca", info, clutter
    if spec.kind in ("null_real", "null_sim"):
        if spec.kind == "null_real":
            return _gotcha(p["degree"]), [], "rpca", {"degree": p["degree"]}, None
        tr, info, clutter = _clutter(rng, [])
        return tr, [], "combined" if spec.seed % 2 == 0 else "rpca", info, clutter
    real = spec.kind == "real" or p.get("real", False)
    base = _gotcha(p["degree"]) if real else None
    ref = float(np.median(np.abs(base.data).max(axis=1))) if real else 1.0
    if spec.kind == "real":
        amp = [ref * 10 ** (-p["attenuation_db"] / 20)] * 2
        movers = [_mover(rng, geom, (1.5, 10.0), a, min_up=1.0) for a in amp]
    elif spec.kind == "slow":
        amp = ref * 10 ** (-rng.uniform(6, 12, 2) / 20)
        movers = [_mover(rng, geom, (0.5, 3.0), a) for a in amp]
    else:  # pairs
        amp = ref * 10 ** (-rng.uniform(6, 12, 2) / 20)
        first = _mover(rng, geom, (2.0, 8.0), amp[0])
        from sarmotion.core import range_speed

        u2 = range_speed(first.velocity_mps, geom) + rng.uniform(-0.5, 0.5)
        movers = [first, _mover(rng, geom, (0, 0), amp[1], u=u2)]
    if real:
        return inject(base, movers), movers, "rpca", {"degree": p["degree"]}, None
    tr, info, clutter = _clutter(rng, movers, snr_db=20.0)
    return tr, movers, "combined" if spec.seed % 2 == 0 else "rpca", info, clutter


# =================================================================== methods
#: Whether the analysis searches its stationary band for defocused movers
#: (``--no-defocus-search`` turns it off; set in each worker by :func:`_set_defocus_search`).
DEFOCUS_SEARCH = True


def _set_defocus_search(on: bool) -> None:
    global DEFOCUS_SEARCH
    DEFOCUS_SEARCH = bool(on)


def run_analysis(traces, method: str):
    """Detection and estimation stages of the analysis (default options).

    Returns the sub-aperture, the estimates, the detection, the moving part and, when the
    analysis refitted its movers, their fits on the separated traces before the refit.
    """
    from sarmotion.pipeline import AnalysisOptions, detect, estimate_movers
    from sarmotion.separation import SeparationOptions

    opts = AnalysisOptions(
        separation=SeparationOptions(method=method),
        trajectory=False,
        defocus_search=DEFOCUS_SEARCH,
    )
    found = detect(traces, opts)
    movers = estimate_movers(found).movers
    out, first = [], []
    for f in movers:
        b = f.bound
        if f.refit_kept is not None:  # the refit ran: score the fit on S too
            s = f.separated_fit
            first.append({"position_m": s.position_m, "velocity_mps": s.velocity_mps})
        out.append(
            {
                "position_m": f.fit.position_m,
                "velocity_mps": f.fit.velocity_mps,
                "statistic_db": f.evidence.statistic_db,
                "sd": [b.range_position_m, b.range_speed_mps, b.cross_range_speed_mps],
                "snr_db": b.snr_db,
                "g_perp_mps": f.g_perp.speed_mps,
            }
        )
    first = first if len(first) == len(out) else None
    return found.sub, out, found.candidates, found.moving_sub, first


def run_baseline(traces, image_size_m: float):
    """No separation: g(u) on all traces, same statistic and threshold, focus search per peak."""
    from sarmotion.motion import (
        central_sub_aperture,
        detect_range_speeds,
        fit_point_mover,
        range_speed_resolution,
    )

    central = central_sub_aperture(traces, 1.0)
    sub = traces.select_pulses(central.start, central.stop)
    geom = sub.geometry
    apparent = geom.speed_mps * (image_size_m / np.sqrt(2.0)) / geom.range_m
    det = detect_range_speeds(
        sub,
        min_speed_mps=max(2.0 * range_speed_resolution(sub), apparent),
        max_width=np.inf,
    )
    out = []
    for u in det.range_speeds.speeds_mps[:5]:
        f = fit_point_mover(sub, float(u))
        out.append({"position_m": f.position_m, "velocity_mps": f.velocity_mps})
    return out


# =================================================================== scoring
def score(sub, movers, estimates):
    """Match estimates to movers; errors after sliding along the estimate's family."""
    from sarmotion.core import cross_range_speed, range_speed
    from sarmotion.imaging import resolution
    from sarmotion.motion import family_member

    geom = sub.geometry
    cells = resolution(sub)
    e_r, e_c = cells.range_direction, cells.cross_range_direction
    pairs = []
    for i, m in enumerate(movers):
        ut = range_speed(m.velocity_mps, geom)
        for j, e in enumerate(estimates):
            du = range_speed(e["velocity_mps"], geom) - ut
            dx = float((np.asarray(e["position_m"])[:2] - m.position_m[:2]) @ e_r)
            if abs(du) <= 1.1 and abs(dx) <= 3.0:
                pairs.append(((du / 0.27) ** 2 + (dx / 0.34) ** 2, i, j))
    used_m, used_e, matches = set(), set(), {}
    for _, i, j in sorted(pairs):
        if i in used_m or j in used_e:
            continue
        used_m.add(i)
        used_e.add(j)
        m, e = movers[i], estimates[j]
        dy = float((m.position_m[:2] - np.asarray(e["position_m"])[:2]) @ e_c)
        fp, fv, _ = family_member(sub, e["position_m"], e["velocity_mps"], dy)
        # and the truth slid to the estimate's cross range, where its bound is defined
        tp, tv, _ = family_member(sub, m.position_m, m.velocity_mps, -dy)
        matches[i] = {
            "estimate": j,
            "du": range_speed(fv, geom) - range_speed(m.velocity_mps, geom),
            "dup": cross_range_speed(fv, geom) - cross_range_speed(m.velocity_mps, geom),
            "dx": float((fp[:2] - m.position_m[:2]) @ e_r),
            "bound_errors": [
                float((np.asarray(e["position_m"])[:2] - tp[:2]) @ e_r),
                range_speed(e["velocity_mps"], geom) - range_speed(tv, geom),
                cross_range_speed(e["velocity_mps"], geom) - cross_range_speed(tv, geom),
            ],
        }
    return matches, len(estimates) - len(used_e)


def run_one(spec: Spec) -> dict:
    from sarmotion.core import cross_range_speed, range_speed
    from sarmotion.imaging import default_scene_size_m
    from sarmotion.motion import local_statistic

    t0 = time.perf_counter()
    traces, movers, method, info = make_scene(spec)
    ref = float(np.median(np.abs(traces.data).max(axis=1)))
    sub, est, det, moving, first = run_analysis(traces, method)
    t1 = time.perf_counter()
    base = run_baseline(traces, default_scene_size_m(traces))
    t2 = time.perf_counter()
    m_a, false_a = score(sub, movers, est)
    m_b, false_b = score(sub, movers, base)
    m_s = score(sub, movers, first)[0] if first is not None else {}
    geom = sub.geometry
    truth = []
    for i, m in enumerate(movers):
        rec = {
            "u": range_speed(m.velocity_mps, geom),
            "up": cross_range_speed(m.velocity_mps, geom),
            "strength_db": float(20 * np.log10(abs(m.reflectivity) / ref)),
            # the mover's g(u) peak over its local floor after separation (dB)
            "statistic_at_truth_db": local_statistic(
                sub.with_data(moving), range_speed(m.velocity_mps, geom)
            ),
            "analysis": m_a.get(i),
            "baseline": m_b.get(i),
            # the same detection's fit on the separated traces, before the final refit
            "analysis_on_s": m_s.get(i),
        }
        if i in m_a:
            e = est[m_a[i]["estimate"]]
            # g_perp and the fit at the same (u, rho), before the family slide
            raw = cross_range_speed(e["velocity_mps"], geom) - rec["up"]
            rec["analysis"].update(
                sd=e["sd"],
                snr_db=e["snr_db"],
                statistic_db=e["statistic_db"],
                raw_dup=raw,
                g_perp_error=e["g_perp_mps"] - rec["up"],
            )
        truth.append(rec)
    return {
        "kind": spec.kind,
        "seed": spec.seed,
        "method": method,
        "info": info,
        "movers": truth,
        "false_analysis": false_a,
        "false_baseline": false_b,
        "threshold_db": det.threshold_db,
        "n_candidates": det.n_candidates,
        "null_statistics": det.statistics.statistic_db[
            np.abs(det.statistics.speeds_mps) >= det.min_speed_mps
        ].tolist()
        if not movers
        else [],
        "seconds_analysis": t1 - t0,
        "seconds_baseline": t2 - t1,
    }


# =================================================================== report
def _rmse(values):
    v = np.asarray([x for x in values if x is not None], dtype=float)
    return float(np.sqrt(np.mean(v**2))) if v.size else float("nan")


def summarise(records: list[dict]) -> dict:
    movers = [m | {"kind": r["kind"]} for r in records for m in r["movers"]]
    s = {"n_scenes": len(records), "n_movers": len(movers)}
    for who in ("analysis", "baseline"):
        found = [m for m in movers if m[who] is not None]
        s[who] = {
            "detected": len(found),
            "false_per_scene": float(np.mean([r[f"false_{who}"] for r in records])),
            "false_on_null": int(
                sum(r[f"false_{who}"] for r in records if r["kind"].startswith("null"))
            ),
            "rmse_u": _rmse([m[who]["du"] for m in found]),
            "rmse_up": _rmse([m[who]["dup"] for m in found]),
            "rmse_x": _rmse([m[who]["dx"] for m in found]),
            "max_abs_up": float(max([abs(m[who]["dup"]) for m in found], default=float("nan"))),
            "within_0p54_up": int(sum(abs(m[who]["dup"]) <= 0.54 for m in found)),
        }
    strong = [m for m in movers if m["statistic_at_truth_db"] >= 8.0]
    s["movers_8db"] = len(strong)
    s["found_8db"] = int(sum(m["analysis"] is not None for m in strong))
    found = [m for m in movers if m["analysis"] is not None]
    sd = np.array([m["analysis"]["sd"] for m in found]) if found else np.zeros((0, 3))
    err = np.array([m["analysis"]["bound_errors"] for m in found])
    if found:
        s["analysis"]["rms_bound"] = np.sqrt(np.mean(sd**2, axis=0)).tolist()
        s["analysis"]["beyond_3_bounds"] = (np.abs(err) > 3 * sd).sum(axis=0).tolist()
        s["bound_by_kind"] = {}
        for kinds, name in (
            (("clutter",), "simulated clutter"),
            (("real",), "real GOTCHA"),
            (("slow", "pairs"), "slow and pairs"),
        ):
            sel = [i for i, m in enumerate(found) if m["kind"] in kinds]
            if sel:
                e, b = err[sel], sd[sel]
                s["bound_by_kind"][name] = {
                    "n": len(sel),
                    "rmse": np.sqrt(np.mean(e**2, axis=0)).tolist(),
                    "rms_bound": np.sqrt(np.mean(b**2, axis=0)).tolist(),
                    "median_ratio": np.median(np.abs(e) / b, axis=0).tolist(),
                    "beyond_3": (np.abs(e) > 3 * b).sum(axis=0).tolist(),
                }
        s["analysis"]["rmse_g_perp"] = _rmse([m["analysis"]["g_perp_error"] for m in found])
        s["analysis"]["rmse_raw_up"] = _rmse([m["analysis"]["raw_dup"] for m in found])
        s["analysis"]["g_perp_beyond_0p54"] = int(
            sum(abs(m["analysis"]["g_perp_error"]) > 0.54 for m in found)
        )
    return s


REGIMES = {
    "clutter": ("clutter",),
    "real": ("real",),
    "slow": ("slow",),
    "pairs": ("pairs",),
    "null": ("null_real", "null_sim"),
}


def by_regime(records: list[dict]) -> dict:
    """Per regime: P_d, false movers per scene, and RMSEs on each method's own movers and on
    the movers both found (the common set), beside the analysis's reported bound.

    Errors are ``du``, ``dup``, ``dx`` (range speed, cross-range speed, range position,
    after the family slide); ``on_s`` is the analysis's fit on the separated traces
    before its final refit, on the same common set (when the records hold it).
    """
    out = {}
    for name, kinds in REGIMES.items():
        rs = [r for r in records if r["kind"] in kinds]
        if not rs:
            continue
        ms = [m for r in rs for m in r["movers"]]
        reg: dict = {"scenes": len(rs), "movers": len(ms)}
        for who in ("analysis", "baseline"):
            found = [m[who] for m in ms if m[who] is not None]
            reg[who] = {
                "detected": len(found),
                "p_d": len(found) / len(ms) if ms else float("nan"),
                "false_per_scene": float(np.mean([r[f"false_{who}"] for r in rs])),
                "rmse": [_rmse([f[k] for f in found]) for k in ("du", "dup", "dx")],
            }
        common = [m for m in ms if m["analysis"] is not None and m["baseline"] is not None]
        reg["common"] = {
            "n": len(common),
            "analysis": [_rmse([m["analysis"][k] for m in common]) for k in ("du", "dup", "dx")],
            "baseline": [_rmse([m["baseline"][k] for m in common]) for k in ("du", "dup", "dx")],
            # bound order in the records: range position, range speed, cross-range speed
            "rms_bound": [_rmse([m["analysis"]["sd"][k] for m in common]) for k in (1, 2, 0)],
        }
        on_s = [m for m in ms if m["analysis"] is not None and m.get("analysis_on_s")]
        if on_s:
            both = [m for m in common if m.get("analysis_on_s")]
            reg["on_s"] = {
                "n": len(on_s),
                "rmse": [_rmse([m["analysis_on_s"][k] for m in on_s]) for k in ("du", "dup", "dx")],
                "rmse_refit": [
                    _rmse([m["analysis"][k] for m in on_s]) for k in ("du", "dup", "dx")
                ],
                "common_n": len(both),
                "common": [
                    _rmse([m["analysis_on_s"][k] for m in both]) for k in ("du", "dup", "dx")
                ],
            }
        out[name] = reg
    return out


def regime_lines(reg: dict) -> list[str]:
    """The per-regime table (markdown)."""
    f = lambda v, d=4: " / ".join("-" if np.isnan(x) else f"{x:.{d}f}" for x in v)  # noqa: E731
    lines = [
        "Per regime, analysis / baseline (RMSE of range speed u, cross-range speed u_perp in "
        "m/s, range position x in m; *common*: the movers both found; the RMS Cramér–Rao "
        "bound the analysis reports on them, u / u_perp / x):",
        "",
        "| regime | scenes | movers | P_d | false movers per scene | own movers: RMSE u_perp | "
        "common | common RMSE u | common RMSE u_perp | common RMSE x | RMS bound (common) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, r in reg.items():
        a, b, c = r["analysis"], r["baseline"], r["common"]
        lines.append(
            f"| {name} | {r['scenes']} | {r['movers']} | "
            + (f"{a['p_d']:.2f} / {b['p_d']:.2f}" if r["movers"] else "-")
            + f" | {a['false_per_scene']:.2f} / {b['false_per_scene']:.2f} | "
            + (
                f"{f([a['rmse'][1]], 3)} ({a['detected']}) / "
                f"{f([b['rmse'][1]], 3)} ({b['detected']})"
                if r["movers"]
                else "-"
            )
            + f" | {c['n']} | {f([c['analysis'][0], c['baseline'][0]], 5)} | "
            f"{f([c['analysis'][1], c['baseline'][1]], 3)} | "
            f"{f([c['analysis'][2], c['baseline'][2]])} | "
            f"{f(c['rms_bound'][:2], 5) if c['n'] else '-'}"
            + (f" / {c['rms_bound'][2]:.4f}" if c["n"] else "")
            + " |"
        )
    if any("on_s" in r for r in reg.values()):
        lines += [
            "",
            "The analysis's final refit against its fit on the separated traces (same "
            "detections, same run): RMSE u / u_perp / x on all its movers, and u_perp on the "
            "common set:",
            "",
            "| regime | movers | fit on S | refit | common | fit on S, u_perp | refit, u_perp "
            "| baseline, u_perp |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for name, r in reg.items():
            if "on_s" not in r:
                continue
            o = r["on_s"]
            lines.append(
                f"| {name} | {o['n']} | {f(o['rmse'][:2], 4)} / {o['rmse'][2]:.4f} | "
                f"{f(o['rmse_refit'][:2], 4)} / {o['rmse_refit'][2]:.4f} | {o['common_n']} | "
                f"{f([o['common'][1]], 3)} | {f([r['common']['analysis'][1]], 3)} | "
                f"{f([r['common']['baseline'][1]], 3)} |"
            )
    return lines


def write_outputs(records: list[dict], out: Path, seconds: float, workers: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    (out / "movers_accuracy.json").write_text(json.dumps(records, indent=1, default=float))
    s = summarise(records)
    movers = [m | {"kind": r["kind"]} for r in records for m in r["movers"]]
    lines = [
        f"Seeded Monte Carlo: {s['n_scenes']} one-degree scenes, {s['n_movers']} movers; "
        f"{seconds / 60:.1f} min on {workers} worker(s).",
        "",
        "| | analysis | baseline (no separation) |",
        "|---|---|---|",
    ]
    a, b = s["analysis"], s["baseline"]
    lines += [
        f"| movers detected | {a['detected']} / {s['n_movers']} | {b['detected']} / {s['n_movers']} |",  # noqa: E501
        f"| false movers per scene (all scenes) | {a['false_per_scene']:.2f} | {b['false_per_scene']:.2f} |",  # noqa: E501
        f"| false movers on the {sum(r['kind'].startswith('null') for r in records)} scenes without movers | {a['false_on_null']} | {b['false_on_null']} |",  # noqa: E501
        f"| RMSE range speed (m/s) | {a['rmse_u']:.4f} | {b['rmse_u']:.4f} |",
        f"| RMSE cross-range speed (m/s) | {a['rmse_up']:.3f} | {b['rmse_up']:.3f} |",
        f"| worst cross-range speed error (m/s) | {a['max_abs_up']:.3f} | {b['max_abs_up']:.3f} |",
        f"| cross-range speed within 0.54 m/s | {a['within_0p54_up']} / {a['detected']} | {b['within_0p54_up']} / {b['detected']} |",  # noqa: E501
        f"| RMSE range position (m) | {a['rmse_x']:.4f} | {b['rmse_x']:.4f} |",
    ]
    if "rms_bound" in a:
        rb = a["rms_bound"]
        lines += [
            f"| RMS Cramér–Rao bound reported: range position / range speed / cross-range speed | "
            f"{rb[0]:.2g} m / {rb[1]:.2g} m/s / {rb[2]:.2g} m/s | |",
            f"| errors beyond 3 reported bounds (x, u, u_perp) | {a['beyond_3_bounds']} | |",
            f"| cross-range speed at the fit's (u, rho), before the family slide: RMSE of the "
            f"ML fit / of g_perp's minimum (m/s); g_perp beyond 0.54 m/s | "
            f"{a['rmse_raw_up']:.3f} / {a['rmse_g_perp']:.3f}; {a['g_perp_beyond_0p54']} | |",
        ]
    if "bound_by_kind" in s:
        lines += [
            "",
            "Errors against the Cramér–Rao bound the analysis reports (truth slid along its "
            "family to the estimate's cross range; x m, u and u_perp m/s):",
            "",
            "| scenes | movers | RMSE (x, u, u_perp) | RMS bound | median error / bound | beyond 3 bounds |",  # noqa: E501
            "|---|---|---|---|---|---|",
        ]
        for name, k in s["bound_by_kind"].items():
            fmt = lambda v: ", ".join(f"{x:.2g}" for x in v)  # noqa: E731
            lines.append(
                f"| {name} | {k['n']} | {fmt(k['rmse'])} | {fmt(k['rms_bound'])} | "
                f"{fmt(k['median_ratio'])} | {k['beyond_3']} |"
            )
    s["by_regime"] = by_regime(records)
    lines += ["", *regime_lines(s["by_regime"])]
    lines += [
        "",
        f"Movers whose g(u) peak after separation stands >= 8 dB over its local floor: "
        f"{s['movers_8db']}, found {s['found_8db']}.",
    ]
    lines += ["", "Detection probability by strength (dB re the median per-pulse peak of |M|):", ""]
    lines += ["| strength (dB) | movers | P_d analysis | P_d baseline |", "|---|---|---|---|"]
    edges = [-40, -24, -20, -16, -12, -8, -4, 10]
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        sel = [m for m in movers if lo <= m["strength_db"] < hi]
        if sel:
            pa = np.mean([m["analysis"] is not None for m in sel])
            pb = np.mean([m["baseline"] is not None for m in sel])
            lines.append(f"| [{lo}, {hi}) | {len(sel)} | {pa:.2f} | {pb:.2f} |")
    lines += ["", "Detection probability by range speed |u| (m/s):", ""]
    lines += ["| abs(u) (m/s) | movers | P_d analysis | P_d baseline |", "|---|---|---|---|"]
    edges = [0.0, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 11.0]
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        sel = [m for m in movers if lo <= abs(m["u"]) < hi]
        if sel:
            pa = np.mean([m["analysis"] is not None for m in sel])
            pb = np.mean([m["baseline"] is not None for m in sel])
            lines.append(f"| [{lo}, {hi}) | {len(sel)} | {pa:.2f} | {pb:.2f} |")
    lines += ["", "By scene kind:", ""]
    lines += [
        "| kind | scenes | movers | detected (analysis / baseline) | false movers (analysis / baseline) |",  # noqa: E501
        "|---|---|---|---|---|",
    ]
    for kind in ("clutter", "real", "slow", "pairs", "null_real", "null_sim"):
        rs = [r for r in records if r["kind"] == kind]
        if not rs:
            continue
        ms = [m for r in rs for m in r["movers"]]
        lines.append(
            f"| {kind} | {len(rs)} | {len(ms)} | {sum(m['analysis'] is not None for m in ms)} / "
            f"{sum(m['baseline'] is not None for m in ms)} | {sum(r['false_analysis'] for r in rs)} / "  # noqa: E501
            f"{sum(r['false_baseline'] for r in rs)} |"
        )
    null = np.concatenate(
        [r["null_statistics"] for r in records if r["null_statistics"]] or [np.zeros(0)]
    )
    if null.size:
        q = np.quantile(null, [0.5, 0.9, 0.99])
        lines += [
            "",
            f"Null statistic on the scenes without movers ({null.size} candidates above the "
            f"stationary band): median {q[0]:.2f} dB, 90 % {q[1]:.2f}, 99 % {q[2]:.2f}, "
            f"max {null.max():.2f}; thresholds used {min(r['threshold_db'] for r in records):.2f}-"
            f"{max(r['threshold_db'] for r in records):.2f} dB.",
        ]
    t_a = np.mean([r["seconds_analysis"] for r in records])
    t_b = np.mean([r["seconds_baseline"] for r in records])
    lines += [
        "",
        f"Mean time per scene: analysis {t_a:.1f} s (incl. separation), baseline {t_b:.1f} s.",
    ]
    (out / "movers_accuracy.md").write_text("\n".join(lines) + "\n")
    (out / "movers_accuracy_summary.json").write_text(json.dumps(s, indent=1))
    _figures(movers, null, records, out, plt)
    print("\n".join(lines))


def _figures(movers, null, records, out, plt):
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for who, c in (("analysis", "tab:blue"), ("baseline", "tab:orange")):
        st = np.array([m["strength_db"] for m in movers])
        hit = np.array([m[who] is not None for m in movers])
        edges = np.arange(-28, 4, 4)
        cen, pd = [], []
        for lo in edges:
            sel = (st >= lo) & (st < lo + 4)
            if sel.any():
                cen.append(lo + 2)
                pd.append(hit[sel].mean())
        axes[0].plot(cen, pd, "o-", color=c, label=who)
        u = np.abs([m["u"] for m in movers])
        edges = np.array([0, 0.75, 1, 1.5, 2, 3, 5, 11])
        cen, pd = [], []
        for lo, hi in zip(edges[:-1], edges[1:], strict=True):
            sel = (u >= lo) & (u < hi)
            if sel.any():
                cen.append(0.5 * (lo + hi))
                pd.append(hit[sel].mean())
        axes[1].plot(cen, pd, "o-", color=c, label=who)
    axes[0].set_xlabel("strength (dB re median per-pulse peak of |M|)")
    axes[0].set_ylabel("P_d")
    axes[1].set_xlabel("|range speed| (m/s)")
    axes[1].set_ylabel("P_d")
    for ax in axes[:2]:
        ax.grid(alpha=0.3)
        ax.legend()
    if null.size:
        axes[2].hist(null, bins=40, color="0.5", log=True)
        for r in records[:1]:
            axes[2].axvline(r["threshold_db"], color="tab:red", label="threshold (1 % per scene)")
        axes[2].set_xlabel("g(u) peak over local floor (dB), scenes without movers")
        axes[2].legend()
    fig.tight_layout()
    fig.savefig(out / "movers_detection.png", dpi=110)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    found = [m for m in movers if m["analysis"] is not None]
    names = ("range position (m)", "range speed (m/s)", "cross-range speed (m/s)")
    for k, (ax, name) in enumerate(zip(axes, names, strict=True)):
        e = np.abs([m["analysis"]["bound_errors"][k] for m in found])
        sd = np.array([m["analysis"]["sd"][k] for m in found])
        ax.loglog(sd, e, "o", ms=3, label="analysis |error| vs its bound")
        lim = [
            min(sd.min(), e[e > 0].min()) if len(e) else 1e-6,
            max(sd.max(), e.max()) if len(e) else 1,
        ]
        ax.plot(lim, lim, "k-", lw=1, label="1 bound")
        ax.plot(lim, [3 * v for v in lim], "k:", lw=1, label="3 bounds")
        ax.set_xlabel(f"Cramér–Rao bound, {name}")
        ax.set_ylabel(f"|error|, {name}")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "movers_errors.png", dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument(
        "--defocus-search",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="the analysis also searches its stationary band for defocused movers "
        "(AnalysisOptions.defocus_search, the default)",
    )
    ap.add_argument(
        "--from-records", type=Path, help="rewrite the table and figures from a saved JSON"
    )
    args = ap.parse_args()
    if args.from_records:
        records = json.loads(args.from_records.read_text())
        write_outputs(records, args.out, float("nan"), args.workers)
        return
    specs = scene_specs(args.seed, args.quick)
    start = time.perf_counter()
    records = []
    with Pool(args.workers, _set_defocus_search, (args.defocus_search,)) as pool:
        for k, rec in enumerate(pool.imap_unordered(run_one, specs)):
            records.append(rec)
            print(
                f"[{k + 1}/{len(specs)}] {rec['kind']} seed {rec['seed']}: "
                f"{sum(m['analysis'] is not None for m in rec['movers'])}/{len(rec['movers'])} found, "  # noqa: E501
                f"{rec['false_analysis']} false (baseline {sum(m['baseline'] is not None for m in rec['movers'])}, "  # noqa: E501
                f"{rec['false_baseline']} false), {rec['seconds_analysis']:.0f}+{rec['seconds_baseline']:.0f} s",  # noqa: E501
                flush=True,
            )
    records.sort(key=lambda r: r["seed"])
    write_outputs(records, args.out, time.perf_counter() - start, args.workers)


if __name__ == "__main__":
    main()
