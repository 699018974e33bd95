"""A two-patch collection end to end: a mover on the border, Dask workers, the command line."""

from __future__ import annotations

import dataclasses
import json
import logging
from types import SimpleNamespace

import numpy as np
import pytest

from sarmotion.cli.main import EXIT_BAD_INPUT, run
from sarmotion.collection import CollectionOptions, analyze_collection, plan_patches
from sarmotion.core import Radar, Traces, Trajectory, range_speed, to_fast_time
from sarmotion.core.blocks import TracesBlocks
from sarmotion.imaging import resolution
from sarmotion.motion import family_member
from sarmotion.pipeline import AnalysisOptions
from sarmotion.simulation import PointTarget, simulate_phase_history

REGION = (-60.0, -25.0, 60.0, 25.0)
#: The region's two patches alone (``--no-search-beyond``): the patches beyond it that
#: search for movers only are ``test_collection_doppler.py``'s.
OPTIONS = CollectionOptions(
    analysis=AnalysisOptions(trajectory=False),
    patch_size_m=60.0,
    max_speed_mps=15.0,
    search_beyond=False,
)
#: Stationary points, both cores; and a mover 2 m from the border x = 0 between them.
STATIONARY = [
    (-40.0, -10.0),
    (-25.0, 12.0),
    (-8.0, -18.0),
    (20.0, 8.0),
    (35.0, -12.0),
    (48.0, 15.0),
]
MOVER = PointTarget(position_m=(2.0, 4.0), velocity_mps=(-6.0, 7.0), reflectivity=0.8j)


@pytest.fixture(scope="module")
def scene() -> Traces:
    traj, radar = Trajectory.circular(), Radar()
    targets = [PointTarget(position_m=p) for p in STATIONARY] + [MOVER]
    ph = simulate_phase_history(targets, traj, radar, (0.0, 0.0, 0.0))
    return Traces(
        data=to_fast_time(ph),
        trajectory=traj,
        radar=radar,
        reference_point_m=(0.0, 0.0, 0.0),
        metadata={"source": "simulation", "scene": "two patches"},
    )


@pytest.fixture(scope="module")
def default_result(scene):
    return analyze_collection(scene, OPTIONS, region_m=REGION)


def _family_error(traces: Traces, position, velocity, truth: PointTarget):
    """(range position (m), range speed (m/s)) error with the truth slid along its family."""
    cells = resolution(traces)
    dy = float((np.asarray(position)[:2] - truth.position_m[:2]) @ cells.cross_range_direction)
    p, v, _ = family_member(traces, truth.position_m, truth.velocity_mps, dy)
    geom = traces.geometry
    return (
        float((np.asarray(position)[:2] - p[:2]) @ cells.range_direction),
        range_speed(velocity, geom) - range_speed(v, geom),
    )


def test_two_patches_find_the_border_mover_once_and_every_stationary_point(scene, default_result):
    res = default_result
    assert len(res.plan.patches) == 2
    assert [p.contains(MOVER.position_m) for p in res.plan.patches] == [False, True]
    assert len(res.movers) == 1, [m.position_m for m, _ in res.movers]
    (m, patches) = res.movers[0]
    dx, du = _family_error(scene, m.position_m, m.velocity_mps, MOVER)
    cells = resolution(scene)
    # within the family-rule accuracy: a range cell, half a range-speed resolution
    assert abs(dx) <= cells.ground_range_m
    assert abs(du) <= 0.5 * scene.radar.range_resolution_m / (0.5 * np.ptp(scene.slow_times_s))
    found = np.array([t.position_m for t in res.stationary])
    cell = max(cells.ground_range_m, cells.cross_range_m)
    for p in STATIONARY:
        assert np.min(np.hypot(*(found - p).T)) <= cell, p
    assert res.stationary_dropped == 0
    assert res.mosaic.shape[0] > 0 and np.isfinite(res.mosaic).all()


