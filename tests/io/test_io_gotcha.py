"""GOTCHA .mat reading and writing: real-data geometry and focus, round trips, bad inputs."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io

from gotcha_files import save_struct, small_struct
from sarmotion.core import C
from sarmotion.io import DataError, is_gotcha_file, read_gotcha, write_gotcha
from sarmotion.simulation import PointTarget, Scene, simulate

# The two calibration reflectors of pass 1 (README of the data set, 4-degree image).
REFLECTORS = [(-15.5, 21.5), (-27.7, 38.7)]


# ----------------------------------------------------------------------------- helpers
def backproject(traces, xs, ys, *, upsample=8):
    """Tiny reference backprojection |sum_s D(s, dtau) exp(+i omega_o dtau)| on a grid.

    Fast time is upsampled by zero-padding the phase history (exact band-limited
    interpolation at the fine grid) and then interpolated linearly.
    """
    ph = traces.phase_history()
    n_pulses, n = ph.shape
    m = n * upsample
    padded = np.zeros((n_pulses, m), dtype=np.complex128)
    padded[:, m // 2 - n // 2 : m // 2 - n // 2 + n] = ph
    d = np.fft.fftshift(np.fft.ifft(np.fft.ifftshift(padded, axes=1), axis=1), axes=1)
    dt = 1.0 / (m * traces.radar.frequency_step_hz)
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
    ref = traces.reference_point_m
    img = np.zeros(gx.size, dtype=np.complex128)
    for j in range(n_pulses):
        r = traces.positions_m[j]
        dtau = 2.0 * (np.linalg.norm(pts - r, axis=1) - np.linalg.norm(r - ref)) / C
        u = dtau / dt + m // 2
        i0 = np.clip(np.floor(u).astype(int), 0, m - 2)
        w = u - i0
        img += ((1 - w) * d[j, i0] + w * d[j, i0 + 1]) * np.exp(
            2j * np.pi * traces.radar.carrier_hz * dtau
        )
    return np.abs(img).reshape(gx.shape)


def peak(traces, x0, y0, *, half=2.0, step=0.02):
    """(x, y, value) of the brightest pixel of a fine grid around (x0, y0)."""
    xs = np.arange(x0 - half, x0 + half + step / 2, step)
    ys = np.arange(y0 - half, y0 + half + step / 2, step)
    a = backproject(traces, xs, ys)
    iy, ix = np.unravel_index(np.argmax(a), a.shape)
    return float(xs[ix]), float(ys[iy]), float(a[iy, ix])


def gotcha_like_scene(reference_point_m=(0.0, 0.0, 0.0), centre_azimuth_deg=0.5):
    targets = (
        PointTarget(position_m=(-15.3, 21.7)),
        PointTarget(position_m=(10.2, -5.4), reflectivity=0.7j),
        PointTarget(position_m=(30.0, 30.0), velocity_mps=(3.0, -2.0)),
    )
    return Scene(
        name="io-round-trip",
        targets=targets,
        reference_point_m=reference_point_m,
        trajectory_spec={
            "kind": "circular",
            "aperture_deg": 1.0,
            "centre_azimuth_deg": centre_azimuth_deg,
        },
    )


# --------------------------------------------------------------------------- real data
@pytest.mark.gotcha
def test_one_file_geometry_and_grid(gotcha_files):
    tr = read_gotcha(gotcha_files[0])
    assert tr.shape == (117, 424)
    f = tr.frequencies_hz
    assert abs(f[0] - 9.288e9) < 1e6 and abs(f[-1] - 9.910e9) < 1e6
    assert tr.radar.frequency_step_hz == pytest.approx(1.4713e6, rel=1e-4)
    pos = tr.positions_m
    assert pos.dtype == np.float64
    assert np.mean(pos[:, 2]) == pytest.approx(7280.0, abs=20.0)  # altitude ~7.28 km
    assert np.mean(np.hypot(pos[:, 0], pos[:, 1])) == pytest.approx(7090.0, abs=20.0)
    # ~1.055 m between pulses at 70 m/s
    assert tr.trajectory.pulse_interval_s == pytest.approx(1.055 / 70.0, rel=0.01)
    s = tr.slow_times_s
    assert s[0] == pytest.approx(-s[-1], abs=1e-12)  # s = 0 at the aperture centre
    assert tr.metadata["files"] == [gotcha_files[0].name]
    assert tr.metadata["autofocus"] is False
    lo, hi = tr.metadata["azimuth_deg"]
    assert 0.0 <= lo < hi <= 1.0
    # The phase history is the file's fp, unchanged (the r0 reference is kept).
    fp = scipy.io.loadmat(gotcha_files[0])["data"][0][0]["fp"]
    np.testing.assert_allclose(tr.phase_history(), fp.T, rtol=0, atol=1e-6 * np.abs(fp).max())


@pytest.mark.gotcha
def test_four_files_in_azimuth_order(gotcha_files):
    shuffled = [gotcha_files[i] for i in (2, 0, 3, 1)]
    tr = read_gotcha(shuffled)
    assert tr.shape == (469, 424)
    assert tr.metadata["pulses_per_file"] == [117, 117, 118, 117]
    assert tr.metadata["files"] == [p.name for p in gotcha_files]
    pos = tr.positions_m
    az = np.unwrap(np.arctan2(pos[:, 1], pos[:, 0]))
    assert np.all(np.diff(az) > 0)
    steps = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    assert steps.max() < 1.01 * np.median(steps)  # contiguous across file boundaries
    assert tr.slow_times_s[0] == pytest.approx(-tr.slow_times_s[-1], abs=1e-12)


@pytest.fixture(scope="module")
def four_degrees(gotcha_files):
    return read_gotcha(gotcha_files)


@pytest.mark.gotcha
def test_calibration_reflectors_focus(four_degrees):
    tr = four_degrees
    # Coarse 0.25 m image of the area holding both reflectors, for the median pixel.
    coarse = backproject(tr, np.arange(-40.0, 0.0, 0.25), np.arange(10.0, 50.0, 0.25))
    median = float(np.median(coarse))
    for x0, y0 in REFLECTORS:
        x, y, value = peak(tr, x0, y0)
        assert np.hypot(x - x0, y - y0) < 1.0, (x, y)
        # Measured: 345 and 176 times the median pixel (51 dB and 45 dB).
        assert value > 50.0 * median


@pytest.mark.gotcha
def test_kept_r0_reference_focuses_better_than_re_referenced(four_degrees, gotcha_files):
    """The measured choice of read_gotcha: keep fp referenced to r0 (docstring numbers)."""
    tr = four_degrees
    r0 = np.concatenate(
        [scipy.io.loadmat(p)["data"][0][0]["r0"].ravel().astype(np.float64) for p in gotcha_files]
    )
    dr = r0 - np.linalg.norm(tr.positions_m, axis=1)
    assert 2e-4 < np.sqrt(np.mean(dr**2)) < 4e-4  # float32 rounding, ~0.3 mm rms
    re_ref = tr.with_data(_times_phase(tr, dr), phase_reference="re-referenced")
    for x0, y0 in REFLECTORS:
        kept = peak(tr, x0, y0, half=0.6)[2]
        other = peak(re_ref, x0, y0, half=0.6)[2]
        assert kept > other * 1.003  # measured +0.8 % and +0.9 %


def _times_phase(traces, ranges_m):
    """Fast-time data of the phase history times exp(-i 4 pi f / c * ranges)."""
    from sarmotion.core import to_fast_time

    cycles = np.multiply.outer(2.0 * ranges_m / C, traces.frequencies_hz)
    cycles -= np.round(cycles)
    return to_fast_time(traces.phase_history() * np.exp(-2j * np.pi * cycles))


@pytest.mark.gotcha
def test_autofocus_sign(four_degrees, gotcha_files):
    """AFRL's sign (r0 + r_correct, fp * exp(+i ph_correct)) focuses; the opposite does not."""
    af = [scipy.io.loadmat(p)["data"][0][0]["af"][0][0] for p in gotcha_files]
    rc = np.concatenate([a["r_correct"].ravel().astype(np.float64) for a in af])
    pc = np.concatenate([a["ph_correct"].ravel().astype(np.float64) for a in af])
    plain = four_degrees
    focused = read_gotcha(gotcha_files, autofocus=True)
    assert focused.metadata["autofocus"] is True
    # The three other sign choices of (r0 +- r_correct, fp * exp(+-i ph_correct)).
    both_flipped = plain.with_data(_times_phase(plain, -rc) * np.exp(-1j * pc)[:, None])
    range_flipped = plain.with_data(_times_phase(plain, -rc) * np.exp(1j * pc)[:, None])
    phase_flipped = plain.with_data(_times_phase(plain, rc) * np.exp(-1j * pc)[:, None])
    x0, y0 = REFLECTORS[0]

    def value(tr):
        return peak(tr, x0, y0, half=1.5, step=0.05)[2]

    p_af = value(focused)
    assert p_af > 0.9 * value(plain)  # measured +0.1 % on this grid
    assert p_af > 1.03 * value(both_flipped)  # measured +8 %
    assert value(range_flipped) < 0.2 * p_af  # measured 0.09
    assert value(phase_flipped) < 0.2 * p_af  # measured 0.08


