"""The collection's region is the data's: the declared image area, tiled at any look.

An X-band arc of 2 degrees at 10 km looking 25 to 60 degrees off the x axis, its CPHD
(written by the block writer) declaring a square scene of +-50 m as its
``SceneCoordinates/ImageArea``: the plan's cores, squares along the look's range and
cross range, hold every point of that square once; the declared area read back is the
one written. Bad input: a declared area outside the data or degenerate, a region below
a core, a plan of too many patches: one line, exit status 2.
"""

from __future__ import annotations

import math
from pathlib import Path

import lxml.etree
import numpy as np
import pytest

from sarmotion.cli.main import EXIT_BAD_INPUT, run
from sarmotion.collection import (
    CollectionOptions,
    RegionError,
    inscribed_box,
    plan_patches,
    unambiguous_scene,
)
from sarmotion.collection.plan import MAX_PATCHES
from sarmotion.core import Acquisition, C, Radar, Trajectory
from sarmotion.core.blocks import TracesBlocks, declared_area
from sarmotion.core.polygon import (
    clip_convex,
    inside_convex,
    inside_polygon,
    polygon_area,
    polygon_problem,
)
from sarmotion.imaging import default_scene_size_m
from sarmotion.io import DataError, open_cphd_blocks, write_cphd_blocks
from sarmotion.simulation import CollectionScene

HALF_M = 50.0
SQUARE = np.array([[-HALF_M, -HALF_M], [HALF_M, -HALF_M], [HALF_M, HALF_M], [-HALF_M, HALF_M]])


def oblique(
    side_m: float, azimuth_deg: float, oversample: float = 1.6, cross: float | None = None
) -> Acquisition:
    """A 2-degree X-band arc at 10 km ground range centred on ``azimuth_deg``.

    The range window is sized for ``oversample`` times the scene's side in slant range,
    the pulse rate for ``cross`` (default ``oversample``) times it in cross range (the
    sampling rules of :func:`~sarmotion.simulation.collection_acquisition`).
    """
    ground, height, aperture = 10e3, 4e3, 2.0
    cos_el = ground / math.hypot(ground, height)
    band, carrier = 300e6, 9.6e9
    window = oversample * side_m * cos_el  # slant range (m)
    df = C / (2.0 * window)
    radar = Radar(
        carrier_hz=carrier, bandwidth_hz=band, n_samples=math.ceil(band / df), frequency_step_hz=df
    )
    per_rad = cos_el * 2.0 * (cross or oversample) * side_m / radar.wavelength_m
    count = math.ceil(np.deg2rad(aperture) * per_rad)
    traj = Trajectory.circular(
        altitude_m=height,
        ground_radius_m=ground,
        speed_mps=150.0,
        pulses_per_deg=count / aperture,
        aperture_deg=aperture,
        centre_azimuth_deg=azimuth_deg,
        n_pulses=count,
    )
    return Acquisition(trajectory=traj, radar=radar, reference_point_m=np.zeros(3))


@pytest.fixture(scope="module", params=[25.0, 40.0, 60.0])
def cphd(request, tmp_path_factory) -> Path:
    # an unambiguous scene of about 310 m x 170 m, as in the file of the report that
    # found the old default (the largest x/y box inside it) a strip
    acq = oblique(2 * HALF_M, request.param, oversample=3.1, cross=1.7)
    scene = CollectionScene(acquisition=acq, stationary=(), movers=())
    path = tmp_path_factory.mktemp("oblique") / "scene.cphd"
    write_cphd_blocks(path, scene, block_pulses=128, image_area_m=SQUARE)
    return path


def test_declared_area_is_read_back(cphd):
    area = declared_area(open_cphd_blocks(cphd))
    # the writer stores it clockwise (CPHD's order): the same square, the other way round
    assert polygon_area(area) == pytest.approx(-polygon_area(SQUARE), rel=1e-12)
    assert {tuple(p) for p in np.round(area, 9)} == {tuple(p) for p in SQUARE}


