"""Block readers: blocks of a CPHD or native file are the full read's traces, in bounded memory."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from sarmotion.core import Radar
from sarmotion.io import (
    DataError,
    load_traces,
    open_cphd_blocks,
    open_native_blocks,
    read_cphd,
    save_traces,
    write_cphd,
)
from sarmotion.simulation import PointTarget, Scene, simulate

N_PULSES = 400
N_SAMPLES = 256


@pytest.fixture(scope="module")
def traces():
    scene = Scene(
        name="blocks",
        targets=(
            PointTarget(position_m=(3.0, -4.0)),
            PointTarget(position_m=(-10.0, 6.0), velocity_mps=(2.0, -1.0), reflectivity=0.5j),
        ),
        reference_point_m=(1.0, 2.0, 0.0),
        trajectory_spec={"kind": "circular", "n_pulses": N_PULSES, "aperture_deg": 3.0},
        radar=Radar(n_samples=N_SAMPLES, frequency_step_hz=2e6, bandwidth_hz=500e6),
    )
    return simulate(scene, snr_db=20.0, rng=2).traces


@pytest.fixture(scope="module")
def files(traces, tmp_path_factory):
    folder = tmp_path_factory.mktemp("blocks")
    return {
        "cphd": (write_cphd(folder / "t.cphd", traces), open_cphd_blocks, read_cphd),
        "native": (save_traces(folder / "t.h5", traces), open_native_blocks, load_traces),
    }


@pytest.mark.parametrize("kind", ["cphd", "native"])
@pytest.mark.parametrize("block", [1, 7, 64, N_PULSES, 10 * N_PULSES])
def test_blocks_concatenated_are_the_full_read(files, kind, block):
    path, open_blocks, read = files[kind]
    full = read(path)
    opened = open_blocks(path)
    assert opened.n_pulses == full.n_pulses
    assert opened.radar == full.radar
    assert opened.reference_point_m.dtype == np.float64 and opened.reference_point_m.shape == (3,)
    np.testing.assert_array_equal(opened.reference_point_m, full.reference_point_m)
    np.testing.assert_array_equal(opened.trajectory.positions_m, full.positions_m)
    np.testing.assert_array_equal(opened.trajectory.slow_times_s, full.slow_times_s)
    assert opened.metadata == full.metadata
    spans, parts = [], []
    for start, stop, data in opened.blocks(block):
        assert data.dtype == full.data.dtype and data.shape == (stop - start, N_SAMPLES)
        spans.append((start, stop))
        parts.append(data)
    assert spans[0][0] == 0 and spans[-1][1] == N_PULSES
    assert all(a[1] == b[0] for a, b in zip(spans[:-1], spans[1:], strict=True))
    assert all(stop - start <= block for start, stop in spans)
    np.testing.assert_array_equal(np.concatenate(parts), full.data)


@pytest.mark.parametrize("kind", ["cphd", "native"])
def test_block_memory_is_bounded_by_a_block(files, kind):
    """Peak memory of iterating blocks of 8 pulses: a few blocks, not the file."""
    path, open_blocks, _ = files[kind]
    opened = open_blocks(path)
    block = 8
    block_bytes = block * N_SAMPLES * 16
    file_bytes = N_PULSES * N_SAMPLES * 16
    tracemalloc.start()
    try:
        for _, _, data in opened.blocks(block):
            del data
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # the block, the working copies of its transform to fast time (module notes of
    # sarmotion._limits: five), the raw samples; the PVPs of the file are read on opening
    assert peak <= 8 * block_bytes + 64 * 1024, (peak, block_bytes, file_bytes)
    assert peak < file_bytes / 4


def test_block_arguments(files):
    path, open_blocks, _ = files["cphd"]
    opened = open_blocks(path)
    with pytest.raises(ValueError, match="block_pulses must be >= 1"):
        opened.blocks(0)
    with pytest.raises(TypeError, match="block_pulses must be an integer"):
        opened.blocks(2.5)


def test_cphd_truncated_in_a_block(files, tmp_path):
    path, _, _ = files["cphd"]
    copy = tmp_path / "t.cphd"
    copy.write_bytes(path.read_bytes())
    opened = open_cphd_blocks(copy)
    size = copy.stat().st_size
    blocks = opened.blocks(64)
    next(blocks)
    with copy.open("r+b") as fh:  # cut while reading: 50 vectors into the block 320:384
        fh.truncate(size - 30 * N_SAMPLES * 8)
    with pytest.raises(DataError) as info:
        for _ in blocks:
            pass
    assert "\n" not in str(info.value) and str(info.value).startswith(str(copy))
    assert "vectors 320:384 cannot be read (truncated" in str(info.value)
    with pytest.raises(DataError, match="truncated"):
        open_cphd_blocks(copy)


def test_block_open_checks_positions_before_any_signal(files, tmp_path):
    import h5py

    path, _, _ = files["native"]
    copy = tmp_path / "t.h5"
    copy.write_bytes(path.read_bytes())
    with h5py.File(copy, "a") as fh:
        fh["traces/positions_m"][5, 2] += 3.0
    with pytest.raises(DataError, match="pulse 5"):
        open_native_blocks(copy)
    assert open_native_blocks(copy, lenient=True).n_pulses == N_PULSES


def test_block_budget(files):
    from sarmotion.io import set_memory_limit

    path, open_blocks, _ = files["native"]
    opened = open_blocks(path)
    set_memory_limit(200_000)
    try:
        next(iter(opened.blocks(8)))  # 8 x 256 samples: within 200 kB with copies
        with pytest.raises(DataError, match="over the memory limit"):
            opened.blocks(N_PULSES)
    finally:
        set_memory_limit(None)
