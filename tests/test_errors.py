"""The error taxonomy: who is at fault decides the exception and the exit status.

Bad input is an :class:`~sarmotion.errors.InputError` (exit 2), an estimator that finds no
answer raises :class:`~sarmotion.errors.EstimationError` (callers that can go on without
the estimate catch it), anything else is a defect (exit 1), a bare ``ValueError``
included.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.cli import run
from sarmotion.cli.main import EXIT_BAD_INPUT, EXIT_INTERNAL
from sarmotion.errors import EstimationError, InputError, SarmotionError


def test_input_errors_of_every_layer_are_input_errors():
    from sarmotion.cli.common import InputError as CliInputError
    from sarmotion.io import DataError
    from sarmotion.io.matv5 import MatStructureError
    from sarmotion.simulation import SceneError

    for cls in (DataError, MatStructureError, SceneError, CliInputError):
        assert issubclass(cls, InputError) and issubclass(cls, ValueError), cls
    assert issubclass(InputError, SarmotionError) and issubclass(EstimationError, SarmotionError)
    assert not issubclass(EstimationError, InputError)


@pytest.mark.parametrize(
    ("raised", "status", "start"),
    [
        (ValueError("array must not contain infs or NaNs"), EXIT_INTERNAL, "internal error"),
        (np.linalg.LinAlgError("SVD did not converge"), EXIT_INTERNAL, "internal error"),
        (EstimationError("g(u) has no peak"), EXIT_INTERNAL, "internal error"),
        (InputError("--size must be > 0"), EXIT_BAD_INPUT, "error: --size must be > 0"),
    ],
)
def test_exit_status_follows_the_class(tmp_path, capsys, monkeypatch, raised, status, start):
    """A numerical defect inside a command exits 1 with one line, bad input exits 2."""
    from sarmotion.cli import image as image_module

    def fails(*args, **kwargs):
        raise raised

    monkeypatch.setattr(image_module, "backproject", fails)
    out = tmp_path / "img"
    assert run(["image", "hyperbola", "--out", str(out)]) == status
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"sarmotion: {start}") and "\n" not in err, err
    if status == EXIT_INTERNAL:
        assert err.endswith("; -vv shows the traceback"), err
    assert not out.exists()


def test_trajectory_stage_skips_only_an_estimation_failure(monkeypatch, caplog):
    """The pipeline goes on without a trajectory the estimator cannot give; a defect stops it."""
    from sarmotion.pipeline import Mover, stages
    from sarmotion.simulation import load_scene, simulate

    traces = simulate(load_scene("hyperbola")).traces
    mover = Mover(
        position_m=np.zeros(3),
        velocity_mps=np.zeros(2),
        range_speed_mps=0.0,
        cross_range_speed_mps=0.0,
        evidence=None,
        separated_fit=None,
        fit=None,
        refit_kept=None,
        g_perp=None,
        aperture=None,
        bound=None,
        family_position_per_m=np.zeros(2),
        family_velocity_per_m=np.zeros(2),
        traces=traces.data,
    )
    acquisition = traces.acquisition

    def no_answer(*args, **kwargs):
        raise EstimationError("sub_aperture_pulses must be an integer in [5, 4], got 9")

    monkeypatch.setattr(stages, "estimate_trajectory", no_answer)
    with caplog.at_level("WARNING"):
        (out,) = stages.estimate_trajectories([mover], acquisition=acquisition)
    assert out.trajectory is None
    assert "trajectory of mover 1 not estimated" in caplog.text

    def defect(*args, **kwargs):
        raise ValueError("operands could not be broadcast together")

    monkeypatch.setattr(stages, "estimate_trajectory", defect)
    with pytest.raises(ValueError, match="broadcast"):
        stages.estimate_trajectories([mover], acquisition=acquisition)


def test_traces_too_short_for_the_estimator_are_an_estimation_error():
    """Valid options the traces cannot serve raise EstimationError; malformed ones ValueError."""
    from sarmotion.motion import estimate_trajectory
    from sarmotion.simulation import load_scene, simulate

    traces = simulate(load_scene("hyperbola")).traces
    n = traces.n_pulses
    with pytest.raises(EstimationError, match="sub_aperture_pulses"):
        estimate_trajectory(
            traces, np.zeros(3), velocity_guess_mps=[1.0, 0.0], sub_aperture_pulses=n + 1
        )
    with pytest.raises(EstimationError, match="fast_time_search"):
        estimate_trajectory(
            traces,
            np.zeros(3),
            velocity_guess_mps=[1.0, 0.0],
            fast_time_search=traces.n_samples,
        )
    with pytest.raises(ValueError, match="sub_aperture_pulses") as info:
        estimate_trajectory(
            traces, np.zeros(3), velocity_guess_mps=[1.0, 0.0], sub_aperture_pulses=3
        )
    assert not isinstance(info.value, EstimationError)
