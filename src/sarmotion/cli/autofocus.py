"""The ``--autofocus`` option shared by ``image``, ``analyze`` and ``convert``."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import click
import numpy as np

from ..core import Traces
from ..imaging.autofocus import AutofocusResult, pga
from ..simulation import Simulation
from .common import InputError, as_flags, say
from .inputs import read_inputs

__all__ = ["ReadOptions", "autofocus_options", "pga_line", "read_focused"]

#: Default most PGA iterations.
PGA_ITERATIONS = 10


def autofocus_options(func: Callable[..., Any]) -> Any:
    """``--autofocus [gotcha|pga]`` and ``--pga-iterations``.

    A bare ``--autofocus`` means ``gotcha`` (the flag's earlier meaning); it takes the
    next word as its value, so write it after the inputs or before another option.
    """
    func = click.option(
        "--pga-iterations",
        type=int,
        default=PGA_ITERATIONS,
        show_default=True,
        help="--autofocus pga: most iterations (1 to the number of pulses).",
    )(func)
    return click.option(
        "--autofocus",
        type=click.Choice(["gotcha", "pga"]),
        is_flag=False,
        flag_value="gotcha",
        default=None,
        help="Focus correction: gotcha (the GOTCHA files' stored corrections; also a bare "
        "--autofocus) or pga (phase-gradient autofocus of the phase history, any input).",
    )(func)


def read_focused(
    inputs: Sequence[str],
    *,
    autofocus: str | None,
    pga_iterations: int = PGA_ITERATIONS,
    **read_options: Any,
) -> tuple[Traces, Simulation | None, AutofocusResult | None]:
    """:func:`~sarmotion.io.read_inputs`, then the requested focus correction.

    Returns
    -------
    (Traces, Simulation or None, AutofocusResult or None)
        The (corrected) traces, the simulation of a scene, and the PGA result.
    """
    if pga_iterations < 1:
        raise InputError(f"--pga-iterations must be >= 1, got {pga_iterations}")
    with as_flags(speed_mps="--speed", snr_db="--snr-db", channel="--channel", vectors="--vectors"):
        traces, sim = read_inputs(inputs, autofocus=autofocus == "gotcha", **read_options)
    if autofocus != "pga":
        return traces, sim, None
    if pga_iterations > traces.n_pulses:
        raise InputError(
            f"--pga-iterations must be at most the number of pulses ({traces.n_pulses}), "
            f"got {pga_iterations}"
        )
    ctx = click.get_current_context(silent=True)
    say(ctx, f"autofocus: phase-gradient autofocus of {traces.n_pulses} pulses, at most "
        f"{pga_iterations} iteration(s)")  # fmt: skip
    try:
        result = pga(traces, max_iter=pga_iterations)
    except ValueError as exc:
        raise InputError(f"--autofocus pga: {exc}") from None
    say(ctx, pga_line(result))
    return result.traces, sim, result


def pga_line(result: AutofocusResult) -> str:
    """What PGA found, in one line: iterations, the estimate's RMS, the final fit."""
    phi = np.asarray(result.phase_error_rad, dtype=np.float64)
    rms = float(np.sqrt(np.mean(phi**2))) if phi.size else 0.0
    last = float(result.rms_history_rad[-1]) if len(result.rms_history_rad) else float("nan")
    fit = (
        f"Legendre fit to order {result.order} on {result.n_fitted_lines} range line(s)"
        if result.order > 0
        else "no final fit"
    )
    stop = "converged" if result.converged else "not converged"
    return (
        f"autofocus: phase error estimated, RMS {rms:.3g} rad over the aperture; "
        f"{result.n_iter} iteration(s), {stop} (last correction {last:.2g} rad against "
        f"{result.tol_rad:g}); {fit}"
    )


@dataclass(frozen=True, kw_only=True)
class ReadOptions:
    """How ``analyze`` reads its inputs: the options of :func:`read_focused`, one record.

    Attributes
    ----------
    speed_mps : float
        GOTCHA: platform speed that sets slow time (m/s).
    snr_db : float, optional
        Scenes: add white noise at this SNR (dB).
    seed : int
        Scenes: noise seed.
    lenient : bool
        Files: log a broken plausibility rule as a warning instead of refusing the file.
    autofocus : {"gotcha", "pga"} or None
        Focus correction; ``True`` means ``"gotcha"`` (the flag's earlier meaning).
    pga_iterations : int
        ``"pga"``: most iterations.
    """

    speed_mps: float = 70.0
    snr_db: float | None = None
    seed: int = 0
    lenient: bool = False
    autofocus: str | None = None
    pga_iterations: int = PGA_ITERATIONS

    def __post_init__(self) -> None:
        if self.autofocus is True:
            object.__setattr__(self, "autofocus", "gotcha")

    def read(
        self, inputs: Sequence[str]
    ) -> tuple[Traces, Simulation | None, AutofocusResult | None]:
        """``(traces, simulation, autofocus result)`` of ``inputs`` (:func:`read_focused`)."""
        return read_focused(
            inputs,
            autofocus=self.autofocus or None,
            pga_iterations=self.pga_iterations,
            speed_mps=self.speed_mps,
            snr_db=self.snr_db,
            seed=self.seed,
            lenient=self.lenient,
        )
