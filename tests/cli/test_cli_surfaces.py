"""The newer surfaces refused as the older ones: one line, exit status 2, nothing left, no hang.

Collection options (``--workers``, ``--max-speed``, ``--size``) on ``analyze`` of a CPHD
file larger than one patch and on ``track``; scheduler addresses (malformed, a loopback
peer that accepts and never answers, a scheduler without workers); data near float32's
largest value; ``--origin`` values off the Earth's surface; ``--max-memory`` beyond the
machine and an allocation that fails; ``--sicd`` on an analysis cut into patches;
non-finite numbers in JSON documents; output paths whose staging cannot work (a mount
point, a name too long, a lock file that is a FIFO, a full disk); scratch directories of
killed runs; Ctrl-C on worker processes.
"""

from __future__ import annotations

import errno
import json
import math
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from gotcha_files import small_struct
from sarmotion.cli.main import EXIT_BAD_INPUT, run

ROOT = Path(__file__).resolve().parents[2]
#: Longest a refusal may take (s), start-up of the command included.
REFUSAL_S = 10.0


def _refused(args, capsys, pattern, out=None, *, within_s=REFUSAL_S):
    """Run ``args`` in-process: exit 2, one line naming ``pattern``, no ``out``, in time.

    With ``-q``: no progress lines, so that stderr holds the refusal alone.
    """
    t0 = time.monotonic()
    code = run(["-q", *args])
    took = time.monotonic() - t0
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT, err
    assert len(err.splitlines()) == 1 and err.startswith("sarmotion: error:"), err
    assert pattern in err, err
    assert "Traceback" not in err
    assert took < within_s, f"refused after {took:.1f} s"
    if out is not None:
        out = Path(out)
        assert not out.exists(), "a refused command left its output"
        assert not list(out.parent.glob(f".{out.name}.*")), list(out.parent.iterdir())
    return err


@pytest.fixture(scope="module", autouse=True)
def _commands_loaded():
    """The commands' modules imported once (numba's and scipy's load is not the command's)."""
    import importlib

    for name in ("analyze", "convert", "image", "track"):
        importlib.import_module(f"sarmotion.cli.{name}")
    importlib.import_module("distributed")


# ------------------------------------------------------------------ inputs
@pytest.fixture(scope="module")
def cphd(tmp_path_factory) -> Path:
    """A simulated collection larger than one patch, as CPHD."""
    from sarmotion.collection import CollectionOptions, plan_patches
    from sarmotion.io import open_cphd_blocks, write_cphd_blocks
    from sarmotion.simulation import collection_acquisition, random_collection

    acq = collection_acquisition(150.0)
    scene = random_collection(acq, 150.0, seed=31, n_movers=1, snr_db=-20.0)
    path = tmp_path_factory.mktemp("surfaces") / "scene.cphd"
    write_cphd_blocks(path, scene, block_pulses=50)
    assert len(plan_patches(open_cphd_blocks(path), CollectionOptions()).patches) > 1
    return path


@pytest.fixture
def gotcha(tmp_path) -> Path:
    """A small valid GOTCHA file."""
    path = tmp_path / "small.mat"
    scipy.io.savemat(path, {"data": small_struct(24, 32, az0_deg=0.3, seed=3)})
    return path


def _worker_limit() -> int:
    from sarmotion._cluster import MAX_WORKERS_PER_CORE

    return MAX_WORKERS_PER_CORE * (os.cpu_count() or 1)


# ------------------------------------------------------------------ collection options
@pytest.mark.parametrize("value", ["-1", "LIMIT+1", "1000"])
def test_workers_refused_by_the_same_rule_in_analyze_and_track(cphd, tmp_path, capsys, value):
    value = str(_worker_limit() + 1) if value == "LIMIT+1" else value
    messages = set()
    for cmd in (["analyze", str(cphd)], ["track", "hyperbola", "--size", "20"]):
        out = tmp_path / "out"
        err = _refused([*cmd, "--out", str(out), "--workers", value], capsys, "--workers", out)
        messages.add(err)
    rule = f"--workers must be within [0, {_worker_limit()}]"
    assert len(messages) == 1 and rule in messages.pop()


