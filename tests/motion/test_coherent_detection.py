"""The coherent detector: its statistic's null distribution and its decisions.

The statistic is ``10 log10(|I|^2 / sigma_I^2)`` (:mod:`sarmotion.motion.coherent`): at
one fixed parameter in circular white noise it is exponential with mean 1 (chi-square
with two degrees of freedom over two). The thresholds are set once, from the stated
false-alarm rate and the null tail measured on other scenes
(``benchmarks/detector_null.py --detector coherent``); seeds 7600+ are used nowhere else.
"""

import numpy as np
import pytest

from sarmotion.motion import (
    COHERENT_NULL_TAIL,
    NULL_TAIL,
    MatchedFilter,
    clairvoyant_threshold_db,
    coherent_false_alarm_probability,
    coherent_statistic_db,
    coherent_threshold_db,
    effective_cells,
    matched_filter_variance,
    neighbourhood_noise,
    screen_threshold_db,
    searching_threshold_db,
)
from sarmotion.pipeline import AnalysisOptions, detect, estimate_movers
from sarmotion.separation import SeparationOptions
from sarmotion.simulation import random_scene, simulate


def _acquisition(seed: int = 7600):
    """The default one-degree acquisition of a simulated scene (117 pulses)."""
    rng = np.random.default_rng(seed)
    return simulate(random_scene(n_stationary=1, rng=rng)).traces


def _noise(shape, rng, sigma2=1.0):
    return np.sqrt(sigma2 / 2) * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape))


def test_likelihood_ratio_of_white_noise_is_exponential():
    """``|I|^2 / sigma_I^2`` at a fixed parameter: mean 1 and ``P(> ln 10) = 0.1``.

    250 seeded draws of white noise of unit variance per fast-time sample; the mean of an
    exponential of mean 1 has standard deviation ``1 / sqrt(250)`` (four allowed), the
    fraction beyond its 90 % point ``ln 10`` a binomial one (three allowed).
    """
    tr = _acquisition()
    rng = np.random.default_rng(7601)
    pos = tr.reference_point_m + np.array([3.0, -2.0, 0.0])
    vel = np.array([[4.0, -1.5]])
    var = matched_filter_variance(tr.acquisition, 1.0)
    ratio = np.array(
        [
            abs(MatchedFilter(tr.with_data(_noise(tr.shape, rng))).responses(pos[None], vel)[0])
            ** 2
            / var
            for _ in range(250)
        ]
    )
    assert abs(ratio.mean() - 1.0) <= 4.0 / np.sqrt(ratio.size), ratio.mean()
    beyond = float(np.mean(ratio > np.log(10.0)))
    assert abs(beyond - 0.1) <= 3.0 * np.sqrt(0.09 / ratio.size), beyond


def test_neighbourhood_level_of_white_noise_is_its_variance():
    """The level the statistic divides by is the noise's variance (unbiased over draws).

    Noise of variance 2.5 per sample; the mean of the level over 16 draws is within four
    of its own standard errors of 2.5, and the statistic at a fixed parameter with that
    level has the mean of the exponential within the same allowance plus the level's.
    """
    tr = _acquisition()
    rng = np.random.default_rng(7602)
    pos = tr.reference_point_m + np.array([-4.0, 5.0, 0.0])
    vel = np.array([-6.0, 2.0])
    levels, stats = [], []
    for _ in range(16):
        d = tr.with_data(_noise(tr.shape, rng, 2.5))
        levels.append(neighbourhood_noise(d, pos, vel))
        stats.append(coherent_statistic_db(d, pos, vel, noise_variance=2.5))
    levels = np.asarray(levels)
    se = levels.std(ddof=1) / np.sqrt(levels.size)
    assert abs(levels.mean() - 2.5) <= 4.0 * se, (levels.mean(), se)
    lin = 10 ** (np.asarray(stats) / 10)
    assert abs(lin.mean() - 1.0) <= 4.0 / np.sqrt(lin.size)


def test_thresholds_follow_the_stated_rules():
    """Screen, coherent and clairvoyant thresholds from their formulas, and their p-values."""
    assert screen_threshold_db(0.1) == pytest.approx(NULL_TAIL["t0_db"])
    t = COHERENT_NULL_TAIL
    thr = coherent_threshold_db(0.01, 5)
    assert thr == pytest.approx(t["t0_db"] + t["scale_db"] * np.log(t["p0"] * 5 / 0.01))
    assert coherent_false_alarm_probability(thr, 5) == pytest.approx(0.01)
    assert coherent_threshold_db(0.01, 10) > thr > coherent_threshold_db(0.1, 5)
    # an exponential of mean 1 exceeds ln(1 / alpha) with probability alpha
    assert 10 ** (clairvoyant_threshold_db(0.01) / 10) == pytest.approx(np.log(100.0))
    with pytest.raises(ValueError):
        coherent_threshold_db(1.5, 3)
    with pytest.raises(ValueError):
        AnalysisOptions(detector="incoherent")


