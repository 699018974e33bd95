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
