"""The exception of the I/O layer, and the staged (atomic) writing both file formats share."""

from __future__ import annotations

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
    """Yield a hidden staging directory; move its files into ``out`` only on success."""
    out = Path(out)
    parent = out.resolve().parent
    parent.mkdir(parents=True, exist_ok=True)
    if out.exists() and not out.is_dir():
        raise DataError(f"--out {out} exists and is not a directory")
    stage = Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=parent))
    try:
        yield stage
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    out.mkdir(parents=True, exist_ok=True)
    for item in sorted(stage.iterdir()):
        target = out / item.name
        if target.is_dir() and item.is_dir():
            shutil.rmtree(target)
        os.replace(item, target)
    shutil.rmtree(stage, ignore_errors=True)
