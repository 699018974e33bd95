"""The detector's null distribution, measured again: the statistic of g(u) peaks without movers.

Regenerate the table (about 5 min on 2 cores)::

    python benchmarks/detector_null.py --out benchmarks/results
    python benchmarks/detector_null.py --detector coherent --scenes 50 --out benchmarks/results

``--detector defocus`` runs the defocus bank of the stationary band
(:mod:`sarmotion.pipeline.defocused`) on the same populations and a noise-free one
(``simulated, no noise``, as ``bench_collection.py``'s scenes) and counts the candidates
its tests leave: each a false mover (table ``detector_null_defocus.md``).

The second measures the coherent detector's statistic (:mod:`sarmotion.motion.coherent`,
``COHERENT_NULL_TAIL``) on the same populations (about 4 min on 2 loaded cores; table
``detector_null_coherent.md``): every candidate the ``g(u)`` screen passes, fitted on
``S``, less those the focus test explains as stationary points; ``--from-records`` writes
a table again from a saved JSON against the tail now in use.

The threshold of :mod:`sarmotion.motion.detector` rests on an exponential tail fitted to
the local-floor statistic of candidates measured on data without movers
(``NULL_TAIL``: ``t_0`` = 1.34 dB, ``s`` = 0.60 dB, ``p_0`` = 0.1). This script measures
that distribution again, on seeds of its own (``--seed``, default 31), in the three
populations of the module notes, each scene through the analysis's own separation and
detection stages (:func:`sarmotion.pipeline.detect`, default options, central degree):

``real, RPCA``           the four real GOTCHA degrees one at a time and together;
``simulated, RPCA``      ``--scenes`` random scenes of 10-80 unit point targets, white
                         noise at 0/10/20/30 dB SNR;
``simulated, combined``  the same scenes separated by the combined method.

Candidates are the local maxima of ``g`` with ``|u| >= 1.1`` m/s (the stationary band
excluded as in the notes). It reports, per population and pooled: the quantiles, the
tail fitted the same way (``t_0`` the 90 % quantile, ``s`` the mean excess over it, the
maximum-likelihood scale of an exponential), the fraction of candidates beyond the
``NULL_TAIL`` model's 99 % and 99.9 % points against the 1 % and 0.1 % it predicts,
and the per-scene rate at which the largest candidate reaches the analysis's
threshold for a 1 % false-alarm rate (before its shape and focus tests, which only
remove candidates).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

GOTCHA = Path(
    os.environ.get(
        "SARMOTION_GOTCHA_DIR", Path(__file__).resolve().parents[2] / "shared" / "data" / "gotcha"
    )
)

#: Candidates slower than this are in the stationary band (module notes), m/s.
MIN_SPEED_MPS = 1.1
QUANTILES = (0.5, 0.9, 0.99, 0.999)

#: The defocus bank's screen level in the null runs (dB over the interference), and the
#: echoes tested per scene: the statistic below the analysis's threshold too.
SCREEN_DB = 6.0
NULL_ECHOES = 8


def _scene(kind: str, index: int, seed: int):
    """Traces and separation method of one null scene."""
    from sarmotion.io import read_gotcha

    if kind == "real":
        files = sorted(GOTCHA.glob("data_3dsar_pass1_az00*_HH.mat"))
        return read_gotcha(files[index : index + 1] if index < 4 else files), "rpca"
    from sarmotion.simulation import random_scene, simulate

    rng = np.random.default_rng(seed + index)
    n = int(rng.integers(10, 81))
    snr = float(rng.choice([0.0, 10.0, 20.0, 30.0]))
    if kind == "sim_clean":  # point clutter without noise, as bench_collection's scenes
        traces = simulate(random_scene(n_stationary=n, rng=rng), snr_db=None, rng=rng).traces
        return traces, "rpca"
    traces = simulate(random_scene(n_stationary=n, rng=rng), snr_db=snr, rng=rng).traces
    return traces, kind.split("_")[1]


def candidates(job: tuple[str, int, int]) -> dict:
    """The null statistics of one scene: every candidate beyond the stationary band."""
    from sarmotion.pipeline import AnalysisOptions, detect
    from sarmotion.separation import SeparationOptions

    kind, index, seed = job
    start = time.perf_counter()
    traces, method = _scene(kind, index, seed)
    opts = AnalysisOptions(separation=SeparationOptions(method=method), trajectory=False)
    det = detect(traces, opts).candidates
    st = det.statistics
    keep = np.abs(st.speeds_mps) >= MIN_SPEED_MPS
    return {
        "population": {"real": "real, RPCA", "sim_rpca": "simulated, RPCA"}.get(
            kind, "simulated, combined"
        ),
        "scene": index,
        "statistic_db": st.statistic_db[keep].tolist(),
        "n_candidates": det.n_candidates,
        "threshold_db": det.threshold_db,
        "declared": int(det.range_speeds.n_movers),
        "seconds": time.perf_counter() - start,
    }


def coherent_candidates(job: tuple[str, int, int]) -> dict:
    """The coherent statistic of every screened candidate of one null scene.

    The analysis's own stages with ``detector="coherent"``: separation, the ``g(u)``
    screen, and for each screened candidate the maximum-likelihood fit on ``S``
    (searched over range position, range speed and cross-range speed) and its
    ``Lambda`` (:func:`sarmotion.motion.coherent_statistic_db`), with the focus test's
    verdict: a candidate the focus test explains as a stationary point is not declared
    whatever its ``Lambda``, so the null of the decision is that of the others (the
    explained ones are listed apart).
    """
    from sarmotion.motion import (
        coherent_statistic_db,
        coherent_threshold_db,
        fit_point_mover,
        stationary_explanation,
    )
    from sarmotion.pipeline import AnalysisOptions, detect
    from sarmotion.separation import SeparationOptions

    kind, index, seed = job
    start = time.perf_counter()
    traces, method = _scene(kind, index, seed)
    opts = AnalysisOptions(
        separation=SeparationOptions(method=method), trajectory=False, detector="coherent"
    )
    found = detect(traces, opts)
    det, sub, moving = found.candidates, found.sub.acquisition, np.asarray(found.moving_sub)
    stats, stationary = [], []
    for u in det.range_speeds.speeds_mps:
        fit = fit_point_mover(
            moving, float(u), acquisition=sub, cross_speed_range_mps=opts.speed_range_mps
        )
        value = fit.amplitude * sub.n_pulses
        stats.append(
            coherent_statistic_db(
                moving, fit.position_m, fit.velocity_mps, acquisition=sub, value=value
            )
        )
        why = stationary_explanation(
            moving, fit.position_m, fit.velocity_mps, value, acquisition=sub
        )
        stationary.append(bool(why.within_extent and why.focus_gain_db < opts.min_focus_gain_db))
    n = det.range_speeds.n_movers
    thr = coherent_threshold_db(opts.false_alarm_rate, n)
    return {
        "population": {"real": "real, RPCA", "sim_rpca": "simulated, RPCA"}.get(
            kind, "simulated, combined"
        ),
        "scene": index,
        # the decision's null: candidates the focus test does not explain as stationary
        "statistic_db": [t for t, st in zip(stats, stationary, strict=True) if not st],
        "stationary_db": [t for t, st in zip(stats, stationary, strict=True) if st],
        "screen_db": det.threshold_db,
        "n_candidates": n,
        "threshold_db": thr,
        "declared": int(sum(t >= thr and not st for t, st in zip(stats, stationary, strict=True))),
        "seconds": time.perf_counter() - start,
    }


def defocus_candidates(job: tuple[str, int, int]) -> dict:
    """The defocus bank's candidates on one null scene, and the tests' verdicts.

    The analysis's own stages: separation and ``g(u)``, then the bank
    (:mod:`sarmotion.pipeline.defocused`) on the central degree's data and, for the
    cells of each of its first ``NULL_ECHOES`` echoes that the analysis fits
    (:func:`~sarmotion.pipeline.defocused.cells_to_fit`: the strongest, then the most
    powerful if another, until one passes), the fit from the cell and the tests against
    stationary points and of the fit's cancellation of its echo. Recorded: the bank
    statistic (power over noise, dB) of the echoes the tests do not explain (each one a
    false mover) and of those they do, with each fitted cell's joint-fit ratio and
    residue.
    """
    from sarmotion.pipeline import AnalysisOptions, detect
    from sarmotion.pipeline.defocused import (
        cells_to_fit,
        distinct_echoes,
        scan_detection,
        search_data,
        test_candidate,
    )
    from sarmotion.separation import SeparationOptions

    kind, index, seed = job
    start = time.perf_counter()
    traces, method = _scene(kind, index, seed)
    opts = AnalysisOptions(separation=SeparationOptions(method=method), trajectory=False)
    found = detect(traces, opts)
    data = found.sub.with_data(search_data(found))
    # the screen lowered to SCREEN_DB, the first NULL_ECHOES echoes: the statistic's
    # distribution below the threshold too, for the tail
    scan = scan_detection(found, data, threshold_db=SCREEN_DB)
    moving = scan.speeds_mps != 0.0
    step = float(np.min(np.abs(scan.speeds_mps[moving]))) if moving.any() else np.inf
    band = float(found.candidates.min_speed_mps)
    tests, left, explained = [], [], []
    echoes = distinct_echoes(scan, data)[:NULL_ECHOES]
    for echo in echoes:
        for cell in cells_to_fit(echo):
            t = test_candidate(data, cell, step, band_mps=band)
            tests.append(t)
            if not t.stationary(opts.min_focus_gain_db) and t.cancels:
                left.append(t)
                break
        else:
            explained.append(echo[0].statistic_db)
    # the screen's own level at the analysis's rate: what a candidate left must reach
    thr = float(10.0 * np.log10(np.log(scan.n_cells / opts.false_alarm_rate)))
    return {
        "population": {
            "real": "real, RPCA",
            "sim_rpca": "simulated, RPCA",
            "sim_clean": "simulated, no noise",
        }.get(kind, "simulated, combined"),
        "scene": index,
        "statistic_db": [t.candidate.statistic_db for t in left],
        "stationary_db": explained,
        "joint_ratios": [t.joint_ratio for t in tests],
        "coherences": [t.coherence for t in tests],
        "residues": [t.residue for t in tests],
        "focus_gains_db": [t.explanation.focus_gain_db for t in tests],
        "screen_db": scan.threshold_db,
        "n_echoes": len(echoes),
        "n_candidates": len(tests),
        "threshold_db": thr,
        "declared": int(sum(t.candidate.statistic_db >= thr for t in left)),
        "seconds": time.perf_counter() - start,
    }


def tail(values: np.ndarray) -> dict:
    """Quantiles and the exponential tail above the 90 % quantile (dB)."""
    t0 = float(np.quantile(values, 0.9))
    excess = values[values > t0] - t0
    return {
        "n": int(values.size),
        "quantiles_db": [float(np.quantile(values, q)) for q in QUANTILES],
        "max_db": float(values.max()),
        "t0_db": t0,
        "scale_db": float(excess.mean()) if excess.size else float("nan"),
    }


def model_tail(detector: str) -> dict:
    """The tail in use: ``NULL_TAIL`` or ``COHERENT_NULL_TAIL`` (the defocus bank: none)."""
    from sarmotion.motion import COHERENT_NULL_TAIL, NULL_TAIL

    return dict(COHERENT_NULL_TAIL if detector == "coherent" else NULL_TAIL)


def model_exceedance(values: np.ndarray, detector: str = "g") -> dict:
    """Fractions beyond the model tail's 99 % and 99.9 % points."""
    t = model_tail(detector)
    out = {}
    for p in (0.01, 0.001):
        point = t["t0_db"] + t["scale_db"] * np.log(t["p0"] / p)
        out[f"{p:g}"] = {"point_db": float(point), "fraction": float(np.mean(values > point))}
    return out


