"""What the commands share: the input error, progress bars, shared options, grids."""

from __future__ import annotations

import atexit
import contextlib
import logging
import os
import re
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import click
import numpy as np

from .._validation import positive
from ..errors import InputError
from ..imaging import ImageGrid

__all__ = [
    "MAX_GROUND_SPEED_MPS",
    "MAX_IMAGE_SIDE_PIXELS",
    "InputError",
    "Progress",
    "as_flags",
    "check_image_size",
    "check_out",
    "check_workers_flag",
    "connect_scheduler_flag",
    "dask_logging",
    "extent_grid",
    "false_alarm_rate_option",
    "force_option",
    "gotcha_force_option",
    "lenient_option",
    "max_speed_callback",
    "method_option",
    "noise_options",
    "ORIGIN_RULE",
    "SCHEDULER_LIMITS",
    "origin_callback",
    "out_option",
    "scheduler_callback",
    "speed_option",
    "say",
    "square_grid",
    "workers_callback",
]


@contextlib.contextmanager
def as_flags(**flags: str) -> Iterator[None]:
    """Report a library's argument error under the flags the user typed.

    ``with as_flags(speed_mps="--speed"): ...`` turns ``ValueError("speed_mps must be >
    0 ...")`` into ``InputError("--speed must be > 0 ...")``. Errors about files
    (:class:`~sarmotion.io.DataError`, scene errors: :class:`~sarmotion.errors.InputError`)
    name their file and pass unchanged.
    """
    try:
        yield
    except InputError:
        raise
    except (TypeError, ValueError) as exc:
        text = str(exc)
        for name, flag in flags.items():
            text = re.sub(rf"(?<![\w-]){re.escape(name)}(?![\w])", flag, text)
        raise InputError(text) from None


#: Loggers of Dask and of the libraries under it (the web server, the event loop).
DASK_LOGGERS = ("distributed", "dask", "tornado", "asyncio", "bokeh")


@contextlib.contextmanager
def dask_logging() -> Iterator[None]:
    """Dask's log lines through sarmotion's verbosity while the block runs.

    ``-v`` (info) and ``-vv`` (debug) show them in sarmotion's format; by default and with
    ``-q`` they are silent (a failure still reaches the user as the task's exception,
    reported as any other error). Importing ``distributed`` sets its own levels, so it is
    imported first; the previous levels come back afterwards.
    """
    import distributed  # noqa: F401

    root = logging.getLogger().getEffectiveLevel()
    level = root if root <= logging.INFO else logging.CRITICAL + 1
    names = [
        n
        for n in list(logging.root.manager.loggerDict)
        if any(n == p or n.startswith(p + ".") for p in DASK_LOGGERS)
    ]
    saved = {}
    for name in sorted(set(names) | set(DASK_LOGGERS)):
        logger = logging.getLogger(name)
        saved[name] = (logger.level, logger.propagate)
        logger.setLevel(level if name in DASK_LOGGERS else logging.NOTSET)
        logger.propagate = logger.propagate or not logger.handlers
    try:
        yield
    finally:
        for name, (lvl, propagate) in saved.items():
            logger = logging.getLogger(name)
            logger.setLevel(lvl)
            logger.propagate = propagate


#: Least time between two progress lines of one stage when not on a terminal (s).
LINE_INTERVAL_S = 1.0