@pytest.mark.gotcha
def test_reference_point_re_references_exactly(four_degrees, gotcha_files):
    x0, y0 = REFLECTORS[0]
    moved = read_gotcha(gotcha_files, reference_point_m=(x0, y0))
    assert np.allclose(moved.reference_point_m, (x0, y0, 0.0))
    # Relative to the new reference the reflector sits near zero differential range,
    # and the image does not depend on the reference: same peak, same value.
    a = peak(four_degrees, x0, y0, half=0.6)
    b = peak(moved, x0, y0, half=0.6)
    assert a[:2] == pytest.approx(b[:2], abs=0.021)
    assert b[2] == pytest.approx(a[2], rel=2e-3)


# ------------------------------------------------------------------- synthetic round trips
@pytest.mark.parametrize("reference", [(0.0, 0.0, 0.0), (5.0, -3.0, 0.0)])
def test_round_trip_simulated_scene(tmp_path, reference):
    sim = simulate(gotcha_like_scene(reference))
    tr = sim.traces
    paths = write_gotcha(tr, tmp_path, pulses_per_file=40)
    assert [p.name for p in paths] == [f"data_3dsar_pass1_az{i:03d}_HH.mat" for i in (1, 2, 3)]
    assert sorted(tmp_path.iterdir()) == sorted(paths)  # no temporary files left
    back = read_gotcha(paths[::-1], speed_mps=70.0)
    # Data: complex64 storage; measured relative error 2.6e-8.
    err = np.linalg.norm(back.data - tr.data) / np.linalg.norm(tr.data)
    assert err < 1e-6
    # Positions: float32, coordinates relative to the reference point; half a float32
    # step at 7.3 km is 0.24 mm (measured max 0.2435 mm).
    shifted = tr.positions_m - np.asarray(reference)
    assert np.abs(back.positions_m - shifted).max() < 5e-4
    assert np.abs(back.slow_times_s - tr.slow_times_s).max() < 1e-6
    assert back.radar.frequency_step_hz == pytest.approx(tr.radar.frequency_step_hz, rel=1e-7)
    assert back.radar.carrier_hz == pytest.approx(tr.radar.carrier_hz, rel=1e-7)
    assert np.allclose(back.reference_point_m, 0.0)
    # The same scene: peaks of the stationary targets at the same pixel with the same
    # value (measured ratio 1 +- 3e-8).
    for t in gotcha_like_scene(reference).stationary:
        x0, y0 = t.position_m[:2]
        a = peak(tr, x0, y0, half=0.5, step=0.02)
        b = peak(back, x0 - reference[0], y0 - reference[1], half=0.5, step=0.02)
        assert (a[0] - reference[0], a[1] - reference[1]) == pytest.approx(b[:2], abs=1e-9)
        assert b[2] == pytest.approx(a[2], rel=1e-5)
        assert np.hypot(a[0] - x0, a[1] - y0) < 0.05