@pytest.mark.filterwarnings("ignore:Port .* is already in use")
def test_distributed_process_workers_give_the_same_answers(scene, default_result, tmp_path):
    import dask
    from distributed import Client, LocalCluster

    with (
        dask.config.set({"temporary-directory": str(tmp_path)}),
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
            host="127.0.0.1",
            local_directory=str(tmp_path),
        ) as cluster,
        Client(cluster) as client,
    ):
        res = analyze_collection(scene, OPTIONS, region_m=REGION, scheduler=client)
    assert len(res.movers) == len(default_result.movers)
    for (a, pa), (b, pb) in zip(res.movers, default_result.movers, strict=True):
        assert pa == pb
        assert np.allclose(a.position_m, b.position_m, atol=1e-6)
        assert np.allclose(a.velocity_mps, b.velocity_mps, atol=1e-6)
    assert np.allclose(
        [t.position_m for t in res.stationary],
        [t.position_m for t in default_result.stationary],
        atol=1e-6,
    )


@pytest.mark.filterwarnings("ignore:Port .* is already in use")
def test_a_scheduler_given_by_its_address_gives_the_same_answers(scene, default_result, tmp_path):
    """``--scheduler tcp://...``: a client of our own, not the process's default one.

    The cluster here has no client of its own (as a scheduler started with ``dask
    scheduler`` has none in this process): the collection must not reach for Dask's
    default client anywhere.
    """
    import dask
    from distributed import LocalCluster

    with (
        dask.config.set({"temporary-directory": str(tmp_path)}),
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=False,
            protocol="tcp://",
            host="127.0.0.1",
            dashboard_address=None,
            silence_logs=logging.ERROR,
        ) as cluster,
    ):
        res = analyze_collection(
            scene, OPTIONS, region_m=REGION, scheduler=cluster.scheduler_address
        )
    assert [p for _, p in res.movers] == [p for _, p in default_result.movers]
    for (a, _), (b, _) in zip(res.movers, default_result.movers, strict=True):
        assert np.allclose(a.velocity_mps, b.velocity_mps, atol=1e-6)


def test_patches_in_process_give_the_same_answers_and_mosaic(scene, default_result):
    """``n_workers=0`` (no Dask, BLAS on one thread) against the local cluster."""
    res = analyze_collection(scene, OPTIONS, region_m=REGION, n_workers=0)
    assert len(res.movers) == len(default_result.movers)
    for (a, pa), (b, pb) in zip(res.movers, default_result.movers, strict=True):
        assert pa == pb
        assert np.allclose(a.position_m, b.position_m, atol=1e-6)
        assert np.allclose(a.velocity_mps, b.velocity_mps, atol=1e-6)
    assert np.allclose(
        [t.position_m for t in res.stationary],
        [t.position_m for t in default_result.stationary],
        atol=1e-6,
    )
    assert res.stationary_sidelobes == default_result.stationary_sidelobes
    np.testing.assert_allclose(res.mosaic, default_result.mosaic, rtol=1e-4, atol=0)
    # the patches' images were pasted into the mosaic, not kept
    assert all(r.image is None for r in res.patches)


@pytest.mark.parametrize("suffix", [".h5", ".cphd"])
def test_command_line_collection_outputs(scene, tmp_path, capsys, suffix):
    """Native and CPHD files go through their block readers: the same two patches."""
    from sarmotion.io import save_traces, write_cphd

    src = tmp_path / f"two{suffix}"
    (save_traces if suffix == ".h5" else write_cphd)(src, scene)
    out = tmp_path / "out"
    code = run(
        [
            "analyze",
            str(src),
            "--out",
            str(out),
            "--region",
            *map(str, REGION),
            "--patch-size",
            "60",
            "--workers",
            "0",
            "--no-trajectory",
            "--no-search-beyond",
        ]
    )
    assert code == 0, capsys.readouterr().err
    doc = json.loads((out / "results.json").read_text())
    assert doc["schema"] == "sarmotion.results/3"
    assert doc["options"]["search_beyond"] is False
    assert len(doc["plan"]["patches"]) == 2
    # the patches of a collection search their stationary band unless told not to
    assert doc["options"]["analysis"]["defocus_search"] is True
    assert len(doc["movers"]) == 1
    assert all("patch" in m and m["patch"] in m["patches"] for m in doc["movers"])
    assert doc["stationary_dropped"] == 0
    assert (out / "report.html").exists() and (out / "mosaic.png").exists()


