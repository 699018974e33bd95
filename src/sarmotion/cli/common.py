"""What the commands share: the input error, progress bars, shared options, grids."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
import numpy as np

from ..imaging import ImageGrid

__all__ = [
    "InputError",
    "Progress",
    "extent_grid",
    "noise_options",
    "out_option",
    "speed_option",
    "square_grid",
]


class InputError(Exception):
    """Bad user input: reported as one line, exit status 2."""


class Progress:
    """tqdm bars driven by the library's ``progress(stage, done, total)`` calls.

    A new bar starts whenever the stage changes; nothing is drawn when disabled (``-q``
    or stderr not a terminal).
    """

    def __init__(self, *, enabled: bool = True) -> None:
        self.enabled = enabled
        self.stage = ""
        self._bar: Any = None

    def __call__(self, stage: str, done: int, total: int) -> None:
        """Advance the bar of ``stage`` to ``done`` of ``total``."""
        if not self.enabled:
            return
        if stage != self.stage:
            self.close()
            self.stage = stage
        if self._bar is None:
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc=stage, unit="step", leave=False)
        self._bar.n = done
        self._bar.refresh()

    def close(self) -> None:
        """Remove the bar."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def out_option(help_text: str, **kwargs: Any) -> Callable[[Callable[..., Any]], Any]:
    """The ``--out`` option (a path), declared once for every command."""
    kwargs.setdefault("required", True)
    return click.option("--out", "out", type=click.Path(path_type=Path), help=help_text, **kwargs)


def _positive_callback(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    if value is not None and not (np.isfinite(value) and value > 0):
        raise click.BadParameter(f"must be > 0, got {value}")
    return value


speed_option = click.option(
    "--speed",
    "speed_mps",
    type=float,
    default=70.0,
    show_default=True,
    callback=_positive_callback,
    help="GOTCHA inputs: platform speed that sets the slow time of the pulses (m/s).",
)


def noise_options(func: Callable[..., Any]) -> Any:
    """``--snr-db`` and ``--seed``: white noise added to simulated (scene) inputs."""
    func = click.option(
        "--seed", type=int, default=0, show_default=True, help="Seed of the noise generator."
    )(func)
    return click.option(
        "--snr-db",
        type=float,
        default=None,
        help="Scene inputs: add white Gaussian noise at this signal-to-noise ratio (dB).",
    )(func)


def square_grid(size_m: float, spacing_m: float, centre: tuple[float, float]) -> ImageGrid:
    """Square image grid from ``--size``, ``--spacing`` and ``--centre``."""
    if not (size_m > 0 and spacing_m > 0):
        raise InputError(f"--size and --spacing must be positive, got {size_m}, {spacing_m}")
    if size_m / spacing_m > 4096:
        raise InputError(
            f"--size/--spacing gives {size_m / spacing_m:.0f} pixels a side (max 4096)"
        )
    return ImageGrid.square(centre_m=centre, size_m=size_m, spacing_m=spacing_m)


def extent_grid(extent: tuple[float, float, float, float], spacing_m: float) -> ImageGrid:
    """Rectangular image grid from ``--grid XMIN XMAX YMIN YMAX`` and ``--spacing``."""
    x0, x1, y0, y1 = extent
    if not (np.all(np.isfinite(extent)) and x1 > x0 and y1 > y0 and spacing_m > 0):
        raise InputError(
            f"--grid must be XMIN < XMAX, YMIN < YMAX (m) and --spacing > 0, got {extent}, "
            f"{spacing_m}"
        )
    if max(x1 - x0, y1 - y0) / spacing_m > 4096:
        raise InputError("--grid/--spacing gives more than 4096 pixels a side")
    return ImageGrid.from_extent(x_range_m=(x0, x1), y_range_m=(y0, y1), spacing_m=spacing_m)