@pytest.mark.parametrize("value", ["1e30", "inf", "nan", "0", "-5", "343.001"])
def test_max_speed_beyond_a_ground_speed(cphd, tmp_path, capsys, value):
    out = tmp_path / "out"
    args = ["analyze", str(cphd), "--out", str(out), "--max-speed", value]
    _refused(args, capsys, "--max-speed must be within (0, 343] m/s", out)


def test_max_speed_bound_is_the_speed_of_sound():
    """Within the bound passes as given; just above it does not."""
    from sarmotion.cli.common import MAX_GROUND_SPEED_MPS, max_speed_callback
    from sarmotion.errors import InputError

    # the speed of sound in dry air at 20 degC: sqrt(gamma R T / M)
    sound = math.sqrt(1.4 * 8.314462618 * 293.15 / 0.0289647)
    assert abs(MAX_GROUND_SPEED_MPS - sound) < 0.5
    assert max_speed_callback(None, None, MAX_GROUND_SPEED_MPS) == MAX_GROUND_SPEED_MPS
    with pytest.raises(InputError):
        max_speed_callback(None, None, np.nextafter(MAX_GROUND_SPEED_MPS, np.inf))


@pytest.mark.parametrize("value", ["1e308", "1025", "inf"])
def test_size_beyond_the_pixel_limit(cphd, tmp_path, capsys, value):
    """4096 pixels a side at the analysis's 0.25 m pixels: 1024 m."""
    for cmd in (["analyze", str(cphd)], ["track", "hyperbola"]):
        out = tmp_path / "out"
        _refused([*cmd, "--out", str(out), "--size", value], capsys, "--size", out)


def test_usage_errors_are_one_line(tmp_path, capsys):
    out = tmp_path / "out"
    _refused(["analyze", "x", "--out", str(out), "--workers", "2.5"], capsys, "'--workers'")
    _refused(["analyze", "x", "--out", str(out), "--wrkers", "2"], capsys, "--workers")
    _refused(["analyz"], capsys, "No such command")


# ------------------------------------------------------------------ scheduler addresses
BAD_ADDRESSES = [
    ("inproc://nothing", "inproc://"),
    ("tls://127.0.0.1:1", "tls:// needs the certificates"),
    ("ucx://127.0.0.1:1", "scheme 'ucx' is not supported"),
    ("file:///etc/passwd", "scheme 'file' is not supported"),
    ("", "empty"),
    ("garbage\x00\xff:%%", "not an address"),
    ("tcp://127.0.0.1:0", "the port must be a number within [1, 65535]"),
    ("tcp://127.0.0.1:65536", "the port must be"),
    ("tcp://999.0.0.1:8786", "not an IPv4 address"),
    ("tcp://[::g]:8786", "not an IPv6 address"),
    ("tcp://a..b:8786", "not a host name"),
    ("tcp://host:8786/path", "the port must be"),
    ("tcp://127.0.0.1", "no host:port"),
    ("tcp:// 127.0.0.1:8786", "holds a space"),
]


@pytest.mark.parametrize(("address", "pattern"), BAD_ADDRESSES)
def test_malformed_scheduler_addresses(cphd, tmp_path, capsys, address, pattern):
    """Refused from the address alone, whatever the input's size (one patch too)."""
    for cmd in (["analyze", str(cphd)], ["analyze", "hyperbola"], ["track", "hyperbola"]):
        out = tmp_path / "out"
        err = _refused([*cmd, "--out", str(out), "--scheduler", address], capsys, pattern, out)
        assert err.startswith("sarmotion: error: --scheduler")


@pytest.fixture
def silent_peer():
    """A loopback listener that accepts connections and never answers; its address."""
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.bind(("127.0.0.1", 0))
    server.listen(16)
    held: list[socket.socket] = []
    stop = threading.Event()

    def accept():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            held.append(conn)  # kept open, never read nor written

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}", held
    finally:
        stop.set()
        thread.join(5)
        for c in held:
            c.close()
        server.close()


def test_a_peer_that_never_answers_does_not_hang(cphd, tmp_path, capsys, silent_peer):
    address, held = silent_peer
    for cmd in (["analyze", str(cphd)], ["analyze", "hyperbola"], ["track", "hyperbola"]):
        out = tmp_path / "out"
        args = [*cmd, "--out", str(out), "--scheduler", address]
        _refused(args, capsys, f"--scheduler {address}: no Dask scheduler answered", out)
    assert held, "the command never reached the listener"