@pytest.mark.parametrize(
    "extra, pattern",
    [
        (["--region", "500", "0", "600", "10"], "--region"),
        (["--patch-size", "0.2"], "resolution cell"),
        (["--region", "10", "0", "0", "10"], "X0 < X1"),
        (["--workers", "-1"], "--workers"),
    ],
)
def test_bad_collection_input_is_one_line_and_exit_2(tmp_path, capsys, extra, pattern):
    out = tmp_path / "out"
    code = run(["analyze", "scene1", "--out", str(out), *extra])
    err = capsys.readouterr().err.strip()
    assert code == EXIT_BAD_INPUT
    assert len(err.splitlines()) == 1 and pattern in err, err
    assert not out.exists()


def test_plan_of_the_test_scene_is_two_patches(scene):
    plan = plan_patches(TracesBlocks(scene), OPTIONS, region_m=REGION)
    # cores along the look's range and cross range: here x and y, to float64 rounding
    cores = [p.core_m for p in plan.patches]
    assert np.allclose(cores, [(-60.0, -25.0, 0.0, 25.0), (0.0, -25.0, 60.0, 25.0)], atol=1e-9)


def _held(scene: Traces, patch, points: np.ndarray) -> np.ndarray:
    """Ground points whose stationary echo, at the aperture centre, lies in ``patch``'s
    fast-time window and in its slow-time band (up to the filter's stop band; every
    Doppler, wrapping at the pulse rate, without a filter)."""
    from sarmotion.collection.plan import BAND_GUARD
    from sarmotion.core import C

    traj, radar = scene.trajectory, scene.radar
    j0 = int(np.argmin(np.abs(traj.slow_times_s)))
    near = slice(j0 - 1, j0 + 2)  # the centre pulse and its neighbours
    pos, s = traj.positions_m[near], traj.slow_times_s[near]
    pts = np.concatenate([points, np.zeros((len(points), 1))], axis=1)
    centre = np.asarray(patch.centre_m, float)
    delay = (
        2.0
        / C
        * (np.linalg.norm(pos[None] - pts[:, None], axis=2) - np.linalg.norm(pos - centre, axis=1))
    )
    doppler = radar.carrier_hz * (delay[:, 2] - delay[:, 0]) / (s[2] - s[0])
    prf = 1.0 / traj.pulse_interval_s
    edge = prf / 2 if patch.taps.size == 1 else (1 + 2 * BAND_GUARD) * patch.passband_hz
    window = np.abs(delay[:, 1]) <= 0.5 * patch.n_samples * radar.sample_interval_s
    if patch.taps.size == 1 and patch.decimation == patch.interpolation == 1:
        return window
    return window & (np.abs(doppler) <= min(edge, prf / 2))


def _scene_points(plan, n: int = 41) -> np.ndarray:
    """A grid of ground points over the unambiguous scene (m)."""
    from sarmotion.core.polygon import inside_convex

    amb = plan.unambiguous_m
    lo, hi = amb.min(axis=0), amb.max(axis=0)
    xx, yy = np.meshgrid(np.linspace(lo[0], hi[0], n), np.linspace(lo[1], hi[1], n))
    pts = np.stack([xx.ravel(), yy.ravel()], axis=1)
    return pts[inside_convex(pts, amb)]


def test_a_patch_images_every_stationary_echo_its_traces_hold(scene):
    """The combined separation takes out the stationary targets its preliminary image
    holds; one whose echo is in a patch's window and band but off its image stays in
    ``S`` and lifts the floor of ``g(u)`` (a mover's statistic 1.3-1.5 dB lower than in
    the whole-trace analysis, benchmarks/results/look_azimuth.md). Each patch's image
    holds every point its traces hold; its core's box alone did not."""
    from sarmotion.collection.run import _patch_options

    plan = plan_patches(TracesBlocks(scene), OPTIONS, region_m=REGION)
    points = _scene_points(plan)
    for p in plan.patches:
        held = _held(scene, p, points)
        assert held.any()
        reach = np.max(np.abs(points[held] - np.asarray(p.centre_m[:2])), axis=1)
        size = _patch_options(p, OPTIONS.analysis, False).image_size_m
        assert np.all(reach <= 0.5 * size + 1e-9), (p.index, reach.max(), size)
        assert np.any(reach > 0.5 * p.size_m)  # the core's box leaves some out
        # a separation without an image (robust PCA) keeps the core's box
        assert _patch_options(p, OPTIONS.analysis, False, halo=False).image_size_m == p.size_m


