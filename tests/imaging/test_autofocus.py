"""Phase-gradient autofocus: known phase errors recovered on GOTCHA and on simulated scenes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sarmotion.documents import results_document
from sarmotion.imaging import autofocus, resolution
from sarmotion.imaging.autofocus import apply_phase_correction, focus_mover, pga
from sarmotion.imaging.quality import point_quality
from sarmotion.io import read_gotcha
from sarmotion.pipeline import AnalysisOptions, analyze
from sarmotion.simulation import PointTarget, Scene, load_scene, simulate

# The two calibration reflectors of pass 1 (brightest points of the 4-degree image).
REFLECTORS = [(-15.6, 21.6), (-27.8, 38.8)]

#: Peak power falls by exp(-sigma^2) for a residual phase error of RMS sigma (Marechal):
#: the 0.5 dB peak criterion allows sigma = sqrt(ln(10^0.05)) = 0.34 rad.
MAX_RESIDUAL_RAD = float(np.sqrt(np.log(10**0.05)))


def injected_error(traces, seed):
    """Quadratic of +-pi..+-4pi at the aperture edges plus random cubic and quartic terms.

    No linear term: a linear phase only shifts the image, which no autofocus observes.
    """
    rng = np.random.default_rng(seed)
    s = traces.slow_times_s
    x = s / np.abs(s).max()
    quad = rng.uniform(np.pi, 4 * np.pi) * rng.choice([-1.0, 1.0]) * x**2
    return quad + np.polynomial.legendre.legval(x, [0, 0, 0, rng.normal(0, 1.5), rng.normal(0, 1)])


def without_line(phi, s):
    a = np.stack([np.ones_like(s), s], axis=1)
    return phi - a @ np.linalg.lstsq(a, phi, rcond=None)[0]


def reflector_figures(traces):
    out = []
    for p in REFLECTORS:
        q = point_quality(traces, p)
        out.append(
            (
                20 * np.log10(q.amplitude),
                q.range.irw_m,
                q.cross_range.irw_m,
                q.range.pslr_db,
                q.cross_range.pslr_db,
            )
        )
    return np.array(out)


@pytest.fixture(scope="module")
def four_degrees(gotcha_files):
    return read_gotcha(gotcha_files)


@pytest.fixture(scope="module")
def reference_figures(four_degrees):
    return reflector_figures(four_degrees)


def check_same_focus(figures, reference):
    np.testing.assert_allclose(figures[:, 0], reference[:, 0], atol=0.5)  # peak, dB
    np.testing.assert_allclose(figures[:, 1:3], reference[:, 1:3], rtol=0.05)  # IRW
    np.testing.assert_allclose(figures[:, 3:5], reference[:, 3:5], atol=1.0)  # PSLR, dB


@pytest.mark.gotcha
@pytest.mark.slow
@pytest.mark.parametrize("seed", [101, 202])
def test_pga_recovers_injected_errors_on_gotcha(four_degrees, reference_figures, seed):
    tr = four_degrees
    phi = injected_error(tr, seed)
    bad = apply_phase_correction(tr, -phi)  # data * exp(+i phi)
    spoilt = reflector_figures(bad)
    # The injected error does defocus the reflectors (else the test proves nothing).
    assert np.all(spoilt[:, 0] < reference_figures[:, 0] - 3.0)
    result = pga(bad)
    assert result.converged and result.n_iter == len(result.rms_history_rad)
    assert np.all(np.diff(result.window_history_m) <= 1e-9)  # the window only shrinks
    check_same_focus(reflector_figures(result.traces), reference_figures)
    residual = without_line(result.phase_error_rad - phi, tr.slow_times_s)
    assert np.sqrt(np.mean(residual**2)) < MAX_RESIDUAL_RAD


@pytest.mark.gotcha
@pytest.mark.slow
def test_pga_leaves_focused_data_alone(four_degrees, reference_figures):
    result = pga(four_degrees)
    assert np.sqrt(np.mean(result.phase_error_rad**2)) < MAX_RESIDUAL_RAD
    check_same_focus(reflector_figures(result.traces), reference_figures)


def point_scene(targets, aperture_deg=1.0):
    return Scene(
        name="pga",
        targets=tuple(PointTarget(position_m=p) for p in targets),
        reference_point_m=(0.0, 0.0, 0.0),
        trajectory_spec={"kind": "circular", "aperture_deg": aperture_deg},
    )


def test_pga_on_simulated_points_recovers_the_error():
    rng = np.random.default_rng(3)
    tr = simulate(point_scene(rng.uniform(-20, 20, size=(8, 2))), snr_db=10.0, rng=4).traces
    phi = injected_error(tr, 5)
    result = pga(apply_phase_correction(tr, -phi))
    residual = without_line(result.phase_error_rad - phi, tr.slow_times_s)
    assert np.sqrt(np.mean(residual**2)) < MAX_RESIDUAL_RAD
    # Correcting with the estimate and re-estimating finds (nearly) nothing left.
    again = pga(result.traces, max_iter=1)
    assert again.rms_history_rad[0] < 0.1 * np.sqrt(
        np.mean(without_line(phi, tr.slow_times_s) ** 2)
    )


def test_pga_finds_no_error_on_a_focused_point_at_the_centre():
    # One noiseless point at the image centre, no phase error: the back-transform with
    # the exact delays returns the point's phase history, constant, so the estimate is
    # zero up to the stopping tolerance. Linearised (kappa_j (y - y_t)), it left the
    # chirp k_o (y - y_t)^2 / R along the range line, which the window truncates into an
    # even phase on the edge pulses: a quadratic bias.
    tr = simulate(point_scene([(0.0, 0.0)])).traces
    result = pga(tr)
    residual = without_line(result.phase_error_rad, tr.slow_times_s)
    assert np.sqrt(np.mean(residual**2)) < result.tol_rad


def test_final_fit_recovers_an_injected_error_on_an_isolated_point():
    # One noiseless point off the image centre (a sub-pixel peak, a window cut
    # asymmetrically about it) with an injected error of orders 2-4: the fit of the
    # window's exact model returns the error within the stopping tolerance. The
    # iteration alone stops with what its final window cannot see, at the aperture edges.
    tr = simulate(point_scene([(3.3, -7.1)])).traces
    phi = injected_error(tr, 35)
    result = pga(apply_phase_correction(tr, -phi))
    assert result.order >= 4  # the injected orders are resolved by the window
    residual = without_line(result.phase_error_rad - phi, tr.slow_times_s)
    assert np.sqrt(np.mean(residual**2)) < result.tol_rad


def test_final_fit_drops_lines_whose_window_holds_more_than_its_point():
    # Scene 1's stationary points, noiseless: some windows hold another point's sidelobes
    # or range lines of two points; kept, they bias the fit beyond the tolerance.
    scene = load_scene("scene1")
    scene = dataclasses.replace(
        scene, targets=tuple(t for t in scene.targets if not np.any(t.velocity_mps))
    )
    tr = simulate(scene).traces
    phi = injected_error(tr, 34)
    result = pga(apply_phase_correction(tr, -phi))
    assert 0 < result.n_fitted_lines < result.lines_history[-1]
    residual = without_line(result.phase_error_rad - phi, tr.slow_times_s)
    assert np.sqrt(np.mean(residual**2)) < result.tol_rad


@pytest.mark.parametrize("seed", [36, 41])
def test_final_fit_keeps_a_high_order_error_the_window_sees(seed, monkeypatch):
    # A sinusoidal error of 3 cycles over the aperture (paired echoes 3 cells from each
    # point, inside the final window) lies beyond the orders the fit's series resolves.
    # What the iteration recovered of it explains the windows better than the series
    # alone, so it is kept: the final estimate is no worse than the iteration's (within
    # the tolerance). The series alone would drop it (residual near the ripple's RMS).
    rng = np.random.default_rng(3)
    tr = simulate(point_scene(rng.uniform(-20, 20, size=(8, 2))), snr_db=10.0, rng=4).traces
    s = tr.slow_times_s
    x = (s - s.mean()) / (np.ptp(s) / 2)
    ripple = 0.5 * np.sin(3 * 2 * np.pi * x + 0.3)
    phi = injected_error(tr, seed) + ripple
    bad = apply_phase_correction(tr, -phi)
    result = pga(bad)
    assert result.order > 0  # the final fit ran
    with monkeypatch.context() as m:
        m.setattr(autofocus, "_final_estimate", lambda *args, **kwargs: None)
        iteration = pga(bad)
    assert iteration.order == 0

    def rms(estimate):
        return np.sqrt(np.mean(without_line(estimate - phi, s) ** 2))

    assert rms(result.phase_error_rad) < rms(iteration.phase_error_rad) + result.tol_rad


def test_pga_is_the_same_whatever_the_block_of_line_models(monkeypatch):
    # The windows' models are computed a block of lines at a time within the read's
    # memory budget; one line per block and all lines at once give the same estimate.
    rng = np.random.default_rng(3)
    tr = simulate(point_scene(rng.uniform(-20, 20, size=(8, 2))), snr_db=10.0, rng=4).traces
    bad = apply_phase_correction(tr, -injected_error(tr, 5))
    estimates = []
    for budget in (1, 10**12):
        monkeypatch.setattr(autofocus, "phase_history_bytes", lambda *shape, b=budget: b)
        estimates.append(pga(bad).phase_error_rad)
    np.testing.assert_allclose(estimates[0], estimates[1], rtol=0, atol=1e-12)


def test_focus_mover_refocuses_a_defocused_mover():
    scene = Scene(
        name="mover",
        targets=(PointTarget(position_m=(2.0, -3.0), velocity_mps=(4.0, 3.0)),),
        reference_point_m=(0.0, 0.0, 0.0),
        trajectory_spec={"kind": "circular", "aperture_deg": 1.0},
    )
    tr = simulate(scene, snr_db=10.0, rng=1).traces
    phi = injected_error(tr, 9)
    bad = apply_phase_correction(tr, -phi)
    good = focus_mover(tr, (2.0, -3.0), (4.0, 3.0), max_iter=1)
    fixed = focus_mover(bad, (2.0, -3.0), (4.0, 3.0))
    peak_good = np.abs(good.image.values).max()
    assert np.abs(fixed.image.values).max() > 10 ** (-0.5 / 20) * peak_good
    residual = without_line(fixed.phase_error_rad - phi, tr.slow_times_s)
    assert np.sqrt(np.mean(residual**2)) < MAX_RESIDUAL_RAD


def test_no_bright_scatterer_is_refused():
    tr = simulate(point_scene([(3.0, 4.0)])).traces
    noise = np.random.default_rng(0).standard_normal(tr.data.shape) * (1 + 1j)
    with pytest.raises(ValueError, match="no bright scatterer"):
        pga(tr.with_data(noise))
    with pytest.raises(ValueError, match="no bright scatterer"):
        pga(tr.with_data(np.zeros_like(tr.data)))


def test_more_iterations_than_pulses_is_refused():
    tr = simulate(point_scene([(3.0, 4.0)])).traces
    with pytest.raises(ValueError, match="max_iter must be between 1 and the number of pulses"):
        pga(tr, max_iter=tr.n_pulses + 1)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [None, 31, 32, 33])
def test_pga_restores_scene1_separation_and_movers(seed):
    # seed None: the uncorrupted data, which PGA must leave as they are.
    sim = simulate(load_scene("scene1"), snr_db=20.0, rng=21)
    tr = sim.traces
    phi = np.zeros(tr.n_pulses) if seed is None else injected_error(tr, seed)
    result = pga(apply_phase_correction(tr, -phi))
    # PGA returns the error up to a line: a common cross-range shift. The reference run
    # is the uncorrupted data with that same shift, which no autofocus can undo.
    d = result.phase_error_rad - phi
    line = d - without_line(d, tr.slow_times_s)
    residual = d - line
    assert np.sqrt(np.mean(residual**2)) < MAX_RESIDUAL_RAD
    opts = AnalysisOptions(trajectory=False)
    ref = analyze(apply_phase_correction(tr, line), opts)
    got = analyze(result.traces, opts)
    ref_doc, got_doc = results_document(ref), results_document(got)
    assert len(got_doc["movers"]) == len(ref_doc["movers"]) == 2
    for a in ref_doc["movers"]:
        b = min(
            got_doc["movers"],
            key=lambda m: np.hypot(*np.subtract(m["position_m"], a["position_m"])),
        )
        se = a["standard_errors"]
        res = resolution(tr, point_m=a["position_m"])
        dpos = np.subtract(b["position_m"], a["position_m"])
        # Range position, range speed and cross-range speed: within 3 standard errors of
        # the difference of the two runs.
        for key, delta in (
            ("range_position_m", abs(dpos @ res.range_direction)),
            ("range_speed_mps", abs(b["range_speed_mps"] - a["range_speed_mps"])),
            (
                "cross_range_speed_mps",
                abs(b["cross_range_speed_mps"] - a["cross_range_speed_mps"]),
            ),
        ):
            sigma = np.hypot(se[key], b["standard_errors"][key])
            assert delta < 3 * sigma, (key, delta, sigma)
    # Separation: the moving part is as close to the truth as without the error, within
    # the share of the echo energy the residual phase error moves, 1 - exp(-sigma^2 / 2).
    truth = sim.moving * np.exp(-1j * line)[:, None]
    err_ref = np.linalg.norm(ref.separation.moving - truth) / np.linalg.norm(truth)
    err_got = np.linalg.norm(got.separation.moving - truth) / np.linalg.norm(truth)
    assert err_got < err_ref + 2 * np.sqrt(np.mean(residual**2))