class Progress:
    """Progress of the library's ``progress(stage, done, total)`` calls, for a person.

    On a terminal, a tqdm bar per stage with its ETA on standard error (a new bar whenever
    the stage changes); elsewhere (output piped to a file or a program), on standard
    output with the plan and the summary, a line at each tenth of a stage's work,
    ``"backprojection: 3/8 (38 %), 2.1 s"``, at most one every :data:`LINE_INTERVAL_S`
    but always the stage's last (a short stage says only when it ended). Nothing when
    disabled (``-q``).

    Parameters
    ----------
    enabled : bool
        Report progress at all (False under ``-q``).
    stream : file, optional
        Where to write (bars if it is a terminal, else lines); default: bars on
        ``sys.stderr`` when it is a terminal, else lines on ``sys.stdout``. Standard error
        is left to errors and logs, so a refused input is one line there.
    """

    def __init__(self, *, enabled: bool = True, stream: Any = None) -> None:
        self.enabled = enabled
        if stream is None:  # bars on a terminal's stderr; lines with the output, on stdout
            self.bars = enabled and _isatty(sys.stderr)
            self.stream = sys.stderr if self.bars else sys.stdout
        else:
            self.bars = enabled and _isatty(stream)
            self.stream = stream
        self.stage = ""
        self._bar: Any = None
        self._tenth = -1
        self._t0 = self._said = time.perf_counter()

    def __call__(self, stage: str, done: int, total: int) -> None:
        """Advance the bar (or the lines) of ``stage`` to ``done`` of ``total``."""
        if not self.enabled:
            return
        if stage != self.stage:
            self.close()
            if self.stage:  # the first stage's clock runs from the start
                self._t0 = time.perf_counter()
            self.stage = stage
            self._tenth = -1
            self._said = time.perf_counter()
        if not self.bars:
            tenth = 10 if total <= 0 else min(10, int(10 * done / total))
            now = time.perf_counter()
            if tenth > self._tenth and (tenth == 10 or now - self._said >= LINE_INTERVAL_S):
                self._tenth = tenth
                self._said = now
                share = 100.0 if total <= 0 else 100.0 * done / total
                took = now - self._t0
                print(
                    f"{stage}: {done}/{total} ({share:.0f} %), {took:.1f} s",
                    file=self.stream,
                    flush=True,
                )
            return
        if self._bar is None:
            from tqdm import tqdm

            self._bar = tqdm(
                total=total,
                desc=stage,
                unit="step",
                leave=False,
                file=self.stream,
                ncols=None if _columns(self.stream) > 0 else 80,
            )
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


