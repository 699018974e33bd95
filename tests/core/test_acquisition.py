"""The acquisition apart from its data: shared geometry, sub-apertures, re-referencing."""

import dataclasses

import numpy as np
import pytest

from sarmotion.core import Acquisition, Traces, as_traces, look_geometry, to_fast_time
from sarmotion.imaging import resolution
from sarmotion.simulation import load_scene, simulate, simulate_phase_history


@pytest.fixture(scope="module")
def scene():
    return load_scene("scene1")


@pytest.fixture(scope="module")
def traces(scene):
    return simulate(scene).traces


def test_blocks_of_data_share_one_acquisition_and_its_geometry(traces):
    other = traces.with_data(2.0 * traces.data)
    assert other.acquisition is traces.acquisition
    assert other.geometry is traces.geometry  # computed once
    assert resolution(other) is resolution(traces)
    direct = look_geometry(traces.trajectory, traces.reference_point_m)
    assert np.allclose(traces.geometry.m_o, direct.m_o, rtol=0, atol=1e-15)
    assert traces.geometry.range_m == direct.range_m


def test_the_cached_geometry_cannot_be_changed_in_place(traces):
    with pytest.raises(ValueError):
        traces.geometry.m_o[0] = 0.0
    with pytest.raises(ValueError):
        traces.reference_point_m[0] = 1.0


def test_a_sub_aperture_is_shared_and_recentred(traces):
    a = traces.select_pulses(10, 60)
    b = traces.select_pulses(10, 60)
    assert a.acquisition is b.acquisition is traces.acquisition.sub_aperture(10, 60)
    s = a.slow_times_s
    assert s[0] == pytest.approx(-s[-1], abs=1e-15)
    np.testing.assert_array_equal(a.positions_m, traces.positions_m[10:60])
    np.testing.assert_array_equal(a.data, traces.data[10:60])
    direct = look_geometry(a.trajectory, a.reference_point_m)
    assert np.allclose(a.geometry.m_o, direct.m_o, rtol=0, atol=1e-15)
    with pytest.raises(ValueError):
        traces.acquisition.sub_aperture(5, 5)


def test_re_referenced_traces_equal_those_compressed_on_the_new_point(scene, traces):
    """Shifting by ``tau(s, rho_n) - tau(s, rho_o)`` is range compression on ``rho_n``.

    Scene 1 (20 stationary points, 2 movers) on a point 5 m from its reference: every
    trace stays inside the fast-time window, so the circular shift is exact to rounding.
    """
    new = np.asarray(scene.reference_point_m, dtype=float) + np.array([4.0, -3.0, 0.0])
    moved = traces.referenced_to(new)
    assert moved.acquisition.trajectory is traces.trajectory
    np.testing.assert_array_equal(moved.reference_point_m, new)
    targets = [*scene.stationary, *scene.moving]
    want = to_fast_time(simulate_phase_history(targets, traces.trajectory, traces.radar, new))
    err = np.linalg.norm(moved.data - want) / np.linalg.norm(want)
    assert err < 1e-9, err


def test_data_first_and_the_acquisition_as_a_keyword(traces):
    acq = traces.acquisition
    assert as_traces(traces) is traces
    assert as_traces(traces.data, acq).acquisition is acq
    with pytest.raises(TypeError, match="acquisition"):
        as_traces(traces.data)
    with pytest.raises(TypeError, match="Acquisition"):
        as_traces(traces.data, traces)
    with pytest.raises(ValueError, match="another acquisition"):
        as_traces(traces, acq.sub_aperture(0, 10))
    turned = dataclasses.replace(traces, reference_point_m=[1.0, 2.0, 0.0])
    assert turned.trajectory is traces.trajectory and turned.acquisition is not acq
    np.testing.assert_array_equal(turned.reference_point_m, [1.0, 2.0, 0.0])
    with pytest.raises(TypeError, match="give acquisition"):
        Traces(data=traces.data, radar=traces.radar)
    with pytest.raises(ValueError, match="pulses"):
        Traces(data=traces.data[:5], acquisition=acq)
    assert isinstance(acq, Acquisition) and acq.shape == traces.shape
