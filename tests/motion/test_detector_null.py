"""The detector's null tail holds on data it was not fitted on.

The threshold of :mod:`sarmotion.motion.detector` assumes that a candidate's statistic
(dB over the local floor of ``g``) without movers exceeds ``t_0 + s ln(p_0 / p)`` with
probability ``p`` (``NULL_TAIL``). Here the fraction of candidates (``|u| >= 1.1`` m/s)
beyond the model's 1 % point is measured on the four real GOTCHA degrees and on
simulated point clutter of seeds used nowhere else (7400+), each through the
analysis's separation and detection stages; it must not exceed 1 % by more than three
binomial standard deviations. ``benchmarks/detector_null.py`` measures the whole
distribution.
"""

import numpy as np
import pytest

from sarmotion.io import read_gotcha
from sarmotion.motion import NULL_TAIL
from sarmotion.pipeline import AnalysisOptions, detect
from sarmotion.separation import SeparationOptions
from sarmotion.simulation import random_scene, simulate


def _null_statistics(traces, method: str) -> np.ndarray:
    options = AnalysisOptions(separation=SeparationOptions(method=method), trajectory=False)
    st = detect(traces, options).candidates.statistics
    return st.statistic_db[np.abs(st.speeds_mps) >= 1.1]


def _within_model(values: np.ndarray, p: float = 0.01) -> tuple[float, float]:
    """(fraction beyond the model's ``p`` point, its allowed maximum)."""
    t = NULL_TAIL
    point = t["t0_db"] + t["scale_db"] * np.log(t["p0"] / p)
    return float(np.mean(values > point)), p + 3.0 * np.sqrt(p * (1 - p) / values.size)


@pytest.mark.gotcha
def test_null_tail_holds_on_the_real_degrees(gotcha_files):
    """Measured: 1 of 528 candidates (0.19 %) beyond the model's 1 % point (2.72 dB)."""
    values = np.concatenate([_null_statistics(read_gotcha([f]), "rpca") for f in gotcha_files])
    assert values.size > 300  # about 110 candidates per degree
    fraction, allowed = _within_model(values)
    assert fraction <= allowed, (fraction, allowed)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["rpca", "combined"])
def test_null_tail_holds_on_fresh_point_clutter(method):
    """Six scenes of 10-80 targets, 0-30 dB SNR; RPCA's is the heavier measured tail.

    Measured: RPCA 1 of 662 candidates (0.15 %) beyond 2.72 dB, largest 2.82 dB;
    combined 0 of 716, largest 2.66 dB; allowed 2.2 %.
    """
    values = []
    for seed in range(7400, 7406):
        rng = np.random.default_rng(seed)
        n = int(rng.integers(10, 81))
        snr = float(rng.choice([0.0, 10.0, 20.0, 30.0]))
        traces = simulate(random_scene(n_stationary=n, rng=rng), snr_db=snr, rng=rng).traces
        values.append(_null_statistics(traces, method))
    values = np.concatenate(values)
    fraction, allowed = _within_model(values)
    assert fraction <= allowed, (fraction, allowed)
