"""The ``sarmotion`` command group, its entry point and its error policy.

The CLI is the only layer that parses arguments and configures logging. Bad input never shows
a traceback: one line on stderr (``sarmotion: error: ...``) and exit status 2; outputs
are staged in a hidden sibling directory and moved into place only on success, so a
failed run leaves nothing half-written.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import sys
import threading
from collections.abc import Iterator, Sequence

import click

from .. import __version__
from .analyze import analyze, demo
from .common import InputError
from .convert import convert
from .image import image
from .inject import inject
from .paper import paper
from .separate import separate
from .simulate import simulate
from .track import track

__all__ = ["main", "run", "entry_point"]


log = logging.getLogger("sarmotion")


EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 1
EXIT_TERMINATED = 128 + signal.SIGTERM


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that staged outputs are removed."""


def _on_sigterm(signum: int, frame: object) -> None:
    raise Terminated


@contextlib.contextmanager
def _sigterm_raises() -> Iterator[None]:
    """Turn SIGTERM into :class:`Terminated` while a command runs (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


# --------------------------------------------------------------------------- commands
@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="sarmotion")
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bars.")
@click.pass_context
def main(ctx: click.Context, verbose: int, quiet: bool) -> None:
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
    ctx.obj["progress"] = not quiet and sys.stderr.isatty()


def _quiet(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    if value:
        ctx.ensure_object(dict)["progress"] = False


def _verbose(ctx: click.Context, param: click.Parameter, value: int) -> None:
    if value:
        logging.getLogger().setLevel(logging.WARNING - 10 * min(value, 2))


for _command in (simulate, image, inject, separate, analyze, track, demo, paper, convert):
    # -q and -v work after the command name too (``sarmotion analyze -q ...``).
    _command.params += [
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
    ]
    main.add_command(_command)


def _known_errors() -> tuple[type[BaseException], ...]:
    from ..io import DataError
    from ..simulation import SceneError

    return (InputError, DataError, SceneError, ValueError, FileNotFoundError, OSError)


def run(args: Sequence[str] | None = None) -> int:
    """Run the CLI with ``args``; return the exit status (never raises for bad input)."""
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
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code
    except _known_errors() as exc:
        log.debug("bad input", exc_info=True)
        click.echo(f"sarmotion: error: {exc}", err=True)
        return EXIT_BAD_INPUT
    except Exception as exc:  # a defect of sarmotion, not of the input
        log.debug("internal error", exc_info=True)
        click.echo(
            f"sarmotion: internal error: {type(exc).__name__}: {exc} (-vv shows the traceback)",
            err=True,
        )
        return EXIT_INTERNAL
    return 0


def entry_point() -> None:
    """Console-script entry point."""
    sys.exit(run())
