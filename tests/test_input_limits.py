"""Inputs that look valid but are not: memory budget, confinement, malformed and implausible files.

Every test builds its input file here. The memory cases run the command line in a child
process under an address-space limit of 2 GB (``RLIMIT_AS``, as ``prlimit --as``) and
require exit status 2 with one line on stderr: the input is refused from its headers,
before the allocation it declares.
"""

from __future__ import annotations

import json
import os
import resource
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io

from gotcha_files import small_struct
from sarmotion.cli.main import run
from sarmotion.core import Radar, Traces, Trajectory
from sarmotion.io import (
    DataError,
    load_traces,
    read_cphd,
    read_gotcha,
    save_traces,
    set_memory_limit,
    write_cphd,
)
from sarmotion.simulation import PointTarget, Scene, simulate

SRC = str(Path(__file__).resolve().parents[1] / "src")
ADDRESS_SPACE = 2_000_000_000


def run_limited(args: list[str], *, timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    """``sarmotion ARGS`` in a child process limited to 2 GB of address space."""

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))

    env = {**os.environ, "PYTHONPATH": SRC, "MPLBACKEND": "Agg"}
    return subprocess.run(
        [sys.executable, "-m", "sarmotion", *args],
        preexec_fn=limit,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        check=False,
    )


def assert_refused(done: subprocess.CompletedProcess[str], *words: str) -> str:
    """Exit 2, one line on stderr naming the problem."""
    err = done.stderr.strip()
    assert done.returncode == 2, (done.returncode, err[-2000:])
    assert "\n" not in err and err.startswith("sarmotion: error: "), err
    for word in words:
        assert word in err, err
    return err


@pytest.fixture(autouse=True)
def default_limit():
    set_memory_limit(None)
    yield
    set_memory_limit(None)


@pytest.fixture(scope="module")
def traces() -> Traces:
    scene = Scene(
        name="limits",
        targets=(
            PointTarget(position_m=(3.0, -4.0)),
            PointTarget(position_m=(-10.0, 6.0), reflectivity=0.5j),
        ),
        trajectory_spec={"kind": "circular", "n_pulses": 24, "aperture_deg": 0.2},
        radar=Radar(n_samples=32, frequency_step_hz=4e6, bandwidth_hz=100e6, pulse="rect"),
    )
    return simulate(scene, snr_db=20.0, rng=5).traces


# ----------------------------------------------------------------------- .mat building
def _mat_header() -> bytes:
    text = b"MATLAB 5.0 MAT-file, written by sarmotion tests"
    return text.ljust(116, b" ") + b"\0" * 8 + struct.pack("<H", 0x0100) + b"IM"


