"""A simulated collection written as CPHD block by block, read back in blocks, analysed.

The scene (``sarmotion.simulation.collection``) is small enough to hold in memory, so the
file can be compared with the whole simulation; the analysis goes through the command
line and its block reader. Bad input to the collection path through a CPHD file: a
region outside the data, a patch below a resolution cell, a file cut inside its signal
block; and Ctrl-C during a run on two workers.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from sarmotion.cli.main import EXIT_BAD_INPUT, run
from sarmotion.collection import CollectionOptions, plan_patches
from sarmotion.imaging import resolution
from sarmotion.io import CphdWriter, open_cphd_blocks, write_cphd_blocks
from sarmotion.pipeline import family_errors
from sarmotion.simulation import (
    CollectionScene,
    PointTarget,
    collection_acquisition,
    random_collection,
    simulate_phase_history,
)

ROOT = Path(__file__).resolve().parents[2]

SIDE_M = 150.0
SEED = 31
SNR_DB = -20.0
#: complex64 rounding: each part of a sample to 2^-24 of its modulus, so the phase
#: history, and the fast-time traces (a unitary transform up to scale), to sqrt(2) 2^-24
#: in Frobenius norm; 2^-23 bounds that with float64 round-off to spare.
FLOAT32_REL = 2.0**-23
#: The family rule of ``benchmarks/bench_collection.py``: range position within 3
#: ground-range cells, range speed within 0.5 m/s.
RANGE_CELLS = 3.0
RANGE_SPEED_MPS = 0.5


def _scene() -> CollectionScene:
    """One mover near the crossing of the plan's inner borders, one near a border."""
    acq = collection_acquisition(SIDE_M)
    probe = CollectionScene(acquisition=acq, stationary=(), movers=())
    plan = plan_patches(probe, CollectionOptions())
    half = SIDE_M / 2
    xs = sorted({p.core_m[0] for p in plan.patches if -half < p.core_m[0] < half})
    ys = sorted({p.core_m[1] for p in plan.patches if -half < p.core_m[1] < half})
    return random_collection(
        acq,
        SIDE_M,
        seed=SEED,
        n_movers=2,
        lines_m=(xs, ys),
        n_corner=1,
        n_border=1,
        snr_db=SNR_DB,
    )


@pytest.fixture(scope="module")
def scene() -> CollectionScene:
    return _scene()


