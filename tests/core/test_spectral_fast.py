"""The compiled phasors of core.spectral against numpy's complex exponential."""

from __future__ import annotations

import numpy as np

from sarmotion.core import delay_phase
from sarmotion.core.spectral import phased_row_sums


def _reference(delays, freqs):
    cycles = np.multiply.outer(delays, freqs)
    cycles -= np.round(cycles)
    return np.exp(2j * np.pi * cycles)


def test_delay_phase_matches_numpy():
    rng = np.random.default_rng(3)
    delays = rng.uniform(-2e-6, 2e-6, 57)  # up to ~2e4 carrier cycles
    freqs = 9.6e9 + (np.arange(424) - 212) * 1.47e6
    got = delay_phase(delays, freqs)
    assert got.shape == (57, 424) and got.dtype == np.complex128
    np.testing.assert_allclose(got, _reference(delays, freqs), rtol=0, atol=1e-13)
    assert delay_phase(delays[0], freqs).shape == (424,)
    assert delay_phase(delays, freqs[0]).shape == (57,)
    np.testing.assert_array_equal(delay_phase([0.0], freqs), np.ones((1, 424)))


def test_phased_row_sums_matches_the_phasor_matrix():
    rng = np.random.default_rng(4)
    values = rng.standard_normal((40, 424)) + 1j * rng.standard_normal((40, 424))
    delays = rng.uniform(-1e-6, 1e-6, 40)
    f0, df = 9.28e9, 1.47e6
    freqs = f0 + np.arange(424) * df
    got = phased_row_sums(values, delays, f0, df)
    ref = np.sum(values * _reference(delays, freqs), axis=1)
    # Re-seeded every 32 terms: errors ~1e-13 of the sum of moduli (6e-13 seen).
    assert np.max(np.abs(got - ref) / np.abs(values).sum(axis=1)) < 5e-12


def test_frequency_planes_sum_as_the_rows():
    """The frequency-major sums equal phased_row_sums (and the phasor matrix) on any block.

    Same re-seeding every 32 terms: measured ~1e-16 of the sum of moduli apart.
    """
    from sarmotion.core.spectral import FrequencyPlanes

    rng = np.random.default_rng(5)
    values = rng.standard_normal((70, 424)) + 1j * rng.standard_normal((70, 424))
    delays = rng.uniform(-1e-6, 1e-6, 70)
    f0, df = 9.28e9, 1.47e6
    planes = FrequencyPlanes(values)
    for rows in (slice(None), slice(10, 45)):
        got = planes.sums(delays[rows], f0, df, rows=rows)
        want = phased_row_sums(values[rows], delays[rows], f0, df)
        scale = np.abs(values[rows]).sum(axis=1)
        assert np.max(np.abs(got - want) / scale) < 1e-14
        ref = np.sum(values[rows] * _reference(delays[rows], f0 + np.arange(424) * df), axis=1)
        assert np.max(np.abs(got - ref) / scale) < 5e-12


def test_pulse_responses_from_planes_match_the_phase_history():
    """pulse_responses with FrequencyPlanes gives the array path's terms (to 1e-14)."""
    from sarmotion.core.spectral import FrequencyPlanes
    from sarmotion.imaging import pulse_responses
    from sarmotion.simulation import random_scene, simulate

    traces = simulate(random_scene(n_stationary=5, rng=2)).traces
    P = traces.phase_history()
    planes = FrequencyPlanes(P)
    for pulses in (slice(None), slice(20, 90)):
        a = pulse_responses(traces, (3.0, -2.0), (4.0, 1.0), phase_history=P, pulses=pulses)
        b = pulse_responses(traces, (3.0, -2.0), (4.0, 1.0), phase_history=planes, pulses=pulses)
        scale = np.abs(P[pulses]).sum(axis=1) / traces.n_samples
        assert np.max(np.abs(a - b) / scale) < 1e-14


def test_sums_and_derivatives_match_the_weighted_phasor_matrix():
    """``A``, ``dA/dd`` and ``d2A/dd2`` in one pass against ``sum (2i pi f)^m x e^{2i pi f d}``.

    Each within 5e-12 of the sum of its terms' moduli (the phasor rounding of
    :func:`phased_row_sums`; the carrier-centred expansion keeps it there).
    """
    from sarmotion.core.spectral import FrequencyPlanes

    rng = np.random.default_rng(6)
    values = rng.standard_normal((30, 424)) + 1j * rng.standard_normal((30, 424))
    delays = rng.uniform(-1e-6, 1e-6, 30)
    f0, df = 9.28e9, 1.47e6
    freqs = f0 + np.arange(424) * df
    got = FrequencyPlanes(values).sums_and_derivatives(delays, f0, df)
    phasors = _reference(delays, freqs)
    for m, sums in enumerate(got):
        weight = (2j * np.pi * freqs) ** m
        ref = np.sum(values * weight * phasors, axis=1)
        scale = np.abs(values * weight).sum(axis=1)
        assert np.max(np.abs(sums - ref) / scale) < 5e-12
