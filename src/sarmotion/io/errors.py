"""The exception of the I/O layer, and the staged (atomic) writing both file formats share."""

from __future__ import annotations

import contextlib
import os
import secrets
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

__all__ = ["DataError", "staged_paths", "staged_directory"]


class DataError(ValueError):
    """An input file or a data set is unusable.

    The message is one line that names the file (when there is one) and what is wrong
    with it: missing file, wrong format, missing field, wrong shape (expected and got),
    non-finite values, inconsistent or non-consecutive files.
    """


@contextmanager
def staged_paths(targets: Sequence[Path], *, overwrite: bool = True) -> Iterator[list[Path]]:
    """Temporary paths next to ``targets``, moved onto them only if the block succeeds.

    The caller creates and writes each temporary file (fresh, unique names in the
    target's own directory, so ``os.replace`` is an atomic rename). When the ``with``
    block ends normally every temporary file replaces its target; when it raises, the
    temporary files are deleted and the targets are left as they were (absent, or with
    their previous content).

    Parameters
    ----------
    targets : sequence of Path
        Final file paths.
    overwrite : bool
        If False, raise :class:`FileExistsError` before anything is written when a
        target exists.

    Yields
    ------
    list of Path
        One temporary path per target, not yet created.
    """
    targets = [Path(t) for t in targets]
    if not overwrite:
        for t in targets:
            if t.exists():
                raise FileExistsError(f"{t}: file exists (overwrite=False)")
    temps = [t.with_name(f".{t.name}.{secrets.token_hex(6)}.tmp") for t in targets]
    try:
        yield temps
        for tmp, target in zip(temps, targets, strict=True):
            os.replace(tmp, target)
    finally:
        for tmp in temps:
            tmp.unlink(missing_ok=True)


@contextmanager
def staged_directory(out: Path) -> Iterator[Path]:
    """A hidden staging directory whose files replace those of ``out`` only on success.

    The stage is created beside ``out`` (in ``out`` itself when ``out`` exists, so that
    a read-only parent does not matter). When the ``with`` block raises anything,
    including ``KeyboardInterrupt`` or a termination signal turned into an exception,
    the stage is removed and ``out`` is left as it was. On success each staged entry
    replaces the entry of the same name in ``out`` (a file or a directory; the command
    line asks for ``--force`` before that); if a replacement fails half-way (permissions,
    a full disk), the entries already moved are put back, and ``out`` is again as it was.

    Raises
    ------
    DataError
        ``out`` exists and is not a directory.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise DataError(f"--out {out} exists and is not a directory")
    created = not out.exists()
    parent = out.resolve().parent if created else out
    missing = [d for d in (parent, *parent.parents) if not d.exists()]
    parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=parent))
    try:
        yield stage
        if created:
            out.mkdir()
        _commit(stage, out)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        for d in ([out] if created else []) + missing:  # directories made here, innermost first
            with contextlib.suppress(OSError):
                d.rmdir()  # only if empty
        raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _commit(stage: Path, out: Path) -> None:
    """Move the entries of ``stage`` into ``out``; on failure undo every move."""
    backup = stage / ".previous"
    backup.mkdir()
    done: list[tuple[Path, Path | None]] = []  # (target, its previous entry in backup)
    try:
        for item in sorted(p for p in stage.iterdir() if p != backup):
            target = out / item.name
            old = None
            if target.exists() or target.is_symlink():
                old = backup / item.name
                os.replace(target, old)
            done.append((target, old))
            os.replace(item, target)
    except BaseException:
        for target, old in reversed(done):
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target, ignore_errors=True)
            else:
                target.unlink(missing_ok=True)
            if old is not None:
                os.replace(old, target)
        raise
