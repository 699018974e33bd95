"""Fuzzing the native HDF5 reader: mutated files are refused with a DataError or read correctly.

The file mutated is a traces file written by :func:`~sarmotion.io.save_traces` from a
simulated scene (24 pulses of 32 samples, three point targets, noise). The mutations are

* byte flips (anywhere, or in the first 4 kB, where HDF5 keeps its superblock, object
  headers and attributes) and truncations;
* structural edits made with h5py: a dataset replaced by an external link to another
  file, by a virtual dataset mapping another file, by a dataset with external raw
  storage in another file, by a soft link into a loop, or by a soft link to a copy of
  itself in the file; a dataset replaced by a never-written one of a huge declared
  shape (up to 10^9 rows);
* value edits: one coordinate of one antenna position changed by 0.1 mm to 100 km, the
  reference point moved by 0.1 mm to 100 km, one sample multiplied by 10 to 1e30, the
  metadata replaced by JSON nested 10 to 10^5 deep.

For every mutant the reader must

* raise nothing but :class:`~sarmotion.io.DataError`, with one line naming the file;
* return within 10 s;
* refuse every mutant that reaches another file (external link, virtual dataset,
  external storage), whatever that file holds, and every soft-link loop;
* read a soft link within the file as the dataset it points to;
* never accept a geometry corruption silently: when it accepts the mutant, the
  differential range ``|a_j - rho| - |a_j - rho_o|`` its traces predict for the points
  ``rho`` of a 100 m scene may differ from the original's by at most a quarter cycle
  of two-way phase (lambda / 8 at the top frequency), after removing one constant;
* never accept a sample more than 1000 times the original peak.

The strategy is seeded (``@seed``); each mutant costs one child process (the reader's
guard against HDF5 library loops), hence 150 mutants.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from fuzzing import assert_every_mutant_ran, read_or_refuse
from sarmotion.core import C, Radar
from sarmotion.io import load_traces, save_traces
from sarmotion.simulation import PointTarget, Scene, simulate

N_PULSES = 24
N_MUTANTS = 150
SCENE_POINTS = np.array(
    [[x, y, 0.0] for x in (-50.0, 0.0, 50.0) for y in (-50.0, 0.0, 50.0)], dtype=np.float64
)
DATASETS = ("data", "positions_m", "slow_times_s")
REACHING = ("external link", "virtual", "external storage")


@pytest.fixture(scope="module")
def original(tmp_path_factory):
    """``(path, other file, original traces, quarter cycle in m)``."""
    scene = Scene(
        name="fuzz",
        targets=(
            PointTarget(position_m=(3.0, -4.0)),
            PointTarget(position_m=(-10.0, 6.0), reflectivity=0.5j),
            PointTarget(position_m=(20.0, 15.0), reflectivity=0.7),
        ),
        reference_point_m=(1.0, 2.0, 0.0),
        trajectory_spec={"kind": "circular", "n_pulses": N_PULSES, "aperture_deg": 0.2},
        radar=Radar(n_samples=32, frequency_step_hz=4e6, bandwidth_hz=100e6, pulse="rect"),
    )
    traces = simulate(scene, snr_db=20.0, rng=3).traces
    folder = tmp_path_factory.mktemp("fuzz")
    path = save_traces(folder / "native.h5", traces)
    other = save_traces(folder / "other.h5", traces)
    quarter = C / float(traces.frequencies_hz.max()) / 8.0
    return path, other, traces, quarter


def _differential_range(positions, reference):
    return (
        np.linalg.norm(positions[:, None] - SCENE_POINTS[None], axis=2)
        - np.linalg.norm(positions - reference, axis=1)[:, None]
    )


def _structural(target: Path, other: Path, kind: str, name: str, size: int) -> None:
    where = f"traces/{name}"
    with h5py.File(target, "a") as fh:
        shape, dtype = fh[where].shape, fh[where].dtype
        if kind == "soft link":  # a copy elsewhere in the file, linked to
            fh.move(where, "moved")
            fh[where] = h5py.SoftLink("/moved")
            return
        del fh[where]
        if kind == "external link":
            fh[where] = h5py.ExternalLink(str(other), f"/{where}")
        elif kind == "virtual":
            layout = h5py.VirtualLayout(shape=shape, dtype=dtype)
            layout[:] = h5py.VirtualSource(str(other), f"/{where}", shape=shape)
            fh.create_virtual_dataset(where, layout)
        elif kind == "external storage":
            fh.create_dataset(where, shape=shape, dtype=dtype, external=[(str(other), 0, 1 << 20)])
        elif kind == "loop":
            fh[where] = h5py.SoftLink("/traces/loop")
            fh["traces/loop"] = h5py.SoftLink(f"/{where}")
        else:  # huge: a never-written dataset of 10^size rows
            rows = 10**size
            fh.create_dataset(
                where, shape=(rows, *shape[1:]), dtype=dtype, chunks=(min(rows, 1024), *shape[1:])
            )


def _edit(target: Path, kind: str, j: int, axis: int, size: float) -> None:
    with h5py.File(target, "a") as fh:
        g = fh["traces"]
        if kind == "position":
            pos = g["positions_m"][()]
            pos[j, axis] += 10.0**size
            g["positions_m"][...] = pos
        elif kind == "reference":
            ref = np.array(g.attrs["reference_point_m"], dtype=np.float64)
            ref[axis] += 10.0**size
            g.attrs["reference_point_m"] = ref
        elif kind == "sample":
            data = g["data"][()]
            data[j, (axis * 11) % data.shape[1]] *= 10.0 ** (1.0 + abs(size) * 5.8)
            g["data"][...] = data
        else:  # nested metadata
            depth = int(10 ** (1.0 + abs(size)))
            g.attrs["metadata"] = '{"a":' + "[" * depth + "]" * depth + "}"


mutants = st.one_of(
    st.tuples(
        st.just("flip"),
        st.tuples(
            st.lists(st.tuples(st.integers(0, 10**6), st.integers(1, 255)), min_size=1, max_size=4),
            st.booleans(),
        ),
    ),
    st.tuples(st.just("truncate"), st.floats(0.0, 0.999)),
    st.tuples(
        st.just("structure"),
        st.tuples(
            st.sampled_from([*REACHING, "loop", "soft link", "huge"]),
            st.sampled_from(DATASETS),
            st.integers(4, 9),
        ),
    ),
    st.tuples(
        st.just("edit"),
        st.tuples(
            st.sampled_from(["position", "reference", "sample", "metadata"]),
            st.integers(0, N_PULSES - 1),
            st.integers(0, 2),
            st.floats(-4.0, 5.0),
        ),
    ),
)

STATS: dict[str, dict[str, int]] = {}


@pytest.mark.slow
@seed(20261126)
@settings(
    max_examples=N_MUTANTS,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(mutant=mutants)
def test_mutated_native_files_are_refused_or_read_correctly(original, tmp_path, mutant):
    path, other, traces, quarter = original
    kind, arg = mutant
    target = tmp_path / "mutant.h5"
    raw = path.read_bytes()
    if kind == "flip":
        flips, structure = arg
        b = bytearray(raw)
        span = 4096 if structure else len(b)
        for where, xor in flips:
            b[where % span] ^= xor
        target.write_bytes(bytes(b))
    elif kind == "truncate":
        target.write_bytes(raw[: int(arg * len(raw))])
    else:
        shutil.copyfile(path, target)
        if kind == "structure":
            _structural(target, other, *arg)
        else:
            _edit(target, *arg)
    got = read_or_refuse(load_traces, target, STATS.setdefault("native", {}))
    if kind == "structure" and arg[0] in (*REACHING, "loop"):
        assert got is None, f"accepted a file that reaches outside itself: {mutant}"
    if got is None:
        return
    if kind == "structure" and arg[0] == "soft link":
        np.testing.assert_array_equal(got.data, traces.data)
    if got.n_pulses == traces.n_pulses:
        err = _differential_range(got.positions_m, got.reference_point_m) - _differential_range(
            traces.positions_m, traces.reference_point_m
        )
        assert np.max(np.abs(err - np.mean(err))) <= quarter, f"geometry accepted: {mutant}"
    peak = float(np.abs(traces.phase_history()).max())
    assert float(np.abs(got.phase_history()).max()) <= 1e3 * peak, mutant


def test_fuzz_ran_every_mutant():
    """Runs after the fuzz test in file order: all mutants were tried, some refused."""
    if not STATS:
        pytest.skip("the fuzz test did not run in this pytest run")
    assert_every_mutant_ran(STATS, N_MUTANTS)
