"""Scene files: the built-in scenes of the paper and clear errors for bad files."""

import numpy as np
import pytest

from sarmotion.simulation import Scene, SceneError, builtin_scene_names, load_scene

COUNTS = {
    "example1": (7, 1),
    "example2": (30, 1),
    "scene1": (20, 2),
    "filter10": (10, 1),
    "filter30": (30, 1),
    "hyperbola": (1, 0),
    "rotscatt": (1, 1),
}


@pytest.mark.parametrize("name", sorted(COUNTS))
def test_builtin_scenes_match_the_paper(name):
    scene = load_scene(name)
    assert (len(scene.stationary), len(scene.moving)) == COUNTS[name]
    for t in scene.stationary:
        assert np.all(np.abs(t.position_m[:2]) <= 25.0)  # the 50 x 50 m^2 region
    for t in scene.moving:
        assert np.linalg.norm(t.velocity_mps) in (pytest.approx(28.0), pytest.approx(14.0))
    scene.trajectory()


def test_builtin_names():
    assert set(COUNTS) <= set(builtin_scene_names())


def test_example1_positions_from_the_paper():
    scene = load_scene("example1")
    got = sorted(tuple(t.position_m[:2]) for t in scene.stationary)
    want = sorted([(0, 0), (5, 0), (-5, 0), (0, 5), (0, -5), (10, 0), (-10, 0)])
    np.testing.assert_allclose(got, want)
    (mover,) = scene.moving
    np.testing.assert_allclose(mover.velocity_mps, 28 / np.sqrt(2) * np.ones(2), rtol=1e-6)


def test_scene1_movers():
    movers = load_scene("scene1").moving
    np.testing.assert_allclose(movers[1].position_m[:2], [-5, 5])
    np.testing.assert_allclose(
        movers[1].velocity_mps, 14 / np.sqrt(3) * np.array([-1, np.sqrt(2)]), rtol=1e-6
    )


def test_dict_round_trip():
    scene = load_scene("scene1")
    again = Scene.from_dict(scene.to_dict())
    assert len(again.targets) == len(scene.targets)
    for a, b in zip(scene.targets, again.targets, strict=True):
        np.testing.assert_allclose(a.position_m, b.position_m)
        np.testing.assert_allclose(a.velocity_mps, b.velocity_mps)
        assert a.reflectivity == pytest.approx(b.reflectivity)


def _write(tmp_path, text):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        (
            "[[targets]]\nposition_m = [0, 0]\nvelocty_mps = [1, 0]\n",
            r"unknown key 'targets\[0\]\.velocty_mps'",
        ),
        (
            "[[targets]]\nposition_m = [0, 'a']\n",
            r"targets\[0\]\.position_m must be .* got \[0, 'a'\]",
        ),
        ("[[targets]]\nvelocity_mps = [1, 0]\n", r"targets\[0\]\.position_m is missing"),
        ("colour = 3\n[[targets]]\nposition_m = [0, 0]\n", "unknown key 'colour'"),
        ("[trajectory]\nkind = 'spiral'\n[[targets]]\nposition_m = [0, 0]\n", "trajectory.kind"),
        ("[trajectory]\naperture_deg = -1\n[[targets]]\nposition_m = [0, 0]\n", "aperture_deg"),
        ("[radar]\npulse = 'square'\n[[targets]]\nposition_m = [0, 0]\n", "pulse"),
        ("name = 'x'\n", "targets must be a non-empty array"),
        ("this is not toml [\n", "not a valid TOML"),
    ],
)
def test_bad_scene_files_name_the_problem(tmp_path, text, pattern):
    with pytest.raises(SceneError, match=pattern):
        Scene.from_file(_write(tmp_path, text))


def test_missing_and_unknown_scenes(tmp_path):
    with pytest.raises(SceneError, match="scene file not found"):
        load_scene(tmp_path / "nope.toml")
    with pytest.raises(SceneError, match="unknown scene 'scene9'"):
        load_scene("scene9")


# ------------------------------------------------------------------ unambiguous scene
# The default acquisition: GOTCHA's radar and one degree of its circle.
from sarmotion.core import C, Radar  # noqa: E402
from sarmotion.core.geometry import (  # noqa: E402
    GOTCHA_ALTITUDE_M,
    GOTCHA_GROUND_RADIUS_M,
    GOTCHA_PULSES_PER_DEG,
)
from sarmotion.simulation import check_aliasing  # noqa: E402

COS_PSI = GOTCHA_GROUND_RADIUS_M / np.hypot(GOTCHA_GROUND_RADIUS_M, GOTCHA_ALTITUDE_M)
#: Ground-range window of the default radar at the aperture centre (m): c / (2 df cos psi).
WINDOW_GROUND_M = C / (2.0 * Radar().frequency_step_hz * COS_PSI)
#: Alias-free cross-range extent of the default circle (m): lambda / (2 cos psi dphi).
EXTENT_CROSS_M = Radar().wavelength_m / (2.0 * COS_PSI * np.deg2rad(1.0 / GOTCHA_PULSES_PER_DEG))