def test_written_file_has_the_gotcha_layout(tmp_path):
    tr = simulate(gotcha_like_scene()).traces
    (path,) = write_gotcha(tr, tmp_path, name_pattern="sim_{index}.mat")
    assert path.name == "sim_1.mat"
    assert is_gotcha_file(path)
    d = scipy.io.loadmat(path)["data"][0][0]
    n = tr.n_pulses
    assert d["fp"].dtype == np.complex64 and d["fp"].shape == (424, n)
    assert d["freq"].shape == (424, 1)
    for name in ("x", "y", "z", "r0", "th", "phi"):
        assert d[name].dtype == np.float32 and d[name].shape == (1, n), name
    af = d["af"][0][0]
    assert np.all(af["r_correct"] == 0) and np.all(af["ph_correct"] == 0)
    xyz = np.stack([d[k].ravel().astype(np.float64) for k in "xyz"], axis=1)
    np.testing.assert_allclose(d["r0"].ravel(), np.linalg.norm(xyz, axis=1), rtol=1e-7)
    np.testing.assert_allclose(
        d["th"].ravel(), np.rad2deg(np.arctan2(xyz[:, 1], xyz[:, 0])), atol=1e-4
    )
    np.testing.assert_allclose(
        d["phi"].ravel(),
        np.rad2deg(np.arctan2(xyz[:, 2], np.hypot(xyz[:, 0], xyz[:, 1]))),
        atol=1e-4,
    )
    np.testing.assert_allclose(d["fp"].T, tr.phase_history(), atol=1e-6 * np.abs(d["fp"]).max())


