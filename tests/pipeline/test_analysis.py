"""The whole analysis (sarmotion.pipeline.analyze) on simulated scenes and real clutter.

Scene 1 (sect:numeric): GOTCHA, one degree (117 pulses), L = 10.18 km, V = 70 m/s;
resolution cells 0.34 m (ground range, x) by 1.29 m (cross range, y). Mover 1 at (0, 0)
(u = 13.80 m/s, u_perp = 19.80 m/s), mover 2 at (-5, 5) (u = -5.64 m/s, u_perp = 11.43
m/s).

The cross-range position of a mover away from the reference cross range is not
determined by the data (sarmotion.motion.aperture, module notes): the estimate lands on the
data-consistent family ``delta u ~ -(V - u_t) delta y / L`` near ``y = 0``. Over one
degree the exact compensated image of mover 2's clean trace is 117.000000 (= n_pulses,
unit reflectivity) from y = 0.2 m to 6.8 m along the family, and over four degrees of
the circular flight a 10 m offset changes the range history by 1/220 of a wavelength
(test_tracking). The tests therefore check the cross-range position only for movers at
the reference cross range, and for the others that the truth is the estimate's family
member at the truth's cross-range offset (``family_*`` of compare_with_truth), which
also reproduces the trace.
"""

import dataclasses
import json

import numpy as np
import pytest

from sarmotion.cli import run
from sarmotion.documents import RESULTS_SCHEMA, results_document
from sarmotion.imaging import point_response, resolution
from sarmotion.io import read_gotcha, write_gotcha
from sarmotion.motion.likelihood import NEAR_EQUAL_LOBES
from sarmotion.pipeline import AnalysisOptions, analyze, compare_with_truth, extract_mover
from sarmotion.separation import SeparationOptions
from sarmotion.simulation import PointTarget, Scene, inject, load_scene, random_scene, simulate

RANGE_SPEED_TOL = 0.2  # m/s, under one range-speed resolution (0.27 m/s)
CROSS_SPEED_TOL = 1.5  # m/s, two cross-range-speed resolutions (0.74 m/s)
RANGE_POS_TOL = 1.0  # m, ~3 ground-range cells
CROSS_POS_TOL = 2.5  # m, ~2 cross-range cells
FAMILY_POS_TOL = 0.05  # m, truth vs the estimate's family member (measured <= 1.4 cm)
FAMILY_SPEED_TOL = 1.5  # m/s, the same for the velocity (as CROSS_SPEED_TOL)


def _alone(scene, target):
    """Clean traces of one target of ``scene`` alone (same acquisition)."""
    one = Scene(
        name="alone",
        targets=(target,),
        radar=scene.radar,
        trajectory_spec=scene.trajectory_spec,
        reference_point_m=scene.reference_point_m,
    )
    return simulate(one).traces


def _check_movers(result, scene, *, focus=0.9, clean=True):
    """Per-mover physics; returns the comparison (measured numbers in the test notes)."""
    cmp = compare_with_truth(result, scene)
    assert cmp.false_movers == 0 and cmp.missed_movers == 0, cmp
    tr = result.traces
    res = resolution(tr)
    for m, err in zip(result.movers, cmp.errors, strict=True):
        truth = next(t for t in scene.moving if t.label == err.matched)
        assert abs(err.range_speed_mps) <= RANGE_SPEED_TOL, err
        assert abs(err.cross_range_speed_mps) <= CROSS_SPEED_TOL, err
        assert abs(err.position_range_m) <= RANGE_POS_TOL, err
        y_true = float(truth.position_m[:2] @ res.cross_range_direction)
        if abs(y_true) < 1.0:  # at the reference cross range: position determined
            assert abs(err.position_cross_range_m) <= CROSS_POS_TOL, err
        # The truth is on the estimate's family (module docstring).
        assert err.family_position_m <= FAMILY_POS_TOL, err
        assert err.family_velocity_mps <= FAMILY_SPEED_TOL, err
        if clean:
            # The estimate reproduces the mover's trace: the compensated image of its
            # clean trace at the estimate is >= 0.98 of n_pulses (the value at the truth).
            alone = _alone(scene, truth)
            value = abs(point_response(alone, m.position_m, velocity_mps=m.velocity_mps)[0])
            assert value >= 0.98 * tr.n_pulses, (err, value)
        # The mover's own image is in focus at its estimate: peak within one cell of the
        # estimated position, and a coherent sum (>= focus n_pulses |sigma|).
        d = m.image_peak_m - m.position_m[:2]
        assert abs(d @ res.range_direction) <= res.ground_range_m
        assert abs(d @ res.cross_range_direction) <= res.cross_range_m
        peak = np.abs(m.image.values).max() / (tr.n_pulses * abs(truth.reflectivity))
        assert peak >= focus, (err, peak)
    return cmp


