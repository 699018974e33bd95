"""The compiled kernels of the speed objectives against the plain numpy transforms.

``_Aligner`` forms the phase-modulated spectra by a rotating phasor (re-seeded exactly
every 32 bins) written straight into the zero-padded FFT buffer, and reduces ``g`` in
compiled code; the references form ``exp(2i pi f dtau)`` with numpy and pad, transform
and reduce with numpy. Tolerances are single-precision rounding (the spectra and the
transformed traces are complex64).
"""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.motion._aligned import _Aligner, _g_reduce
from sarmotion.motion.range_speed import _range_trials
from sarmotion.simulation import random_scene, simulate


@pytest.fixture(scope="module")
def aligner():
    traces = simulate(random_scene(n_stationary=12, rng=5), snr_db=10.0, rng=5).traces
    return _Aligner(traces, traces.reference_point_m)


def _spectra_reference(al, velocities):
    cycles = al.delays(velocities)[:, :, None] * al.freq[None, None, :]
    cycles -= np.rint(cycles)
    return np.exp(2j * np.pi * cycles) * al.spectrum[None]


def _transformed_reference(al, velocities):
    x = _spectra_reference(al, velocities)
    padded = np.zeros(x.shape[:2] + (al.n_fft,), dtype=np.complex128)
    padded[..., al.slots] = x
    return np.fft.ifft(padded, axis=-1)


def test_spectra_match_the_phasor_array(aligner):
    """Within 2 float32 rounding units of the largest spectrum sample."""
    vel = _range_trials(np.linspace(-25.0, 25.0, 13), aligner.traces.geometry, 4.0)
    got = aligner.spectra(vel)
    ref = _spectra_reference(aligner, vel)
    assert got.dtype == np.complex64
    scale = np.abs(aligner.spectrum).max()
    assert np.max(np.abs(got - ref)) <= 2 * np.finfo(np.float32).eps * scale


def test_g_of_the_chunks_matches_the_padded_transform(aligner):
    """``g`` on 3 chunks of trials within 1e-6 (relative) of numpy in double precision."""
    n = 3 * aligner.chunk - 1
    vel = _range_trials(np.linspace(-30.0, 30.0, n), aligner.traces.geometry, None)
    got = aligner.map_chunks(vel, _g_reduce)
    ref = np.abs(_transformed_reference(aligner, vel)).sum(axis=1).max(axis=-1)
    np.testing.assert_allclose(got, ref, rtol=1e-6)


def test_g_from_the_shift_table_within_its_interpolation_bound(aligner):
    """``g_values`` reads each pulse's trace at its shift by linear interpolation between
    16 sub-sample phases: per trial, its error is at most ``(2 pi nu / 16)^2 / 8`` (band
    edge ``nu = 1/4`` cycle per sample of the 2x-padded transform) times the sum of the
    pulses' peak moduli, against numpy's transform of each trial in double precision."""
    n = 3 * aligner.chunk + 7
    vel = _range_trials(np.linspace(-30.0, 30.0, n), aligner.traces.geometry, 1.5)
    x = np.abs(_transformed_reference(aligner, vel))
    ref = x.sum(axis=1).max(axis=-1)
    bound = (2 * np.pi * 0.25 / 16) ** 2 / 8 * x.max(axis=-1).sum(axis=1)
    got = aligner.g_values(vel)
    assert np.all(np.abs(got - ref) <= bound)
    # the interpolation is not exact: the check above has room to fail
    assert np.max(np.abs(got - ref) / bound) > 0.01  # measured 3-7 % of the bound


def test_second_differences_and_columns_match_the_transform(aligner):
    """The ``lag`` path and the column-basis path give the same fast-time samples."""
    vel = _range_trials(np.linspace(-10.0, 10.0, 5), aligner.traces.geometry, 2.0)
    h = 3
    full = _transformed_reference(aligner, vel)
    ds2 = (full[:, 2 * h :] - 2 * full[:, h:-h] + full[:, : -2 * h]) / (
        h * aligner.traces.trajectory.pulse_interval_s
    ) ** 2
    cols = np.arange(-8, 9) % aligner.n_fft
    seen = {"fft": [], "cols": []}

    def keep(tag):
        def reduce(x):
            seen[tag].append(np.array(x))
            return np.zeros(x.shape[0])

        return reduce

    aligner.map_chunks(vel, keep("fft"), lag=h)
    aligner.map_chunks(vel, keep("cols"), lag=h, columns=cols)
    seen = {tag: np.concatenate(chunks) for tag, chunks in seen.items()}
    scale = np.abs(ds2).max()
    assert np.max(np.abs(seen["fft"] - ds2)) <= 1e-6 * scale
    assert np.max(np.abs(seen["cols"] - ds2[..., cols])) <= 1e-6 * scale


def test_g_without_a_table_above_the_memory_cap(aligner, monkeypatch):
    """Above the table cap ``g_values`` transforms each trial (the exact values)."""
    import sarmotion.motion._aligned as aligned

    vel = _range_trials(np.linspace(-20.0, 20.0, 7), aligner.traces.geometry, None)
    fresh = _Aligner(aligner.traces, aligner.traces.reference_point_m)
    monkeypatch.setattr(aligned, "_MAX_TABLE_BYTES", fresh.table_bytes() - 1)
    got = fresh.g_values(vel)
    assert fresh._table is None
    np.testing.assert_array_equal(got, fresh.map_chunks(vel, _g_reduce))