def _isatty(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


def _columns(stream: Any) -> int:
    """The terminal's width in columns (0 where unknown, e.g. a pseudo-terminal of size 0)."""
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (AttributeError, ValueError, OSError):
        return 0


def say(ctx: click.Context | None, text: str) -> None:
    """Tell the user what the command is about to do, unless ``-q``.

    On standard output, with the command's summary (as ``track`` prints its plan):
    standard error holds progress and, on bad input, the one line of the error.
    """
    quiet = ctx is not None and bool((ctx.find_root().obj or {}).get("quiet"))
    if not quiet:
        click.echo(text)


def out_option(help_text: str, **kwargs: Any) -> Callable[[Callable[..., Any]], Any]:
    """The ``--out`` option (a path), declared once for every command."""
    kwargs.setdefault("required", True)
    return click.option("--out", "out", type=click.Path(path_type=Path), help=help_text, **kwargs)


force_option = click.option(
    "--force",
    is_flag=True,
    help="Replace an existing output as a whole (the files this command writes there; "
    "other files are kept).",
)

#: ``--force`` of the commands that write GOTCHA ``.mat`` files into a folder.
gotcha_force_option = click.option(
    "--force",
    is_flag=True,
    help="Replace the GOTCHA files this command writes (data_3dsar_pass1_azNNN_HH.mat, NNN "
    "from the data's azimuths) and those of that name that sarmotion wrote before (marked "
    "in their header); every other file in the folder is kept, .mat files included. A "
    "single-file output (.h5, .cphd) is replaced as a whole.",
)

lenient_option = click.option(
    "--lenient",
    is_flag=True,
    help="Accept input files that break a plausibility rule (antenna track, r0, dynamic "
    "range), with a warning: for unusual but genuine data. A scene whose targets lie "
    "beyond its unambiguous scene is simulated aliased, with a warning saying where to.",
)


def _writable_ancestor(path: Path) -> Path:
    """The nearest existing directory at or above ``path``."""
    p = path.resolve()
    while not p.exists():
        p = p.parent
    return p


def check_out(
    out: Path,
    *,
    force: bool,
    names: Sequence[str] = (),
    patterns: Sequence[str] = (),
    sweep: bool | Callable[[Path], bool] = True,
) -> None:
    """Check and claim ``--out`` before any work is done (:mod:`sarmotion.io.staging`).

    A file output (``names`` empty, ``patterns`` empty) may not be an existing directory
    and is replaced only with ``--force``; a directory output may not be an existing file,
    and may already hold none of ``names`` (or entries matching ``patterns``) unless
    ``--force``. Links, devices, FIFOs and sockets are refused, with or without
    ``--force``. The directory that will receive the output must be writable. The
    target is then locked for this run (a concurrent run is refused at once, naming this
    one's PID) until the command ends; :func:`~sarmotion.io.staged_directory` and
    :func:`~sarmotion.io.staged_file` write through this claim.
    """
    from ..io.staging import OutputError, claim_output

    is_file = not names and not patterns
    try:
        claim = claim_output(
            out,
            kind="file" if is_file else "directory",
            force=force,
            names=names,
            patterns=patterns,
            sweep=sweep,
            check=lambda: _check_writable(out, is_file=is_file),
        )
    except OutputError as exc:
        raise InputError(str(exc)) from None
    ctx = click.get_current_context(silent=True)
    if ctx is not None:
        ctx.call_on_close(claim.release)
    else:
        atexit.register(claim.release)


def _check_writable(out: Path, *, is_file: bool) -> None:
    """InputError unless this user may write where ``out`` goes (and in ``out``)."""
    where = [_writable_ancestor(out.parent)]
    if not is_file and out.is_dir() and not out.is_symlink():
        where.insert(0, out)
    for w in where:
        if not os.access(w, os.W_OK | os.X_OK):
            raise InputError(f"--out {out}: cannot write in {w} (permission denied)")


method_option = click.option(
    "--method",
    type=click.Choice(["auto", "combined", "rpca", "annihilation"]),
    default="auto",
    show_default=True,
    help="How the stationary and moving echoes are separated. auto: combined for "
    "simulated scenes, rpca (eta x 2) for measured data.",
)

false_alarm_rate_option = click.option(
    "--false-alarm-rate",
    type=float,
    default=0.01,
    show_default=True,
    help="Per-scene false-alarm rate of the mover detector; sets the threshold on the "
    "g(u) peak over its local floor from the statistic's measured null distribution.",
)


#: Platform speeds (m/s) accepted by --speed: from a ground-based rail SAR (mm/s to cm/s)
#: to a satellite in low orbit (7.6 km/s).
SPEED_RANGE_MPS = (1e-3, 1e4)


def _speed_callback(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    lo, hi = SPEED_RANGE_MPS
    if not (np.isfinite(value) and lo <= value <= hi):
        raise InputError(f"--speed must be within [{lo:g}, {hi:g}] m/s, got {value!r}")
    return value


speed_option = click.option(
    "--speed",
    "speed_mps",
    type=float,
    default=70.0,
    show_default=True,
    callback=_speed_callback,
    help="GOTCHA inputs: platform speed that sets the slow time of the pulses (m/s, 1e-3 to 1e4).",
)


#: Largest ground speed of a mover (m/s) that --max-speed accepts: the speed of sound in
#: air at 20 degC, just above the land speed record (ThrustSSC, 341 m/s in 1997). No ground
#: vehicle moves faster.
MAX_GROUND_SPEED_MPS = 343.0


def max_speed_callback(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    """``--max-speed`` within ``(0, MAX_GROUND_SPEED_MPS]`` m/s."""
    if not (np.isfinite(value) and 0.0 < value <= MAX_GROUND_SPEED_MPS):
        raise InputError(
            f"--max-speed must be within (0, {MAX_GROUND_SPEED_MPS:g}] m/s (a ground mover: "
            f"below the speed of sound), got {value!r}"
        )
    return value


def check_workers_flag(n_workers: int | None) -> int | None:
    """``--workers``: None (one per core), 0 (no Dask) or within the local cluster's limit.

    The rule of :func:`~sarmotion._cluster.check_workers`, for every command that takes
    the flag.
    """
    from .._cluster import check_workers

    if n_workers is not None and n_workers != 0:
        with as_flags(n_workers="--workers"):
            check_workers(n_workers)
    return n_workers


def workers_callback(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    """Click callback of ``--workers`` (:func:`check_workers_flag`)."""
    return check_workers_flag(value)


def _scheduler_limits() -> str:
    from .._cluster import CONNECT_TIMEOUT_S, WORKER_WAIT_S

    return (
        f"It must answer within {CONNECT_TIMEOUT_S:g} s and have a worker within "
        f"{WORKER_WAIT_S:g} s more, else the command stops before any work."
    )


#: The limits a ``--scheduler`` is held to, for the commands' help (from their constants).
SCHEDULER_LIMITS = _scheduler_limits()


def scheduler_callback(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    """``--scheduler``: a ``tcp://`` or ``tls://`` address.

    The rule of :func:`~sarmotion._cluster.check_address`; nothing is connected to here.
    """
    from .._cluster import check_address

    if value is None:
        return None
    with as_flags():
        return check_address(value, "--scheduler")


def connect_scheduler_flag(address: str | None) -> Any:
    """A client of ``--scheduler`` held until the command ends, or None without the flag.

    Connected before any work (:func:`~sarmotion._cluster.connect_scheduler`: the
    address's rule, a connection within its timeout, a worker within its wait); each
    failure is one line naming the address.
    """
    if address is None:
        return None
    from .._cluster import connect_scheduler

    ctx = click.get_current_context()
    with dask_logging():
        return ctx.with_resource(connect_scheduler(address, name="--scheduler"))


def origin_callback(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    """``--origin LAT LON HAE``: a scene origin on the ground.

    The rule of :func:`~sarmotion._validation.geodetic_origin`, for every command.
    """
    from .._validation import geodetic_origin

    if value is None:
        return None
    with as_flags():
        return tuple(float(v) for v in geodetic_origin(value, "--origin"))


#: Help of ``--origin`` (convert, image): what it is and the rule of its values.
ORIGIN_RULE = (
    "latitude within [-90, 90], longitude within [-180, 360), height above the WGS 84 "
    "ellipsoid within [-1000, 10000] m (the Earth's land surface)"
)


#: Most pixels a side of an image (``--size`` / the analysis's pixel spacing): a 4096 x
#: 4096 complex128 image is 256 MiB, and an analysis holds a few of them at once.
MAX_IMAGE_SIDE_PIXELS = 4096


def check_image_size(size_m: float | None, spacing_m: float, flag: str = "--size") -> None:
    """InputError unless ``size_m`` (m) gives at most :data:`MAX_IMAGE_SIDE_PIXELS` a side."""
    if size_m is None:
        return
    with as_flags():
        positive(size_m, flag, unit="m")
    if size_m / spacing_m > MAX_IMAGE_SIDE_PIXELS:
        raise InputError(
            f"{flag} {size_m:g} m at {spacing_m:g} m pixels gives {size_m / spacing_m:.3g} "
            f"pixels a side (at most {MAX_IMAGE_SIDE_PIXELS}: {flag} <= "
            f"{MAX_IMAGE_SIDE_PIXELS * spacing_m:g} m)"
        )


def _seed_callback(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    if value is not None and value < 0:
        raise InputError(f"--seed must be >= 0, got {value}")
    return value


def noise_options(func: Callable[..., Any]) -> Any:
    """``--snr-db`` and ``--seed``: white noise added to simulated (scene) inputs."""
    func = click.option(
        "--seed",
        type=int,
        default=0,
        show_default=True,
        callback=_seed_callback,
        help="Seed of the noise generator (>= 0).",
    )(func)
    return click.option(
        "--snr-db",
        type=float,
        default=None,
        help="Scene inputs: add white Gaussian noise at this signal-to-noise ratio (dB).",
    )(func)


def _within_envelope(flags: str, coordinates: Sequence[float]) -> None:
    """Image coordinates within twice the inputs' range envelope of the scene centre.

    No antenna of an accepted input is more than 1000 km from the scene centre
    (:data:`~sarmotion.io.plausibility.RANGE_ENVELOPE_M`), so no pixel further than
    2000 km from it is within the range envelope of any of them.
    """
    from ..io.plausibility import RANGE_ENVELOPE_M

    reach = 2.0 * RANGE_ENVELOPE_M[1]
    if not all(np.isfinite(c) and abs(c) <= reach for c in coordinates):
        raise InputError(
            f"{flags} must keep the image within {reach:g} m of the scene centre (twice the "
            "range envelope of the inputs)"
        )


def square_grid(size_m: float, spacing_m: float, centre: tuple[float, float]) -> ImageGrid:
    """Square image grid from ``--size``, ``--spacing`` and ``--centre``."""
    with as_flags():  # the messages name the flags already
        size_m = positive(size_m, "--size", unit="m")
        spacing_m = positive(spacing_m, "--spacing", unit="m")
    _within_envelope("--size/--centre", [c + h for c in centre for h in (-size_m / 2, size_m / 2)])
    if size_m / spacing_m > MAX_IMAGE_SIDE_PIXELS:
        raise InputError(
            f"--size/--spacing gives {size_m / spacing_m:.0f} pixels a side "
            f"(max {MAX_IMAGE_SIDE_PIXELS})"
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
    _within_envelope("--grid", extent)
    if max(x1 - x0, y1 - y0) / spacing_m > MAX_IMAGE_SIDE_PIXELS:
        raise InputError(f"--grid/--spacing gives more than {MAX_IMAGE_SIDE_PIXELS} pixels a side")
    return ImageGrid.from_extent(x_range_m=(x0, x1), y_range_m=(y0, y1), spacing_m=spacing_m)