def _check_stationary(result, scene):
    """Each true stationary target listed within one resolution cell, nothing else."""
    res = resolution(result.traces)
    found = np.array([s.position_m for s in result.stationary])
    for t in scene.stationary:
        d = found - t.position_m[:2]
        dr = np.abs(d @ res.range_direction)
        dc = np.abs(d @ res.cross_range_direction)
        assert np.any((dr <= res.ground_range_m) & (dc <= res.cross_range_m)), t.position_m
    assert len(result.stationary) == len(scene.stationary)


@pytest.fixture(scope="module")
def scene1():
    sim = simulate(load_scene("scene1"))
    return sim, analyze(sim.traces)


@pytest.mark.slow
def test_scene1_end_to_end(scene1):
    sim, result = scene1
    assert result.method == "combined"
    cmp = _check_movers(result, sim.scene)
    # Measured: mover 1 du 0.0002, du_perp 0.004 m/s, position (0.001, -0.047) m off;
    # mover 2 du 0.029, du_perp 0.013 m/s, range 0.005 m, cross range -4.98 m; the truth
    # is 5 mm and 0.019 m/s from the estimate's family member at +4.98 m. Mover images
    # 0.993 / 0.995 of n_pulses.
    by_label = {e.matched: e for e in cmp.errors}
    assert abs(by_label["mover 1"].image_peak_m) <= resolution(sim.traces).cross_range_m
    _check_stationary(result, sim.scene)
    # Stationary image focused: brightest pixel at a true stationary target.
    x, y, _ = result.stationary_image.peak(refine=True)
    truth = np.array([t.position_m[:2] for t in sim.scene.stationary])
    assert np.min(np.hypot(*(truth - [x, y]).T)) <= 0.34
    # Both movers taken out of S: the residual is the separation's own error, no more
    # (measured ||residual|| / ||S_true|| = 0.132, ||S - S_true|| / ||S_true|| = 0.131).
    left = np.linalg.norm(result.residual) / np.linalg.norm(sim.moving)
    sep_error = np.linalg.norm(result.separation.moving - sim.moving) / np.linalg.norm(sim.moving)
    assert left < sep_error + 0.02
    assert set(result.timings_s) >= {"preliminary_image", "separation", "movers", "total"}


def test_extract_mover_separates_two_crossing_movers(scene1):
    """Mover extraction on the true S: each mover's part within 3 % of its clean trace."""
    sim, result = scene1
    scene = sim.scene
    for m in result.movers:
        truth = next(t for t in scene.moving if abs(t.position_m[0] - m.position_m[0]) < 1)
        other = next(t for t in scene.moving if t is not truth)
        own = extract_mover(
            sim.moving,
            acquisition=sim.traces.acquisition,
            position_m=m.position_m,
            velocity_mps=m.velocity_mps,
        )
        clean = _alone(scene, truth).data
        rest = _alone(scene, other).data
        # Measured 0.024 for both (half-window 3 samples); the other mover stays whole.
        assert np.linalg.norm(own - clean) / np.linalg.norm(clean) < 0.03
        assert np.linalg.norm(sim.moving - own - rest) / np.linalg.norm(rest) < 0.03


def test_results_json_document(scene1):
    sim, result = scene1
    doc = json.loads(
        json.dumps(results_document(result, truth=compare_with_truth(result, sim.scene)))
    )
    assert doc["schema"] == RESULTS_SCHEMA
    assert doc["n_pulses"] == 117 and abs(doc["platform_speed_mps"] - 70.0) < 0.01
    assert len(doc["movers"]) == 2 and len(doc["truth"]) == 2
    for m in doc["movers"]:
        assert {"position_m", "velocity_mps", "range_speed_mps", "cross_range_speed_mps"} <= set(m)
        assert len(m["position_m"]) == 2 and len(m["velocity_mps"]) == 2
        assert m["errors"]["range_speed_mps"] is not None
        # Scene 1's movers are isolated: one lobe of the likelihood stands above the rest
        lobes = m["likelihood_lobes"]
        assert lobes["ambiguous"] is False and 0.0 <= lobes["lobe_ratio"] < NEAR_EQUAL_LOBES
    assert all(len(s["position_m"]) == 2 and s["peak_db"] <= 0 for s in doc["stationary"])
    # the combined separation lists Doppler-tested points: none is dropped as a sidelobe
    assert result.method == "combined" and doc["stationary_sidelobes_dropped"] == 0


