"""``analyze`` on a device: ``AnalysisOptions(device=...)`` and ``analyze --device``.

Every image of the analysis (preliminary, stationary, each mover's) is backprojected on
the device the options name. Here, without a GPU: the options carry the device to every
image (the GPU path stood in for by a recorder that runs the CPU's sum, so the results
must be the CPU's exactly); the command line refuses ``--device cuda`` in one line, exit
2, writing nothing; and, under numba's CUDA simulator in a subprocess, a tiny analysis
with ``device="cuda"`` finds the CPU's movers (``tests/imaging/test_cuda_sim.py`` holds the GPU
kernel itself to the exact sum).
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sarmotion.imaging import backprojection
from sarmotion.imaging.cuda import NEEDS, available
from sarmotion.pipeline import AnalysisOptions, analyze
from sarmotion.separation import SeparationOptions
from sarmotion.simulation import load_scene, simulate


def _tiny_options(device: str) -> AnalysisOptions:
    """A small analysis of Scene 1 (its movers at 0 and 5 m): 16 m at 0.5 m, 4 m mover
    images."""
    return AnalysisOptions(
        separation=SeparationOptions(method="combined"), image_size_m=16.0, spacing_m=0.5,
        mover_image_size_m=4.0, trajectory=False, device=device,
    )  # fmt: skip


def _summary(result) -> dict:
    return {
        "movers": [
            {
                "position_m": [float(v) for v in m.position_m[:2]],
                "velocity_mps": [float(v) for v in m.velocity_mps[:2]],
            }
            for m in result.movers
        ],  # fmt: skip
        "stationary_peak": float(np.abs(result.stationary_image.values).max()),
    }


def test_options_check_the_device():
    assert AnalysisOptions().device == "cpu"
    with pytest.raises(ValueError, match="device must be 'cpu' or 'cuda'"):
        AnalysisOptions(device="gpu")


@pytest.fixture(scope="module")
def cpu_summary() -> dict:
    """The tiny analysis on the CPU."""
    result = analyze(simulate(load_scene("scene1")).traces, _tiny_options("cpu"))
    assert result.options.to_dict()["device"] == "cpu"
    return _summary(result)


def test_every_image_goes_to_the_device(monkeypatch, cpu_summary):
    calls = []
    real = backprojection.backproject

    def recorder(traces, grid, **keywords):
        calls.append(grid.shape)
        return real(traces, grid, **keywords)  # device="cpu": the CPU's sum

    monkeypatch.setattr(backprojection, "_backproject_cuda", recorder)
    gpu = analyze(simulate(load_scene("scene1")).traces, _tiny_options("cuda"))
    # preliminary and stationary images, then one per mover
    assert len(calls) == 2 + len(gpu.movers) and len(gpu.movers) > 0
    assert _summary(gpu) == cpu_summary
    assert gpu.options.to_dict()["device"] == "cuda"


def test_command_line_without_gpu_one_line_exit_2(tmp_path, capsys):
    from sarmotion.cli.main import EXIT_BAD_INPUT, run

    if available():
        pytest.skip("a CUDA device (or the simulator) is present")
    out = tmp_path / "analysis"
    code = run(["analyze", "hyperbola", "--out", str(out), "--device", "cuda"])
    err = capsys.readouterr().err
    assert code == EXIT_BAD_INPUT
    assert err.count("\n") == 1 and NEEDS in err and "--device cuda" in err
    assert not out.exists()


def _run_simulated(out: Path) -> None:
    """Under the simulator: the tiny analysis with ``device="cuda"``."""
    assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
    gpu = analyze(simulate(load_scene("scene1")).traces, _tiny_options("cuda"))
    assert {m.image.metadata["kernel_variant"] for m in gpu.movers} == {"cuda-hermite"}
    out.write_text(json.dumps(_summary(gpu)))


@pytest.mark.slow
def test_analysis_under_the_cuda_simulator_finds_the_cpu_movers(tmp_path, cpu_summary):
    if importlib.util.find_spec("numba.cuda") is None:
        pytest.skip("numba.cuda is absent (numba without CUDA support and no numba-cuda)")
    out = tmp_path / "analysis.json"
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    proc = subprocess.run([sys.executable, __file__, str(out)], env=env, capture_output=True,
                          text=True, timeout=900)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    cpu, gpu = cpu_summary, json.loads(out.read_text())
    assert len(gpu["movers"]) == len(cpu["movers"]) > 0
    # The two sums differ by their interpolation errors (>= 80 dB from the exact sum
    # each): the movers' estimates agree to far below their resolution.
    for a, b in zip(gpu["movers"], cpu["movers"], strict=True):
        np.testing.assert_allclose(a["position_m"], b["position_m"], atol=1e-3)
        np.testing.assert_allclose(a["velocity_mps"], b["velocity_mps"], atol=1e-3)
    assert gpu["stationary_peak"] == pytest.approx(cpu["stationary_peak"], rel=1e-3)


if __name__ == "__main__":
    _run_simulated(Path(sys.argv[1]))