def test_a_closed_port_is_refused_at_once(tmp_path, capsys):
    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()  # nothing listens there now
    out = tmp_path / "out"
    args = ["track", "hyperbola", "--out", str(out), "--scheduler", f"tcp://127.0.0.1:{port}"]
    _refused(args, capsys, "Connection refused", out)


def test_a_scheduler_without_workers_is_refused_after_the_wait(cphd, tmp_path, capsys, monkeypatch):
    distributed = pytest.importorskip("distributed")
    import sarmotion._cluster as cluster_module

    monkeypatch.setattr(cluster_module, "WORKER_WAIT_S", 1.0)
    with distributed.LocalCluster(
        n_workers=0, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None
    ) as cluster:
        address = cluster.scheduler_address
        for cmd in (["analyze", str(cphd)], ["track", "hyperbola"]):
            out = tmp_path / "out"
            t0 = time.monotonic()
            args = [*cmd, "--out", str(out), "--scheduler", address]
            _refused(
                args, capsys, f"--scheduler {address}: the scheduler has no worker after 1 s", out
            )
            assert time.monotonic() - t0 >= 1.0  # it waited the stated time
        # with a worker the same address is accepted
        cluster.scale(1)
        with cluster_module.connect_scheduler(address) as client:
            assert client.submit(sum, [1, 2], pure=False).result(timeout=30) == 3


def test_the_library_refuses_a_silent_scheduler_too(silent_peer):
    from sarmotion._cluster import SchedulerError, connect_scheduler
    from sarmotion.errors import InputError

    address, _ = silent_peer
    t0 = time.monotonic()
    with pytest.raises(SchedulerError, match="no Dask scheduler answered") as info:
        with connect_scheduler(address, connect_timeout_s=1.0):
            pass
    assert time.monotonic() - t0 < 3.0
    assert isinstance(info.value, InputError)


# ------------------------------------------------------------------ extreme data
def _scaled_gotcha(path: Path, total: float) -> Path:
    """The small GOTCHA file with its samples scaled so that sum |P| = ``total``."""
    s = small_struct(24, 32, az0_deg=0.3, seed=3)
    fp = s["fp"].astype(np.complex128)
    s["fp"] = (fp * (total / np.abs(fp).sum())).astype(np.complex64)
    scipy.io.savemat(path, {"data": s})
    return path


def test_data_near_the_float32_range_is_refused(tmp_path, capsys):
    """Samples near float32's largest value: refused by the readers' rule, leniently too."""
    from sarmotion.io import read_gotcha
    from sarmotion.io.plausibility import MAX_COHERENT_SUM

    s = small_struct(24, 32, az0_deg=0.3, seed=3)
    fp = s["fp"]
    s["fp"] = (fp / np.abs(fp).max() * 3.4e38).astype(np.complex64)
    assert np.all(np.isfinite(s["fp"]))
    huge = tmp_path / "huge.mat"
    scipy.io.savemat(huge, {"data": s})
    for cmd in (["image"], ["analyze"], ["analyze", "--lenient"]):
        out = tmp_path / "out"
        _refused(
            [cmd[0], str(huge), "--out", str(out), *cmd[1:]],
            capsys,
            "overflow single precision",
            out,
        )
    # the bound: sqrt(float32 max); twice below it is read, just above it is not
    assert MAX_COHERENT_SUM == pytest.approx(math.sqrt(float(np.finfo(np.float32).max)))
    read_gotcha(_scaled_gotcha(tmp_path / "under.mat", 0.5 * MAX_COHERENT_SUM))
    with pytest.raises(ValueError, match="overflow single precision"):
        read_gotcha(_scaled_gotcha(tmp_path / "over.mat", 1.01 * MAX_COHERENT_SUM))