def test_cores_cover_the_declared_area_at_an_oblique_look(cphd):
    """Every point of the declared square lies in exactly one core, its corners too.

    The look is 25 to 60 degrees off x, so the old default (the largest box along x and
    y inside the unambiguous scene) left parts of the square out; the cores are squares
    along the look's range and cross range.
    """
    src = open_cphd_blocks(cphd)
    plan = plan_patches(src, CollectionOptions())
    assert plan.declared_area_m is not None and plan.declared_outside_m2 == 0.0
    rng = np.random.default_rng(5)
    points = rng.uniform(-HALF_M, HALF_M, size=(20_000, 2))
    corners = 0.999 * SQUARE
    if plan.single:  # today's analysis: its image, a square about the reference, holds it
        assert len(plan.patches) == 1
        return
    held = np.sum([p.inside(np.vstack([points, corners])) for p in plan.patches], axis=0)
    assert np.all(held == 1), f"{np.mean(held == 1):.4%} of the points held once"
    e_r = plan.range_direction
    for p in plan.patches:  # each core a rectangle along the look, its side at most P
        u = p.corners_m[1] - p.corners_m[0]
        v = p.corners_m[3] - p.corners_m[0]
        assert abs(u @ e_r) == pytest.approx(np.linalg.norm(u), rel=1e-9)
        assert abs(v @ e_r) <= 1e-9 * np.linalg.norm(v)
        assert max(np.linalg.norm(u), np.linalg.norm(v)) <= plan.patch_size_m * (1 + 1e-9)


def test_the_largest_xy_box_left_the_declared_corners_out_where_the_cores_do_not():
    """At 25 degrees off x, an unambiguous scene of about 310 m x 170 m: the largest box
    along x and y inside it (the former default) is a strip that misses part of the
    declared +-50 m square; the cores hold all of it."""
    acq = oblique(2 * HALF_M, 25.0, oversample=3.1, cross=1.7)
    src = CollectionScene(
        acquisition=acq, stationary=(), movers=(), metadata={"image_area_m": SQUARE.tolist()}
    )
    points = np.random.default_rng(9).uniform(-HALF_M, HALF_M, size=(20_000, 2))
    x0, y0, x1, y1 = inscribed_box(unambiguous_scene(src))
    in_box = (points[:, 0] >= x0) & (points[:, 0] < x1) & (points[:, 1] >= y0) & (points[:, 1] < y1)
    assert np.mean(in_box) < 0.9
    # one patch by default: today's analysis, whose image (a square about the reference
    # point, 0.6 of the ground-range window and at most 100 m) holds the declared square
    assert plan_patches(src, CollectionOptions()).single
    assert 0.5 * default_scene_size_m(src.traces()) >= HALF_M
    # cut into patches, the cores hold every point of it once
    plan = plan_patches(src, CollectionOptions(patch_size_m=40.0))
    held = np.sum([p.inside(points) for p in plan.patches], axis=0)
    assert len(plan.patches) > 1 and np.all(held == 1)


def test_a_look_frame_region_is_the_box_along_the_look():
    acq = oblique(100.0, 40.0)
    src = CollectionScene(acquisition=acq, stationary=(), movers=())
    plan = plan_patches(src, CollectionOptions(), region_m=(-30, -20, 30, 20), region_frame="look")
    e_r = plan.range_direction
    e_c = np.array([-e_r[1], e_r[0]])
    ab = plan.region_polygon @ np.stack([e_r, e_c], axis=1)
    assert np.allclose(ab, [[-30, -20], [30, -20], [30, 20], [-30, 20]], atol=1e-9)
    assert abs(polygon_area(plan.region_polygon)) == pytest.approx(60 * 40, rel=1e-12)


