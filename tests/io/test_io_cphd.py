"""CPHD reading and writing: round trips (simulated and GOTCHA), sarkit's consistency
checker on every written file, files from elsewhere (moving SRP, SGN +1, CI4 with AmpSF,
two channels), and bad files."""

from __future__ import annotations

import copy
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sarkit.cphd as skcphd
import sarkit.verification as skver

from sarmotion.core import Radar, Traces
from sarmotion.imaging import ImageGrid, backproject
from sarmotion.io import (
    DataError,
    is_cphd_file,
    is_gotcha_file,
    load_traces,
    read_cphd,
    read_gotcha,
    save_traces,
    write_cphd,
)
from sarmotion.simulation import PointTarget, Scene, simulate

#: Dayton, Ohio: a scene frame origin whose east/north/up axes are not ECF axes.
DAYTON = (39.78, -84.05, 250.0)

#: The two calibration reflectors of GOTCHA pass 1 (README).
REFLECTORS = [(-15.6, 21.6), (-27.8, 38.8)]


# ----------------------------------------------------------------------------- helpers
def scene(reference=(1.0, 2.0, 0.0), pulse="gaussian", aperture_deg=0.5) -> Scene:
    bandwidth = 500e6 if pulse == "gaussian" else 400e6
    return Scene(
        name=f"cphd-{pulse}",
        targets=(
            PointTarget(position_m=(3.0, -4.0)),
            PointTarget(position_m=(-10.0, 6.0), velocity_mps=(2.0, 1.0), reflectivity=0.5j),
        ),
        reference_point_m=reference,
        trajectory_spec={"kind": "circular", "aperture_deg": aperture_deg},
        radar=Radar(n_samples=128, frequency_step_hz=4e6, bandwidth_hz=bandwidth, pulse=pulse),
    )


@pytest.fixture(scope="module")
def sim_traces() -> Traces:
    return simulate(scene(), snr_db=20.0, rng=1).traces


def assert_consistent(path: Path) -> None:
    """sarkit's CPHD consistency checker (thorough): no failed check, errors or warnings."""
    with open(path, "rb") as fh:
        con = skver.CphdConsistency.from_file(fh, thorough=True)
        con.check()
    failures = con.failures(omit_passed_sub=True)
    assert not failures, {k: v["details"] for k, v in failures.items()}
    assert len(con.passes()) > 40  # the checks did run (measured: 61 pass)


def cphdcheck_command() -> list[str]:
    """sarkit's ``cphdcheck`` console command (beside this Python, else on the PATH)."""
    exe = Path(sys.executable).with_name("cphdcheck")
    if exe.exists():
        return [str(exe)]
    found = shutil.which("cphdcheck")
    return [found] if found else [sys.executable, "-m", "sarkit.verification._cphdcheck"]


def assert_same(a: Traces, b: Traces, *, data_rtol=1e-6, pos_atol=1e-6) -> None:
    """Same traces up to complex64 storage of the data and ECF rounding of positions."""
    assert b.shape == a.shape
    scale = np.abs(a.data).max()
    assert np.abs(b.data - a.data).max() < data_rtol * scale
    assert np.abs(b.positions_m - a.positions_m).max() < pos_atol
    assert np.abs(b.slow_times_s - a.slow_times_s).max() < 1e-9
    assert np.abs(b.reference_point_m - a.reference_point_m).max() < pos_atol


def rewrite(src: Path, dst: Path, edit) -> Path:
    """Read every channel with sarkit, let ``edit(root, signals, pvps)`` change them, write.

    ``root`` is an ElementWrapper of the XML; ``signals`` maps channel id to the signal
    array and ``pvps`` maps channel id to ``{pvp name: values}``; fields named in the
    edited XML are written, others dropped.
    """
    with open(src, "rb") as fh, skcphd.Reader(fh) as reader:
        xml = copy.deepcopy(reader.metadata.xmltree)
        ids = [n.text for n in xml.findall("{*}Data/{*}Channel/{*}Identifier")]
        signals = {i: reader.read_signal(i) for i in ids}
        pvps = {}
        for i in ids:
            arr = reader.read_pvps(i)
            pvps[i] = {name: arr[name].copy() for name in arr.dtype.names}
    edit(skcphd.ElementWrapper(xml.getroot()), signals, pvps)
    dtype = skcphd.get_pvp_dtype(xml)
    with open(dst, "wb") as fh, skcphd.Writer(fh, skcphd.Metadata(xmltree=xml)) as writer:
        for i in [n.text for n in xml.findall("{*}Data/{*}Channel/{*}Identifier")]:
            out = np.zeros(len(signals[i]), dtype=dtype)
            for name in dtype.names:
                out[name] = pvps[i][name]
            writer.write_signal(i, signals[i])
            writer.write_pvp(i, out)
    return dst