def test_huge_cphd_refused_by_the_block_reader(cphd, tmp_path, capsys):
    """A collection read block by block: the running sum is checked block by block."""
    from sarmotion.io import read_cphd, write_cphd
    from sarmotion.io.plausibility import MAX_COHERENT_SUM

    traces = read_cphd(cphd)
    ph = traces.phase_history()
    scale = 1e37 / np.abs(ph).max()
    assert np.abs(ph).sum() * scale > MAX_COHERENT_SUM
    big = tmp_path / "big.cphd"
    write_cphd(big, traces.with_data(traces.data * scale))
    out = tmp_path / "out"
    args = ["analyze", str(big), "--out", str(out), "--workers", "0"]
    _refused(args, capsys, "overflow single precision", out, within_s=60.0)


# ------------------------------------------------------------------ --origin
@pytest.mark.parametrize(
    ("origin", "pattern"),
    [
        (["91", "0", "0"], "latitude must be within [-90, 90]"),
        (["nan", "0", "0"], "latitude must be within [-90, 90]"),
        (["0", "1e30", "0"], "longitude must be within [-180, 360)"),
        (["0", "360", "0"], "longitude must be within [-180, 360)"),
        (["0", "0", "1e30"], "height must be within [-1000, 10000] m"),
        (["0", "0", "-1e7"], "height must be within [-1000, 10000] m"),
        (["0", "0", "inf"], "height must be within"),
    ],
)
def test_origin_off_the_earth_is_refused_by_every_command(
    gotcha, tmp_path, capsys, origin, pattern
):
    out = tmp_path / "x.cphd"
    args = ["convert", str(gotcha), "--to", "cphd", "--out", str(out), "--origin", *origin]
    _refused(args, capsys, f"--origin {pattern}", out)
    out = tmp_path / "img"
    sicd = tmp_path / "img.nitf"
    args = ["image", str(gotcha), "--out", str(out), "--sicd", str(sicd), "--origin", *origin]
    _refused(args, capsys, f"--origin {pattern}", out)
    assert not sicd.exists()


def test_origin_rule_of_the_writers():
    from sarmotion._validation import HAE_RANGE_M, geodetic_origin

    assert list(geodetic_origin((45, -180, HAE_RANGE_M[0]), "o")) == [45.0, -180.0, -1000.0]
    assert list(geodetic_origin((-90, 359.5, HAE_RANGE_M[1]), "o")) == [-90.0, 359.5, 10000.0]
    # the Dead Sea shore and Everest lie inside; a satellite's altitude does not
    assert HAE_RANGE_M[0] < -430.0 - 110.0 and HAE_RANGE_M[1] > 8849.0 + 110.0
    with pytest.raises(ValueError, match="height"):
        geodetic_origin((0, 0, 400e3), "o")


# ------------------------------------------------------------------ memory
def test_max_memory_beyond_the_machine(gotcha, tmp_path, capsys):
    from sarmotion._limits import available_memory

    beyond = str(2 * available_memory())
    out = tmp_path / "x.h5"
    for args in (
        ["--max-memory", beyond, "convert", str(gotcha), "--to", "h5", "--out", str(out)],
        ["convert", str(gotcha), "--to", "h5", "--out", str(out), "--max-memory", beyond],
    ):
        _refused(args, capsys, "is beyond this machine's usable memory", out)
    # within the machine it is a limit, as before
    assert run(["convert", str(gotcha), "--to", "h5", "--out", str(out), "--max-memory", "1G"]) == 0


def test_a_failed_allocation_is_one_line_naming_max_memory(gotcha, tmp_path, capsys, monkeypatch):
    import sarmotion.cli.convert as convert

    def allocate(*args, **kwargs):
        raise MemoryError("Unable to allocate 3.00 EiB for an array with shape (1000000, 10000000)")

    monkeypatch.setattr(convert, "read_focused", allocate)
    out = tmp_path / "x.h5"
    args = ["convert", str(gotcha), "--to", "h5", "--out", str(out)]
    err = _refused(args, capsys, "out of memory (Unable to allocate 3.00 EiB", out)
    assert "--max-memory" in err


# ------------------------------------------------------------------ accepted but wrong
def test_sicd_on_patches_is_refused_before_the_analysis(cphd, tmp_path, capsys, monkeypatch):
    import sarmotion.collection.analysis as analysis

    def never(*args, **kwargs):
        raise AssertionError("the patches were analysed")

    monkeypatch.setattr(analysis, "analyze_collection", never)
    out = tmp_path / "out"
    _refused(["analyze", str(cphd), "--out", str(out), "--sicd"], capsys, "--sicd", out)
    _refused(
        ["analyze", "hyperbola", "--out", str(out), "--sicd", "--region", "-5", "-5", "5", "5"],
        capsys,
        "--sicd",
        out,
    )
    assert run(["analyze", "--help"]) == 0
    assert "scene cut into patches is refused" in " ".join(capsys.readouterr().out.split())


