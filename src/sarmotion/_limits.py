"""The memory budget of the readers: what an input will make them allocate, checked first.

Every reader (GOTCHA, native HDF5, CPHD, scene files) computes from the headers of its
input, before it allocates anything, the bytes it will hold at once, and refuses an
input beyond :func:`memory_limit` with one line naming the input, the bytes and the
limit. A small file can declare a huge array (a never-written HDF5 dataset, a sparse
CPHD, a zlib stream of zeros, a scene of 10^8 pulses): refusing it from its headers is
the only refusal that costs nothing.

The limit
---------
``--max-memory`` on the command line (:func:`set_memory_limit` in the API); by default
:data:`DEFAULT_FRACTION` (one half) of the memory this process may use: the smallest of
the machine's physical memory, the cgroup limit of its container
(``/sys/fs/cgroup/memory.max``) and, under an address-space limit (``ulimit -v``,
``prlimit --as``), what is left of that limit beyond the address space the process
already maps. One half because a reader's estimate covers the read itself, and every
command then holds at least one more array of the same size (the separated traces, the
image stack) while the operating system and the interpreter need the rest.

What a read holds
-----------------
The arrays as stored, plus :data:`WORKING_COPIES` complex128 arrays of the phase
history's shape: the phase history itself, a re-referencing factor, and the three arrays
of the transform to fast time (:func:`sarmotion.core.spectral.to_fast_time`: the shifted
input, the inverse FFT and its shifted output).
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import resource
from collections.abc import Iterator
from pathlib import Path

__all__ = [
    "DEFAULT_FRACTION",
    "WORKING_COPIES",
    "available_memory",
    "format_bytes",
    "memory_limit",
    "memory_limit_set",
    "over_budget",
    "parse_size",
    "phase_history_bytes",
    "set_memory_limit",
]

#: Fraction of the usable memory a read may take by default.
DEFAULT_FRACTION = 0.5

#: complex128 arrays of the phase history's shape alive at once during a read (module notes).
WORKING_COPIES = 5

_limit: int | None = None

_UNITS = {
    "": 1, "b": 1,
    "k": 10**3, "kb": 10**3, "kib": 2**10,
    "m": 10**6, "mb": 10**6, "mib": 2**20,
    "g": 10**9, "gb": 10**9, "gib": 2**30,
    "t": 10**12, "tb": 10**12, "tib": 2**40,
}  # fmt: skip
_SIZE_RE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([a-zA-Z]*)\s*$")


def _physical() -> int:
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return 1 << 62


def _cgroup() -> int | None:
    for name in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        with contextlib.suppress(OSError, ValueError):
            text = Path(name).read_text().strip()
            if text != "max" and int(text) < 1 << 60:
                return int(text)
    return None


def _mapped() -> int:
    """Address space this process maps now (bytes; 0 when unknown)."""
    with contextlib.suppress(OSError, ValueError, IndexError):
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0


def available_memory() -> int:
    """Bytes this process may still use: physical memory, cgroup and address-space limits."""
    usable = _physical()
    cgroup = _cgroup()
    if cgroup is not None:
        usable = min(usable, cgroup)
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY:
        usable = min(usable, max(soft - _mapped(), 0))
    return usable


def memory_limit() -> int:
    """The largest allocation a read may make (bytes): the set limit, else the default."""
    if _limit is not None:
        return _limit
    return int(DEFAULT_FRACTION * available_memory())


def set_memory_limit(nbytes: int | str | None) -> None:
    """Set the memory limit of the readers (bytes, or a size such as ``"4G"``; None: default)."""
    global _limit
    _limit = None if nbytes is None else parse_size(nbytes)


@contextlib.contextmanager
def memory_limit_set(nbytes: int | str | None) -> Iterator[None]:
    """:func:`set_memory_limit` for the duration of a ``with`` block."""
    global _limit
    previous = _limit
    set_memory_limit(nbytes)
    try:
        yield
    finally:
        _limit = previous


def parse_size(value: int | float | str) -> int:
    """Bytes from ``1000000``, ``"512M"``, ``"2.5GB"`` or ``"4GiB"`` (k, M, G, T: powers of 10).

    Raises
    ------
    ValueError
        Not a positive finite size.
    """
    if isinstance(value, bool):
        raise TypeError(f"a memory size must be a number of bytes or a string, got {value!r}")
    if isinstance(value, (int, float)):
        number, unit = float(value), ""
    elif isinstance(value, str):
        m = _SIZE_RE.match(value)
        if m is None or m[2].lower() not in _UNITS:
            raise ValueError(
                f"memory size must be a number with an optional unit (k, M, G, T, KiB, MiB, "
                f"GiB, TiB), got {value!r}"
            )
        number, unit = float(m[1]), m[2].lower()
    else:
        raise TypeError(f"a memory size must be a number of bytes or a string, got {value!r}")
    nbytes = number * _UNITS[unit]
    if not (math.isfinite(nbytes) and nbytes >= 1):
        raise ValueError(f"memory size must be at least 1 byte, got {value!r}")
    return int(min(nbytes, 2**62))


def format_bytes(nbytes: float) -> str:
    """``1.5 GB`` style (powers of 10), for messages."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{int(nbytes)} bytes"


def phase_history_bytes(n_pulses: int, n_samples: int) -> int:
    """Working bytes of a read of an ``(n_pulses, n_samples)`` phase history (module notes)."""
    return WORKING_COPIES * 16 * int(n_pulses) * int(n_samples)


def over_budget(nbytes: float, what: str) -> str | None:
    """None when ``nbytes`` fits the limit; else the reason, to follow ``"<input>: "``."""
    limit = memory_limit()
    if nbytes <= limit:
        return None
    return (
        f"reading it would allocate {format_bytes(nbytes)} ({what}), over the memory limit "
        f"of {format_bytes(limit)} (--max-memory sets it)"
    )