def one_line_error(path: Path, match: str, **kwargs) -> str:
    with pytest.raises(DataError, match=match) as info:
        read_cphd(path, **kwargs)
    message = str(info.value)
    assert "\n" not in message
    assert str(path) in message
    return message


# ------------------------------------------------------------------ simulated round trips
@pytest.mark.parametrize(
    ("pulse", "reference", "origin"),
    [("gaussian", (1.0, 2.0, 0.0), DAYTON), ("rect", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))],
)
def test_simulated_scene_round_trip_equals_native(tmp_path, pulse, reference, origin):
    traces = simulate(scene(reference, pulse), snr_db=20.0, rng=2).traces
    native = load_traces(save_traces(tmp_path / "t.h5", traces))
    path = write_cphd(tmp_path / "t.cphd", traces, origin_llh=origin)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.cphd", "t.h5"]  # no temp files
    assert_consistent(path)
    back = read_cphd(path)
    # Data: complex64 phase history (measured relative error 1e-8); positions through
    # ECF at ~6.4e6 m (measured 5e-10 m); radar and metadata restored as stored.
    assert_same(native, back, data_rtol=1e-6, pos_atol=1e-6)
    assert back.radar == native.radar
    assert {k: v for k, v in back.metadata.items() if k != "cphd"} == native.metadata
    assert back.metadata["cphd"]["vectors"] == [0, traces.n_pulses]
    assert back.metadata["cphd"]["sgn"] == "-1"


def test_sub_range_of_vectors_is_select_pulses(tmp_path, sim_traces):
    path = write_cphd(tmp_path / "t.cphd", sim_traces, origin_llh=DAYTON)
    part = read_cphd(path, vectors=(10, 40))
    assert_same(sim_traces.select_pulses(10, 40), part)
    assert part.metadata["cphd"]["vectors"] == [10, 40]
    assert part.metadata["cphd"]["n_vectors_in_channel"] == sim_traces.n_pulses


def test_reference_point_option_re_references_exactly(tmp_path):
    """Against the simulator: the same scene simulated with another reference point."""
    a = simulate(scene((1.0, 2.0, 0.0)), snr_db=None).traces
    b = simulate(scene((-6.0, 4.0, 0.0)), snr_db=None).traces
    back = read_cphd(
        write_cphd(tmp_path / "a.cphd", a, origin_llh=DAYTON), reference_point_m=(-6, 4)
    )
    assert_same(b, back, data_rtol=1e-5)


def test_moving_srp_is_re_referenced_to_one_point(tmp_path):
    """Vectors referenced to two SRPs (halves simulated with each) read as one reference."""
    a = simulate(scene((1.0, 2.0, 0.0)), snr_db=None).traces
    b = simulate(scene((-6.0, 4.0, 0.0)), snr_db=None).traces
    src = write_cphd(tmp_path / "a.cphd", a, origin_llh=DAYTON)
    half = a.n_pulses // 2
    with open(write_cphd(tmp_path / "b.cphd", b, origin_llh=DAYTON), "rb") as fh:
        srp_b_ecf = skcphd.Reader(fh).read_pvps("1")["SRPPos"][0].copy()  # SRP of b, ECF

    def edit(root, signals, pvps):
        signals["1"] = signals["1"].copy()
        signals["1"][half:] = b.phase_history()[half:].astype(np.complex64)
        pvps["1"]["SRPPos"][half:] = srp_b_ecf
        root["Channel"]["SRPFixedCPHD"] = False
        root["Channel"]["Parameters"][0]["SRPFixed"] = False
        root["ReferenceGeometry"] = skcphd.compute_reference_geometry(
            root.elem.getroottree(), _pvp_array(root, pvps["1"])
        )

    path = rewrite(src, tmp_path / "moving.cphd", edit)
    assert_consistent(path)
    assert_same(a, read_cphd(path, reference_point_m=(1, 2)), data_rtol=1e-5)
    # Default reference: the SRP of the middle vector (here the second SRP).
    assert_same(b, read_cphd(path), data_rtol=1e-5)