def _strict(text: str):
    def refuse(name):
        raise ValueError(f"bare {name} in JSON")

    return json.loads(text, parse_constant=refuse)


def test_json_documents_hold_no_bare_nan(tmp_path):
    from sarmotion.io import write_json

    doc = {
        "metadata": {"altitude_m": float("nan"), "gain": np.float32("inf")},
        "values": np.array([1.0, np.nan, -np.inf]),
        "pair": (np.float64(2.5), complex(np.nan, 1.0)),
        "count": np.int64(3),
        "flag": True,
        "none": None,
    }
    write_json(tmp_path / "d.json", doc)
    back = _strict((tmp_path / "d.json").read_text())
    assert back == {
        "metadata": {"altitude_m": None, "gain": None},
        "values": [1.0, None, None],
        "pair": [2.5, [None, 1.0]],
        "count": 3,
        "flag": True,
        "none": None,
    }


def test_results_of_a_native_file_with_nan_metadata_are_strict_json(tmp_path, capsys):
    """End to end: the file's NaN reaches the document as null."""
    from sarmotion.io import load_traces, save_traces
    from sarmotion.simulation import load_scene, simulate

    traces = simulate(load_scene("hyperbola")).traces
    odd = traces.with_data(traces.data, antenna_gain_db=float("nan"))
    path = tmp_path / "nan.h5"
    save_traces(path, odd)
    assert math.isnan(load_traces(path).metadata["antenna_gain_db"])
    out = tmp_path / "out"
    assert run(["image", str(path), "--out", str(out), "--size", "20"]) == 0, (
        capsys.readouterr().err
    )
    for doc in out.glob("*.json"):
        _strict(doc.read_text())


# ------------------------------------------------------------------ output paths
def test_out_name_beyond_name_max_is_refused_before_work(gotcha, tmp_path, capsys):
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    # fits the file system, but not with the staging names made beside it
    out = tmp_path / "new" / ("a" * (limit - 15))
    err = _refused(
        ["image", str(gotcha), "--out", str(out)], capsys, f"limit of {limit} bytes", out
    )
    assert not (tmp_path / "new").exists()
    allowed = int(err.rsplit("at most ", 1)[1].split()[0])
    good = tmp_path / ("b" * allowed)
    assert run(["image", str(gotcha), "--out", str(good), "--size", "10"]) == 0
    assert (good / "image.h5").is_file()


def test_out_that_is_a_mount_point_is_refused_before_work(gotcha, capsys):
    mounts = [Path(p) for p in ("/dev/shm", "/run", "/tmp") if os.path.ismount(p)]
    mounts = [m for m in mounts if os.access(m, os.W_OK)]
    if not mounts:
        pytest.skip("no writable mount point")
    before = sorted(os.listdir(mounts[0]))
    err = _refused(
        ["image", str(gotcha), "--out", str(mounts[0]), "--force"], capsys, "mount point"
    )
    assert str(mounts[0]) in err
    assert sorted(os.listdir(mounts[0])) == before
    assert not os.path.exists(mounts[0].parent / f".{mounts[0].name}.lock")


def test_lock_file_that_is_a_fifo(gotcha, tmp_path, capsys):
    out = tmp_path / "out"
    os.mkfifo(tmp_path / ".out.lock")
    _refused(
        ["image", str(gotcha), "--out", str(out)], capsys, f"{tmp_path / '.out.lock'} is a FIFO"
    )
    assert not out.exists()


