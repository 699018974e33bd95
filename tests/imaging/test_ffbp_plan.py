"""The shape of the FFBP tree and how its work is shared among threads.

:mod:`sarmotion.imaging.ffbp` splits a sub-aperture at its midpoint when both halves'
bands fit the children's grid, else where the two bands are most nearly equal
(:func:`~sarmotion.imaging.ffbp._halves`); it plans with each oversampling of
:data:`~sarmotion.imaging.ffbp.ALPHAS` (each with the taps its error budget needs) and
keeps the cheapest plan by its cost model; each tree level's tasks are
taken by the threads one at a time, dearest first
(:func:`~sarmotion.imaging.ffbp._task_order`). Here:

- the split rule on a band model whose floor grows along the aperture: the balanced split
  is the narrowest widest child, and it lets a node split that the midpoint cannot;
- the planner keeps the cheapest of the oversamplings, and an image planned with each
  oversampling of :data:`~sarmotion.imaging.ffbp.ALPHAS` reaches
  :data:`~sarmotion.imaging.ffbp.TARGET_DB` against exact backprojection;
- the tasks of a region: their costs follow the cost model, the threads take each once,
  dearest first, and a region is the same (bit for bit) on one worker loop or several;
- a plan is reused for other data on the same geometry and grid, and only there.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarmotion.core import Trajectory
from sarmotion.imaging import ImageGrid, backproject, ffbp
from sarmotion.simulation import PointTarget, Scene, simulate


def _band_model(n: int, slope: float, floor0: float, floor1: float):
    """Pulse ``j``'s band: centre ``slope j``, width rising from ``floor0`` to ``floor1``.

    The sub-aperture ``j0:j1`` spans the union of its pulses' bands (as
    :func:`~sarmotion.imaging.ffbp._strip_plans` reads it: first, middle and last pulse).
    """
    j = np.arange(n)
    width = floor0 + (floor1 - floor0) * j / (n - 1)
    lo, hi = slope * j - width / 2, slope * j + width / 2

    def band(j0: int, j1: int) -> tuple[float, float]:
        jm = (j0 + j1 - 1) // 2
        return min(lo[j0], lo[jm], lo[j1 - 1]), max(hi[j0], hi[jm], hi[j1 - 1])

    return band


def _extent(band, j0: int, j1: int) -> float:
    lo, hi = band(j0, j1)
    return hi - lo


def test_halves_split_at_the_midpoint_when_both_halves_fit():
    band = _band_model(400, 0.01, 0.05, 0.05)  # no floor change: the halves are alike
    kids = ffbp._halves(ffbp._Node(0, 400), band, width=2.5)
    assert [(k.j0, k.j1) for k in kids] == [(0, 200), (200, 400)]
    for k in kids:  # each child carries its own band's centre and half-width
        lo, hi = band(k.j0, k.j1)
        assert (k.centre, k.half) == pytest.approx((0.5 * (lo + hi), 0.5 * (hi - lo)))


def test_halves_balance_the_bands_when_the_midpoint_does_not_fit():
    # The floor grows tenfold along the aperture (a look turning away from u): the second
    # half's band is the wider, and a width between the balanced split's and the
    # midpoint's widest child admits only the balanced split.
    n = 400
    band = _band_model(n, 0.01, 0.02, 0.4)
    mid = n // 2
    at_mid = max(_extent(band, 0, mid), _extent(band, mid, n))
    widest = {m: max(_extent(band, 0, m), _extent(band, m, n)) for m in range(2, n - 1)}
    best = min(widest.values())
    assert best < at_mid
    width = 0.5 * (best + at_mid)
    kids = ffbp._halves(ffbp._Node(0, n), band, width)
    m = kids[0].j1
    assert kids[0].j0 == 0 and kids[1].j0 == m and kids[1].j1 == n
    assert m > mid  # the first half, of the smaller floor, takes more pulses
    assert widest[m] == pytest.approx(best)  # the narrowest widest child of any split
    assert max(_extent(band, k.j0, k.j1) for k in kids) <= width
    # Narrower than any split can give: a leaf.
    assert ffbp._halves(ffbp._Node(0, n), band, 0.99 * best) is None


def _look_off_u(n_pixels: int = 256, spacing_m: float = 0.2):
    """Points seen over 4 degrees from 0 to 4 degrees off ``x``, and an ``n`` x ``n`` grid.

    The look direction turns away from the grid's ``u = x`` axis along the aperture, so the
    band floor grows along it (the module docstring's floor): the case the balanced split
    and the lower oversampling serve.
    """
    targets = [PointTarget(position_m=(3.1, -7.7)),
               PointTarget(position_m=(-12.0, 9.4), reflectivity=0.6j)]  # fmt: skip
    trajectory = Trajectory.circular(aperture_deg=4.0, centre_azimuth_deg=2.0)
    tr = simulate(Scene(name="plan", targets=targets), trajectory=trajectory).traces
    return tr, ImageGrid.square(size_m=n_pixels * spacing_m, spacing_m=spacing_m)


def _ser_db(ref: np.ndarray, x: np.ndarray) -> float:
    return 20.0 * math.log10(np.linalg.norm(ref) / np.linalg.norm(x - ref))


def test_the_planner_keeps_the_cheapest_oversampling():
    tr, grid = _look_off_u()
    chosen = backproject(tr, grid, method="ffbp").metadata["ffbp"]
    costs = {}
    exact = backproject(tr, grid).values
    for alpha in ffbp.ALPHAS:
        img = backproject(tr, grid, method="ffbp", ffbp_oversampling=alpha)
        info = img.metadata["ffbp"]
        assert info["path"] == "axis-aligned"
        assert info["most_taps"] == ffbp.default_taps(alpha)  # the taps its budget needs
        costs[alpha] = info["cost_pixel_pulses"]
        # Every candidate meets the target (each with its own derived taps).
        assert _ser_db(exact, img.values) >= ffbp.TARGET_DB
    assert chosen["cost_pixel_pulses"] == min(costs.values())
    assert chosen["alpha"] == min(costs, key=costs.get)


def test_tasks_are_taken_dearest_first_each_once():
    rng = np.random.default_rng(9090)
    costs = np.concatenate([rng.uniform(50.0, 200.0, 24), np.full(150, 4.0), np.zeros(10)])
    rng.shuffle(costs)
    order = ffbp._task_order(costs)
    np.testing.assert_array_equal(np.sort(order), np.flatnonzero(costs > 0))
    assert np.all(np.diff(costs[order]) <= 0)


def test_tasks_follow_the_cost_model():
    # Two leaves (3 and 5 pulses) on 10 and 7 rows, tiles of 8 x 4 and 4 x 4 over 6
    # columns; one parent merged on 9 rows, in blocks of 4 rows.
    tasks, costs, total = ffbp._tasks(np.array([3, 5]), [10, 7], np.array([[8, 4], [4, 4]]),
                                      [9], 6, 4)  # fmt: skip
    expected = {(0, 0, 0): 3 * 8 * 4, (0, 0, 4): 3 * 8 * 2, (0, 8, 0): 3 * 2 * 4,
                (0, 8, 4): 3 * 2 * 2, (1, 0, 0): 5 * 4 * 4, (1, 0, 4): 5 * 4 * 2,
                (1, 4, 0): 5 * 3 * 4, (1, 4, 4): 5 * 3 * 2}  # fmt: skip
    expected.update({(-1, m0, 0): ffbp._MERGE_COST * 6 * r for m0, r in ((0, 4), (4, 4), (8, 1))})
    got = {tuple(int(v) for v in t): c for t, c in zip(tasks, costs, strict=True)}
    assert got == pytest.approx(expected)
    assert total == pytest.approx(sum(expected.values()))
    assert np.all(np.diff(costs) <= 0)  # dearest first


def test_a_level_is_the_same_whichever_thread_takes_each_task(monkeypatch):
    # Each task writes its own tile or row: the workers change who computes, not what.
    tr, grid = _look_off_u(96, 0.25)
    level = ffbp._kernels.level
    runs = []

    def twice(*args):
        *head, order, counter, _, block = args
        for workers in (1, 3):  # three loops on however many threads there are
            re, im = head[0].copy(), head[1].copy()
            level(re, im, *head[2:], order, np.zeros(1, np.int64), workers, block)
            runs.append((re, im))
        level(*args)

    monkeypatch.setattr(ffbp._kernels, "level", twice)
    img = backproject(tr, grid, method="ffbp", ffbp_oversampling=1.3)
    assert img.metadata["ffbp"]["levels"] >= 3 and len(runs) >= 4
    for (re1, im1), (re3, im3) in zip(runs[::2], runs[1::2], strict=True):
        np.testing.assert_array_equal(re1, re3)
        np.testing.assert_array_equal(im1, im3)


def test_a_plan_is_reused_on_the_same_geometry_only(monkeypatch):
    # The plan depends on the geometry and the grid, not on the data: other data on the
    # same acquisition and grid reuse it, and give the image a fresh plan gives; another
    # geometry (motion compensation moves the antennas) plans afresh.
    tr, grid = _look_off_u(96, 0.25)
    planned = []
    plan_aligned = ffbp._plan_aligned

    def counting(*args, **kwargs):
        planned.append(1)
        return plan_aligned(*args, **kwargs)

    monkeypatch.setattr(ffbp, "_plan_aligned", counting)
    monkeypatch.setattr(ffbp, "PLANS", ffbp.PlanCache(4))
    rng = np.random.default_rng(4141)
    other = tr.with_data(tr.data * np.exp(2j * np.pi * rng.uniform(size=tr.data.shape)))
    first = backproject(tr, grid, method="ffbp")
    assert first.metadata["ffbp"]["path"] == "axis-aligned" and len(planned) == 1
    reused = backproject(other, grid, method="ffbp")
    assert len(planned) == 1 and reused.metadata["ffbp"] == first.metadata["ffbp"]
    backproject(tr, grid, method="ffbp", velocity_mps=(3.0, 1.0))
    assert len(planned) == 2
    ffbp.PLANS.clear()
    fresh = backproject(other, grid, method="ffbp")
    assert len(planned) == 3
    np.testing.assert_array_equal(reused.values, fresh.values)


def test_both_layouts_of_the_regions_form_the_same_image(monkeypatch):
    # Leaves at several depths: all nodes in one set of planes (one region forms every
    # leaf, then the merges), or, where they would not fit the scratch, one region per
    # depth. Each task computes the same tile or rows either way: the same image.
    tr, grid = _look_off_u(96, 0.25)
    layouts = []
    schedule = ffbp._schedule

    def recording(*args):
        regions, g = schedule(*args)
        layouts.append([(r.starts.size, r.kids.shape[0]) for r in regions])
        return regions, g

    monkeypatch.setattr(ffbp, "_schedule", recording)
    monkeypatch.setattr(ffbp, "PLANS", ffbp.PlanCache(1))
    fused = backproject(tr, grid, method="ffbp").values
    monkeypatch.setattr(ffbp, "SCRATCH_BYTES", 0)
    monkeypatch.setattr(ffbp, "PLANS", ffbp.PlanCache(1))
    by_depth = backproject(tr, grid, method="ffbp").values
    # fused: the leaves of every depth in the first region, only merges after it
    assert layouts[0][0][0] > 0 and all(leaves == 0 for leaves, _ in layouts[0][1:])
    # by depth: one region per depth, leaves in more than one
    assert len(layouts[1]) == len(layouts[0]) and sum(1 for n, _ in layouts[1] if n) > 1
    np.testing.assert_array_equal(fused, by_depth)


@pytest.mark.parametrize("rows", [2, 12, 15])
def test_too_few_rows_to_factorise_run_exact_backprojection(rows):
    # A grid with fewer than 16 rows along v (here y) has no strip to plan:
    # method="ffbp" runs exact backprojection there (the same image) and says so. Turned
    # the other way (v along the 64-pixel axis) the grid factorises, at FFBP's accuracy
    # against the exact sum (no interpolation).
    from sarmotion.imaging.exact_sum import exact_sum

    tr, _ = _look_off_u(96, 0.25)
    for (nx, ny), want in (((64, rows), "exact"), ((rows, 64), "axis-aligned")):
        grid = ImageGrid.from_extent(x_range_m=(-0.1 * nx, 0.1 * (nx - 1) - 0.1 * nx),
                                     y_range_m=(-0.1 * ny, 0.1 * (ny - 1) - 0.1 * ny),
                                     spacing_m=0.1)  # fmt: skip
        assert grid.shape == (ny, nx)
        fast = backproject(tr, grid, method="ffbp")
        assert fast.metadata["ffbp"]["path"] == want
        if want == "exact":
            np.testing.assert_array_equal(fast.values, backproject(tr, grid).values)
        else:
            gx, gy = np.meshgrid(grid.x_m, grid.y_m)
            ref = exact_sum(tr, np.stack([gx.ravel(), gy.ravel()], axis=-1)).reshape(gx.shape)
            assert _ser_db(ref, fast.values) >= ffbp.TARGET_DB