def test_a_patch_lists_its_core_from_an_image_of_its_core(scene, monkeypatch):
    """The stationary image that lists a patch's targets and fills the mosaic covers the
    core's box and its margin, not the halo the separation images; the core's targets
    are the same as from the halo's image (here points of one amplitude: the same
    brightest pixel), and the mosaic's pixels the same to the images' float32 rounding."""
    import sarmotion.collection.run as run
    from sarmotion.collection.extract import extract_patches

    plan = plan_patches(TracesBlocks(scene), OPTIONS, region_m=REGION)
    traces = extract_patches(TracesBlocks(scene), plan.patches)
    opts = dataclasses.replace(OPTIONS.analysis, image_method="exact")
    for p, tr in zip(plan.patches, traces, strict=True):
        box = run.stationary_box(tr, p)
        slim, res = run.analyze_patch(tr, p, opts)
        g = res.stationary_image.grid
        x0, x1, y0, y1 = g.extent
        dx, dy = g.spacing_m
        # within the box, and over the core to a pixel
        assert box[0] - dx <= x0 <= p.core_m[0] and p.core_m[2] <= x1 <= box[2] + dx
        assert box[1] - dy <= y0 <= p.core_m[1] and p.core_m[3] <= y1 <= box[3] + dy
        assert g.shape[0] * g.shape[1] < 0.5 * res.preliminary_image.grid.shape[0] ** 2
        with monkeypatch.context() as m:
            m.setattr(run, "stationary_box", lambda traces, patch: None)
            halo, _ = run.analyze_patch(tr, p, opts)
        assert [t.position_m for t in slim.stationary] == [t.position_m for t in halo.stationary]
        assert np.allclose([t.level for t in slim.stationary], [t.level for t in halo.stationary],
                           rtol=1e-6)  # fmt: skip
        assert slim.image is not None and halo.image is not None
        assert np.array_equal(slim.image.x_m, halo.image.x_m)
        assert np.array_equal(slim.image.y_m, halo.image.y_m)
        peak = float(halo.image.magnitude.max())
        assert np.max(np.abs(slim.image.magnitude - halo.image.magnitude)) <= 1e-5 * peak