def test_the_default_without_a_declared_area_is_the_whole_unambiguous_scene():
    src = CollectionScene(acquisition=oblique(100.0, 30.0), stationary=(), movers=())
    plan = plan_patches(src, CollectionOptions())
    amb = unambiguous_scene(src)
    assert plan.declared_area_m is None
    assert abs(polygon_area(plan.region_polygon)) == pytest.approx(
        abs(polygon_area(amb)), rel=1e-12
    )


# ------------------------------------------------------------------ bad input
def _with_area(area) -> TracesBlocks:
    """An oblique acquisition (no targets) whose metadata declare ``area``."""
    src = CollectionScene(acquisition=oblique(100.0, 30.0), stationary=(), movers=())
    tr = src.traces()
    return TracesBlocks(tr.with_data(tr.data, image_area_m=area))


def test_a_declared_area_partly_outside_is_cut_and_said_in_numbers():
    """A square centred on a corner of the unambiguous rectangle: three quarters out."""
    amb = unambiguous_scene(_with_area(None))
    shifted = SQUARE + amb[1]
    plan = plan_patches(_with_area(shifted.tolist()), CollectionOptions())
    whole = abs(polygon_area(SQUARE))
    inside = abs(polygon_area(plan.region_polygon))
    # the rectangle's corner is a right angle, its sides longer than the square's half
    assert inside == pytest.approx(0.25 * whole, rel=1e-9)
    assert plan.declared_outside_m2 == pytest.approx(0.75 * whole, rel=1e-9)
    assert plan.declared_outside_share == pytest.approx(0.75, rel=1e-9)
    assert plan.to_dict()["declared_outside_share"] == pytest.approx(0.75, rel=1e-9)


@pytest.mark.parametrize(
    "area, pattern",
    [
        ((SQUARE + [5000.0, 0.0]).tolist(), "outside the data's unambiguous scene"),
        ([[0, 0], [10, 10], [20, 20], [0, 0]], "no area"),
        ([[0, 0], [10, 0], [10, 0]], "3 distinct vertices"),
        ([[0, 0], [20, 0], [0, 20], [20, 20]], "cross"),
    ],
)
def test_a_bad_declared_area_is_refused(area, pattern):
    with pytest.raises(RegionError, match=pattern):
        plan_patches(_with_area(area))


def _image_area_xml(inner: str):
    ns = "http://api.nsgreg.nga.mil/schema/cphd/1.1.0"
    return lxml.etree.fromstring(
        f'<CPHD xmlns="{ns}"><SceneCoordinates><ImageArea>{inner}</ImageArea>'
        "</SceneCoordinates></CPHD>"
    )


def test_the_reader_refuses_a_degenerate_polygon():
    from sarmotion.io.cphd import _image_area

    box = "<X1Y1><X>-5</X><Y>-5</Y></X1Y1><X2Y2><X>5</X><Y>5</Y></X2Y2>"
    verts = "".join(
        f'<Vertex index="{k + 1}"><X>{x}</X><Y>{y}</Y></Vertex>'
        for k, (x, y) in enumerate([(0, 0), (10, 10), (20, 20)])
    )
    with pytest.raises(DataError, match="ImageArea: the polygon has no area"):
        _image_area(_image_area_xml(box + f'<Polygon size="3">{verts}</Polygon>'), Path("f"))
    got = _image_area(_image_area_xml(box), Path("f"))
    assert np.allclose(got, [[-5, -5], [5, -5], [5, 5], [-5, 5]])


@pytest.mark.parametrize(
    "extra, pattern",
    [
        (["--region", "0", "0", "0.01", "0.01"], "narrower than the least patch core"),
        (["--patch-size", "2"], "resolution cells"),
        (
            ["--region", "-150", "-80", "150", "80", "--region-frame", "look"]
            + ["--patch-size", "5"],
            "a plan may hold",
        ),
        (
            ["--region", "-20", "-10", "20", "10", "--region-frame", "look", "--patch-size", "3"],
            "resolution cells",
        ),
    ],
)
def test_a_region_below_a_core_or_too_many_patches_is_refused(
    cphd, tmp_path, capsys, extra, pattern
):
    out = tmp_path / "out"
    code = run(["analyze", str(cphd), "--out", str(out), "--workers", "0", *extra])
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT
    assert len(err.splitlines()) == 1 and pattern in err, err
    assert not out.exists()