def test_a_full_disk_leaves_no_lock_file(gotcha, tmp_path, capsys, monkeypatch):
    import sarmotion.io.staging as staging

    real_write = os.write

    def full(fd, data):
        if os.fstat(fd).st_size == 0 and data.strip().isdigit():
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write(fd, data)

    monkeypatch.setattr(staging.os, "write", full)
    out = tmp_path / "out"
    _refused(["image", str(gotcha), "--out", str(out)], capsys, "No space left on device", out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["small.mat"]


def test_scratch_of_a_killed_run_is_removed_at_the_next_start(tmp_path):
    from sarmotion._cluster import SCRATCH_PREFIX, local_cluster, remove_stale_scratch

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f"{SCRATCH_PREFIX}{dead.pid}-abc123"
    (stale / "dask-scratch-space").mkdir(parents=True)
    live = tmp_path / f"{SCRATCH_PREFIX}{os.getpid()}-def456"
    live.mkdir()
    other = tmp_path / f"{SCRATCH_PREFIX}nopid"
    other.mkdir()
    assert remove_stale_scratch(tmp_path) == [stale]
    assert not stale.exists() and live.is_dir() and other.is_dir()
    # a local cluster sweeps the system's temporary directory before it starts, and
    # names its own scratch directory with its PID
    import tempfile

    system = Path(tempfile.gettempdir()) / f"{SCRATCH_PREFIX}{dead.pid}-ghi789"
    system.mkdir()
    try:
        with local_cluster(1) as cluster:
            assert not system.exists()
            own = list(Path(tempfile.gettempdir()).glob(f"{SCRATCH_PREFIX}{os.getpid()}-*"))
            assert own and cluster is not None
    finally:
        if system.exists():
            system.rmdir()


def _worker_processes(pid):
    """The worker processes (multiprocessing's spawned children) of process ``pid``."""
    import psutil

    try:
        children = psutil.Process(pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []
    found = []
    for child in children:
        try:
            if "spawn_main" in " ".join(child.cmdline()):
                found.append(child)
        except psutil.Error:
            continue
    return found


@pytest.mark.slow
@pytest.mark.parametrize("verbosity", ["-q", "-v"])
@pytest.mark.parametrize("moment", ["start", "work"])
def test_ctrl_c_on_worker_processes_is_one_line(tmp_path, moment, verbosity):
    """The terminal's Ctrl-C (SIGINT to the whole process group) on worker processes.

    ``start``: as soon as the first worker process exists, while the workers start
    (importing Dask takes them seconds); ``work``: six seconds later, while they analyse
    the 65 sub-apertures (10 s of tracking alone on a quiet 2-core machine, the workers'
    start 3 s before it; with 12 sub-apertures of the rank-one separation the run could
    end before the Ctrl-C). Either way: exit 130, ``sarmotion: aborted`` once and last,
    no traceback, no blank line, no output, and no worker process or scratch directory
    left.
    """
    import psutil

    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "TMPDIR": str(tmp_path)}
    cmd = [sys.executable, "-m", "sarmotion", verbosity, "track", "hyperbola", "--out", str(out)]
    cmd += ["--size", "20", "--processes", "--workers", "2", "--sub-aperture", "0.5"]
    cmd += ["--overlap", "0.9", "--method", "rpca"]  # 65 sub-apertures: work outlasts 6 s
    proc = subprocess.Popen(
        cmd,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp_path,
        start_new_session=True,  # its own process group, as a terminal's foreground job
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        deadline = time.monotonic() + 120.0
        while not (workers := _worker_processes(proc.pid)) and time.monotonic() < deadline:
            assert proc.poll() is None, proc.communicate()[1]
            time.sleep(0.02)
        assert workers, "no worker process started within 120 s"
        if moment == "work":
            time.sleep(6.0)
        assert proc.poll() is None, proc.communicate()[1]
        workers = _worker_processes(proc.pid)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    lines = err.splitlines()
    assert lines[-1] == "sarmotion: aborted", err
    assert lines.count("sarmotion: aborted") == 1, err
    assert "" not in lines, err
    if verbosity == "-q":
        assert err == "sarmotion: aborted\n"
    else:  # Dask's lines of the workers' orderly close, at most (no warning, no error)
        assert not [x for x in lines if "WARNING" in x or "ERROR" in x], err
    assert not out.exists()
    assert not list(tmp_path.glob(".out*"))
    assert not list(tmp_path.glob("sarmotion-dask-*"))
    alive = [w for w in workers if w.is_running() and w.status() != psutil.STATUS_ZOMBIE]
    assert alive == [], [w.pid for w in alive]
