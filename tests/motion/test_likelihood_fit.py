"""The matched filter's local fit (Newton ascent) against a tight Nelder-Mead.

``_local_fit`` climbs ``|I(x, u_r, u_p)|^2`` with analytic derivatives from a start as the
global search gives it (within a quarter of the Doppler resolution in range speed, half a
grid step in cross-range speed, a few cm in range). It must end at the same maximum as a
derivative-free search run to 1e-7 on the same ``|I|`` (to 1e-4 m, 1e-5 m/s and 1e-3 m/s),
with ``|I|`` no lower.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from sarmotion.core import C, cross_range_speed, ground_velocity, range_speed
from sarmotion.imaging import resolution
from sarmotion.motion.likelihood import MatchedFilter, _local_fit
from sarmotion.simulation import random_scene, simulate


@pytest.mark.parametrize("seed", [101, 102, 103, 104])
def test_local_fit_reaches_the_nelder_mead_maximum(seed):
    rng = np.random.default_rng(seed)
    velocity = rng.uniform(-10.0, 10.0, 2)
    sim = simulate(
        random_scene(n_stationary=0, movers=[(rng.uniform(-8, 8, 2), velocity)], rng=seed),
        snr_db=10.0,
        rng=seed,
    )
    tr = sim.traces
    geom = tr.geometry
    truth = np.asarray(sim.scene.moving[0].position_m, dtype=float)
    e_r = np.r_[resolution(tr).range_direction, 0.0]
    start = truth + rng.uniform(-0.03, 0.03) * e_r
    ur = range_speed(velocity, geom) + rng.uniform(-0.003, 0.003)
    up = cross_range_speed(velocity, geom) + rng.uniform(-0.2, 0.2)
    mf = MatchedFilter(tr)
    pos, fit_ur, fit_up, value = _local_fit(tr, mf, start, ur, up)

    def neg_abs(q):
        v = ground_velocity(ur + q[1], up + q[2], geom)
        return -abs(mf.responses((start + q[0] * e_r)[None], v[None])[0])

    q0 = np.zeros(3)
    ref = minimize(
        neg_abs,
        q0,
        method="Nelder-Mead",
        options={
            "initial_simplex": np.vstack([q0, np.diag([0.03, 0.01, 0.15])]),
            "xatol": 1e-7,
            "fatol": 1e-12 * -neg_abs(q0),
            "maxiter": 4000,
        },
    )
    assert abs((pos - start) @ e_r - ref.x[0]) < 1e-4
    assert abs(fit_ur - (ur + ref.x[1])) < 1e-5
    assert abs(fit_up - (up + ref.x[2])) < 1e-3
    assert abs(value) >= -ref.fun * (1 - 1e-9)


def test_responses_on_the_planes_are_the_row_sums_and_the_direct_sum():
    # I(theta) for one point (row sums, no planes built), for a batch (which builds the
    # frequency-major planes) and after them (the planes again), against the direct
    # sum of P W exp(2i pi f dtau) over pulses and frequencies: the same to 1e-13 of
    # sum |P W| / sum W^2, the largest |I| the data allow; each pulse's term too.
    sim = simulate(random_scene(n_stationary=3, movers=[((2.0, -3.0), (4.0, 6.0))], rng=7))
    tr = sim.traces
    rng = np.random.default_rng(7)
    pos = np.column_stack([rng.uniform(-5, 5, (4, 2)), np.zeros(4)])
    vel = rng.uniform(-8, 8, (4, 2))
    mf = MatchedFilter(tr)
    single = np.array([mf.responses(p[None], v[None])[0] for p, v in zip(pos, vel, strict=True)])
    assert mf._planes is None
    batch = mf.responses(pos, vel)
    assert mf._planes is not None
    again = mf.responses(pos[:1], vel[:1])
    w = tr.radar.spectral_weights()
    weighted = tr.phase_history() * w[None, :]
    direct, per_pulse = [], []
    for p, v in zip(pos, vel, strict=True):
        where = p[None, :] + tr.slow_times_s[:, None] * np.r_[v, 0.0][None, :]
        dtau = (
            2.0
            * (
                np.linalg.norm(tr.positions_m - where, axis=1)
                - np.linalg.norm(tr.positions_m - tr.reference_point_m, axis=1)
            )
            / C
        )
        phase = np.exp(2j * np.pi * np.outer(dtau, tr.frequencies_hz))
        direct.append(np.sum(weighted * phase) / np.sum(w**2))
        per_pulse.append(np.sum(weighted * phase, axis=1) / np.sum(w**2))
    scale = np.sum(np.abs(weighted)) / np.sum(w**2)
    for got in (single, batch, np.r_[again, batch[1:]]):
        np.testing.assert_allclose(got, direct, rtol=0, atol=1e-13 * scale)
    # each pulse's term (pulse_responses) is the direct sum's row
    for p, v, rows in zip(pos, vel, per_pulse, strict=True):
        np.testing.assert_allclose(mf.pulse_responses(p, v), rows, rtol=0, atol=1e-13 * scale)