def summarise(records: list[dict], detector: str = "g") -> dict:
    pops = sorted({r["population"] for r in records})
    out = {"detector": detector, "null_tail": model_tail(detector), "populations": {}}
    for name in pops + ["all"]:
        rs = [r for r in records if name in ("all", r["population"])]
        values = np.concatenate([np.asarray(r["statistic_db"], dtype=float) for r in rs])
        if not values.size:
            continue
        over = [max(r["statistic_db"], default=-np.inf) >= r["threshold_db"] for r in rs]
        out["populations"][name] = {
            "scenes": len(rs),
            **tail(values),
            "model": model_exceedance(values, detector),
            "scenes_reaching_threshold": int(np.sum(over)),
            "declared_movers": int(sum(r["declared"] for r in rs)),
        }
    return out


def write_defocus(records: list[dict], out: Path, seconds: float) -> None:
    """The defocus bank's null: candidates, those explained, those left over the screen."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "detector_null_defocus.json").write_text(json.dumps({"records": records}, indent=1))
    lines = [
        "| population | scenes | echoes | cells fitted | echoes explained by the stationary "
        "scene | left | left: largest statistic (dB) | left over the 1 % screen "
        "| scenes with a false mover |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    pops = sorted({r["population"] for r in records})
    for name in pops + ["all"]:
        rs = [r for r in records if name in ("all", r["population"])]
        values = [v for r in rs for v in r["statistic_db"]]
        top = f"{max(values):.2f}" if values else "-"
        lines.append(
            f"| {name} | {len(rs)} | {sum(r.get('n_echoes', r['n_candidates']) for r in rs)} | "
            f"{sum(r['n_candidates'] for r in rs)} | "
            f"{sum(len(r['stationary_db']) for r in rs)} | {len(values)} | {top} | "
            f"{sum(r['declared'] for r in rs)} | {sum(r['declared'] > 0 for r in rs)} |"
        )
    text = "\n".join(
        [
            "# The defocus bank on data without movers",
            "",
            "Each scene through the analysis's separation and g(u) stages, then the bank "
            "(sarmotion.pipeline.defocused) over the stationary band of the central degree, "
            f"its screen lowered to {SCREEN_DB:g} dB over the interference: the strongest cell "
            f"of each of its first {NULL_ECHOES} echoes, and its most powerful cell if another "
            "when the first is explained (as the analysis fits them), fitted from the cell and "
            "tested against the stationary scene (focused as stationary; the best stationary "
            "point's focus gain under 1 dB; the stationary points near its range history, fitted "
            "jointly with it, leaving under half its amplitude; its per-pulse sums keeping "
            "under half their power in their coherent sum), and whether its fit, "
            "subtracted, removes its echo (at most 1/4 of the echo's peak power left at its "
            "main lobe and at the cells of its extent that no stationary smear explains). "
            "'left': the candidates those "
            "tests do not explain; 'left over the 1 % screen': those whose statistic (dB over "
            "the interference) reaches the screen's level for a 1 % rate, each a false mover "
            "of the analysis.",
            "",
            *lines,
            "",
            f"{seconds:.0f} s." if not np.isnan(seconds) else "",
        ]
    )
    (out / "detector_null_defocus.md").write_text(text + "\n")
    print(text)


def write(summary: dict, records: list[dict], out: Path, seconds: float) -> None:
    defocus = summary["detector"] == "defocus"
    coherent = summary["detector"] == "coherent" or defocus
    stem = {"coherent": "detector_null_coherent", "defocus": "detector_null_defocus"}.get(
        summary["detector"], "detector_null"
    )
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{stem}.json").write_text(
        json.dumps({"summary": summary, "records": records}, indent=1)
    )
    t = summary["null_tail"]
    lines = [
        "| population | scenes | candidates | 50 % | 90 % | 99 % | 99.9 % | max | t0 | s "
        "| > model 1 % point | > model 0.1 % point | scenes >= threshold | declared |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, p in summary["populations"].items():
        q = p["quantiles_db"]
        m = p["model"]
        lines.append(
            f"| {name} | {p['scenes']} | {p['n']} | {q[0]:.2f} | {q[1]:.2f} | {q[2]:.2f} | "
            f"{q[3]:.2f} | {p['max_db']:.2f} | {p['t0_db']:.2f} | {p['scale_db']:.2f} | "
            f"{100 * m['0.01']['fraction']:.2f} % | {100 * m['0.001']['fraction']:.2f} % | "
            f"{p['scenes_reaching_threshold']} | {p['declared_movers']} |"
        )
    name = "COHERENT_NULL_TAIL" if coherent else "NULL_TAIL"
    title = (
        "# Null distribution of the coherent statistic (dB: fitted |I|^2 over sigma_I^2)"
        if coherent
        else "# Null distribution of the detector statistic (dB over the local floor)"
    )
    if defocus:
        title += ": the defocus bank's candidates"
    if defocus:
        explained = [t for r in records for t in r["stationary_db"]]
        ratios = np.array([j for r in records for j in r["joint_ratios"]])
        note = (
            "Statistic: the bank cell's power over the noise level (dB). Candidates: the "
            "strongest cell of each of the first echoes of the defocus bank "
            "(sarmotion.pipeline.defocused) over the stationary band, each fitted on the "
            "central degree's data from its cell, less those the stationary points explain "
            f"({len(explained)} of {len(explained) + sum(r['declared'] for r in records)}; "
            f"joint-fit ratio |a_joint| / |a|: median {np.median(ratios):.2f}, largest "
            f"{ratios.max():.2f} against the rule's 0.5); 'declared': candidates left, each a "
            "false mover (the bank's noise threshold is the false-alarm control)."
        )
    elif coherent:
        explained = [t for r in records for t in r["stationary_db"]]
        note = (
            "Candidates: the g(u) peaks that pass the screen (the g(u) null's per-candidate "
            f"10 % point, {records[0]['screen_db']:.2f} dB, beyond the stationary band, shape "
            "test), each fitted on S, less those the focus test explains as stationary "
            f"points ({len(explained)} more, largest "
            f"{max(explained, default=float('nan')):.2f} dB); 'scenes >= threshold': the "
            "largest candidate reaches the 1 %-per-scene threshold over the scene's "
            "screened candidates; 'declared': candidates over it."
        )
    else:
        note = (
            f"Candidates with |u| >= {MIN_SPEED_MPS} m/s; 'scenes >= threshold': the largest "
            "candidate reaches the 1 %-per-scene threshold before the shape and focus tests; "
            "'declared': candidates the detection stage passed on (threshold and shape "
            "tests, any speed; its focus test, which follows, rejects the slow stationary "
            "ones)."
        )
    text = "\n".join(
        [
            title,
            "",
            f"Model in use ({name}): t0 = {t['t0_db']} dB, s = {t['scale_db']} dB, "
            f"p0 = {t['p0']}; its 1 % point is "
            f"{summary['populations']['all']['model']['0.01']['point_db']:.2f} dB and its "
            f"0.1 % point {summary['populations']['all']['model']['0.001']['point_db']:.2f} dB.",
            "",
            *lines,
            "",
            note + ("" if np.isnan(seconds) else f" {seconds:.0f} s."),
        ]
    )
    (out / f"{stem}.md").write_text(text + "\n")
    print(text)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--seed", type=int, default=31)
    ap.add_argument("--scenes", type=int, default=25, help="simulated scenes per method")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument(
        "--detector",
        choices=("g", "coherent", "defocus"),
        default="g",
        help="the g(u) statistic (default) or the coherent one (detector_null_coherent.*)",
    )
    ap.add_argument(
        "--from-records",
        type=Path,
        help="rewrite the table from a saved JSON, against the model tail now in use",
    )
    args = ap.parse_args()
    if args.from_records:
        records = json.loads(args.from_records.read_text())["records"]
        if args.detector == "coherent":
            from sarmotion.motion import coherent_threshold_db

            for r in records:
                r["threshold_db"] = coherent_threshold_db(0.01, r["n_candidates"])
                r["declared"] = int(sum(t >= r["threshold_db"] for t in r["statistic_db"]))
        write(summarise(records, args.detector), records, args.out, float("nan"))
        return
    jobs = [("real", d, 0) for d in range(5)]
    kinds = ("sim_rpca", "sim_combined") + (("sim_clean",) if args.detector == "defocus" else ())
    jobs += [(k, i, args.seed) for k in kinds for i in range(args.scenes)]
    run = {"coherent": coherent_candidates, "defocus": defocus_candidates}.get(
        args.detector, candidates
    )
    start = time.perf_counter()
    records = []
    with Pool(args.workers) as pool:
        for k, rec in enumerate(pool.imap_unordered(run, jobs)):
            records.append(rec)
            top = max(rec["statistic_db"], default=float("nan"))
            print(
                f"[{k + 1}/{len(jobs)}] {rec['population']} {rec['scene']}: "
                f"{len(rec['statistic_db'])} candidates, largest {top:.2f} dB "
                f"(threshold {rec['threshold_db']:.2f}), {rec['seconds']:.1f} s",
                flush=True,
            )
    records.sort(key=lambda r: (r["population"], r["scene"]))
    if args.detector == "defocus":
        write_defocus(records, args.out, time.perf_counter() - start)
        return
    write(summarise(records, args.detector), records, args.out, time.perf_counter() - start)


if __name__ == "__main__":
    main()