def test_the_patch_count_is_bounded():
    """Cores above the least side, but more of them than a plan may hold: refused."""
    src = CollectionScene(acquisition=oblique(400.0, 30.0), stationary=(), movers=())
    assert len(plan_patches(src, CollectionOptions()).patches) <= MAX_PATCHES
    side = 10.0
    assert abs(polygon_area(unambiguous_scene(src))) / side**2 > MAX_PATCHES
    with pytest.raises(RegionError, match=f"more than the {MAX_PATCHES} a plan may hold"):
        plan_patches(src, CollectionOptions(patch_size_m=side))


# ------------------------------------------------------------------ polygons
def test_polygon_tools_against_known_answers():
    sq = np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float)
    tri = np.array([[1, 1], [2.5, 1], [1, 2.5]], float)
    assert polygon_area(sq) == 4.0 and polygon_area(sq[::-1]) == -4.0
    # the triangle's part inside the square: its area 1.5^2 / 2 less the two corners of
    # legs 0.5 beyond x = 2 and y = 2
    assert abs(polygon_area(clip_convex(tri, sq))) == pytest.approx(1.125 - 0.25, rel=1e-12)
    assert clip_convex(tri + 10, sq).shape[0] == 0
    pts = np.array([[1.0, 1.0], [2.5, 1.0], [0.0, 0.0], [1.9999, 0.5]])
    assert inside_polygon(pts, sq).tolist() == [True, False, True, True]
    # lower sides in, upper sides out: tiles sharing sides hold a point once
    held = inside_convex([[0, 0], [2, 1], [1, 2], [1, 1]], sq)
    assert held.tolist() == [True, False, False, True]
    assert polygon_problem(sq) is None
    assert "cross" in polygon_problem([[0, 0], [2, 0], [0, 2], [2, 2]])


def test_points_on_a_shared_side_of_turned_cores_are_held_once():
    """A target placed on the border of two cores turned 45 degrees lies in one of them.

    On the shared side the coordinate along it is within rounding of 1 in one core and of
    0 in the other; with the sides exactly on that line half of such points fell in
    neither (measured: 5016 of 10000), so the sides are shifted by ``SIDE_SHIFT``.
    """
    c = np.sqrt(0.5)
    e1, e2 = np.array([c, c]), np.array([-c, c])
    a = np.array([0 * e1, 70 * e1, 70 * e1 + 70 * e2, 70 * e2]) + np.array([-50.0, 0.0])
    b = a + 70 * e1
    t = np.linspace(0, 1, 10001)[:-1]
    on_side = a[1] + t[:, None] * (70 * e2)
    held = inside_convex(on_side, a).astype(int) + inside_convex(on_side, b)
    assert np.all(held == 1)