@pytest.mark.slow
def test_scene1_over_four_degrees():
    """Scene 1's targets over 4 degrees (468 pulses): movers estimated on the central
    degree and focused on all pulses (sarmotion.motion.aperture)."""
    scene = load_scene("scene1")
    scene = dataclasses.replace(
        scene, trajectory_spec={**scene.trajectory_spec, "aperture_deg": 4.0}
    )
    sim = simulate(scene)
    result = analyze(sim.traces, AnalysisOptions(trajectory=False))
    assert result.traces.n_pulses == 468
    # Measured: du 0.0006 / 0.026 m/s, du_perp 0.0007 / -0.005 m/s, range within 2 mm,
    # cross range -0.12 / -4.60 m with the truth 1 mm and 5e-5 m/s from the family;
    # mover images 0.999 / 0.998 of n_pulses; 13 s (the same analysis without the central
    # sub-aperture took 102 s and missed both movers by 16-55 m).
    _check_movers(result, scene, focus=0.95)
    # Every stationary target listed; one more point, at -17.8 dB between the two close
    # targets (-16.97, 23.50) and (-17.79, 22.43) m (their interference over 4 degrees).
    _check_stationary_recall(result, scene, fraction=1.0)
    truth = np.array([t.position_m[:2] for t in scene.stationary])
    extra = [s for s in result.stationary if np.hypot(*(truth - s.position_m).T).min() > 0.1]
    assert len(extra) <= 1 and all(s.level_db < -15.0 for s in extra), extra


@pytest.mark.slow
def test_scene1_through_gotcha_files(tmp_path):
    sim = simulate(load_scene("scene1"))
    files = write_gotcha(sim.traces, tmp_path)
    traces = read_gotcha(files)
    # Read back as measured data; a point scene: the combined separation.
    result = analyze(
        traces,
        AnalysisOptions(separation=SeparationOptions(method="combined"), trajectory=False),
    )
    _check_movers(result, sim.scene)
    _check_stationary(result, sim.scene)


@pytest.mark.slow
def test_random_scene_three_movers_20db():
    movers = [
        ([3.0, -4.0], [9.0, 6.0]),  # u = 6.27 m/s
        ([-12.0, 8.0], [-4.0, -7.0]),  # u = -2.79 m/s
        ([10.0, 12.0], [3.0, -10.0]),  # u = 2.09 m/s
    ]
    scene = random_scene(n_stationary=40, movers=movers, rng=7)
    sim = simulate(scene, snr_db=20, rng=7)
    result = analyze(sim.traces)
    cmp = compare_with_truth(result, scene)
    assert cmp.false_movers == 0 and cmp.missed_movers == 0
    # Measured range-speed errors 0.057 (mover 2), 0.091 (mover 3), -0.022 (mover 1) m/s,
    # cross-range-speed errors 0.001, -0.008, 0.0001 m/s after the focus polish (0.016,
    # 0.81, 0.08 from g_perp alone); range positions within 1.1 cm; cross-range positions
    # -7.6, -11.5, 3.6 m off, the truth within 1 cm / 0.013 m/s of the family.
    # (With candidate_threshold_db = -25 dB the combined separation accepts ~100 noise
    # and sidelobe peaks and leaks enough clutter into S to send mover 3 to u_perp 6.6
    # m/s off.)
    # Own-image peaks 0.995 (mover 2), 0.835 (mover 3), 0.794 (mover 1) of n_pulses:
    # noise and clutter leaking into the extraction windows cost movers 3 and 1 1.5-2 dB
    # (their velocities are right); hence focus >= 0.7 here (0.9 on noise-free scenes).
    _check_movers(result, scene, focus=0.7, clean=False)
    _check_stationary_recall(result, scene)


def _check_stationary_recall(result, scene, fraction=0.9):
    res = resolution(result.traces)
    found = np.array([s.position_m for s in result.stationary])
    hits = 0
    for t in scene.stationary:
        d = found - t.position_m[:2]
        ok = (np.abs(d @ res.range_direction) <= res.ground_range_m) & (
            np.abs(d @ res.cross_range_direction) <= res.cross_range_m
        )
        hits += bool(np.any(ok))
    assert hits >= fraction * len(scene.stationary), hits


@pytest.mark.gotcha
@pytest.mark.slow
def test_gotcha_clutter_with_two_injected_movers(gotcha_files):
    clutter = read_gotcha(gotcha_files[:1])  # one degree, 117 pulses
    amp = float(np.median(np.abs(clutter.data).max(axis=1)))
    movers = (
        PointTarget(position_m=[5.0, -10.0], velocity_mps=[8.0, 3.0], reflectivity=amp, label="A"),
        PointTarget(position_m=[-12.0, 6.0], velocity_mps=[-6.0, 4.0], reflectivity=amp, label="B"),
    )
    data = inject(clutter, movers)
    result = analyze(data)  # measured data: RPCA with eta x 2
    assert result.method == "rpca"
    cmp = compare_with_truth(result, Scene(name="injected", targets=movers))
    assert cmp.false_movers == 0 and cmp.missed_movers == 0
    # Measured range-speed errors -0.071 (A) and 0.042 (B) m/s, cross-range speed errors
    # -0.017 and -0.009 m/s; range positions within 1.1 cm; cross range on the family (A
    # 10.8 m, B -6.5 m off; the truth within 1.1 cm of the family members).
    for err in cmp.errors:
        assert abs(err.range_speed_mps) <= 0.5, err
        assert abs(err.position_range_m) <= RANGE_POS_TOL, err
        assert err.family_position_m <= FAMILY_POS_TOL, err