def test_searching_threshold_is_the_clairvoyant_one_for_one_cell_and_ln_n_over_alpha():
    """``N = 1`` is the single test; large ``N``: ``ln(N / alpha)`` to first order in ``alpha``.

    The largest of ``N`` exponentials passes its threshold with probability ``alpha``
    exactly: ``1 - (1 - exp(-t))^N``.
    """
    assert searching_threshold_db(0.01, 1) == pytest.approx(clairvoyant_threshold_db(0.01))
    for n in (10.0, 1e4, 1.7e9):
        t = 10 ** (searching_threshold_db(0.01, n) / 10)
        assert -np.expm1(n * np.log1p(-np.exp(-t))) == pytest.approx(0.01, rel=1e-9)
        assert t == pytest.approx(np.log(n / 0.01), abs=0.01)
    with pytest.raises(ValueError):
        searching_threshold_db(0.01, 0.5)


def test_effective_cells_recovers_the_number_of_independent_cells():
    """Seeded maxima of ``N`` independent unit exponentials give back ``N``.

    400 maxima of 1000 and of 2000 cells: the estimate's relative standard deviation is
    ``1 / sqrt(400)`` = 5 %; four allowed. Correlated cells (each value repeated twice,
    the maxima unchanged) count once: the estimate is of independent cells, not values.
    """
    rng = np.random.default_rng(7603)
    cells = rng.exponential(size=(400, 1000))
    maxima = cells.max(axis=1)
    assert effective_cells(maxima) == pytest.approx(1000, rel=4 * 0.05)
    twice = np.concatenate([cells, cells], axis=1).max(axis=1)
    assert effective_cells(twice) == pytest.approx(1000, rel=4 * 0.05)
    n = effective_cells(rng.exponential(size=(400, 2000)).max(axis=1))
    assert n == pytest.approx(2000, rel=4 * 0.05)


@pytest.mark.slow
@pytest.mark.parametrize(("seed", "method"), [(7610, "rpca"), (7611, "combined"), (7612, "rpca")])
def test_no_mover_in_point_clutter_without_movers(seed, method):
    """Fresh clutter scenes (10-80 targets, 0-30 dB SNR): the coherent detector declares none."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(10, 81))
    snr = float(rng.choice([0.0, 10.0, 20.0, 30.0]))
    traces = simulate(random_scene(n_stationary=n, rng=rng), snr_db=snr, rng=rng).traces
    options = AnalysisOptions(
        separation=SeparationOptions(method=method), trajectory=False, detector="coherent"
    )
    assert estimate_movers(detect(traces, options)).movers == ()


@pytest.mark.gotcha
def test_no_mover_on_a_real_degree(gotcha_files):
    """A real GOTCHA degree without movers (the one with most screened candidates).

    The degree is one of those of the null measurement, but the tail in use was fitted on
    simulated clutter; the screen passes several candidates here, so stage 2 runs.
    """
    from sarmotion.io import read_gotcha

    options = AnalysisOptions(trajectory=False, detector="coherent")
    found = detect(read_gotcha([gotcha_files[3]]), options)
    assert found.candidates.range_speeds.n_movers >= 2  # stage 2 is exercised
    assert estimate_movers(found).movers == ()


@pytest.mark.slow
def test_scene1_keeps_its_movers_with_the_coherent_detector():
    """Scene 1's two movers are declared by the coherent detector, with its evidence.

    Their range speeds are those of the truth within a range-speed resolution; each
    passed its likelihood-ratio threshold, and ``results.json`` carries the record.
    """
    from sarmotion.core import range_speed
    from sarmotion.documents.results import results_document
    from sarmotion.motion import range_speed_resolution
    from sarmotion.pipeline import analyze
    from sarmotion.simulation import load_scene

    sim = simulate(load_scene("scene1"))
    result = analyze(sim.traces, AnalysisOptions(detector="coherent", trajectory=False))
    geom = sim.traces.geometry
    truth = sorted(range_speed(t.velocity_mps, geom) for t in sim.scene.moving)
    found = sorted(m.range_speed_mps for m in result.movers)
    assert len(found) == len(truth)
    assert np.allclose(found, truth, atol=range_speed_resolution(sim.traces))
    for m, entry in zip(result.movers, results_document(result)["movers"], strict=True):
        ev = m.evidence
        assert ev.coherent_statistic_db >= ev.coherent_threshold_db
        assert ev.coherent_p_value <= 0.01
        assert entry["detection"]["coherent"]["statistic_db"] == ev.coherent_statistic_db