def _pvp_array(root, fields):
    dtype = skcphd.get_pvp_dtype(root.elem.getroottree())
    out = np.zeros(len(fields["TxTime"]), dtype=dtype)
    for name in dtype.names:
        out[name] = fields[name]
    return out


def test_sgn_plus_one_ci4_samples_and_amp_sf(tmp_path, sim_traces):
    """A file as another producer may write it: SGN +1, integer samples scaled by AmpSF,
    transmit and receive positions at their own times (the antenna is their mid-point)."""
    src = write_cphd(tmp_path / "t.cphd", sim_traces)
    ph = sim_traces.phase_history()
    amp = np.abs(ph).max(axis=1) / 30000.0

    def edit(root, signals, pvps):
        root["Global"]["SGN"] = 1
        root["Data"]["SignalArrayFormat"] = "CI4"
        root["Data"]["NumBytesPVP"] += 8
        root["PVP"]["AmpSF"] = {"Offset": 28, "Size": 1, "dtype": np.dtype("f8")}
        counts = np.conj(ph) / amp[:, None]
        ci4 = np.zeros(ph.shape, dtype=[("real", "i2"), ("imag", "i2")])
        ci4["real"], ci4["imag"] = np.round(counts.real), np.round(counts.imag)
        signals["1"] = ci4
        pvps["1"]["AmpSF"] = amp
        half_way = 0.5 * (pvps["1"]["RcvTime"] - pvps["1"]["TxTime"])[:, None] * pvps["1"]["TxVel"]
        pvps["1"]["TxPos"] -= half_way  # ~1.7 mm at 70 m/s
        pvps["1"]["RcvPos"] += half_way

    path = rewrite(src, tmp_path / "ci4.cphd", edit)
    assert_consistent(path)
    back = read_cphd(path)
    # 16-bit integers: error of half a count in 30000 per component.
    assert_same(sim_traces, back, data_rtol=1e-3)
    assert back.metadata["cphd"]["sgn"] == "1"


def test_two_channels(tmp_path, sim_traces):
    src = write_cphd(tmp_path / "t.cphd", sim_traces)
    other = sim_traces.with_data(2j * sim_traces.data)
    nbytes = sim_traces.data.size * 8

    def edit(root, signals, pvps):
        data = root["Data"]
        data["NumCPHDChannels"] = 2
        data.add("Channel", {**dict(data["Channel"][0]), "Identifier": "VV"})
        data["Channel"][1]["SignalArrayByteOffset"] = nbytes
        data["Channel"][1]["PVPArrayByteOffset"] = sim_traces.n_pulses * data["NumBytesPVP"]
        chan = root["Channel"]
        chan.add("Parameters", copy.deepcopy(chan["Parameters"][0].elem))
        chan["Parameters"][1]["Identifier"] = "VV"
        signals["VV"] = other.phase_history().astype(np.complex64)
        pvps["VV"] = pvps["1"]

    path = rewrite(src, tmp_path / "two.cphd", edit)
    assert_consistent(path)
    assert_same(sim_traces, read_cphd(path))  # default: the reference channel
    assert_same(other, read_cphd(path, channel="VV"))
    assert_same(other, read_cphd(path, channel=1))
    one_line_error(path, r"no channel 'HH' \(channels: 1, VV\)", channel="HH")
    one_line_error(path, "channel index 2 outside 0..1", channel=2)