@pytest.mark.gotcha
@pytest.mark.slow
def test_gotcha_four_degrees_with_two_injected_movers(gotcha_files):
    """All four GOTCHA degrees (469 pulses): movers estimated on the central degree."""
    clutter = read_gotcha(gotcha_files)
    amp = float(np.median(np.abs(clutter.data).max(axis=1)))
    movers = (
        PointTarget(position_m=[5.0, -10.0], velocity_mps=[8.0, 3.0], reflectivity=amp, label="A"),
        PointTarget(position_m=[-12.0, 6.0], velocity_mps=[-6.0, 4.0], reflectivity=amp, label="B"),
    )
    result = analyze(inject(clutter, movers), AnalysisOptions(trajectory=False))
    cmp = compare_with_truth(result, Scene(name="injected", targets=movers))
    assert cmp.false_movers == 0 and cmp.missed_movers == 0
    # Measured range-speed errors -0.064 (A) and 0.053 (B) m/s, range positions within
    # 1.7 cm, truth within 1.8 cm of the estimates' family members; cross-range speed
    # errors -0.33 (A, clutter left in S) and -0.006 (B) m/s.
    for err in cmp.errors:
        assert abs(err.range_speed_mps) <= 0.5, err
        assert abs(err.position_range_m) <= RANGE_POS_TOL, err
        assert err.family_position_m <= FAMILY_POS_TOL, err


@pytest.mark.slow
def test_cli_analyze_writes_results_and_report(tmp_path, capsys):
    out = tmp_path / "run"
    assert run(["analyze", "scene1", "--out", str(out), "--no-trajectory"]) == 0
    doc = json.loads((out / "results.json").read_text())
    assert doc["schema"] == "sarmotion.results/3"
    for key in ("reference_point_m", "platform_speed_mps", "n_pulses", "movers", "stationary"):
        assert key in doc
    assert len(doc["movers"]) == 2 and "truth" in doc and "timings_s" in doc
    det = doc["detection"]
    assert det["false_alarm_rate"] == 0.01 and det["n_candidates"] > 0
    for m in doc["movers"]:
        d = m["detection"]
        assert d["statistic_db"] >= d["threshold_db"] == det["threshold_db"]
        assert 0.0 <= d["p_value"] <= d["false_alarm_rate"]
        se = m["standard_errors"]
        for key in ("range_position_m", "range_speed_mps", "cross_range_speed_mps", "amplitude"):
            assert se[key] > 0
        # noise-free Scene 1: g_perp and the fit agree (measured within 0.004 m/s)
        assert abs(m["cross_range_speed_mps"] - m["g_perp_cross_range_speed_mps"]) < 0.1
    html = (out / "report.html").read_text()
    assert "false-alarm rate" in html and "standard errors" in html
    assert html.count("data:image/png;base64,") >= 4
    assert 'src="http' not in html
    assert "mover 2" in html
    assert not list(tmp_path.glob(".run.partial-*"))


def test_cli_analyze_bad_input_is_one_line(tmp_path, capsys):
    assert run(["analyze", str(tmp_path / "missing.mat"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sarmotion: error:") and len(err.strip().splitlines()) == 1
    assert run(["analyze", "scene1", "--out", str(tmp_path / "o"), "--max-movers", "-1"]) == 2
    capsys.readouterr()
    assert run(["analyze", "scene1", "--out", str(tmp_path / "o"), "--sub-aperture", "0"]) == 2
    err = capsys.readouterr().err
    assert "--sub-aperture must be > 0" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


@pytest.mark.gotcha
@pytest.mark.slow
def test_real_stationary_scene_has_no_mover(gotcha_files):
    # The GOTCHA pass is a parked-car scene with no truthed mover: over all 4 degrees
    # the clutter left in S once made g(u) peaks of 12-14 dB over the global median at
    # 0.2-1.1 m/s (the apparent range speed of stationary targets off the reference cross
    # range). Over the local floor the largest candidate above the stationary band stands
    # 1.7 dB, under the 5.5 dB threshold of 1 % false alarms per scene.
    result = analyze(read_gotcha(gotcha_files), AnalysisOptions(trajectory=False))
    assert len(result.movers) == 0
    assert len(result.stationary) > 10
    det = result.detection
    assert det.false_alarm_rate == 0.01 and 5.0 < det.threshold_db < 6.0
