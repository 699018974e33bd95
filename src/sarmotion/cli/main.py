"""The ``sarmotion`` command group, its entry point and its error policy.

The CLI is the only layer that parses arguments and configures logging. Bad input
(:class:`~sarmotion.errors.InputError`, a file that cannot be opened) never shows a
traceback: one line on stderr (``sarmotion: error: ...``) and exit status 2. Any other
exception is a defect of sarmotion, not of the input: one line (``sarmotion: internal
error: ...; -vv shows the traceback``) and exit status 1. Outputs are staged in a hidden
sibling directory and moved into place only on success, so a failed run leaves nothing
half-written.
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import os
import signal
import sys
import textwrap
import threading
import time
from collections.abc import Iterator, Sequence
from typing import Any

import click

from .._version import __version__

__all__ = ["main", "run", "entry_point", "elapsed_s"]


log = logging.getLogger("sarmotion")


EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 1
EXIT_TERMINATED = 128 + signal.SIGTERM


_MAX_MEMORY_HELP = (
    "Largest allocation an input may make its reader do, e.g. 4G or 512MiB; inputs "
    "beyond it are refused from their headers. Default: half the memory available."
)


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that staged outputs are removed."""


def _on_sigterm(signum: int, frame: object) -> None:
    raise Terminated


@contextlib.contextmanager
def _sigterm_raises() -> Iterator[None]:
    """Turn SIGTERM into :class:`Terminated` while a command runs (main thread only).

    SIGINT raises ``KeyboardInterrupt`` as Python's own handler does, and also sets
    ``_cluster.INTERRUPTED``, so that a Ctrl-C raised inside a callback that swallows it
    is still acted on; where SIGINT is ignored (a command started in the background), it
    stays ignored.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    from .._cluster import INTERRUPTED, on_sigint

    INTERRUPTED.clear()
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    interrupt = signal.getsignal(signal.SIGINT)
    if interrupt is signal.default_int_handler:
        signal.signal(signal.SIGINT, on_sigint)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
        if interrupt is signal.default_int_handler:
            signal.signal(signal.SIGINT, interrupt)


# --------------------------------------------------------------------------- commands
#: Each command: its module (imported when the command runs or shows its own help) and
#: the first sentence of its help, which ``sarmotion --help`` lists without importing
#: the library (numba, scipy and matplotlib take ~1.5 s to load); a test checks that the
#: sentences are the commands' own.
COMMANDS: dict[str, tuple[str, str]] = {
    "analyze": (
        "analyze",
        "Separate, estimate and image the stationary and moving targets of INPUTS.",
    ),
    "convert": (
        "convert",
        "Convert INPUTS (a scene, a native .h5 file, GOTCHA .mat files or a .cphd file).",
    ),
    "demo": (
        "analyze",
        "Analyse the built-in Scene 1 (20 stationary targets, 2 movers) into OUT.",
    ),
    "image": (
        "image",
        "Backprojection image of INPUTS: a scene, native traces, GOTCHA .mat or CPHD files.",
    ),
    "inject": (
        "inject",
        "Add simulated point targets (stationary or moving) to real or simulated traces.",
    ),
    "paper": ("paper", "Regenerate every figure of the paper, with the numbers behind it."),
    "separate": ("separate", "Separate the traces of stationary and moving targets in INPUTS."),
    "simulate": (
        "simulate",
        "Simulate the traces of SCENE (a built-in name or a scene .toml file).",
    ),
    "track": ("track", "Follow the movers of INPUTS across overlapping sub-apertures."),
}


class _LazyGroup(click.Group):
    """A command group that imports a command's module only when the command is used."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in COMMANDS:
            return None
        if cmd_name not in self.commands:
            module = importlib.import_module(f".{COMMANDS[cmd_name][0]}", __package__)
            command = getattr(module, cmd_name)
            _add_shared_options(command)
            self.add_command(command, cmd_name)
        return self.commands[cmd_name]

    def invoke(self, ctx: click.Context) -> Any:
        """Run the command; a Ctrl-C is click's ``Abort`` (one line, no blank line before it)."""
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            raise click.Abort() from None

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The command list with the sentences of :data:`COMMANDS` (no import)."""
        names = self.list_commands(ctx)
        limit = formatter.width - 6 - max(len(n) for n in names)
        rows = [(n, textwrap.shorten(COMMANDS[n][1], limit, placeholder="...")) for n in names]
        with formatter.section("Commands"):
            formatter.write_dl(rows)


@click.group(
    cls=_LazyGroup,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)
@click.version_option(__version__, prog_name="sarmotion")
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bars.")
@click.option(
    "--max-memory",
    "max_memory",
    metavar="SIZE",
    default=None,
    help=_MAX_MEMORY_HELP,
)
@click.pass_context
def main(ctx: click.Context, verbose: int, quiet: bool, max_memory: str | None) -> None:
    """Single-antenna SAR imaging and motion estimation of complex scenes.

    Separates the echoes of stationary and moving targets (travel-time annihilation
    filters, windowed robust PCA), estimates the movers' velocities and positions, and
    images everything in focus (Borcea, Callaghan & Papanicolaou). Inputs are built-in
    scenes (example1, example2, scene1, filter10, filter30, hyperbola, rotscatt), scene
    .toml files, native .h5 traces, GOTCHA .mat or CPHD .cphd phase-history files.
    """
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    ctx.ensure_object(dict)
    # progress: bars on a terminal, a line per tenth of the work elsewhere, none with -q
    ctx.obj["progress"] = not quiet
    ctx.obj["quiet"] = quiet
    _max_memory(ctx, None, max_memory)


def _quiet(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    if value:
        obj = ctx.find_root().ensure_object(dict)
        obj["progress"] = False
        obj["quiet"] = True


def _verbose(ctx: click.Context, param: click.Parameter, value: int) -> None:
    if value:
        logging.getLogger().setLevel(logging.WARNING - 10 * min(value, 2))


def _max_memory(ctx: click.Context, param: click.Parameter | None, value: str | None) -> None:
    from .._limits import available_memory, format_bytes, parse_size, set_memory_limit
    from ..errors import InputError

    if param is None:  # the group's option: reset the limit of a previous run in-process
        set_memory_limit(None)
    if value is not None:
        try:
            nbytes = parse_size(value)
        except (TypeError, ValueError) as exc:
            raise InputError(f"--max-memory: {exc}") from None
        usable = available_memory()
        if nbytes > usable:
            raise InputError(
                f"--max-memory {value} ({format_bytes(nbytes)}) is beyond this machine's usable "
                f"memory ({format_bytes(usable)}: physical memory, cgroup and address-space "
                "limits)"
            )
        set_memory_limit(nbytes)


def _add_shared_options(command: click.Command) -> None:
    """-q, -v and --max-memory after the command name too (``sarmotion analyze -q ...``)."""
    command.params += [
        click.Option(
            ["-q", "--quiet"],
            is_flag=True,
            expose_value=False,
            callback=_quiet,
            help="No progress bars.",
        ),
        click.Option(
            ["-v", "--verbose"],
            count=True,
            expose_value=False,
            callback=_verbose,
            help="More log output (-v info, -vv debug).",
        ),
        click.Option(
            ["--max-memory"],
            metavar="SIZE",
            expose_value=False,
            callback=_max_memory,
            help=_MAX_MEMORY_HELP,
        ),
    ]


def _bad_input() -> tuple[type[BaseException], ...]:
    """The exceptions that mean bad input: exit status 2 with one line.

    :class:`~sarmotion.errors.InputError` (its subclasses included: the I/O layer's
    ``DataError``, ``SceneError``, the command line's own checks), an output that cannot
    be claimed (:class:`~sarmotion.io.staging.OutputError`, a ``ValueError``: the staging
    module imports nothing of the package, so that it can be loaded alone) and files that
    cannot be opened. Any other exception, a bare ``ValueError`` included, is a defect.
    """
    from ..errors import InputError
    from ..io.staging import OutputError

    return (InputError, OutputError, FileNotFoundError, OSError)


#: When the running command started, on the :func:`time.monotonic` clock: the process's
#: start for the console script, the call of :func:`run` otherwise.
_STARTED = [time.monotonic()]


def elapsed_s() -> float:
    """Seconds since the running command started: start-up, reading, work and writing."""
    return time.monotonic() - _STARTED[0]


def _process_age_s() -> float:
    """Seconds since this process started (Linux ``/proc``; 0 where it cannot be read).

    ``/proc/self/stat`` field 22 is the start time in clock ticks after boot and
    ``/proc/uptime`` the time since boot: their difference is the process's age, to a
    clock tick (10 ms).
    """
    try:
        with open("/proc/self/stat", encoding="ascii") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        with open("/proc/uptime", encoding="ascii") as fh:
            uptime = float(fh.read().split()[0])
        return max(0.0, uptime - int(fields[19]) / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError, AttributeError):
        return 0.0


def run(args: Sequence[str] | None = None, *, started: float | None = None) -> int:
    """Run the CLI with ``args``; return the exit status (never raises for bad input).

    ``started``: when the command started (:func:`time.monotonic`), for the time it
    reports (:func:`elapsed_s`); default now.
    """
    _STARTED[0] = time.monotonic() if started is None else started
    try:
        with _sigterm_raises():
            main.main(
                args=list(args) if args is not None else None,
                prog_name="sarmotion",
                standalone_mode=False,
            )
    except Terminated:
        click.echo("sarmotion: terminated; no output written", err=True)
        return EXIT_TERMINATED
    except click.exceptions.Abort:
        click.echo("sarmotion: aborted", err=True)
        return 130
    except click.UsageError as exc:  # a flag's type, a missing argument: one line too
        where = exc.ctx.command_path if exc.ctx is not None else "sarmotion"
        text = " ".join(exc.format_message().split())
        click.echo(f"sarmotion: error: {text} ({where} --help shows the usage)", err=True)
        return exc.exit_code
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code
    except _bad_input() as exc:
        log.debug("bad input", exc_info=True)
        click.echo(f"sarmotion: error: {exc}", err=True)
        return EXIT_BAD_INPUT
    except MemoryError as exc:  # an input's size that no header declared, or a limit set too high
        log.debug("out of memory", exc_info=True)
        what = str(exc).splitlines()[0] if str(exc) else "an allocation failed"
        click.echo(
            f"sarmotion: error: out of memory ({what}); --max-memory below this machine's "
            "free memory refuses such inputs from their headers",
            err=True,
        )
        return EXIT_BAD_INPUT
    except Exception as exc:  # a defect of sarmotion, not of the input
        log.debug("internal error", exc_info=True)
        click.echo(
            f"sarmotion: internal error: {type(exc).__name__}: {exc}; -vv shows the traceback",
            err=True,
        )
        return EXIT_INTERNAL
    return 0


def entry_point() -> None:
    """Console-script entry point."""
    sys.exit(run(started=time.monotonic() - _process_age_s()))
