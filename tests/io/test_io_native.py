"""Native HDF5 files: exact round trips, schema and version checks, bad files, atomic writes."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from sarmotion.core import Radar, Traces, Trajectory
from sarmotion.io import (
    IMAGE_SCHEMA,
    TRACES_SCHEMA,
    DataError,
    load_extra,
    load_image,
    load_traces,
    native_schema,
    save_image,
    save_traces,
)
from sarmotion.simulation import PointTarget, Scene, simulate


@pytest.fixture(scope="module")
def sim():
    scene = Scene(
        name="native",
        targets=(
            PointTarget(position_m=(3.0, -4.0)),
            PointTarget(position_m=(-10.0, 6.0), velocity_mps=(2.0, 1.0), reflectivity=0.5j),
        ),
        reference_point_m=(1.0, 2.0, 0.0),
        trajectory_spec={"kind": "circular", "aperture_deg": 0.5},
        radar=Radar(n_samples=128, frequency_step_hz=4e6, bandwidth_hz=500e6, pulse="gaussian"),
    )
    return simulate(scene, snr_db=20.0, rng=1)


def assert_same_traces(a: Traces, b: Traces) -> None:
    assert b.data.dtype == a.data.dtype
    np.testing.assert_array_equal(b.data, a.data)
    np.testing.assert_array_equal(b.positions_m, a.positions_m)
    np.testing.assert_array_equal(b.slow_times_s, a.slow_times_s)
    np.testing.assert_array_equal(b.reference_point_m, a.reference_point_m)
    assert b.radar == a.radar
    assert b.metadata == a.metadata


# --------------------------------------------------------------------------- round trips
def test_traces_round_trip_is_exact(tmp_path, sim):
    path = save_traces(tmp_path / "t.h5", sim.traces)
    assert native_schema(path) == TRACES_SCHEMA
    assert_same_traces(sim.traces, load_traces(path))
    assert load_extra(path) == {}


def test_complex64_traces_and_metadata_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    traj = Trajectory.linear(centre_m=(-7000.0, 0.0, 7000.0), aperture_m=20.0)
    radar = Radar(n_samples=16, frequency_step_hz=4e6, bandwidth_hz=60e6)
    data = (rng.standard_normal((traj.n_pulses, 16)) + 1j).astype(np.complex64)
    meta = {"source": "test", "files": ["a", "b"], "nested": {"x": [1.5, None, True]}}
    tr = Traces(data=data, trajectory=traj, radar=radar, reference_point_m=(0, 0, 0), metadata=meta)
    back = load_traces(save_traces(tmp_path / "c64.h5", tr))
    assert back.data.dtype == np.complex64
    assert_same_traces(tr, back)


def test_extra_trace_sets_round_trip(tmp_path, sim):
    extra = {"L": sim.stationary, "S": sim.moving, "M": sim.traces.data.astype(np.complex64)}
    path = save_traces(tmp_path / "sep.h5", sim.traces, extra=extra)
    got = load_extra(path)
    assert set(got) == {"L", "S", "M"}
    for name, value in extra.items():
        assert got[name].dtype == value.dtype
        np.testing.assert_array_equal(got[name], value)
    assert_same_traces(sim.traces, load_traces(path))


@pytest.mark.parametrize("velocity", [None, (3.5, -1.25)])
@pytest.mark.parametrize("dtype", [np.complex128, np.complex64, np.float64])
def test_image_round_trip_is_exact(tmp_path, velocity, dtype):
    rng = np.random.default_rng(5)
    values = (rng.standard_normal((7, 9)) * (1 + 0.5j if dtype != np.float64 else 1)).astype(dtype)
    x = np.linspace(-4.0, 4.0, 9)
    y = np.linspace(10.0, 16.0, 7)
    meta = {"inputs": ["scene1"], "pixel_m": 1.0}
    path = save_image(
        tmp_path / "img.h5", values, x_m=x, y_m=y, velocity_mps=velocity, metadata=meta
    )
    assert native_schema(path) == IMAGE_SCHEMA
    got = load_image(path)
    assert got["values"].dtype == values.dtype
    np.testing.assert_array_equal(got["values"], values)
    np.testing.assert_array_equal(got["x_m"], x)
    np.testing.assert_array_equal(got["y_m"], y)
    assert got["metadata"] == meta
    assert got["schema"] == IMAGE_SCHEMA
    if velocity is None:
        assert got["velocity_mps"] is None
    else:
        np.testing.assert_array_equal(got["velocity_mps"], velocity)


def test_file_layout_is_the_documented_one(tmp_path, sim):
    path = save_traces(tmp_path / "t.h5", sim.traces, extra={"L": sim.stationary})
    n, m = sim.traces.shape
    with h5py.File(path, "r") as fh:
        assert fh.attrs["schema"] == "sarmotion.traces/1"
        g = fh["traces"]
        assert g["data"].shape == (n, m) and g["data"].dtype.kind == "c"
        assert g["positions_m"].shape == (n, 3) and g["positions_m"].dtype == np.float64
        assert g["slow_times_s"].shape == (n,)
        for name in (
            "carrier_hz",
            "bandwidth_hz",
            "frequency_step_hz",
            "n_samples",
            "pulse",
            "reference_point_m",
            "geometry_sha256",
            "metadata",
        ):
            assert name in g.attrs, name
        assert fh["extra/L"].shape == (n, m)


# ------------------------------------------------------------------------ schema checks
def test_schema_kind_and_version_are_checked(tmp_path, sim):
    img = save_image(tmp_path / "img.h5", np.ones((2, 3)), x_m=[0, 1, 2], y_m=[0, 1])
    with pytest.raises(DataError, match=r"img\.h5: schema is 'sarmotion\.image/1', expected"):
        load_traces(img)
    tr = save_traces(tmp_path / "t.h5", sim.traces)
    with pytest.raises(DataError, match=r"schema is 'sarmotion\.traces/1', expected 'sarm"):
        load_image(tr)
    with h5py.File(tr, "r+") as fh:
        fh.attrs["schema"] = "sarmotion.traces/2"
    with pytest.raises(DataError, match=r"t\.h5: schema 'sarmotion\.traces/2' is newer"):
        load_traces(tr)
    with h5py.File(tr, "r+") as fh:
        del fh.attrs["schema"]
    with pytest.raises(DataError, match=r"no root attribute 'schema'"):
        load_traces(tr)
    assert native_schema(tr) is None


def test_not_hdf5_and_missing_file(tmp_path):
    text = tmp_path / "notes.h5"
    text.write_text("not hdf5\n")
    with pytest.raises(DataError, match=r"notes\.h5: not an HDF5 file"):
        load_traces(text)
    with pytest.raises(DataError, match=r"gone\.h5: file not found"):
        load_image(tmp_path / "gone.h5")
    assert native_schema(text) is None
    assert native_schema(tmp_path / "gone.h5") is None


def _edit(path, fn):
    with h5py.File(path, "r+") as fh:
        fn(fh)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda fh: fh.__delitem__("traces/positions_m"), r"missing dataset /traces/positions_m"),
        (lambda fh: fh.__delitem__("traces"), r"missing group /traces"),
        (
            lambda fh: (
                fh.__delitem__("traces/positions_m"),
                fh.create_dataset("traces/positions_m", data=np.zeros((5, 2))),
            ),
            r"/traces/positions_m has shape \(5, 2\), expected \(\d+, 3\)",
        ),
        (
            lambda fh: fh["traces/data"].__setitem__((0, 0), np.nan),
            r"/traces/data contains 1 NaN/inf value\(s\) \(first at \(0, 0\)\)",
        ),
        (lambda fh: fh["traces"].attrs.__delitem__("carrier_hz"), r"missing attribute 'carrier_h"),
        (lambda fh: fh["traces"].attrs.__setitem__("metadata", "{oops"), r"not valid JSON"),
        (lambda fh: fh["traces"].attrs.__setitem__("n_samples", 7), r"inconsistent traces"),
        (
            lambda fh: (
                fh.__delitem__("traces/data"),
                fh.create_dataset("traces/data", data=np.zeros((3, 4))),
            ),
            r"/traces/data must be complex",
        ),
    ],
)
def test_bad_traces_files(tmp_path, sim, edit, message):
    path = save_traces(tmp_path / "bad.h5", sim.traces)
    _edit(path, edit)
    with pytest.raises(DataError, match=message) as info:
        load_traces(path)
    assert str(path) in str(info.value)


def test_bad_image_file(tmp_path):
    path = save_image(tmp_path / "img.h5", np.ones((2, 3)), x_m=[0, 1, 2], y_m=[0, 1])
    _edit(path, lambda fh: (fh.__delitem__("x_m"), fh.create_dataset("x_m", data=[0.0, 1.0])))
    with pytest.raises(DataError, match=r"img\.h5: axes x_m \(2,\) and y_m \(2,\) do not match"):
        load_image(path)
    _edit(path, lambda fh: fh.__delitem__("values"))
    with pytest.raises(DataError, match=r"missing dataset /values"):
        load_image(path)


def test_bad_extra_file(tmp_path, sim):
    path = save_traces(tmp_path / "x.h5", sim.traces, extra={"L": sim.stationary})
    _edit(
        path,
        lambda fh: (fh.__delitem__("extra/L"), fh.create_dataset("extra/L", data=np.ones((2, 2)))),
    )
    with pytest.raises(DataError, match=r"/extra/L has shape \(2, 2\), expected"):
        load_extra(path)


# ----------------------------------------------------------------------- bad arguments
def test_bad_arguments_write_nothing(tmp_path, sim):
    tr = sim.traces
    target = tmp_path / "out.h5"
    cases = [
        (lambda: save_traces(target, tr, extra={"L": np.ones((3, 3))}), r"extra\['L'\] must have"),
        (lambda: save_traces(target, tr, extra={"a/b": sim.stationary}), r"without '/'"),
        (lambda: save_traces(target, tr, extra={"L": sim.stationary * np.nan}), r"NaN"),
        (lambda: save_traces(target, tr.with_data(tr.data, bad=object())), r"JSON-serialisable"),
        (lambda: save_image(target, np.ones((2, 3)), x_m=[0, 1], y_m=[0, 1]), r"x_m must have"),
        (lambda: save_image(target, np.ones((2, 3)), x_m=[0, 2, 1], y_m=[0, 1]), r"monotonic"),
        (lambda: save_image(target, np.full((2, 3), np.inf), x_m=[0, 1, 2], y_m=[0, 1]), r"NaN"),
        (
            lambda: save_image(
                target, np.ones((2, 3)), x_m=[0, 1, 2], y_m=[0, 1], velocity_mps=(1, 2, 3)
            ),
            r"velocity_mps",
        ),
    ]
    for call, message in cases:
        with pytest.raises(DataError, match=message):
            call()
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- atomicity
def test_failed_write_leaves_no_file_and_keeps_the_old_one(tmp_path, sim, monkeypatch):
    path = tmp_path / "t.h5"
    old = sim.traces.with_data(sim.stationary)
    save_traces(path, old)
    real = h5py.Group.create_dataset
    calls = []

    def failing(self, *args, **kwargs):
        calls.append(args[0] if args else kwargs.get("name"))
        if len(calls) == 2:
            raise OSError("No space left on device")
        return real(self, *args, **kwargs)

    monkeypatch.setattr(h5py.Group, "create_dataset", failing)
    with pytest.raises(OSError, match="No space"):
        save_traces(path, sim.traces)
    calls.clear()
    with pytest.raises(OSError, match="No space"):
        save_image(tmp_path / "img.h5", np.ones((2, 3)), x_m=[0, 1, 2], y_m=[0, 1])
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.h5"]  # no temporary left
    assert_same_traces(old, load_traces(path))


def test_overwrite_false(tmp_path, sim):
    path = save_traces(tmp_path / "t.h5", sim.traces)
    with pytest.raises(FileExistsError, match=r"t\.h5"):
        save_traces(path, sim.traces, overwrite=False)
    with pytest.raises(FileExistsError):
        save_image(path, np.ones((2, 2)), x_m=[0, 1], y_m=[0, 1], overwrite=False)
    assert_same_traces(sim.traces, load_traces(path))


# ------------------------------------------------------------------- plausibility rules
def _saved_scene(tmp_path, edit):
    from sarmotion.io import save_traces
    from sarmotion.simulation import load_scene, simulate

    tr = simulate(load_scene("rotscatt")).traces
    data, pos = tr.data.copy(), tr.positions_m.copy()
    edit(data, pos)
    bad = Traces(
        data=data,
        trajectory=Trajectory(positions_m=pos, slow_times_s=tr.slow_times_s),
        radar=tr.radar,
        reference_point_m=tr.reference_point_m,
        metadata=tr.metadata,
    )
    return save_traces(tmp_path / "t.h5", bad)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d, p: d.__setitem__((40, 200), 1e9), r"data \(as phase history\), pulse 40,"),
        (lambda d, p: p.__setitem__((30, 2), 0.0), r"/traces/positions_m, pulse 30"),
        # y + 0.5 m at one pulse: 0.5 m off the midpoint, a second difference of 1 m.
        (lambda d, p: p.__setitem__((30, 1), p[30, 1] + 0.5), r"pulse 30: the antenna is 0.5 m"),
    ],
)
def test_implausible_native_traces_are_refused(tmp_path, edit, message):
    path = _saved_scene(tmp_path, edit)
    with pytest.raises(DataError, match=message) as info:
        load_traces(path)
    assert str(info.value).startswith(str(path)) and "rule" in str(info.value)
    assert load_traces(path, lenient=True).n_pulses == 117


@pytest.mark.parametrize(
    ("where", "axis", "shift"),
    [("reference_point_m", 1, 10.0), ("positions_m", 0, 1e-3), ("slow_times_s", None, 1e-6)],
)
def test_geometry_altered_after_writing_is_refused(tmp_path, sim, where, axis, shift):
    # A reference point moved by metres, an antenna 1 mm off or a time 1 us off passes
    # every plausibility rule yet moves the travel times the phases rest on by more than
    # a quarter cycle over the scene (or, for the small edits, by an unknown amount):
    # only the digest written with the geometry tells. Without --lenient it is refused;
    # with it, read with a warning; a file written without a digest is read as before.
    path = save_traces(tmp_path / "t.h5", sim.traces)
    with h5py.File(path, "a") as fh:
        g = fh["traces"]
        if where == "reference_point_m":
            ref = np.array(g.attrs[where], dtype=np.float64)
            ref[axis] += shift
            g.attrs[where] = ref
        else:
            value = g[where][()]
            if axis is None:
                value[len(value) // 2] += shift
            else:
                value[len(value) // 2, axis] += shift
            g[where][...] = value
    with pytest.raises(DataError, match="do not match the digest written with them"):
        load_traces(path)
    assert load_traces(path, lenient=True).n_pulses == sim.traces.n_pulses
    with h5py.File(path, "a") as fh:
        del fh["traces"].attrs["geometry_sha256"]
    assert load_traces(path).n_pulses == sim.traces.n_pulses