def _compressed_zeros(name: str, n_doubles: int) -> bytes:
    """An miCOMPRESSED element holding a double (n, 1) array of zeros named ``name``."""
    raw_name = name.encode()
    padded = raw_name.ljust((len(raw_name) + 7) // 8 * 8, b"\0")
    body = (
        struct.pack("<II", 6, 8) + struct.pack("<II", 6, 0)  # array flags: mxDOUBLE
        + struct.pack("<II", 5, 8) + struct.pack("<ii", n_doubles, 1)  # dimensions
        + struct.pack("<II", 1, len(raw_name)) + padded  # name
        + struct.pack("<II", 9, 8 * n_doubles)  # real part, zeros follow
    )  # fmt: skip
    head = struct.pack("<II", 14, len(body) + 8 * n_doubles) + body
    z = zlib.compressobj(1)
    parts = [z.compress(head)]
    chunk = bytes(1 << 24)
    left = 8 * n_doubles
    while left:
        parts.append(z.compress(chunk[: min(left, len(chunk))]))
        left -= min(left, len(chunk))
    parts.append(z.flush())
    stream = b"".join(parts)
    return struct.pack("<II", 15, len(stream)) + stream


# ------------------------------------------------------------------- memory: .mat files
def test_mat_variables_other_than_data_are_not_inflated(tmp_path):
    """A valid ``data`` beside three compressed 1 GB arrays: read within 2 GB."""
    good = tmp_path / "good.mat"
    scipy.io.savemat(good, {"data": small_struct(24, 32, az0_deg=0.3, seed=3)})
    bomb = tmp_path / "bomb.mat"
    junk = b"".join(_compressed_zeros(f"junk{k}", 1 << 27) for k in range(3))
    bomb.write_bytes(good.read_bytes() + junk)
    assert bomb.stat().st_size < 20e6
    done = run_limited(["convert", str(bomb), "--to", "h5", "--out", str(tmp_path / "o.h5")])
    assert done.returncode == 0, done.stderr[-2000:]
    np.testing.assert_array_equal(load_traces(tmp_path / "o.h5").data, read_gotcha(good).data)


def test_mat_data_that_inflates_beyond_the_limit_is_refused(tmp_path):
    """``data`` itself a zlib stream of 3 GB of zeros: refused while inflating it."""
    bomb = tmp_path / "bomb.mat"
    bomb.write_bytes(_mat_header() + _compressed_zeros("data", 3 << 27))
    done = run_limited(["convert", str(bomb), "--to", "h5", "--out", str(tmp_path / "o.h5")])
    assert_refused(done, "bomb.mat", "memory limit")
    assert not (tmp_path / "o.h5").exists()


def test_mat_budget_counts_every_file(tmp_path):
    for k in range(2):
        scipy.io.savemat(
            tmp_path / f"f{k}.mat",
            {"data": small_struct(24, 32, az0_deg=0.3 + k * 24 * 0.00853, seed=3)},
        )
    files = [tmp_path / "f0.mat", tmp_path / "f1.mat"]
    assert read_gotcha(files).n_pulses == 48
    set_memory_limit(2 * 24 * 32 * 16 * 5)  # the working copies of one file's pulses
    with pytest.raises(DataError, match=r"f0\.mat \.\. f1\.mat: reading it would allocate"):
        read_gotcha(files)


# ---------------------------------------------------------------- memory: native files
def test_never_written_huge_native_dataset_is_refused(tmp_path, traces):
    """A few kB of HDF5 declaring 10^6 pulses of 424 samples."""
    path = save_traces(tmp_path / "t.h5", traces)
    with h5py.File(path, "a") as fh:
        g = fh["traces"]
        for name in ("data", "positions_m", "slow_times_s"):
            del g[name]
        g.create_dataset("data", shape=(10**6, 424), dtype=np.complex64, chunks=(64, 424))
        g.create_dataset("positions_m", shape=(10**6, 3), dtype=np.float64, chunks=(4096, 3))
        g.create_dataset("slow_times_s", shape=(10**6,), dtype=np.float64, chunks=(4096,))
        g.attrs["n_samples"] = 424
    assert path.stat().st_size < 100_000
    done = run_limited(["convert", str(path), "--to", "cphd", "--out", str(tmp_path / "o.cphd")])
    assert_refused(done, "t.h5", "memory limit", "1000000 x 424")


def test_plausible_track_with_huge_compressed_data_is_refused_by_image(tmp_path):
    """10^5 pulses on a smooth track, 4096 samples of unwritten gzip chunks (3.3 GB)."""
    n, m = 10**5, 4096
    traj = Trajectory.circular(n_pulses=n, pulses_per_deg=1000.0)
    path = tmp_path / "big.h5"
    with h5py.File(path, "w") as fh:
        fh.attrs["schema"] = "sarmotion.traces/1"
        g = fh.create_group("traces")
        d = g.create_dataset(
            "data", shape=(n, m), dtype=np.complex64, chunks=(256, m), compression="gzip"
        )
        d[:256] = 1.0
        g.create_dataset("positions_m", data=traj.positions_m)
        g.create_dataset("slow_times_s", data=traj.slow_times_s)
        radar = Radar(n_samples=m, frequency_step_hz=1e5, bandwidth_hz=m * 1e5)
        for key in ("carrier_hz", "bandwidth_hz", "frequency_step_hz"):
            g.attrs[key] = float(getattr(radar, key))
        g.attrs["n_samples"] = m
        g.attrs["pulse"] = "rect"
        g.attrs["reference_point_m"] = np.zeros(3)
        g.attrs["metadata"] = "{}"
    assert path.stat().st_size < 20e6
    done = run_limited(["image", str(path), "--out", str(tmp_path / "img")])
    assert_refused(done, "big.h5", "memory limit")
    assert not (tmp_path / "img").exists()


# ------------------------------------------------------------------ memory: CPHD files
def _sparse_cphd(original: Path, target: Path, n_vectors: int, n_samples: int) -> None:
    """``original`` declaring ``n_vectors x n_samples``: header and XML, the rest a hole."""
    import copy

    import lxml.etree
    import sarkit.cphd as skcphd

    with original.open("rb") as fh:
        reader = skcphd.Reader(fh)
        xml = copy.deepcopy(reader.metadata.xmltree)
        pvp_dtype = reader.read_pvps("1").dtype
    for e in xml.getroot().iter():
        name = lxml.etree.QName(e).localname
        if name in ("NumVectors", "NumSamples"):
            e.text = str(n_vectors if name == "NumVectors" else n_samples)
    full = target.with_suffix(".full")
    with full.open("wb") as fh:
        writer = skcphd.Writer(fh, skcphd.Metadata(xmltree=xml))
        writer.write_pvp("1", np.zeros(n_vectors, pvp_dtype))
    _, kvp = skcphd.read_file_header(full.open("rb"))
    end = int(kvp["SIGNAL_BLOCK_BYTE_OFFSET"]) + int(kvp["SIGNAL_BLOCK_SIZE"])
    with full.open("rb") as src, target.open("wb") as dst:
        dst.write(src.read(int(kvp["PVP_BLOCK_BYTE_OFFSET"])))
        dst.truncate(end)
    full.unlink()


def test_sparse_cphd_declaring_200000_vectors_is_refused(tmp_path, traces):
    small = write_cphd(tmp_path / "small.cphd", traces)
    sparse = tmp_path / "sparse.cphd"
    _sparse_cphd(small, sparse, 200_000, 424)
    assert os.stat(sparse).st_blocks * 512 < 1e6  # a hole, not data
    done = run_limited(["convert", str(sparse), "--to", "h5", "--out", str(tmp_path / "o.h5")])
    assert_refused(done, "sparse.cphd", "memory limit", "200000 x 424")


# ------------------------------------------------------------------ memory: scene files
def test_scene_with_10_to_8_pulses_is_refused(tmp_path):
    scene = tmp_path / "big.toml"
    scene.write_text("[trajectory]\nn_pulses = 100000000\n[[targets]]\nposition_m = [0.0, 0.0]\n")
    assert scene.stat().st_size < 200
    done = run_limited(["simulate", str(scene), "--out", str(tmp_path / "o.h5")])
    assert_refused(done, "big.toml", "100000000 pulses")


def test_scene_work_is_limited(tmp_path):
    """pulses x samples x targets beyond 1e10 is refused at once, not simulated for minutes."""
    targets = "".join(f"[[targets]]\nposition_m = [{k % 50}.0, {k // 50}.0]\n" for k in range(1200))
    scene = tmp_path / "many.toml"
    scene.write_text("[trajectory]\nn_pulses = 20000\n" + targets)
    done = run_limited(["simulate", str(scene), "--out", str(tmp_path / "o.h5")], timeout=60)
    assert_refused(done, "many.toml", "20000 pulses x 424 samples x 1200 targets")


def test_max_memory_option(tmp_path, traces, capsys):
    path = save_traces(tmp_path / "t.h5", traces)
    out = tmp_path / "o.h5"
    assert run(["--max-memory", "10k", "convert", str(path), "--to", "h5", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "over the memory limit of 10 kB" in err, err
    assert run(["convert", str(path), "--to", "h5", "--out", str(out), "--max-memory", "1M"]) == 0
    assert run(["--max-memory", "lots", "convert", str(path), "--to", "h5", "--out", "x"]) == 2
    assert "--max-memory" in capsys.readouterr().err


# ----------------------------------------------------------------- HDF5 confinement
@pytest.fixture
def secret(tmp_path):
    """A file of another user's, whose bytes must not reach any output."""
    path = tmp_path / "secret.bin"
    rng = np.random.default_rng(7)
    path.write_bytes(rng.standard_normal(24 * 32 * 2).astype(np.float64).tobytes())
    return path


def _replace(path: Path, name: str, make) -> None:
    with h5py.File(path, "a") as fh:
        del fh[name]
        make(fh, name)


@pytest.mark.parametrize("kind", ["external link", "virtual", "external storage"])
def test_hdf5_that_reaches_other_files_is_refused(tmp_path, traces, secret, kind, capsys):
    path = save_traces(tmp_path / "t.h5", traces)
    other = save_traces(tmp_path / "other.h5", traces)
    shape = traces.data.shape
    if kind == "external link":
        _replace(path, "traces/data", lambda f, n: f.__setitem__(n, h5py.ExternalLink(
            str(other), "/traces/data")))  # fmt: skip
    elif kind == "virtual":
        layout = h5py.VirtualLayout(shape=shape, dtype=traces.data.dtype)
        layout[:] = h5py.VirtualSource(str(other), "/traces/data", shape=shape)
        _replace(path, "traces/data", lambda f, n: f.create_virtual_dataset(n, layout))
    else:
        _replace(
            path,
            "traces/data",
            lambda f, n: f.create_dataset(
                n, shape=shape, dtype=np.complex128, external=[(str(secret), 0, h5py.h5f.UNLIMITED)]
            ),
        )
    with pytest.raises(DataError, match="reads no file but the one given"):
        load_traces(path, lenient=True)
    out = tmp_path / "o.h5"
    assert run(["convert", str(path), "--to", "h5", "--out", str(out), "--lenient"]) == 2
    assert "reads no file but the one given" in capsys.readouterr().err
    assert not out.exists()


def test_hdf5_soft_link_loop_is_refused(tmp_path, traces, capsys):
    path = save_traces(tmp_path / "t.h5", traces)
    with h5py.File(path, "a") as fh:
        del fh["traces/data"]
        fh["traces/data"] = h5py.SoftLink("/traces/other")
        fh["traces/other"] = h5py.SoftLink("/traces/data")
    assert run(["convert", str(path), "--to", "h5", "--out", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "soft link" in err and "does not resolve" in err, err


def test_hdf5_soft_link_inside_the_file_is_followed(tmp_path, traces):
    path = save_traces(tmp_path / "t.h5", traces)
    with h5py.File(path, "a") as fh:
        fh.move("traces/data", "stored")
        fh["traces/data"] = h5py.SoftLink("/stored")
    np.testing.assert_array_equal(load_traces(path).data, traces.data)


# ----------------------------------------------------------------- malformed inputs
@pytest.mark.parametrize(
    ("field", "value"),
    [("NumVectors", 25), ("NumVectors", 20), ("NumSamples", 33), ("NumSamples", 31)],
)
def test_cphd_counts_that_disagree_with_the_file(tmp_path, traces, field, value, capsys):
    path = write_cphd(tmp_path / "t.cphd", traces)
    raw = path.read_bytes()
    old = {"NumVectors": 24, "NumSamples": 32}[field]
    tag = f"<{field}>{old}</{field}>".encode()
    assert raw.count(tag) == 1
    bad = tmp_path / "bad.cphd"
    bad.write_bytes(raw.replace(tag, f"<{field}>{value}</{field}>".encode()))
    assert run(["convert", str(bad), "--to", "h5", "--out", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "disagree with the file" in err, err


def test_cphd_channel_identifier_with_a_quote(tmp_path, traces, capsys):
    path = write_cphd(tmp_path / "t.cphd", traces)
    raw = path.read_bytes()
    raw = raw.replace(b"<Identifier>1</Identifier>", b"<Identifier>'</Identifier>", 1)
    raw = raw.replace(b"<RefChId>1</RefChId>", b"<RefChId>'</RefChId>")  # same length
    bad = tmp_path / "quote.cphd"
    bad.write_bytes(raw)
    assert run(["convert", str(bad), "--to", "h5", "--out", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "contains a quote" in err, err


def test_deeply_nested_json_metadata(tmp_path, traces, capsys):
    path = save_traces(tmp_path / "t.h5", traces)
    with h5py.File(path, "a") as fh:
        fh["traces"].attrs["metadata"] = '{"a":' + "[" * 100_000 + "]" * 100_000 + "}"
    assert run(["convert", str(path), "--to", "h5", "--out", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "nests JSON too deeply" in err, err


def test_deeply_nested_json_in_cphd_parameters(tmp_path, traces):
    padded = Traces(
        data=traces.data,
        trajectory=traces.trajectory,
        radar=traces.radar,
        reference_point_m=traces.reference_point_m,
        metadata={"pad": "x" * 20_000},
    )
    raw = write_cphd(tmp_path / "t.cphd", padded).read_bytes()
    start = raw.index(b'name="sarmotion.metadata">') + len(b'name="sarmotion.metadata">')
    end = raw.index(b"</Parameter>", start)
    half = (end - start) // 2
    nested = (b"[" * half + b"]" * half).ljust(end - start)  # same length: same offsets
    bad = tmp_path / "nested.cphd"
    bad.write_bytes(raw[:start] + nested + raw[end:])
    with pytest.raises(DataError, match="sarmotion.metadata is not valid JSON"):
        read_cphd(bad)


def _zero_traces(traces: Traces, value: complex) -> Traces:
    ph = np.full(traces.shape, value, dtype=np.complex128)
    return Traces.from_phase_history(
        ph,
        trajectory=traces.trajectory,
        radar=traces.radar,
        reference_point_m=traces.reference_point_m,
    )


def _written(kind: str, traces: Traces, tmp_path: Path) -> list[Path]:
    if kind == "native":
        return [save_traces(tmp_path / "t.h5", traces)]
    if kind == "cphd":
        return [write_cphd(tmp_path / "t.cphd", traces)]
    from sarmotion.io import write_gotcha

    return write_gotcha(traces, tmp_path / "g")


@pytest.mark.parametrize("kind", ["native", "cphd", "gotcha"])
def test_all_zero_phase_history_is_refused_by_every_reader(tmp_path, traces, kind, capsys):
    files = _written(kind, _zero_traces(traces, 0.0), tmp_path)
    args = ["image", *map(str, files), "--out", str(tmp_path / "img"), "--lenient"]
    assert run(args) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "every sample is zero" in err, err
    assert not (tmp_path / "img").exists()


@pytest.mark.parametrize("kind", ["native", "cphd", "gotcha"])
def test_constant_phase_history_is_refused_by_every_reader(tmp_path, traces, kind, capsys):
    files = _written(kind, _zero_traces(traces, 0.3 - 0.4j), tmp_path)
    args = ["convert", *map(str, files), "--to", "h5", "--out", str(tmp_path / "o.h5")]
    assert run(args) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "every sample equals" in err, err
    assert run([*args, "--lenient"]) == 0  # a reflector at the reference point, leniently


@pytest.mark.parametrize("command", ["image", "separate"])
def test_size_1e308(tmp_path, traces, command, capsys):
    path = save_traces(tmp_path / "t.h5", traces)
    args = [command, str(path), "--out", str(tmp_path / "o"), "--size", "1e308"]
    assert run([*args, "--spacing", "1e306"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--size" in err, err


# ------------------------------------------------------------------- plausibility gaps
def _with(traces: Traces, *, positions=None, times=None, ref=None) -> Traces:
    traj = Trajectory(
        positions_m=traces.positions_m if positions is None else positions,
        slow_times_s=traces.slow_times_s if times is None else times,
    )
    return Traces(
        data=traces.data,
        trajectory=traj,
        radar=traces.radar,
        reference_point_m=traces.reference_point_m if ref is None else ref,
    )


@pytest.mark.parametrize("factor", [1e-6, 1e12])
def test_native_slow_times_imply_a_physical_speed(tmp_path, traces, factor):
    """Times scaled so that the platform flies at 7e-5 or 7e13 m/s."""
    path = save_traces(tmp_path / "t.h5", _with(traces, times=traces.slow_times_s / factor))
    with pytest.raises(DataError, match=r"platform speed of .* \(rule: 0\.001 to 10000 m/s"):
        load_traces(path)
    assert load_traces(path, lenient=True).n_pulses == traces.n_pulses


def test_native_reference_point_far_from_the_scene(tmp_path, traces):
    moved = traces.reference_point_m + np.array([1e5, 0.0, 0.0])
    path = save_traces(tmp_path / "t.h5", _with(traces, ref=moved))
    with pytest.raises(DataError, match=r"grazing angle of .* \(rule: at least 5 deg"):
        load_traces(path)
    near = traces.reference_point_m + np.array([30.0, -20.0, 0.0])  # in the scene
    load_traces(save_traces(tmp_path / "near.h5", _with(traces, ref=near)))


def test_gotcha_jump_across_files_is_refused(tmp_path, capsys):
    a = small_struct(24, 32, az0_deg=0.3, seed=3)
    b = small_struct(24, 32, az0_deg=0.3 + 24 * 0.00853, seed=4)
    scipy.io.savemat(tmp_path / "a.mat", {"data": a})
    scipy.io.savemat(tmp_path / "b.mat", {"data": b})
    files = [tmp_path / "a.mat", tmp_path / "b.mat"]
    assert read_gotcha(files).n_pulses == 48  # consecutive files join
    shifted = dict(b)
    shifted["z"] = b["z"] + np.float32(1.0)  # the whole second file 1 m higher
    r = np.sqrt(b["x"].astype(np.float64) ** 2 + b["y"] ** 2 + shifted["z"].astype(np.float64) ** 2)
    shifted["r0"] = r.astype(np.float32)
    shifted["phi"] = np.rad2deg(
        np.arctan2(shifted["z"].astype(np.float64), np.hypot(b["x"], b["y"]))
    ).astype(np.float32)
    scipy.io.savemat(tmp_path / "b.mat", {"data": shifted})
    read_gotcha(tmp_path / "b.mat")  # plausible on its own
    with pytest.raises(DataError, match=r"b\.mat: .*does not continue that of a\.mat"):
        read_gotcha(files)
    assert run(["convert", *map(str, files), "--to", "h5", "--out", str(tmp_path / "o.h5")]) == 2
    assert "does not continue" in capsys.readouterr().err


# ------------------------------------------------------------------------ the Python API
def test_api_arguments_are_checked(tmp_path, traces):
    from sarmotion import analyze

    with pytest.raises(TypeError, match="options must be an AnalysisOptions"):
        analyze(traces, {"separation": "rpca"})
    with pytest.raises(TypeError, match="paths must be a path"):
        read_gotcha(b"data.mat")
    with pytest.raises(TypeError, match="paths must be a path"):
        read_gotcha([b"a.mat", b"b.mat"])
    path = save_traces(tmp_path / "t.h5", traces)
    with pytest.raises(TypeError, match="lenient must be True or False"):
        load_traces(path, lenient="no")
    with pytest.raises(ValueError, match=r"speed_mps must be within \[0\.001, 10000\]"):
        read_gotcha(tmp_path / "none.mat", speed_mps=1e9)


def test_api_reads_native_files_as_the_command_line_does(tmp_path, traces, monkeypatch):
    """load_traces runs the child-process guard against HDF5 library loops itself."""
    from sarmotion.io import native

    path = save_traces(tmp_path / "t.h5", traces)
    monkeypatch.setattr(native, "_WALK", "import time; time.sleep(30)")
    with pytest.raises(DataError, match="reading it did not finish"):
        native.check_hdf5_terminates(path, timeout_s=1.0)
    monkeypatch.setattr(native, "check_hdf5_terminates", _refuse)
    with pytest.raises(DataError, match="checked"):
        load_traces(path, lenient=True)


def _refuse(path, **kwargs):
    raise DataError(f"{path}: checked")


# ---------------------------------------------------------------------------- roads
def _roads(tmp_path: Path, doc, *, prefix: bytes = b"") -> Path:
    path = tmp_path / "roads.geojson"
    path.write_bytes(prefix + (doc if isinstance(doc, bytes) else json.dumps(doc).encode()))
    return path


def _line(points, **extra):
    return {"type": "Feature", "geometry": {"type": "LineString", "coordinates": points}, **extra}


def test_roads_beyond_the_range_envelope_are_refused(tmp_path):
    from sarmotion.documents import read_roads

    path = _roads(tmp_path, _line([[-1e308, 0.0], [1e308, 10.0]]))
    with pytest.raises(DataError, match=r"roads\.geojson: feature 1: .*beyond 2e\+06 m"):
        read_roads(path)


def test_roads_with_a_crs_or_in_degrees_are_refused_with_advice(tmp_path):
    from sarmotion.documents import read_roads

    crs = {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32617"}}
    doc = {"type": "FeatureCollection", "crs": crs, "features": [_line([[0, 0], [50, 0]])]}
    with pytest.raises(DataError, match="'crs' member.*convert them"):
        read_roads(_roads(tmp_path, doc))
    dayton = _line([[-84.0512, 39.7801], [-84.0498, 39.7809]])  # a 150 m road, in degrees
    with pytest.raises(DataError, match="like longitude/latitude in degrees"):
        read_roads(_roads(tmp_path, dayton))


def test_roads_with_a_byte_order_mark_are_read(tmp_path):
    from sarmotion.documents import read_roads

    roads = read_roads(_roads(tmp_path, _line([[0, 0], [50, 5]]), prefix=b"\xef\xbb\xbf"))
    np.testing.assert_array_equal(roads[0].points_m, [[0, 0], [50, 5]])


def test_road_count_and_nesting_are_limited(tmp_path):
    from sarmotion.documents import read_roads
    from sarmotion.documents.roads import MAX_ROADS

    many = {
        "type": "FeatureCollection",
        "features": [_line([[k, 0.0], [k, 10.0]]) for k in range(MAX_ROADS + 1)],
    }
    with pytest.raises(DataError, match=f"more than {MAX_ROADS} roads"):
        read_roads(_roads(tmp_path, many))
    nested = b'{"type": "LineString", "coordinates": ' + b"[" * 100_000 + b"]" * 100_000 + b"}"
    with pytest.raises(DataError, match="nested too deeply"):
        read_roads(_roads(tmp_path, nested))


def test_scene_file_size_is_limited_before_parsing(tmp_path, capsys):
    from sarmotion.simulation.scene import MAX_SCENE_FILE_BYTES

    scene = tmp_path / "huge.toml"
    line = b"[[targets]]\nposition_m = [1.0, 2.0]\n"
    scene.write_bytes(line * (MAX_SCENE_FILE_BYTES // len(line) + 1))
    assert run(["simulate", str(scene), "--out", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "a scene file holds at most" in err, err
