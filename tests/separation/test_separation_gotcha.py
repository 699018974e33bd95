"""Separation on real GOTCHA clutter with injected movers (the way it is judged on data)."""

import numpy as np
import pytest

from sarmotion.core import range_speed
from sarmotion.io import read_gotcha
from sarmotion.separation import mover_trace_coverage, separate_rpca
from sarmotion.simulation import PointTarget, inject


@pytest.mark.gotcha
@pytest.mark.slow
def test_rpca_removes_real_clutter_and_keeps_injected_movers(gotcha_files):
    clutter = read_gotcha(gotcha_files[:1])  # one degree, 117 pulses
    # Amplitude: the median over pulses of the brightest sample, i.e. as bright as the
    # strongest scatterers of the scene.
    amp = float(np.median(np.abs(clutter.data).max(axis=1)))
    movers = [
        PointTarget(position_m=[5.0, -10.0], velocity_mps=[8.0, 3.0], reflectivity=amp),
        PointTarget(position_m=[-12.0, 6.0], velocity_mps=[-6.0, 4.0], reflectivity=amp),
    ]
    for m in movers:  # range speeds of several m/s
        assert abs(range_speed(m.velocity_mps, clutter.geometry)) > 3.0
    data = inject(clutter, movers)
    true_moving = data.data - clutter.data
    sep = separate_rpca(data, window=64, eta_scale=2.0, tol=1e-5)
    clutter_left = sep.moving - true_moving
    reduction_db = 10 * np.log10(
        np.vdot(clutter_left, clutter_left).real / np.vdot(clutter.data, clutter.data).real
    )
    # >= 10 dB less clutter energy in S than in M (14.4 dB measured).
    assert reduction_db <= -10.0
    # Both movers' traces are in S: >= 90 % of each trace within 6 dB of its median
    # (0.96 measured).
    for m in movers:
        assert mover_trace_coverage(sep.moving, data, [m]) >= 0.9
    assert np.vdot(true_moving, sep.moving).real / np.vdot(true_moving, true_moving).real > 0.4