def test_files_across_zero_azimuth_are_ordered(tmp_path):
    tr = simulate(gotcha_like_scene(centre_azimuth_deg=0.0)).traces
    paths = write_gotcha(tr, tmp_path, pulses_per_file=30)
    th = [scipy.io.loadmat(p)["data"][0][0]["th"].ravel() for p in paths]
    assert th[0][0] > 359.0 and th[-1][-1] > 360.0  # continuous azimuth across 360
    back = read_gotcha([paths[2], paths[0], paths[3], paths[1]])
    np.testing.assert_allclose(back.positions_m, tr.positions_m, atol=5e-4)


def test_write_is_atomic(tmp_path, monkeypatch):
    tr = simulate(gotcha_like_scene()).traces
    calls = []
    real = scipy.io.savemat

    def failing(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise OSError("No space left on device")
        return real(*args, **kwargs)

    monkeypatch.setattr(scipy.io, "savemat", failing)
    existing = tmp_path / "data_3dsar_pass1_az001_HH.mat"
    existing.write_bytes(b"previous content")
    with pytest.raises(OSError, match="No space"):
        write_gotcha(tr, tmp_path, pulses_per_file=50)
    assert sorted(p.name for p in tmp_path.iterdir()) == [existing.name]
    assert existing.read_bytes() == b"previous content"


def test_write_refuses_to_overwrite_when_asked(tmp_path):
    tr = simulate(gotcha_like_scene()).traces
    write_gotcha(tr, tmp_path)
    with pytest.raises(FileExistsError, match="az001"):
        write_gotcha(tr, tmp_path, overwrite=False)


def test_write_rejects_bad_arguments(tmp_path):
    tr = simulate(gotcha_like_scene()).traces
    with pytest.raises(ValueError, match="pulses_per_file"):
        write_gotcha(tr, tmp_path, pulses_per_file=0)
    with pytest.raises(ValueError, match="same name"):
        write_gotcha(tr, tmp_path, pulses_per_file=50, name_pattern="fixed.mat")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------- bad inputs
def test_small_valid_file_reads(tmp_path):
    p = save_struct(tmp_path / "ok.mat", small_struct())
    assert is_gotcha_file(p)
    tr = read_gotcha(p)
    assert tr.shape == (5, 16)


def _bad(tmp_path, name, mutate):
    s = small_struct()
    mutate(s)
    return save_struct(tmp_path / name, s)


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda s: s.pop("fp"), r"no field 'fp'"),
        (lambda s: s.pop("r0"), r"no field 'r0'"),
        (lambda s: s.update(fp=s["fp"][:10]), r"data\.fp has shape \(10, 5\), expected \(16, "),
        (lambda s: s.update(x=s["x"][:, :4]), r"data\.x has shape \(1, 4\), expected \(1, 5\)"),
        (lambda s: s["fp"].__setitem__((3, 2), np.nan), r"data\.fp contains 1 NaN"),
        (
            lambda s: s["z"].__setitem__((0, 1), np.inf),
            r"data\.z contains 1 NaN/inf value\(s\) \(first at pulse 1\)",
        ),
        (lambda s: s["freq"].__setitem__((7, 0), s["freq"][7, 0] + 2e5), r"not a uniform grid"),
        (lambda s: s.update(fp=s["fp"].real.copy()), r"data\.fp must be complex"),
    ],
)
def test_bad_struct_raises_data_error(tmp_path, mutate, message):
    path = _bad(tmp_path, "bad.mat", mutate)
    with pytest.raises(DataError, match=message) as info:
        read_gotcha(path)
    assert str(path) in str(info.value)
    assert "\n" not in str(info.value)


