"""Truth checks match on the cross-range family, never on an aliased range; the detector's
pulse width does not depend on the data's scale."""

import dataclasses

import numpy as np
import pytest

from sarmotion.core import C, Radar
from sarmotion.core.geometry import GOTCHA_ALTITUDE_M, GOTCHA_GROUND_RADIUS_M
from sarmotion.motion.detector import point_peak_width
from sarmotion.pipeline import AnalysisOptions, analyze, compare_with_truth
from sarmotion.pipeline.truth import MATCH_CELLS, TrueMover, family_match
from sarmotion.simulation import PointTarget, Scene, load_scene, simulate

E_R = np.array([1.0, 0.0])  # ground range for the default look (antenna towards +x)
E_C = np.array([0.0, 1.0])
SCALES = (0.35, 0.27, 0.74)  # ground-range cell (m), range- and cross-range-speed resolutions
TRUTH = TrueMover(
    label="t",
    position_m=(10.0, -4.0),
    velocity_mps=(6.0, 8.0),
    range_speed_mps=6.0,
    cross_range_speed_mps=8.0,
)
#: A family tangent per metre of cross-range offset: position and velocity.
PER_M = np.array([0.02, 1.0])
VEL_PER_M = np.array([0.004, -0.01])


def _estimate(offset_m, range_shift_m=0.0, speed_shift_mps=0.0):
    """The family member ``offset_m`` from the truth, moved in range and range speed."""
    return dict(
        position_m=np.array(TRUTH.position_m) + offset_m * PER_M + range_shift_m * E_R,
        velocity_mps=np.array(TRUTH.velocity_mps) + offset_m * VEL_PER_M + speed_shift_mps * E_R,
        range_speed_mps=TRUTH.range_speed_mps + speed_shift_mps,
        position_per_m=PER_M,
        velocity_per_m=VEL_PER_M,
        truth=TRUTH,
        cross_range_direction=E_C,
        scales=SCALES,
    )


@pytest.mark.parametrize("offset", [-40.0, 0.0, 25.0])
def test_a_member_of_the_truths_family_matches_it_exactly(offset):
    assert family_match(**_estimate(offset)) == pytest.approx(0.0, abs=1e-9)


def test_a_match_lies_within_four_cells_of_range_and_resolutions_of_speed():
    cell, du = SCALES[0], SCALES[1]
    got = family_match(**_estimate(30.0, range_shift_m=0.9 * MATCH_CELLS * cell))
    assert got == pytest.approx(0.9 * MATCH_CELLS, rel=1e-9)
    assert family_match(**_estimate(30.0, range_shift_m=1.1 * MATCH_CELLS * cell)) is None
    assert family_match(**_estimate(30.0, speed_shift_mps=1.1 * MATCH_CELLS * du)) is None
    # an echo folded by one range window (146 m on the default radar) never matches
    cos_psi = GOTCHA_GROUND_RADIUS_M / np.hypot(GOTCHA_GROUND_RADIUS_M, GOTCHA_ALTITUDE_M)
    window = C / (2.0 * Radar().frequency_step_hz) / cos_psi
    assert family_match(**_estimate(0.0, range_shift_m=window)) is None


def test_an_aliased_mover_is_a_false_mover_plus_a_missed_one(tmp_path):
    text = (
        '[radar]\npulse = "gaussian"\n'
        "[[targets]]\nposition_m = [5.0, -3.0]\n"
        "[[targets]]\nposition_m = [-12.0, 8.0]\n"
        '[[targets]]\nlabel = "aliased"\nposition_m = [-110.0, 0.0]\nvelocity_mps = [6.0, 8.0]\n'
    )
    path = tmp_path / "wide.toml"
    path.write_text(text)
    scene = load_scene(path, lenient=True)
    result = analyze(simulate(scene).traces, AnalysisOptions())
    (mover,) = result.movers
    # the echo is found folded into the window: about -110 m + 146 m of ground range
    assert 25.0 < mover.position_m[0] < 45.0
    cmp = compare_with_truth(result, scene)
    assert (cmp.false_movers, cmp.missed_movers) == (1, 1)
    # its range speed alone would have matched the truth (the former rule)
    assert (
        abs(mover.range_speed_mps - cmp.truth[0].range_speed_mps)
        < 4 * result.range_speeds.resolution_mps
    )


def test_the_pulse_width_does_not_depend_on_the_datas_scale():
    traces = simulate(load_scene("example1")).traces
    width = point_peak_width(traces)
    tiny = dataclasses.replace(traces, data=traces.data * 1e-300)  # squares underflow to 0
    assert point_peak_width(tiny) == pytest.approx(width, rel=1e-12)
    # no signal at all: the radar's nominal spectrum, that of one point target at the
    # reference point (its measured spectrum is the pulse's, |W(f)|)
    one = simulate(
        Scene(name="one", targets=(PointTarget(position_m=(0.0, 0.0)),), radar=traces.radar)
    ).traces
    zero = dataclasses.replace(traces, data=np.zeros_like(traces.data))
    assert point_peak_width(zero) == pytest.approx(point_peak_width(one), rel=1e-9)