def test_writer_contract(tmp_path, sim_traces):
    path = write_cphd(tmp_path / "t.cphd", sim_traces, collection_start="2008-07-01T12:00:00Z")
    assert is_cphd_file(path)
    assert not is_gotcha_file(path)
    assert not is_cphd_file(save_traces(tmp_path / "t.h5", sim_traces))
    assert not is_cphd_file(tmp_path / "missing.cphd")
    with pytest.raises(FileExistsError):
        write_cphd(path, sim_traces, overwrite=False)
    back = read_cphd(path)
    assert back.metadata["cphd"]["collection_start"].startswith("2008-07-01T12:00:00")
    assert back.metadata["cphd"]["core_name"] == sim_traces.metadata["scene"]
    with pytest.raises(ValueError, match="origin_llh"):
        write_cphd(tmp_path / "x.cphd", sim_traces, origin_llh=(95.0, 0.0, 0.0))


def test_cphdcheck_command_passes_a_written_file(tmp_path, sim_traces):
    path = write_cphd(tmp_path / "t.cphd", sim_traces, origin_llh=DAYTON)
    run = subprocess.run(
        [*cphdcheck_command(), str(path), "--thorough"], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stdout + run.stderr

    # The checker does fail a broken file: the same file with a wrong FxBW.
    def wrong_bandwidth(root, signals, pvps):
        root["Channel"]["Parameters"][0]["FxBW"] = 1e6

    bad = rewrite(path, tmp_path / "bad.cphd", wrong_bandwidth)
    run = subprocess.run(
        [*cphdcheck_command(), str(bad), "--thorough"], capture_output=True, text=True, timeout=120
    )
    assert run.returncode != 0


# ----------------------------------------------------------------------------- GOTCHA
@pytest.fixture(scope="module")
def gotcha_round_trip(gotcha_files, tmp_path_factory):
    traces = read_gotcha(gotcha_files)
    path = write_cphd(tmp_path_factory.mktemp("cphd") / "gotcha.cphd", traces, origin_llh=DAYTON)
    return traces, path


@pytest.mark.gotcha
def test_gotcha_round_trip_same_traces_and_image(gotcha_round_trip):
    mat, path = gotcha_round_trip
    assert_consistent(path)
    back = read_cphd(path)
    assert back.shape == (469, 424)
    assert_same(mat, back, data_rtol=1e-6)
    assert back.metadata["files"] == mat.metadata["files"]  # stored provenance
    # Both reflectors in a 48 m x 48 m image at 0.2 m.
    grid = ImageGrid.square(centre_m=(-21.6, 30.2), size_m=48.0, spacing_m=0.2)
    a = backproject(mat, grid).values
    b = backproject(back, grid).values
    # Signal-to-error ratio of the images >= 60 dB; measured 186 dB (the data are
    # complex64 in both formats; the positions pass through ECF, 5e-10 m).
    assert np.linalg.norm(b - a) <= 1e-3 * np.linalg.norm(a)
    gx, gy = np.meshgrid(grid.x_m, grid.y_m)
    for x0, y0 in REFLECTORS:
        near = np.hypot(gx - x0, gy - y0) < 3.0
        ia = np.argmax(np.where(near, np.abs(a), 0))
        ib = np.argmax(np.where(near, np.abs(b), 0))
        assert ia == ib
        assert np.hypot(gx.flat[ia] - x0, gy.flat[ia] - y0) < 1.0


@pytest.mark.gotcha
def test_gotcha_sub_range_is_one_file(gotcha_round_trip, gotcha_files):
    mat, path = gotcha_round_trip
    second = read_gotcha(gotcha_files[1])
    part = read_cphd(path, vectors=(117, 234))
    assert_same(second, part, data_rtol=1e-6)


# ----------------------------------------------------------------------------- bad files
@pytest.fixture(scope="module")
def good(tmp_path_factory, sim_traces) -> Path:
    return write_cphd(tmp_path_factory.mktemp("good") / "good.cphd", sim_traces)


def test_missing_and_not_cphd(tmp_path):
    one_line_error(tmp_path / "none.cphd", "file not found")
    text = tmp_path / "text.cphd"
    text.write_text("hello\n")
    one_line_error(text, "not a CPHD file")
    old = tmp_path / "old.cphd"
    old.write_bytes(b"CPHD/0.3\nXML_DATA_SIZE := 10\n")
    one_line_error(old, r"CPHD version '0.3' is not supported")


@pytest.mark.parametrize("keep", [0.5, 0.05, 0.002])
def test_truncated(tmp_path, good, keep):
    raw = good.read_bytes()
    path = tmp_path / "cut.cphd"
    path.write_bytes(raw[: int(len(raw) * keep)])
    msg = one_line_error(path, "truncated|unreadable CPHD header or XML")
    if keep >= 0.05:
        assert "truncated" in msg


def test_toa_domain_is_refused(tmp_path, good):
    def toa(root, signals, pvps):
        root["Global"]["DomainType"] = "TOA"

    path = rewrite(good, tmp_path / "toa.cphd", toa)
    one_line_error(path, r"signal in the TOA domain \(Global/DomainType TOA\)")


@pytest.mark.parametrize("name", ["SRPPos", "TxPos", "SCSS"])
def test_missing_pvp(tmp_path, good, name):
    def edit(root, signals, pvps):
        del root["PVP"][name]

    path = rewrite(good, tmp_path / "nopvp.cphd", edit)
    one_line_error(path, f"no PVP {name} ")


def test_nan_pvp_and_varying_grid(tmp_path, good):
    def nan(root, signals, pvps):
        pvps["1"]["TxPos"][7] = np.nan

    one_line_error(rewrite(good, tmp_path / "nan.cphd", nan), "PVP TxPos is NaN/inf .*vector 7")

    def grid(root, signals, pvps):
        pvps["1"]["SC0"][3:] += 0.5 * pvps["1"]["SCSS"][0]

    one_line_error(rewrite(good, tmp_path / "grid.cphd", grid), "frequency grid varies")


def test_bad_vector_range(good):
    one_line_error(good, r"vectors \[5, 500\) outside", vectors=(5, 500))
    one_line_error(good, "at least 2 vectors", vectors=(5, 6))


def _antenna_off_track(root, signals, pvps):
    pvps["1"]["TxPos"][9] += [0.0, 0.0, 0.2]  # 20 cm: 19 % of the 1.06 m spacing
    pvps["1"]["RcvPos"][9] += [0.0, 0.0, 0.2]


def _srp_outlier(root, signals, pvps):
    pvps["1"]["SRPPos"][4] += [3.0, 0.0, 0.0]


def _time_gap(root, signals, pvps):
    t = pvps["1"]["TxTime"]
    t[6:] += 3.0 * (t[1] - t[0])  # a gap of 4 intervals


def _iarp_disagrees(root, signals, pvps):
    iarp = root["SceneCoordinates"]["IARP"]
    iarp["ECF"] = np.asarray(iarp["ECF"]) + [0.0, 0.0, 5.0]


def _bright_sample(root, signals, pvps):
    signals["1"] = np.array(signals["1"])
    signals["1"][3, 5] = 1e4 * np.abs(signals["1"]).max()


@pytest.mark.parametrize(
    ("edit", "match", "lenient_reads"),
    [
        (_antenna_off_track, r"TxPos/RcvPos \(mid-point\), pulse 9: the antenna is 0.2 m", True),
        (_srp_outlier, r"PVP SRPPos, vector 4: the SRP of this vector alone", True),
        (_time_gap, r"PVP TxTime, pulse 6: a step of 0.0\d+ s from pulse 5", True),
        (_iarp_disagrees, r"IARP: ECF and LLH are 5 m apart", False),
        (_bright_sample, r"signal, pulse 3, frequency index 5: magnitude", True),
    ],
)
def test_implausible_files_are_refused_in_one_line(
    tmp_path, good, caplog, edit, match, lenient_reads
):
    """Each plausibility rule refuses its case; ``lenient`` reads it with the same warning."""
    path = rewrite(good, tmp_path / "bad.cphd", edit)
    message = one_line_error(path, match)
    assert "--lenient accepts it" in message or not lenient_reads
    if lenient_reads:
        with caplog.at_level("WARNING", logger="sarmotion.io"):
            read_cphd(path, lenient=True)
        assert any("accepted: --lenient" in r.getMessage() for r in caplog.records)
    else:
        one_line_error(path, match, lenient=True)


def test_plausibility_accepts_a_file_as_written(good, sim_traces):
    """The rules pass on a file as written (fixed SRP, uniform PRF): nothing refused.

    (The GOTCHA round trip above reads 4 real degrees written as CPHD through the same
    rules.)"""
    assert read_cphd(good).shape == sim_traces.shape