def _scene_text(targets, radar="", trajectory=""):
    out = []
    if radar:
        out += ["[radar]", radar]
    if trajectory:
        out += ["[trajectory]", trajectory]
    for pos, vel in targets:
        out += ["[[targets]]", f"position_m = [{float(pos[0])!r}, {float(pos[1])!r}]"]
        if vel is not None:
            out += [f"velocity_mps = [{float(vel[0])!r}, {float(vel[1])!r}]"]
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("name", sorted(COUNTS))
def test_builtin_scenes_lie_inside_their_unambiguous_scene(name):
    check_aliasing(load_scene(name))  # raises on a target that aliases


@pytest.mark.parametrize("share", [0.97, 1.03])
def test_range_window_bounds_a_target_in_ground_range(tmp_path, share):
    # x is ground range for the default look (antenna towards +x).
    x = -share * 0.5 * WINDOW_GROUND_M
    path = _write(tmp_path, _scene_text([((0.0, 0.0), None), ((x, 0.0), None)]))
    if share < 1:
        Scene.from_file(path)
        return
    with pytest.raises(SceneError) as info:
        Scene.from_file(path)
    text = str(info.value)
    assert "\n" not in text and text.startswith(str(path))
    assert "targets[1] at (" in text
    assert f"{WINDOW_GROUND_M:.6g} m of ground range" in text  # the extent, from c / (2 df)
    assert "radar.frequency_step_hz <=" in text and "radar.n_samples >=" in text
    assert "--lenient" in text
    # the step it names fits the target, with the sample count it names (same band)
    df = float(text.split("radar.frequency_step_hz <= ")[1].split(" Hz")[0])
    n = int(text.split("radar.n_samples >= ")[1].split(" ")[0])
    assert df < Radar().frequency_step_hz
    Scene.from_file(
        _write(
            tmp_path,
            _scene_text(
                [((0.0, 0.0), None), ((x, 0.0), None)],
                radar=f"frequency_step_hz = {float(df * (1 - 1e-6))!r}\nn_samples = {n}",
            ),
        )
    )


@pytest.mark.parametrize("share", [0.97, 1.03])
def test_cross_range_extent_bounds_a_target_on_the_circle(tmp_path, share):
    y = share * 0.5 * EXTENT_CROSS_M
    path = _write(tmp_path, _scene_text([((0.0, y), None)]))
    if share < 1:
        Scene.from_file(path)
        return
    with pytest.raises(SceneError, match=r"trajectory\.pulses_per_deg >= ") as info:
        Scene.from_file(path)
    text = str(info.value)
    assert f"extent of {EXTENT_CROSS_M:.6g} m" in text and "\n" not in text
    ppd = float(text.split("pulses_per_deg >= ")[1].split(" ")[0])
    # the density it names fits the target (same aperture, more pulses)
    Scene.from_file(
        _write(
            tmp_path,
            _scene_text([((0.0, y), None)], trajectory=f"pulses_per_deg = {float(ppd * 1.001)!r}"),
        )
    )


def test_cross_range_extent_of_a_straight_path_is_lambda_r_over_2dx(tmp_path):
    dx, R = 2.0, 10_000.0
    traj = (
        f'kind = "linear"\ncentre_m = [{R / np.sqrt(2)}, 0.0, {R / np.sqrt(2)}]\n'
        f"pulse_spacing_m = {dx}\naperture_m = 200.0"
    )
    extent = Radar().wavelength_m * R / (2.0 * dx)  # broadside: the path along the cross range
    Scene.from_file(_write(tmp_path, _scene_text([((0.0, 0.47 * extent), None)], trajectory=traj)))
    with pytest.raises(SceneError, match=r"trajectory\.pulse_spacing_m <= ") as info:
        Scene.from_file(
            _write(tmp_path, _scene_text([((0.0, 0.53 * extent), None)], trajectory=traj))
        )
    assert f"extent of {extent:.4g}" in str(info.value).replace(f"{extent:.6g}", f"{extent:.4g}")


def test_a_mover_is_checked_along_its_path(tmp_path):
    # inside the window at s = 0, out of it by the aperture's end (0.88 s at 60 m/s: 53 m)
    x = -0.4 * WINDOW_GROUND_M
    Scene.from_file(_write(tmp_path, _scene_text([((x, 0.0), None)])))
    with pytest.raises(SceneError, match=r"targets\[0\] .* moving, at"):
        Scene.from_file(_write(tmp_path, _scene_text([((x, 0.0), (60.0, 0.0))])))


def test_lenient_warns_where_the_target_aliases_to(tmp_path, caplog):
    x = -110.0
    path = _write(tmp_path, _scene_text([((0.0, 0.0), None), ((x, 0.0), (6.0, 8.0))]))
    with caplog.at_level("WARNING", logger="sarmotion.simulation"):
        scene = load_scene(path, lenient=True)
    assert len(scene.moving) == 1
    (record,) = [r for r in caplog.records if "aliases to about" in r.getMessage()]
    alias = float(record.getMessage().split("aliases to about ")[1].split(" m")[0])
    assert alias == pytest.approx(x + WINDOW_GROUND_M, abs=0.01)  # folded by one window


