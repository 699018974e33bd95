"""Outputs that cannot clobber or mix: a claimed target, staged whole, swapped in by rename.

Guarantees
----------
For an output target ``out`` (a file, or a directory of files):

1. **One writer.** ``out`` is claimed before any work by an exclusive lock on the file
   ``.NAME.lock`` beside it (``NAME`` = ``out``'s name; :func:`fcntl.flock`, which the
   kernel releases when its holder dies, even by SIGKILL, so a lock is never stale). The
   holder writes its PID into it. A second claim is refused at once with one line naming
   the holder's PID; the lock file is removed when the claim is released (after a
   SIGKILL it stays, unlocked, until the next claim of the same target takes it over).
2. **Nothing but regular files and directories, and never through a link.** A target that
   is a symbolic link (to anything, dangling, to itself, or in a loop), a device, a FIFO
   or a socket is refused, with or without ``force``; the final path component is never
   resolved, so no other file can be written through it.
3. **Old or new, never a mix.** Whatever stops the process (an exception, SIGTERM,
   Ctrl-C, SIGKILL, a power cut once the file system has its metadata on disk), ``out``
   holds either its previous content or the complete new output:

   - the new output is written in full in a staging directory
     ``.NAME.partial-PID-TOKEN`` beside ``out`` (same file system, so every move is a
     rename);
   - a directory output is then swapped in as a whole: one ``renameat2(RENAME_EXCHANGE)``
     where the system has it (Linux >= 3.15; atomic), otherwise ``rename(out, old)``
     then ``rename(stage, out)`` with ``old = .NAME.old-PID-TOKEN``; the previous
     directory is deleted afterwards. A file output is one ``rename`` onto ``out``
     (atomic replace), or ``link`` where ``out`` must not exist yet (atomic, fails if
     it appeared). Outputs are never moved file by file;
   - a run cut between the two renames of the fallback leaves ``out`` absent and the
     previous output intact under ``.NAME.old-*``; the next claim of ``out`` puts it
     back (**recovery**), and removes the staging directories of dead runs. Both are
     recognised by name and by the PID in it: only a PID that no longer runs (or this
     process's own) marks leftovers, and only the claim's holder touches them.
4. **``force`` replaces the whole previous output set.** After a swap ``out`` holds
   exactly the entries the new run wrote, plus the files of the previous directory that
   are not outputs of the command (user files: not named in ``names``, not written by
   this run, and not matching ``patterns`` where the claim sweeps them), which are
   carried over as hard links (copies where the file system has none), so they are
   never moved out of ``out`` before the swap. A command whose files share a naming
   scheme with files a user keeps (GOTCHA ``.mat`` files) claims with ``sweep``, a test
   of a previous output's content (its writer's mark): ``force`` replaces the entries
   the run writes and the entries matching ``patterns`` that pass the test, never a
   user's file that merely matches a pattern. A directory holding folders the command
   does not write, or holding the current directory, is refused: it is not an output
   directory, and swapping it would move them. Without ``force`` an existing output
   entry refuses the claim before any work; a target that appears while the command
   runs (a file the user created) is not replaced without ``force``.

Exceptions and termination signals before the swap remove the staging directory and any
parent directory the claim created, and leave the target as it was; once the swap is
done the new output stands (what remains is deleting the previous one, which the next
claim finishes if the process dies first).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import fnmatch
import logging
import os
import re
import secrets
import shutil
import stat
import time
from collections.abc import Callable, Iterator, Sequence, Set
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows: an O_EXCL lock file instead
    fcntl = None  # type: ignore[assignment]

__all__ = [
    "OutputClaim",
    "OutputError",
    "claim_output",
    "staged_directory",
    "staged_file",
    "staged_paths",
]

log = logging.getLogger(__name__)

Kind = Literal["file", "directory"]


class OutputError(ValueError):
    """An output target cannot be claimed or replaced: one line naming it and why."""


# ------------------------------------------------------------------ system calls
_AT_FDCWD = -100
_RENAME_NOREPLACE = 1
_RENAME_EXCHANGE = 2


def _load_renameat2():  # type: ignore[no-untyped-def]
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):  # no libc by that name, or no renameat2 (not Linux)
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    return fn


_renameat2_fn = _load_renameat2()


def _renameat2(src: Path, dst: Path, flags: int) -> bool:
    """``renameat2(src, dst, flags)``; False where the system or file system lacks it."""
    if _renameat2_fn is None:
        return False
    if _renameat2_fn(_AT_FDCWD, os.fsencode(src), _AT_FDCWD, os.fsencode(dst), flags) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(dst))


def _exchange(a: Path, b: Path) -> bool:
    """Swap the entries ``a`` and ``b`` atomically; False where not supported."""
    return _renameat2(a, b, _RENAME_EXCHANGE)


def _rename_noreplace(src: Path, dst: Path) -> bool:
    """Rename ``src`` to ``dst`` unless ``dst`` exists (FileExistsError); False if unsupported."""
    return _renameat2(src, dst, _RENAME_NOREPLACE)


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (or exists under another user)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OSError:
        return False
    return True


_LOCK_FLAGS = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)


def _read_pid(fd: int) -> str:
    """The text of a lock file (its holder's PID, or empty)."""
    os.lseek(fd, 0, os.SEEK_SET)
    return os.read(fd, 32).decode("ascii", "replace").strip()


def _flock(fd: int, path: Path) -> None:
    """Lock ``fd`` exclusively without waiting (BlockingIOError if another process holds it).

    Without ``fcntl`` (Windows) the lock is the lock file's PID: held while that process
    runs.
    """
    if fcntl is not None:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return
    text = _read_pid(fd)  # pragma: no cover
    if text.isdigit() and int(text) != os.getpid() and _alive(int(text)):  # pragma: no cover
        raise BlockingIOError(errno.EWOULDBLOCK, "locked", str(path))


# --------------------------------------------------------------------- the target
_KINDS = {
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFIFO: "a FIFO (named pipe)",
    stat.S_IFSOCK: "a socket",
}


def _state(out: Path) -> Literal["missing", "file", "directory"]:
    """What is at ``out`` (never following a link); OutputError for anything else."""
    try:
        st = os.lstat(out)
    except FileNotFoundError:
        return "missing"
    except NotADirectoryError:
        raise OutputError(f"--out {out}: a parent of it is not a directory") from None
    if stat.S_ISLNK(st.st_mode):
        try:
            target = os.readlink(out)
        except OSError:
            target = "?"
        raise OutputError(
            f"--out {out} is a symbolic link (to {target}); outputs are never written "
            "through a link: give the real path"
        )
    if stat.S_ISREG(st.st_mode):
        return "file"
    if stat.S_ISDIR(st.st_mode):
        return "directory"
    what = _KINDS.get(stat.S_IFMT(st.st_mode), "a special file")
    raise OutputError(f"--out {out} is {what}, not a regular file or directory")


def _absolute(out: Path) -> Path:
    """``out`` made absolute with its parent's links resolved and its own name kept."""
    p = Path(os.path.abspath(out))
    if p.parent == p:
        raise OutputError(f"--out {out} is the file system's root")
    return p.parent.resolve() / p.name


def _leftover(name: str, entry: str) -> tuple[str, int | None] | None:
    """``("partial" | "old", pid)`` if ``entry`` is a staging leftover of output ``name``."""
    m = re.fullmatch(rf"\.{re.escape(name)}\.(partial|old)-(\d+)-[0-9a-f]{{12}}", entry)
    if m:
        return m.group(1), int(m.group(2))
    if re.fullmatch(rf"\.{re.escape(name)}\.partial-[a-z0-9_]{{8}}", entry):
        return "partial", None  # an older naming without PID: no running claim has it
    return None


def _rmtree(path: Path) -> None:
    shutil.rmtree(path, ignore_errors=True)
    with contextlib.suppress(FileNotFoundError, IsADirectoryError, OSError):
        if os.path.lexists(path) and not os.path.isdir(path):
            os.unlink(path)


def _carry(src: Path, dst: Path) -> None:
    """Put the file ``src`` at ``dst`` as a hard link (a copy where links are refused)."""
    st = os.lstat(src)
    try:
        os.link(src, dst, follow_symlinks=False)
    except OSError:
        if stat.S_ISLNK(st.st_mode):
            os.symlink(os.readlink(src), dst)
        elif stat.S_ISREG(st.st_mode):
            shutil.copy2(src, dst)
        else:
            raise


# ----------------------------------------------------------------------- the claim
_CLAIMS: dict[Path, OutputClaim] = {}
#: Directories this process's claims created (as parents of their targets): a target
#: among them did not "appear while the run worked", this run made it.
_CREATED: set[Path] = set()


@dataclass(eq=False)
class OutputClaim:
    """An output target held by this process (:func:`claim_output`).

    Attributes
    ----------
    out : Path
        The target, absolute, its last component not resolved.
    kind : {"file", "directory"}
        What the run writes there.
    force : bool
        Whether previous outputs (and a target that appears while the run works) may be
        replaced.
    names, patterns : tuple of str
        A directory output's entries (names, and shell patterns such as ``"*.mat"``):
        without ``force`` they refuse the claim; with it they are replaced (entries
        matching ``patterns`` only where ``sweep``).
    sweep : bool or callable
        Whether ``force`` removes previous entries that match ``patterns`` but that this
        run did not write (True: a previous output set, e.g. ``mover-3.nitf`` from a run
        that found more movers); a callable ``sweep(path) -> bool`` removes only those
        it recognises as a previous output (e.g. by their writer's mark).
    existed : bool
        Whether ``out`` existed when claimed.
    """

    out: Path
    kind: Kind
    force: bool
    names: tuple[str, ...] = ()
    patterns: tuple[str, ...] = ()
    sweep: bool | Callable[[Path], bool] = True
    existed: bool = False
    _fd: int | None = field(default=None, repr=False)
    _made: list[Path] = field(default_factory=list, repr=False)

    @property
    def lock_path(self) -> Path:
        """The lock file ``.NAME.lock`` beside the target."""
        return self.out.parent / f".{self.out.name}.lock"

    @property
    def held(self) -> bool:
        """Whether the claim is still held."""
        return self._fd is not None

    # ------------------------------------------------------------------ lock
    def _acquire(self) -> None:
        path = self.lock_path
        for _ in range(20):
            try:
                fd = os.open(path, _LOCK_FLAGS, 0o644)
            except OSError as exc:
                if exc.errno == errno.ELOOP:
                    raise OutputError(f"--out {self.out}: its lock file {path} is a link") from None
                raise OutputError(
                    f"--out {self.out}: cannot create {path}: {exc.strerror}"
                ) from None
            kind = stat.S_IFMT(os.fstat(fd).st_mode)
            if kind != stat.S_IFREG:
                os.close(fd)
                what = _KINDS.get(kind, "a special file")
                raise OutputError(
                    f"--out {self.out}: its lock file {path} is {what}, not a regular file; "
                    "remove it"
                )
            try:
                _flock(fd, path)
            except BlockingIOError:
                holder = _holder(fd)
                os.close(fd)
                raise OutputError(
                    f"--out {self.out} is being written by another sarmotion run "
                    f"(pid {holder}); wait for it to end or choose another --out"
                ) from None
            mine = os.fstat(fd)
            try:
                now = os.lstat(path)
            except FileNotFoundError:
                now = None
            if now is None or (now.st_dev, now.st_ino) != (mine.st_dev, mine.st_ino):
                os.close(fd)  # locked a lock file that its holder has just removed
                continue
            previous = _holder(fd, wait_s=0.0)
            try:
                os.ftruncate(fd, 0)
                os.lseek(fd, 0, os.SEEK_SET)
                if os.write(fd, f"{os.getpid()}\n".encode()) == 0:
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            except OSError as exc:  # a full disk: no lock file is left behind, empty
                with contextlib.suppress(OSError):
                    os.unlink(path)
                os.close(fd)
                raise OutputError(
                    f"--out {self.out}: cannot write its lock file {path}: {exc.strerror}"
                ) from None
            self._fd = fd
            if previous not in ("unknown", str(os.getpid())):
                log.info("%s: the previous run (pid %s) ended without releasing it", path, previous)
            return
        raise OutputError(f"--out {self.out}: its lock file {path} keeps changing")

    def release(self) -> None:
        """Give the target up: remove the lock file, and the parents the claim created if empty."""
        if self._fd is None:
            return
        with contextlib.suppress(OSError):
            os.unlink(self.lock_path)
        os.close(self._fd)
        self._fd = None
        for d in self._made:  # innermost first
            with contextlib.suppress(OSError):
                d.rmdir()  # only if empty
            if not d.exists():
                _CREATED.discard(d)
        self._made = []
        if _CLAIMS.get(self.out) is self:
            del _CLAIMS[self.out]

    # -------------------------------------------------------------- recovery
    def _recover(self) -> None:
        """Put back an output a dead run set aside; remove dead runs' staging directories."""
        parent, name = self.out.parent, self.out.name
        stale: list[tuple[str, str]] = []
        for entry in os.listdir(parent):
            found = _leftover(name, entry)
            if found is None:
                continue
            kind, pid = found
            if pid is None or pid == os.getpid() or not _alive(pid):
                stale.append((kind, entry))
        for kind, entry in sorted(stale, key=lambda x: x[0] != "old"):
            path = parent / entry
            if kind == "old" and not os.path.lexists(self.out):
                os.rename(path, self.out)
                log.warning("--out %s: restored the previous output from %s", self.out, entry)
            else:
                _rmtree(path)
                log.info("--out %s: removed %s, left by a run that died", self.out, entry)

    # ------------------------------------------------------------- the check
    def _ours(self, entry: str, written: Set[str] = frozenset()) -> bool:
        return (
            entry in written
            or entry in self.names
            or any(fnmatch.fnmatchcase(entry, p) for p in self.patterns)
        )

    def _check(self, state: str, *, written: Set[str] = frozenset()) -> None:
        out = self.out
        if self.kind == "file":
            if state == "directory":
                raise OutputError(f"--out {out} is a directory; expected a file name")
            if state == "file" and not self.force:
                raise OutputError(f"--out {out} already exists; --force replaces it")
            return
        if state == "file":
            raise OutputError(f"--out {out} exists and is not a directory")
        if state != "directory":
            return
        cwd = Path.cwd().resolve()
        if out.resolve() in (cwd, *cwd.parents):
            raise OutputError(
                f"--out {out} is the current directory or holds it; outputs are swapped in "
                "as a whole directory: give one of their own"
            )
        entries = os.listdir(out)
        folders = sorted(e for e in entries if not self._ours(e, written) and (out / e).is_dir())
        if folders:
            shown = ", ".join(folders[:4]) + (", ..." if len(folders) > 4 else "")
            raise OutputError(
                f"--out {out} holds folders sarmotion does not write ({shown}); outputs are "
                "swapped in as a whole directory: give a new or empty one, or a previous output"
            )
        if not self.force:
            clash = sorted(e for e in entries if self._ours(e, written))
            if clash:
                shown = ", ".join(clash[:4]) + (", ..." if len(clash) > 4 else "")
                raise OutputError(f"--out {out} already holds {shown}; --force replaces them")

    # ------------------------------------------------------------------ stage
    @contextmanager
    def stage(self) -> Iterator[Path]:
        """Stage the output; commit it to the target if the block succeeds.

        Yields
        ------
        Path
            A directory output: the (empty) staging directory, to fill. A file output:
            the path to write the file at (in the staging directory).
        """
        if not self.held:
            raise RuntimeError(f"{self.out}: the output claim was released")
        stage = self.out.parent / f".{self.out.name}.partial-{os.getpid()}-{secrets.token_hex(6)}"
        os.mkdir(stage)
        try:
            yield stage if self.kind == "directory" else stage / self.out.name
            if self.kind == "directory":
                self._swap_directory(stage)
            else:
                self._swap_file(stage / self.out.name)
        finally:
            _rmtree(stage)

    def _appeared(self) -> OutputError:
        return OutputError(f"--out {self.out} was created while sarmotion ran; --force replaces it")

    def _present(self, state: str, written: Set[str] = frozenset()) -> None:
        """Check the target found at commit time (``state`` not "missing")."""
        if not self.existed and not self.force and self.out not in _CREATED:
            raise self._appeared()
        self._check(state, written=written)

    def _swap_file(self, staged: Path) -> None:
        if not staged.is_file():
            raise RuntimeError(f"{staged}: nothing was written")
        if _state(self.out) == "missing":
            try:
                os.link(staged, self.out)  # atomic, and fails if the target appeared
                return
            except FileExistsError:
                pass
            except OSError:  # no hard links here: a rename, checked just before
                if not os.path.lexists(self.out):
                    os.rename(staged, self.out)
                    return
        self._present(_state(self.out))
        os.rename(staged, self.out)  # atomic replace

    def _swap_directory(self, stage: Path) -> None:
        out = self.out
        written = set(os.listdir(stage))
        state = _state(out)
        if state == "missing":
            try:
                if _rename_noreplace(stage, out):
                    return
            except FileExistsError:
                pass
            else:  # no renameat2: a rename, checked just before
                if not os.path.lexists(out):
                    os.rename(stage, out)
                    return
            state = _state(out)
        self._present(state, written)
        for entry in os.listdir(out):
            replaced = self._ours(entry, written)
            if replaced and callable(self.sweep) and entry not in written:
                replaced = entry in self.names or self.sweep(out / entry)
            if not replaced:
                _carry(out / entry, stage / entry)  # the user's own files stay
        os.chmod(stage, stat.S_IMODE(os.lstat(out).st_mode))
        if _exchange(stage, out):
            return  # the stage now holds the previous output; removed by stage()
        old = out.parent / f".{out.name}.old-{os.getpid()}-{secrets.token_hex(6)}"
        os.rename(out, old)
        try:
            os.rename(stage, out)
        except BaseException:
            if not os.path.lexists(out):
                os.rename(old, out)
            raise
        _rmtree(old)


def _holder(fd: int, wait_s: float = 0.5) -> str:
    """The PID written in a lock file (waiting up to ``wait_s`` for its holder to write it)."""
    deadline = time.monotonic() + wait_s
    while True:
        text = _read_pid(fd)
        if text.isdigit():
            return text
        if time.monotonic() >= deadline:
            return "unknown"
        time.sleep(0.01)


def _longest_name(out: Path) -> str:
    """The longest name the staging of ``out`` creates beside it: its staging directory's.

    ``.NAME.partial-PID-TOKEN`` (this process's PID, 12 hex digits of token); the lock
    file ``.NAME.lock``, the set-aside ``.NAME.old-PID-TOKEN`` and the temporary files
    ``.NAME.TOKEN.tmp`` of :func:`staged_paths` are shorter.
    """
    return f".{out.name}.partial-{os.getpid()}-{'0' * 12}"


def _check_names(out: Path) -> None:
    """OutputError if a name the staging of ``out`` creates exceeds the file system's limit.

    The limit is ``NAME_MAX`` (bytes of one path component) of the nearest existing
    directory at or above ``out``'s parent, where the names will be created.
    """
    where = out.parent
    while not where.exists() and where.parent != where:
        where = where.parent
    try:
        limit = os.pathconf(where, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255  # POSIX file systems' usual NAME_MAX
    longest = _longest_name(out)
    size, own = len(os.fsencode(longest)), len(os.fsencode(out.name))
    if size > limit:
        raise OutputError(
            f"--out {out}: its name is {own} bytes; with the staging names made beside it "
            f"(up to {size} bytes, such as {longest[:24]}...) it exceeds this file system's "
            f"limit of {limit} bytes a name: give a name of at most {limit - (size - own)} bytes"
        )


def claim_output(
    out: Path | str,
    *,
    kind: Kind,
    force: bool = False,
    names: Sequence[str] = (),
    patterns: Sequence[str] = (),
    sweep: bool | Callable[[Path], bool] = True,
    check: Callable[[], None] | None = None,
) -> OutputClaim:
    """Claim the output target ``out`` for this process (module notes).

    Checks what is at ``out`` (refusing links and special files), locks it, recovers
    what a dead run left, and checks that the run may write there: a file target must
    not be a directory, nor exist without ``force``; a directory target must not be a
    file, nor hold an entry named in ``names`` or matching ``patterns`` without
    ``force``. Parent directories are created (and removed again on release if still
    empty). Release with :meth:`OutputClaim.release`.

    Parameters
    ----------
    out : Path or str
        The target.
    kind : {"file", "directory"}
        What the run writes.
    force : bool
        Replace previous outputs.
    names, patterns : sequence of str
        A directory output's entries: names and shell patterns.
    sweep : bool or callable
        With ``force``, also remove previous entries matching ``patterns`` that the run
        does not write: all of them (True, default), none (False), or those for which
        ``sweep(path)`` is true.
    check : callable, optional
        Called once the target is known to be no link or special file, before anything
        is created (the caller's own checks, such as permissions); what it raises
        propagates.

    Returns
    -------
    OutputClaim

    Raises
    ------
    OutputError
        Refused: one line naming the target (another run holds it, a link or special
        file, an existing output without ``force``, ...).
    """
    if kind not in ("file", "directory"):
        raise ValueError(f"kind must be 'file' or 'directory', got {kind!r}")
    target = _absolute(Path(out))
    if target in _CLAIMS:
        raise OutputError(f"--out {out} is already claimed by this process")
    state = _state(target)  # refuse links and special files before creating anything
    _check_names(target)
    if state != "missing" and os.path.ismount(target):
        raise OutputError(
            f"--out {out} is a mount point; outputs are put in place by renaming, which "
            "cannot move a mount point: give a path inside it"
        )
    if check is not None:
        check()
    claim = OutputClaim(
        out=target,
        kind=kind,
        force=bool(force),
        names=tuple(names),
        patterns=tuple(patterns),
        sweep=sweep if callable(sweep) else bool(sweep),
    )
    missing = [d for d in (target.parent, *target.parent.parents) if not d.exists()]
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"--out {out}: cannot create {target.parent}: {exc.strerror}") from None
    claim._made = missing
    _CREATED.update(missing)
    try:
        claim._acquire()
    except BaseException:
        claim._fd = None
        for d in missing:
            with contextlib.suppress(OSError):
                d.rmdir()
            _CREATED.discard(d)
        raise
    _CLAIMS[target] = claim
    try:
        claim._recover()
        state = _state(target)
        claim._check(state)
        claim.existed = state != "missing"
    except BaseException:
        claim.release()
        raise
    return claim


def claimed(out: Path | str) -> OutputClaim | None:
    """The claim this process holds on ``out``, if any."""
    try:
        return _CLAIMS.get(_absolute(Path(out)))
    except OutputError:
        return None


@contextmanager
def _staged(out: Path | str, kind: Kind) -> Iterator[Path]:
    claim = claimed(out)
    if claim is not None:
        if claim.kind != kind:
            raise RuntimeError(f"{out} was claimed as a {claim.kind} output, not a {kind}")
        with claim.stage() as path:
            yield path
        return
    claim = claim_output(out, kind=kind, force=True)
    try:
        with claim.stage() as path:
            yield path
    finally:
        claim.release()


@contextmanager
def staged_directory(out: Path | str) -> Iterator[Path]:
    """A staging directory whose content becomes the directory ``out`` only on success.

    Uses this process's claim on ``out`` (:func:`claim_output`, as the command line makes
    before any work) or, without one, claims ``out`` for the block with ``force``: each
    staged entry then replaces the entry of the same name, and the other entries of
    ``out`` are kept (module notes). When the block raises anything, including
    ``KeyboardInterrupt`` or a termination signal turned into an exception, the stage is
    removed and ``out`` is left as it was, and so are its parents (created ones removed).

    Raises
    ------
    OutputError
        ``out`` is a file, a link or a special file, or another run holds it.
    """
    with _staged(out, "directory") as stage:
        yield stage


@contextmanager
def staged_file(out: Path | str) -> Iterator[Path]:
    """A path to write the file ``out`` at; the file replaces ``out`` only on success.

    As :func:`staged_directory`, for a single file: the yielded path lies in a staging
    directory beside ``out`` and is renamed onto it when the block ends normally.
    """
    with _staged(out, "file") as path:
        yield path


@contextmanager
def staged_paths(targets: Sequence[Path], *, overwrite: bool = True) -> Iterator[list[Path]]:
    """Temporary paths next to ``targets``, moved onto them only if the block succeeds.

    The library's writers (one file each, or the files of one GOTCHA set) use this; the
    command line stages whole outputs with :func:`staged_directory` and
    :func:`staged_file`. The caller creates and writes each temporary file (fresh,
    unique names in the target's own directory, so ``os.replace`` is an atomic rename).
    When the ``with`` block ends normally every temporary file replaces its target; when
    it raises, the temporary files are deleted and the targets are left as they were
    (absent, or with their previous content). Each file is replaced atomically; a set of
    several files is not (a process killed between two renames leaves some new, some
    old).

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