def test_missing_file(tmp_path):
    path = tmp_path / "nope.mat"
    with pytest.raises(DataError, match=r"nope\.mat: file not found"):
        read_gotcha(path)
    assert not is_gotcha_file(path)


def test_text_file_renamed_mat(tmp_path):
    path = tmp_path / "notes.mat"
    path.write_text("these are not radar data\n" * 20)
    with pytest.raises(DataError, match=r"notes\.mat: not a readable MATLAB \.mat file"):
        read_gotcha(path)
    assert not is_gotcha_file(path)


def test_mat_without_data_struct(tmp_path):
    path = tmp_path / "other.mat"
    scipy.io.savemat(path, {"phdata": np.ones((3, 3))})
    with pytest.raises(DataError, match=r"other\.mat: not a GOTCHA file: no MATLAB struct 'data'"):
        read_gotcha(path)
    assert not is_gotcha_file(path)


def test_data_that_is_not_a_struct(tmp_path):
    path = tmp_path / "array.mat"
    scipy.io.savemat(path, {"data": np.ones((3, 3))})
    with pytest.raises(DataError, match=r"'data' must be a 1x1 MATLAB struct"):
        read_gotcha(path)


def test_matlab_v73_file(tmp_path):
    path = tmp_path / "v73.mat"
    with h5py.File(path, "w") as fh:
        fh["data"] = np.ones(3)
    with pytest.raises(DataError, match=r"v73\.mat: MATLAB v7\.3 \(HDF5\)"):
        read_gotcha(path)


def test_inconsistent_frequencies_between_files(tmp_path):
    a = save_struct(tmp_path / "a.mat", small_struct())
    s = small_struct(az0_deg=5 * 0.00853)
    s["freq"] = (s["freq"].astype(np.float64) + 1e6).astype(np.float32)
    b = save_struct(tmp_path / "b.mat", s)
    with pytest.raises(DataError, match=r"b\.mat: frequencies differ from those of a\.mat"):
        read_gotcha([a, b])
    c = save_struct(tmp_path / "c.mat", small_struct(n_freq=12, az0_deg=5 * 0.00853))
    with pytest.raises(DataError, match=r"c\.mat: 12 frequencies, but a\.mat has 16"):
        read_gotcha([a, c])


def test_non_consecutive_and_repeated_files(tmp_path):
    step = 0.00853
    a = save_struct(tmp_path / "a.mat", small_struct(az0_deg=0.0))
    b = save_struct(tmp_path / "b.mat", small_struct(az0_deg=5 * step))
    c = save_struct(tmp_path / "c.mat", small_struct(az0_deg=10 * step))
    assert read_gotcha([c, a, b]).n_pulses == 15
    with pytest.raises(DataError, match=r"c\.mat: does not follow a\.mat: .*consecutive"):
        read_gotcha([a, c])
    with pytest.raises(DataError, match=r"a\.mat: given twice"):
        read_gotcha([a, b, a])
    copy = tmp_path / "copy_of_a.mat"
    copy.write_bytes(a.read_bytes())
    # The same file under two names is called a duplicate, not a gap.
    with pytest.raises(DataError, match=r"copy_of_a\.mat: duplicate of a\.mat: .* same 5 pulses"):
        read_gotcha([a, copy])


def test_autofocus_without_af(tmp_path):
    s = small_struct()
    s.pop("af")
    path = save_struct(tmp_path / "hv.mat", s)
    assert read_gotcha(path).n_pulses == 5  # af is only needed for autofocus
    with pytest.raises(DataError, match=r"hv\.mat: autofocus requested .* no struct data\.af"):
        read_gotcha(path, autofocus=True)


def test_empty_list_and_directory(tmp_path):
    with pytest.raises(DataError, match="no GOTCHA file"):
        read_gotcha([])
    with pytest.raises(DataError, match="not a file"):
        read_gotcha(tmp_path)