@pytest.fixture(scope="module")
def cphd(scene, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("collection") / "scene.cphd"
    write_cphd_blocks(path, scene, block_pulses=50)  # a short last block
    return path


@pytest.mark.parametrize("side, pulses, samples", [(150.0, None, None), (400.0, 2000, 2000)])
def test_acquisition_is_sampled_for_the_scene(side, pulses, samples):
    """Unambiguous extent 1.3 x the side in range and cross range, or the counts asked for.

    The acquisition samples 1.3 x the side at the aperture centre; the unambiguous scene
    holds at every pulse, so the look's turn at the aperture's ends, half a degree,
    couples the other side in: each extent is at most ``tan(0.5 deg)`` of the other
    side (a square here) under the rule. Pulses and samples are rounded up, so each
    extent lies within one sample above it; 1e-4 of relative slack for the first-order
    geometry of the rule (the elevation and the Doppler rate at the reference point).
    """
    from sarmotion.collection import unambiguous_scene

    acq = collection_acquisition(side, n_pulses=pulses, n_samples=samples)
    amb = unambiguous_scene(CollectionScene(acquisition=acq, stationary=(), movers=()))
    extent = np.ptp(amb[:, 0]), np.ptp(amb[:, 1])  # range (x), cross range (y)
    turn = np.tan(np.deg2rad(0.5))
    for width, count, least in zip(extent, acq.shape[::-1], (samples, pulses), strict=True):
        if least is None:
            assert 1.3 * side * (1 - turn - 1e-4) <= width <= 1.3 * side * (1 + 2 / count)
        else:
            assert count >= least and width >= 1.3 * side * (1 - turn - 1e-4)
    # one degree of azimuth: n pulses 1/n degree apart
    azimuth = np.degrees(np.arctan2(acq.positions_m[:, 1], acq.positions_m[:, 0]))
    assert np.isclose(np.ptp(azimuth), (acq.n_pulses - 1) / acq.n_pulses, rtol=1e-9)


def test_the_plan_cuts_the_scene_and_movers_sit_near_its_borders(scene):
    plan = plan_patches(scene, CollectionOptions())
    assert len(plan.patches) > 1
    inner = [p.core_m[0] for p in plan.patches] + [p.core_m[1] for p in plan.patches]
    lines = np.array([v for v in inner if -SIDE_M / 2 < v < SIDE_M / 2])
    for m in scene.movers:
        x, y = m.position_m[:2]
        assert min(abs(lines - x).min(), abs(lines - y).min()) <= 2.0, m.label


def test_blocks_are_the_forward_model_plus_noise_of_the_stated_level(scene):
    clean = CollectionScene(
        acquisition=scene.acquisition, stationary=scene.stationary, movers=scene.movers
    )
    acq = scene.acquisition
    targets = [*scene.stationary, *scene.movers]
    whole = simulate_phase_history(targets, acq.trajectory, acq.radar, acq.reference_point_m)
    n = acq.n_pulses
    # to the rounding of the travel times (a few 1e-9 rad a term: simulation/echoes.py)
    bound = 1e-8 * sum(abs(t.reflectivity) for t in targets) * acq.radar.spectral_weights().max()
    assert np.allclose(clean.phase_history(0, n), whole, rtol=0, atol=bound)
    noise = scene.phase_history(0, n) - whole
    # per sample: mean |n|^2 = sigma^2 = mean(W^2) / 10^(snr/10); the estimate's relative
    # standard deviation is 1/sqrt(N) for N samples (|n|^2 is exponential): 5 of them
    expected = np.mean(acq.radar.spectral_weights() ** 2) / 10.0 ** (SNR_DB / 10.0)
    ratio = np.mean(np.abs(noise) ** 2) / expected
    assert abs(ratio - 1.0) <= 5.0 / np.sqrt(noise.size)
    # the noise of a pulse does not depend on the block that holds it
    a = np.concatenate([b for _, _, b in scene.blocks(7)])
    b = np.concatenate([b for _, _, b in scene.blocks(64)])
    assert np.array_equal(a, b)


def test_file_read_in_blocks_equals_the_simulation(scene, cphd):
    truth = scene.traces()
    src = open_cphd_blocks(cphd)
    assert src.n_pulses == truth.n_pulses and src.radar == truth.radar
    # positions through the ECF transform and back: float64 round-off at 10 km (nm)
    assert np.allclose(src.trajectory.positions_m, truth.positions_m, rtol=0, atol=1e-6)
    assert np.allclose(src.trajectory.slow_times_s, truth.slow_times_s, rtol=0, atol=1e-9)
    assert np.allclose(src.reference_point_m, truth.reference_point_m, rtol=0, atol=1e-6)
    stops = []
    err = 0.0
    for start, stop, block in src.blocks(64):
        err += float(np.sum(np.abs(block - truth.data[start:stop]) ** 2))
        stops.append(stop)
    assert stops[-1] == truth.n_pulses
    assert np.sqrt(err) <= FLOAT32_REL * np.linalg.norm(truth.data)
    assert src.metadata["scene"] == scene.metadata["scene"]


def test_analysis_of_the_file_finds_each_mover_on_its_family(scene, cphd, tmp_path, capsys):
    """Both movers, near the patches' borders, found on their families, no false one.

    The collection's false-alarm rate is shared by its patches; 0.04 over this plan's 4
    patches tests each at 0.01, the single analysis's default (at 0.01 for the whole
    collection the border mover's statistic, 6.2 dB at this SNR, falls between the
    two thresholds, 5.6 and 6.4 dB).
    """
    out = tmp_path / "out"
    assert len(plan_patches(scene, CollectionOptions()).patches) == 4
    code = run(
        [
            "analyze",
            str(cphd),
            "--out",
            str(out),
            "--workers",
            "0",
            "--false-alarm-rate",
            "0.04",
            "-q",
        ]
    )
    assert code == 0, capsys.readouterr().err
    doc = json.loads((out / "results.json").read_text())
    assert len(doc["plan"]["patches"]) > 1
    acq = scene.acquisition
    cells = resolution(acq)
    fits = [
        PointTarget(position_m=m["position_m"][:2], velocity_mps=m["velocity_mps"])
        for m in doc["movers"]
    ]
    used = set()
    for truth in scene.movers:
        hits = []
        for j, fit in enumerate(fits):
            e = family_errors(acq, fit, truth)
            if abs(e[0]) <= RANGE_CELLS * cells.ground_range_m and abs(e[1]) <= RANGE_SPEED_MPS:
                hits.append(j)
        assert hits, f"{truth.label} not found: {doc['movers']}"
        used.update(hits[:1])
    assert len(fits) == len(used), f"false movers: {doc['movers']}"


# ------------------------------------------------------------------ the writer
def test_a_writer_that_fails_leaves_nothing(scene, tmp_path):
    path = tmp_path / "cut.cphd"
    with pytest.raises(RuntimeError, match="stop"):  # noqa: PT012
        with CphdWriter(path, scene) as out:
            for start, _, block in scene.blocks(40):
                out.write(start, block)
                if start >= 40:
                    raise RuntimeError("stop")
    with pytest.raises(ValueError, match="40 of"):  # noqa: PT012
        with CphdWriter(path, scene) as out:
            out.write(0, next(scene.blocks(40))[2])
    with pytest.raises(ValueError, match="in order"):  # noqa: PT012
        with CphdWriter(path, scene) as out:
            out.write(40, next(scene.blocks(40))[2])
    assert list(tmp_path.iterdir()) == []


def test_a_failed_rewrite_keeps_the_previous_file(scene, cphd, tmp_path):
    path = tmp_path / "kept.cphd"
    path.write_bytes(cphd.read_bytes())
    before = path.read_bytes()
    with pytest.raises(ValueError, match="vectors written"):
        with CphdWriter(path, scene):
            pass
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.cphd"]


# ------------------------------------------------------------------ bad input
def _signal_offset(path: Path) -> int:
    import sarkit.cphd as skcphd

    with path.open("rb") as fh:
        _, kvp = skcphd.read_file_header(fh)
    return int(kvp["SIGNAL_BLOCK_BYTE_OFFSET"])


@pytest.mark.parametrize(
    "extra, pattern",
    [
        (["--region", "-50", "5000", "50", "5100"], "--region"),
        (["--patch-size", "0.1"], "resolution cell"),
    ],
)
def test_bad_region_or_patch_of_a_cphd_file(cphd, tmp_path, capsys, extra, pattern):
    out = tmp_path / "out"
    code = run(["analyze", str(cphd), "--out", str(out), "--workers", "0", *extra])
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT
    assert len(err.splitlines()) == 1 and pattern in err, err
    assert not out.exists()


def test_a_cphd_cut_inside_a_block_is_refused(scene, cphd, tmp_path, capsys):
    raw = cphd.read_bytes()
    row = scene.radar.n_samples * 8
    cut = tmp_path / "cut.cphd"
    cut.write_bytes(raw[: _signal_offset(cphd) + 70 * row + row // 2])  # inside the 2nd block
    out = tmp_path / "out"
    code = run(["analyze", str(cut), "--out", str(out), "--workers", "0"])
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT
    assert len(err.splitlines()) == 1 and "truncated" in err, err
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.cphd"]


def test_a_cphd_that_shrinks_while_its_blocks_are_read(cphd, tmp_path):
    from sarmotion.io import DataError

    copy = tmp_path / "shrinks.cphd"
    copy.write_bytes(cphd.read_bytes())
    src = open_cphd_blocks(copy)
    with copy.open("r+b") as fh:
        fh.truncate(_signal_offset(copy) + 70 * src.radar.n_samples * 8)
    with pytest.raises(DataError, match="truncated"):
        for _ in src.blocks(64):
            pass


def _alive(pids: list[int]) -> list[int]:
    import psutil

    alive = []
    for pid in pids:
        try:
            if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                alive.append(pid)
        except psutil.NoSuchProcess:
            pass
    return alive


def test_ctrl_c_stops_every_worker(cphd, tmp_path):
    """SIGINT once the patches are on the two workers: exit 130, no output, no process."""
    import psutil

    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    cmd = [sys.executable, "-m", "sarmotion", "-v", "analyze", str(cphd), "--out", str(out)]
    # 40 m patches (25 tasks): the run is still on the workers a second after the
    # cluster is up, however fast a patch is
    proc = subprocess.Popen(
        [*cmd, "--workers", "2", "--patch-size", "40"],
        env=env,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp_path,
        # a child inherits an ignored SIGINT (and Python then installs no handler): the
        # test process may have had it ignored by an earlier test; a user's shell has not
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        lines = []
        for line in proc.stderr:  # -v: "patches on <Client ...>" once the cluster is up
            lines.append(line)
            if "patches on" in line:
                break
        assert proc.poll() is None, "".join(lines)
        time.sleep(1.0)  # the first tasks running
        children = [p.pid for p in psutil.Process(proc.pid).children(recursive=True)]
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, err
    # the command line's last word (above it, -v shows Dask's own log lines)
    assert err.strip().splitlines()[-1] == "sarmotion: aborted", err
    assert err.rstrip().splitlines()[-2] != "", "a blank line before the message"
    assert not out.exists()
    assert not list(tmp_path.glob(".out*"))
    # a helper the workers started (such as multiprocessing's resource tracker) ends when
    # its parent's pipe closes: give it a few seconds, not more
    deadline = time.monotonic() + 10.0
    while _alive(children) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _alive(children) == [], [psutil.Process(p).cmdline() for p in _alive(children)]


def test_block_writer_writes_the_file_of_write_cphd(scene, tmp_path):
    """The same XML (but its creation time), PVPs and signal bytes as the whole-traces writer."""
    import lxml.etree
    import sarkit.cphd as skcphd

    from sarmotion.core.blocks import TracesBlocks
    from sarmotion.io import write_cphd

    traces = scene.traces()
    whole = write_cphd(tmp_path / "whole.cphd", traces)
    blocks = write_cphd_blocks(tmp_path / "blocks.cphd", TracesBlocks(traces), block_pulses=33)
    parts = []
    for path in (whole, blocks):
        with path.open("rb") as fh:
            reader = skcphd.Reader(fh)
            xml = reader.metadata.xmltree
            for node in xml.findall(".//{*}CreationInfo/{*}DateTime"):
                node.text = ""
            samples = reader.read_signal("1")
            parts.append((lxml.etree.tostring(xml), reader.read_pvps("1").tobytes(), samples))
    assert parts[0][0] == parts[1][0]
    assert parts[0][1] == parts[1][1]
    assert parts[0][2].tobytes() == parts[1][2].tobytes()