# ------------------------------------------------------- the movers' images beyond
@pytest.mark.parametrize(
    "side_m, patch_m, speed_mps", [(100.0, 30.0, 0.1), (100.0, 30.0, 15.0), (400.0, 75.0, 15.0)]
)
def test_patches_beyond_the_region_reach_a_movers_image_shift(side_m, patch_m, speed_mps):
    """The searched ground is the declared square widened in cross range by a mover's
    image shift, ``v cos(elevation) R / V`` at the largest ground speed ``v`` (a range
    rate ``u_r`` moves the Doppler by ``2 u_r / lambda``, and the stationary Doppler
    changes by ``2 V / (lambda R)`` per metre of cross range), within the unambiguous
    scene: 7 m either side at 0.1 m/s, its whole cross-range extent at 15 m/s (a shift
    of about 1 km, which wraps).

    Every searched point is held: by a core (once), or, where the square's patches hold
    every Doppler of the data (no slow-time filter: the 100 m square), by a square's
    patch whose band reports a mover imaged there (``run.in_band``). With a filter (the
    400 m square) the cores hold all of it. The cores beyond the square search for movers
    only and touch none of it."""
    from types import SimpleNamespace

    from sarmotion.collection.run import in_band

    half = 0.5 * side_m
    square = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    src = CollectionScene(
        acquisition=oblique(side_m, 40.0),
        stationary=(),
        movers=(),
        metadata={"image_area_m": square.tolist()},
    )
    plan = plan_patches(src, CollectionOptions(patch_size_m=patch_m, max_speed_mps=speed_mps))
    slant = math.hypot(10e3, 4e3)
    cos_el = 10e3 / slant
    # at the aperture centre's reference point; the square's corners (the shift's largest
    # there) see a range and a look that differ by their distance over R
    corner = math.hypot(half, half) / slant
    assert plan.image_shift_m == pytest.approx(speed_mps * cos_el * slant / 150.0, rel=corner)
    e_r = plan.range_direction
    to_look = np.stack([e_r, [-e_r[1], e_r[0]]], axis=1)
    region = plan.region_polygon @ to_look
    searched = plan.search_polygon @ to_look
    amb = unambiguous_scene(src) @ to_look
    widened = np.ptp(region[:, 1]) + 2.0 * plan.image_shift_m
    assert np.ptp(searched[:, 1]) == pytest.approx(min(widened, np.ptp(amb[:, 1])), rel=1e-9)
    assert np.ptp(searched[:, 0]) == pytest.approx(np.ptp(region[:, 0]), rel=1e-9)
    rng = np.random.default_rng(3)
    lo, hi = plan.search_polygon.min(axis=0), plan.search_polygon.max(axis=0)
    points = rng.uniform(lo, hi, size=(20_000, 2))
    points = points[inside_polygon(points, plan.search_polygon)]
    held = np.sum([p.inside(points) for p in plan.patches], axis=0)
    assert np.all(held <= 1)
    ours = [p for p in plan.patches if not p.movers_only]
    unfiltered = all(p.taps.size == 1 for p in ours)
    if speed_mps > 1.0:  # the margins for 15 m/s need every Doppler of the 100 m data
        assert unfiltered == (side_m == 100.0)
    if unfiltered:
        traces = src.traces()
        keeps = [in_band(traces, p) for p in ours]
        for x in points[held == 0]:
            fit = SimpleNamespace(position_m=np.r_[x, 0.0], velocity_mps=np.zeros(2))
            assert any(keep(fit) for keep in keeps), x
    else:
        assert np.all(held == 1)
    for p in plan.patches:  # beyond the square: no part of it in the core
        overlap = abs(polygon_area(clip_convex(square, p.corners_m)))
        assert (overlap > 1e-6) != p.movers_only, (p.index, overlap)
    if speed_mps > 1.0 and not unfiltered:  # the whole extent, in cores: some beyond it
        assert sum(p.movers_only for p in plan.patches) > 0


def test_the_mosaic_of_a_scene_without_echoes_is_drawn_without_nan():
    """A null input (every sample zero): the mosaic is zero and its figure finite, no
    warning (a float32 zero over the 1e-300 guard was 0/0)."""
    import warnings

    from sarmotion.collection import analyze_collection
    from sarmotion.report.collection import mosaic_figure

    acq = oblique(2 * HALF_M, 25.0, oversample=3.1, cross=1.7)
    src = CollectionScene(
        acquisition=acq, stationary=(), movers=(), metadata={"image_area_m": SQUARE.tolist()}
    )
    res = analyze_collection(src.traces(), CollectionOptions(patch_size_m=40.0), n_workers=0)
    assert len(res.plan.patches) > 1 and not res.movers and not res.stationary
    assert np.all(res.mosaic == 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        fig = mosaic_figure(res)
    assert np.all(np.isfinite(fig.axes[0].images[0].get_array()))
