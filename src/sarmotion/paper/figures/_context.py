"""What the figures share: the scenes and analyses computed once, helpers for numbers."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = []


NU_O = 9.6e9  # carrier of the rank model (Hz), GOTCHA centre


B_RANK = 622e6  # bandwidth of the rank model (Hz), GOTCHA


EPS = 1e-3  # rank threshold on the eigenvalues of Y


@dataclass
class _Result:
    fig: Any
    arrays: dict[str, Any]
    headline: dict[str, float]
    summary: str


# ============================================================== shared computations
class _Context:
    """Simulations and separations shared by several figures, computed once."""

    def __init__(self, quick: bool, gotcha_paths: Sequence[Any] | None = None) -> None:
        self.quick = quick
        self.gotcha_paths = list(gotcha_paths) if gotcha_paths else []
        self._sims: dict[str, Any] = {}
        self._rpca: dict[tuple[str, int | None], Any] = {}

    @cached_property
    def gotcha_traces(self) -> Any:
        """The GOTCHA files as one aperture (:func:`sarmotion.io.read_gotcha`), or None."""
        if not self.gotcha_paths:
            return None
        from ...io import read_gotcha

        return read_gotcha(self.gotcha_paths)

    # sizes ------------------------------------------------------------------------
    @property
    def spacing_m(self) -> float:
        return 0.5 if self.quick else 0.25

    @property
    def speed_step_mps(self) -> float:
        return 0.25 if self.quick else 0.05

    def sim(self, name: str) -> Any:
        from ...simulation import load_scene, simulate

        if name not in self._sims:
            self._sims[name] = simulate(load_scene(name))
        return self._sims[name]

    def rpca(self, name: str, window: int | None) -> Any:
        """Windowed (``window=None``: chosen from the data) or whole-matrix RPCA."""
        from ...separation import separate_rpca

        key = (name, window)
        if key not in self._rpca:
            tr = self.sim(name).traces
            self._rpca[key] = separate_rpca(tr, window=window, tol=1e-4, max_iter=300)
        return self._rpca[key]

    def grid(self, size_m: float = 60.0, centre_m: Sequence[float] = (0.0, 0.0)) -> Any:
        from ...imaging import ImageGrid

        return ImageGrid.square(centre_m=centre_m, size_m=size_m, spacing_m=self.spacing_m)

    @cached_property
    def scene1_image(self) -> Any:
        from ...imaging import backproject

        return backproject(self.sim("scene1").traces, self.grid())

    @cached_property
    def scene1_analysis(self) -> Any:
        """The paper's pipeline on Scene 1 (RPCA, then one mover at a time)."""
        from ...pipeline import AnalysisOptions, analyze
        from ...separation import SeparationOptions

        tr = self.sim("scene1").traces
        options = AnalysisOptions(
            separation=SeparationOptions(method="rpca"), trajectory=False, spacing_m=self.spacing_m
        )
        return analyze(tr, options)

    @cached_property
    def scene1_moving_traces(self) -> Any:
        sim = self.sim("scene1")
        return sim.traces.with_data(sim.moving)

    @cached_property
    def scene1_g(self) -> dict[str, NDArray[np.float64]]:
        """``g(u)`` on all of Scene 1 and on its moving traces."""
        from ...motion import range_speed_objective

        u = np.arange(-30.0, 30.0 + 1e-9, self.speed_step_mps)
        g_all = range_speed_objective(self.sim("scene1").traces, u)
        g_mov = range_speed_objective(self.scene1_moving_traces, u)
        return {"u_mps": u, "g_all": g_all, "g_moving": g_mov}

    @cached_property
    def scene1_estimates(self) -> list[Any]:
        """Velocity estimates of Scene 1's movers on their traces, at the true positions."""
        from ...motion import estimate_range_speeds, estimate_velocity

        tr = self.scene1_moving_traces
        speeds = estimate_range_speeds(tr, max_movers=2)
        out = []
        for mover in self.sim("scene1").scene.moving:
            from ...core import range_speed

            u_true = range_speed(mover.velocity_mps, tr.geometry)
            u0 = speeds.speeds_mps[int(np.argmin(np.abs(speeds.speeds_mps - u_true)))]
            out.append(
                estimate_velocity(tr, range_speed_mps=float(u0), position_m=mover.position_m)
            )
        return out