@pytest.mark.gotcha
def test_gotcha_dir_fixture_files_are_gotcha(gotcha_files):
    assert len(gotcha_files) == 4
    assert all(is_gotcha_file(p) for p in gotcha_files)
    assert not is_gotcha_file(Path(gotcha_files[0]).parent / "README.md")


# ------------------------------------------------------------------- plausibility rules
def _set(field, pulse, value):
    def mutate(s):
        s[field][0, pulse] = value

    return mutate


def _scale_sample(factor):
    def mutate(s):
        s["fp"][3, 2] *= factor

    return mutate


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        # The findings: an antenna height of ~0, an r0 of 23645 m instead of ~10158 m,
        # a sample 1e6 x the peak.
        (
            _set("z", 2, 1e-3),
            r"data\.x/y/z, pulse 2: .* off the midpoint .*second differences at most 0\.01",
        ),
        (_set("r0", 2, 23645.0), r"data\.r0, pulse 2: 23645 m but the antenna is 10\d\d\d\.\d+ m"),
        (
            _scale_sample(1e6),
            r"data\.fp, pulse 2, frequency index 3: magnitude .*rule: at most 1000 x",
        ),
        (_set("z", 1, -7275.0), r"data\.x/y/z, pulse 1: .* outside the plausible envelope"),
        (_set("x", 4, 9000.0), r"data\.x/y/z, pulse 4: a step of .*rule: the track moves"),
        (_set("y", 2, 1.0), r"data\.x/y/z, pulse 2: the antenna is .* off the midpoint"),
        (_set("th", 0, 12.0), r"data\.th, pulse 0: 12 deg but the antenna position gives"),
        (_set("phi", 3, 30.0), r"data\.phi, pulse 3: 30 deg .*agree to 0\.01 deg"),
    ],
)
def test_implausible_geometry_and_samples_are_refused(tmp_path, mutate, message, caplog):
    path = _bad(tmp_path, "odd.mat", mutate)
    with pytest.raises(DataError, match=message) as info:
        read_gotcha(path)
    text = str(info.value)
    assert text.startswith(f"{path}: ") and "\n" not in text
    assert text.endswith("(--lenient accepts it)")
    # Leniently the same file reads, with the rule logged as a warning.
    with caplog.at_level("WARNING", logger="sarmotion.io"):
        tr = read_gotcha(path, lenient=True)
    assert tr.n_pulses == 5
    assert any("accepted: --lenient" in r.getMessage() for r in caplog.records)


def test_r0_beyond_float32_rounding_is_refused_then_re_referenced_leniently(tmp_path):
    """r0 3 mm off |r| (beyond 2 eps_32 |r| = 2.4 mm at 10.2 km) is refused by default."""
    s = small_struct()
    s["r0"] = (s["r0"].astype(np.float64) + 3e-3).astype(np.float32)
    path = save_struct(tmp_path / "shifted.mat", s)
    with pytest.raises(DataError, match=r"data\.r0, pulse \d: .*rule: agree to 2\.4e-07 x range"):
        read_gotcha(path)
    tr = read_gotcha(path, lenient=True)
    assert tr.metadata["phase_reference"].startswith("re-referenced from data.r0")
    # The re-referenced phase history is the stored one times exp(-i 4 pi f / c dr).
    plain = read_gotcha(save_struct(tmp_path / "plain.mat", small_struct()))
    dr = s["r0"].ravel().astype(np.float64) - np.linalg.norm(plain.positions_m, axis=1)
    ratio = tr.phase_history() / plain.phase_history()
    expected = np.exp(-4j * np.pi * np.outer(dr, tr.frequencies_hz) / C)
    np.testing.assert_allclose(ratio, expected, atol=1e-5)


def test_corrupt_mat_structure_gets_a_short_reason(tmp_path):
    """scipy's internal messages (reshape sizes, codecs) are not shown as the reason."""
    good = save_struct(tmp_path / "good.mat", small_struct())
    raw = bytearray(good.read_bytes())
    raw[200:204] = b"\xff\xff\xff\x7f"  # an array dimension in a header
    bad = tmp_path / "bad.mat"
    bad.write_bytes(bytes(raw))
    with pytest.raises(DataError) as info:
        read_gotcha(bad)
    text = str(info.value)
    assert "reshape" not in text and "codec" not in text and "local variable" not in text
    assert text.startswith(f"{bad}: ")