# ------------------------------------------------------------------ hostile files
@pytest.mark.parametrize(
    "text",
    [
        "x = " + "[" * 5000 + "]" * 5000 + "\n",
        "x = " + "{a = " * 3000 + "1" + "}" * 3000 + "\n",
        "[" + ".".join(["a"] * 20000) + "]\n",
        "[[targets]]\nposition_m = [0, 0]\nlabel." + ".".join(["b"] * 50) + " = 1\n",
    ],
)
def test_deep_nesting_is_refused_in_one_line(tmp_path, text):
    with pytest.raises(SceneError, match=r"more than 8 deep") as info:
        Scene.from_file(_write(tmp_path, text))
    assert "\n" not in str(info.value)


def test_brackets_in_strings_and_comments_are_not_nesting(tmp_path):
    text = (
        '# [[[[[[[[[[[[\nname = "[[[[[[[[[[[["\ndescription = """{{{{{{{{{{\n]]]]"""\n'
        "[[targets]]\nposition_m = [0, 0]\nlabel = '[[[[[[[[[[[['\n"
    )
    assert Scene.from_file(_write(tmp_path, text)).name == "[[[[[[[[[[[["


@pytest.mark.parametrize(
    ("setting", "pattern"),
    [
        (
            '[trajectory]\nkind = "linear"\ncentre_m = [7000, 0, 7000]\npulse_spacing_m = 0',
            r"trajectory\.pulse_spacing_m must be > 0",
        ),
        (
            '[trajectory]\nkind = "linear"\ncentre_m = [7000, 0, 7000]\npulse_spacing_m = 1e-320',
            r"aperture_m / pulse_spacing_m is not a finite number of pulses",
        ),
        ("[trajectory]\naltitude_m = 1e30", r"altitude_m must be at most 1e\+06 m"),
        ("[trajectory]\nground_radius_m = 1e30", r"ground_radius_m must be at most 1e\+06 m"),
        (
            "[trajectory]\nground_radius_m = 999000.0\naltitude_m = 100000.0",
            r"is 1.00399e\+06 m from the reference point; the readers accept 10 to 1e\+06 m",
        ),
        ("[trajectory]\ncentre_azimuth_deg = 1e308", r"centre_azimuth_deg must be within -360"),
        ("[trajectory]\npulses_per_deg = 1e-320\nn_pulses = 16", r"within one turn"),
        ("[trajectory]\npulses_per_deg = 1e30\nn_pulses = 16", r"less than 1e-09 of its range"),
        ("[radar]\nfrequency_step_hz = 1e308", r"lowest sampled frequency"),
        ("reference_point_m = [1e308, 0.0]", r"targets\[0\]\.position_m must lie within 1e\+06 m"),
        ("[trajectory]\nground_radius_m = 1e5", r"grazing angle of 4.18 deg"),
        ("[trajectory]\nspeed_mps = 1e30", r"speed_mps must be within 0.001 to 10000 m/s"),
        ("[trajectory]\nspeed_mps = 1e-9", r"speed_mps must be within"),
        ("[radar]\ncarrier_hz = 1e30", r"carrier_hz must be within 3e\+06 to 3e\+12 Hz"),
        ("[trajectory]\nn_pulses = 1", r"n_pulses must be >= 2"),
    ],
)
def test_values_outside_the_readers_bounds_are_refused(tmp_path, setting, pattern):
    text = setting + "\n[[targets]]\nposition_m = [1.0, 2.0]\n"
    with pytest.raises(SceneError, match=pattern) as info:
        Scene.from_file(_write(tmp_path, text))
    assert "\n" not in str(info.value)


def test_the_bounds_are_the_readers(tmp_path):
    from sarmotion.io import plausibility

    assert plausibility.SPEED_RANGE_MPS == (1e-3, 1e4)
    edge = "[trajectory]\nspeed_mps = 1e4\n[[targets]]\nposition_m = [1.0, 2.0]\n"
    Scene.from_file(_write(tmp_path, edge))


@pytest.mark.parametrize(
    ("amplitude", "ok"),
    [(1e-15, True), (1e-16, False), (1e-300, False), (1e14, True), (1e15, False)],
)
def test_amplitudes_within_float32_power_range(tmp_path, amplitude, ok):
    text = f"[[targets]]\nposition_m = [1.0, 2.0]\namplitude = {amplitude!r}\n"
    if ok:
        assert abs(Scene.from_file(_write(tmp_path, text)).targets[0].reflectivity) == amplitude
    else:
        with pytest.raises(SceneError, match="amplitude must be within 1e-15 to 1e"):
            Scene.from_file(_write(tmp_path, text))