# ================================================================== plotting helpers
def _peak_delays_s(data: NDArray, fast_times_s: NDArray) -> NDArray[np.float64]:
    """Fast time of each pulse's peak (s), interpolated between samples.

    A parabola through ``log|data|`` at the largest sample and its two neighbours: exact
    for a Gaussian envelope (the built-in scenes' compressed pulse), whose logarithm is a
    parabola.
    """
    a = np.abs(np.asarray(data))
    t = np.asarray(fast_times_s, dtype=np.float64)
    n, m = a.shape
    i = np.clip(np.argmax(a, axis=1), 1, m - 2)
    rows = np.arange(n)
    tiny = np.finfo(float).tiny
    y0, y1, y2 = (np.log(np.maximum(a[rows, i + k], tiny)) for k in (-1, 0, 1))
    den = y0 - 2 * y1 + y2
    off = np.where(den < 0, 0.5 * (y0 - y2) / np.where(den < 0, den, -1.0), 0.0)
    return t[i] + np.clip(off, -0.5, 0.5) * (t[1] - t[0])


def _peak_delay_spread_ns(data: NDArray, fast_times_s: NDArray) -> float:
    """Spread (max - min) over slow time of each pulse's sub-sample peak time (ns)."""
    t = _peak_delays_s(data, fast_times_s)
    return float((t.max() - t.min()) * 1e9)


#: The one definition of signal-to-clutter used by every figure (quoted in the index).
SCR_DEFINITION = (
    "signal-to-clutter = 10 log10(||X_S||^2 / ||X - X_S||^2), X the moving output of a "
    "separation and X_S what the method makes of the movers' true traces alone: Q S_true "
    "for the (linear) annihilation filter, S_true for a split M = L + S (and a mover's own "
    "true trace for a mover-by-mover separation). Everything else in X is clutter: "
    "stationary energy left in it and, for a split, what it lost of the movers."
)


def _scr_db(output: NDArray, movers_part: NDArray) -> float:
    """Signal-to-clutter (dB) by :data:`SCR_DEFINITION`."""
    x = np.asarray(output)
    xs = np.asarray(movers_part)
    e = x - xs
    return float(10 * np.log10(np.vdot(xs, xs).real / max(np.vdot(e, e).real, 1e-300)))


def _rel(a: NDArray, b: NDArray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def _fmt(x: float, nd: int = 2) -> str:
    return f"{x:.{nd}f}"


def _annihilate_complete_stencils(name: str, points_m: Any) -> tuple[Any, Any, Any]:
    """Composed filters at ``points_m`` with a complete stencil at every shown pulse.

    ``N`` alternated differences reach ``ceil(N / 2)`` pulses forward and ``floor(N / 2)``
    back; the scene is simulated on its circular aperture extended by ``ceil(N / 2) + 1``
    pulses at each end (same pulse spacing: the radar keeps recording), filtered, and the
    scene's own pulses kept.
    Returns ``(Q M, Q L_true, Q S_true)`` on the scene's pulses.
    """
    from ...core import Trajectory
    from ...separation import annihilate
    from ...simulation import load_scene, simulate

    scene = load_scene(name)
    spec = dict(scene.trajectory_spec)
    if spec.pop("kind", "circular") != "circular":
        raise ValueError(f"scene {name!r} must have a circular trajectory")
    n = scene.trajectory().n_pulses
    pad = (len(points_m) + 1) // 2 + 1
    wide = simulate(scene, trajectory=Trajectory.circular(**spec, n_pulses=n + 2 * pad))
    keep = slice(pad, pad + n)
    out = []
    for data in (wide.traces.data, wide.stationary, wide.moving):
        out.append(annihilate(wide.traces.with_data(data), points_m).data[keep])
    return tuple(out)