@pytest.mark.parametrize("azimuth_deg", [0.0, 30.0, 135.0])
def test_a_patch_outline_holds_every_stationary_echo_its_traces_hold(azimuth_deg):
    """Where a slow-time filter bounds a patch's band (a 400 m scene at 1.6 times its
    pulse rate: patches of a fraction of it), its halo outline, the only pixels of its
    preliminary image, holds every ground point whose echo its window and band hold,
    the square image holds the outline, and the outline is a fraction of the square."""
    from sarmotion.collection.run import _patch_options
    from sarmotion.imaging import in_outline

    acq = _look_azimuth_acquisition(azimuth_deg, side=400.0)
    traces = Traces(
        data=np.zeros((acq.n_pulses, acq.radar.n_samples), np.complex64),
        trajectory=acq.trajectory,
        radar=acq.radar,
        reference_point_m=acq.reference_point_m,
        metadata={"image_area_m": [[-200, -200], [200, -200], [200, 200], [-200, 200]]},
    )
    plan = plan_patches(TracesBlocks(traces), CollectionOptions())
    points = _scene_points(plan, n=81)
    outlined = [p for p in plan.patches if p.halo_outline_m is not None]
    assert len(outlined) == len(plan.patches) > 4
    for p in outlined[:: max(1, len(outlined) // 8)]:
        held = _held(traces, p, points)
        assert held.any()
        assert np.all(in_outline(points[held], p.halo_outline_m)), p.index
        size = _patch_options(p, AnalysisOptions(), False).image_size_m
        reach = np.abs(p.halo_outline_m - p.centre_m[:2]).max()
        assert reach <= 0.5 * size + 1e-9
        o = p.halo_outline_m
        u, v = o[1] - o[0], o[3] - o[0]
        assert abs(u[0] * v[1] - u[1] * v[0]) < 0.6 * size**2


@pytest.mark.slow
def test_stationary_points_the_pulse_rate_wraps_into_a_patch_are_no_movers():
    """A 500 m square seen at 30 degrees spans 683 m in cross range; a pulse rate sized
    for 500 m wraps the Doppler of the points near two of its corners onto the far side
    of the scene, where their echoes have the range walk of points about 500 m away: to a
    patch there, a mover of 5-7 m/s. The analysis of the whole data tests such a
    candidate against the stationary point of its range history anywhere in the data's
    alias-free extent; each patch now does the same (``Patch.alias_free_m``), where it
    tested only its own, one pulse in ``q`` (9 false movers on this null before)."""
    side, half = 500.0, 250.0
    acq = _look_azimuth_acquisition(30.0, side=side, over=1.6, rate_over=1.0)
    rng = np.random.default_rng(5)
    from sarmotion.simulation import CollectionScene

    sc = CollectionScene(
        acquisition=acq,
        stationary=tuple(
            PointTarget(position_m=p) for p in rng.uniform(-0.9 * half, 0.9 * half, (30, 2))
        ),
        movers=(),
        snr_db=-20.0,
        seed=3,
        metadata={
            "source": "simulation",
            "image_area_m": [[-half, -half], [half, -half], [half, half], [-half, half]],
        },
    )
    traces = sc.traces()
    res = analyze_collection(traces, CollectionOptions(analysis=AnalysisOptions(trajectory=False)))
    extent = [p.alias_free_m for p in res.plan.patches]
    # the rate covers about 500 m of the square's 683 m in cross range
    assert all(e is not None and 0.9 * side < e[2] < 1.1 * side for e in extent)
    assert any(p.decimation > 1 for p in res.plan.patches)
    assert len(res.movers) == 0, [(m.position_m, m.velocity_mps) for m, _ in res.movers]


def test_the_false_alarm_rate_is_shared_by_the_data_the_patches_report(scene):
    """Patch ``p`` tests at ``alpha_p = alpha min(1, |H_p| / sum |K_q|)``: a null candidate
    anywhere in the data it holds (``H_p``) is reported only where its band keeps it
    (``K_p``, :func:`in_band`), so the collection reports a false mover with probability
    at most ``sum alpha_p |K_p| / |H_p| <= alpha``, measured here on a grid of points;
    and each ``g(u)`` threshold rises by ``s ln(1 / share)``, less than the ``s ln N``
    of ``alpha / N`` where the patches hold the same data."""
    from sarmotion.collection.extract import make_traces
    from sarmotion.collection.run import in_band, patch_false_alarm
    from sarmotion.motion import NULL_TAIL, threshold_db

    src = TracesBlocks(scene)
    plan = plan_patches(src, OPTIONS, region_m=REGION)
    points = _scene_points(plan)
    total = 0.0
    options = AnalysisOptions(false_alarm_rate=0.01)
    for p in plan.patches:
        held = _held(scene, p, points)
        tr = make_traces(p, src, np.zeros((p.pulses.size, p.n_samples), np.complex64))
        keep = in_band(tr, p)
        # keep reads a fit's position and velocity: a stationary point's
        kept = [
            keep(SimpleNamespace(position_m=np.r_[x, 0.0], velocity_mps=np.zeros(2)))
            for x in points[held]
        ]
        total += p.false_alarm_share * np.mean(kept)
        per_patch = patch_false_alarm(options, p)
        assert per_patch.false_alarm_rate == pytest.approx(0.01 * p.false_alarm_share)
        rise = threshold_db(per_patch.false_alarm_rate, 50) - threshold_db(0.01, 50)
        assert rise == pytest.approx(NULL_TAIL["scale_db"] * np.log(1 / p.false_alarm_share))
        assert 1 / len(plan.patches) < p.false_alarm_share < 1  # the two hold common data
    assert total <= 1.0 + 0.02, total
    one = dataclasses.replace(plan.patches[0], false_alarm_share=1.0)
    assert patch_false_alarm(options, one) is options


def test_patches_holding_the_same_echoes_are_one_test():
    """A 100 m square seen 30 degrees off x, its pulse rate sized for 1.6 times it: the
    plan's 2 x 2 cores keep every Doppler (no slow-time filter), and the two cores of a
    row in range hold the same echoes (the same pulses, the same ground in their
    windows). They are one test: with each row's null candidate as likely anywhere in the
    ground it holds, the collection reports a false mover with probability at most
    ``sum_rows alpha_p |K_row| / |H_p|``, ``K_row`` the ground any patch of the row keeps
    (:func:`in_band`, on a grid of points), at most ``alpha``; each patch then tests at
    more than the union bound over the four allows (which counts a row's keeps twice)."""
    from sarmotion.collection.extract import make_traces
    from sarmotion.collection.run import in_band

    acq = _look_azimuth_acquisition(30.0)
    traj, radar, count = acq.trajectory, acq.radar, acq.n_pulses
    zeros = Traces(
        data=np.zeros((count, radar.n_samples), np.complex64),
        trajectory=traj,
        radar=radar,
        reference_point_m=np.zeros(3),
    )
    src = TracesBlocks(zeros)
    plan = plan_patches(
        src,
        CollectionOptions(search_beyond=False),
        region_m=(-50, -50, 50, 50),
        region_frame="look",
    )
    assert len(plan.patches) == 4
    assert all(p.taps.size == 1 and p.decimation == p.interpolation == 1 for p in plan.patches)
    points = _scene_points(plan, n=81)
    held = [_held(zeros, p, points) for p in plan.patches]
    kept = []
    for p in plan.patches:
        keep = in_band(make_traces(p, src, np.zeros((p.pulses.size, p.n_samples), np.complex64)), p)
        still = np.zeros(2)
        kept.append(
            np.array(
                [
                    keep(SimpleNamespace(position_m=np.r_[x, 0.0], velocity_mps=still))
                    for x in points
                ]
            )
        )
    # rows in range: the cores' spans along the look at the aperture centre
    j0 = int(np.argmin(np.abs(traj.slow_times_s)))
    e_r = traj.positions_m[j0, :2] / np.linalg.norm(traj.positions_m[j0, :2])
    rows: dict[tuple, list[int]] = {}
    for i, p in enumerate(plan.patches):
        span = np.asarray(p.outline_m) @ e_r
        rows.setdefault((round(span.min(), 3), round(span.max(), 3)), []).append(i)
    assert sorted(len(r) for r in rows.values()) == [2, 2]
    total = 0.0
    for row in rows.values():
        first, second = (plan.patches[i] for i in row)
        assert np.array_equal(first.pulses, second.pulses)
        assert first.n_samples == second.n_samples
        # the same ground's echoes, up to the windows' edges (their centres' delays differ
        # by the cores' offsets squared over twice the range: centimetres)
        assert np.mean(held[row[0]] ^ held[row[1]]) < 0.01
        share = first.false_alarm_share
        assert second.false_alarm_share == share
        in_row = held[row[0]]
        total += share * np.mean((kept[row[0]] | kept[row[1]])[in_row])
        # the union bound over the four: each keep counted on its own
        own = share * sum(np.mean(kept[i][in_row]) for i in row)
        assert own > 1.5 * share * np.mean((kept[row[0]] | kept[row[1]])[in_row])
    assert 0.8 < total <= 1.0 + 0.02, total
    assert all(p.false_alarm_share > 0.6 for p in plan.patches)


def test_the_keeps_of_a_group_are_measured_on_the_circle_of_its_doppler():
    """A group's keeps in cross range wrap at the unambiguous extent (the pulse rate):
    their union's length against a fine sampling of the circle, seeded draws."""
    from sarmotion.collection.plan import _arc_union

    rng = np.random.default_rng(5)
    period = 157.6
    grid = (np.arange(200_000) + 0.5) * period / 200_000
    for _ in range(20):
        arcs = [(rng.uniform(-300, 300), rng.uniform(0, 60)) for _ in range(rng.integers(1, 5))]
        covered = np.zeros(grid.size, bool)
        for centre, half in arcs:
            covered |= np.abs((grid - centre + 0.5 * period) % period - 0.5 * period) <= half
        assert _arc_union(arcs, period) == pytest.approx(covered.mean() * period, abs=2e-3)
    assert _arc_union([(3.0, 80.0)], period) == period


def test_candidates_beyond_max_movers_are_kept_in_the_document_and_said(scene, tmp_path, capsys):
    """``--max-movers 0``: the border mover passes a patch's detector and is listed, with
    its patch, its range speed and its range from that patch's centre, in results.json,
    on the console and in the report; so is the count of sidelobe listings dropped."""
    from sarmotion.io import save_traces

    src = tmp_path / "two.h5"
    save_traces(src, scene)
    out = tmp_path / "out"
    args = ["analyze", str(src), "--out", str(out), "--region", *map(str, REGION)]
    args += ["--patch-size", "60", "--workers", "0", "--no-trajectory", "--max-movers", "0"]
    args += ["--no-search-beyond"]
    code = run([*args, "--no-defocus-search"])
    console = capsys.readouterr().out
    assert code == 0
    doc = json.loads((out / "results.json").read_text())
    assert doc["options"]["analysis"]["defocus_search"] is False
    assert doc["movers"] == []
    extra = doc["movers_not_estimated"]
    assert extra and {c["patch"] for c in extra} <= {0, 1}
    assert sum(p["movers_not_estimated"] for p in doc["patch_summaries"]) == len(extra)
    patches = {p["index"]: p for p in doc["plan"]["patches"]}
    geom = scene.geometry
    u_true = range_speed(MOVER.velocity_mps, geom)
    # one range-speed resolution: range resolution over half the aperture time
    du = scene.radar.range_resolution_m / (0.5 * np.ptp(scene.slow_times_s))
    for c in extra:
        assert c["statistic_db"] > 0 and c["width_resolutions"] > 0
        assert abs(c["range_speed_mps"] - u_true) <= du, (c, u_true, du)
        # the range of the mover from its patch's centre, along that centre's range axis
        centre = np.asarray(patches[c["patch"]]["centre_m"], float)
        cells = resolution(scene, point_m=(*centre[:2], 0.0))
        truth = float((np.asarray(MOVER.position_m[:2]) - centre[:2]) @ cells.range_direction)
        assert abs(c["range_m"] - truth) <= 2 * cells.ground_range_m, (c, truth)
    assert f"{len(extra)} more candidate(s) passed a patch's detector, not estimated" in console
    assert console.count("from the patch centre (aligned trace, not fitted)") == len(extra)
    report = (out / "report.html").read_text()
    assert f"Detected, not estimated: {len(extra)} candidate(s)" in report
    sidelobes = doc["stationary_sidelobes_dropped"]
    assert f"{sidelobes} dropped as a brighter target's sidelobes" in report
    assert (f"{sidelobes} dropped as a brighter target's sidelobes" in console) == (sidelobes > 0)


def _look_azimuth_acquisition(
    azimuth_deg: float, side: float = 100.0, over: float = 1.6, rate_over: float | None = None
):
    """benchmarks/look_azimuth.py's acquisition (100 m): a 2-degree X-band arc (9.6 GHz,
    640 MHz) at 10 km ground range and 4 km height about ``azimuth_deg``, window and
    pulse rate sized for ``over`` (1.6) times the side (the pulse rate for ``rate_over``
    times it, if given)."""
    import math

    from sarmotion.core import Acquisition, C

    ground, height = 10e3, 4e3
    cos_el = ground / math.hypot(ground, height)
    df = C / (2.0 * over * side * cos_el)
    radar = Radar(
        carrier_hz=9.6e9, bandwidth_hz=640e6, n_samples=math.ceil(640e6 / df), frequency_step_hz=df
    )
    rate = over if rate_over is None else rate_over
    count = math.ceil(np.deg2rad(2.0) * cos_el * 2.0 * rate * side / radar.wavelength_m)
    traj = Trajectory.circular(
        altitude_m=height,
        ground_radius_m=ground,
        speed_mps=150.0,
        pulses_per_deg=count / 2.0,
        aperture_deg=2.0,
        centre_azimuth_deg=azimuth_deg,
        n_pulses=count,
    )
    return Acquisition(trajectory=traj, radar=radar, reference_point_m=np.zeros(3))


def _look_azimuth_scene(azimuth_deg: float):
    """benchmarks/look_azimuth.py's 100 m scene at ``azimuth_deg`` (seed 7, no clutter).

    A 2-degree X-band arc (9.6 GHz, 640 MHz) at 10 km ground range and 4 km height,
    window and pulse rate for 1.6 times the side; 8 unit points, 4 unit movers (their
    positions and velocities those the benchmark draws at 45 degrees), noise -20 dB per
    sample of a unit point; the square declared as the image area.
    """
    from sarmotion.simulation import CollectionScene

    side = 100.0
    acq = _look_azimuth_acquisition(azimuth_deg)
    corners = [(-45.0, -45.0), (45.0, -45.0), (45.0, 45.0), (-45.0, 45.0)]
    inner = [(8.8, 27.8), (19.3, -19.2), (-14.0, 26.1), (-34.6, 22.5)]
    movers = [
        ((40.0, -40.0), (-4.0, -4.1)),
        ((-42.5, 5.0), (1.0, 5.7)),
        ((14.9, -1.6), (14.8, 1.1)),
        ((-9.8, -11.1), (5.3, -1.0)),
    ]
    half = 0.5 * side
    sc = CollectionScene(
        acquisition=acq,
        stationary=tuple(PointTarget(position_m=p) for p in corners + inner),
        movers=tuple(
            PointTarget(position_m=p, velocity_mps=v, label=f"mover {k + 1}")
            for k, (p, v) in enumerate(movers)
        ),
        snr_db=-20.0,
        seed=7,
        metadata={
            "source": "simulation",
            "image_area_m": [[-half, -half], [half, -half], [half, half], [-half, half]],
        },
    )
    return sc


def test_the_collection_finds_the_movers_the_whole_trace_analysis_finds():
    """The 100 m scene at a 45-degree look is cut into patches. Every mover the analysis of the
    whole traces finds accurate on its family (range within 3 ground-range cells, range
    speed within 0.5 m/s), the collection of the same data finds too, and it lists no
    other. Each patch's image the core's box and alpha / 4 found 2 of the 4."""
    from sarmotion.pipeline import analyze, family_errors

    sc = _look_azimuth_scene(45.0)
    traces = sc.traces()
    acq = traces.acquisition
    cell = resolution(acq).ground_range_m

    def found(fits):
        hits = []
        for truth in sc.movers:
            errors = [family_errors(acq, m, truth) for m in fits]
            hits.append(any(abs(e[0]) <= 3 * cell and abs(e[1]) <= 0.5 for e in errors))
        return hits

    whole = analyze(traces, AnalysisOptions(image_size_m=100.0, trajectory=False))
    by_whole = found(list(whole.movers))
    assert sum(by_whole) >= 3
    options = CollectionOptions(analysis=AnalysisOptions(trajectory=False))
    res = analyze_collection(traces, options, n_workers=0)
    # 4 cores, and none beyond: they keep every Doppler of the data (no slow-time filter),
    # so their bands reach every mover's image in the unambiguous scene
    assert len(res.plan.patches) == 4
    fits = [m for m, _ in res.movers]
    by_patches = found(fits)
    assert all(p for p, w in zip(by_patches, by_whole, strict=True) if w), (by_whole, by_patches)
    assert len(fits) == sum(by_patches)  # no other fit
