"""Seeded fuzzing of the collection options and scheduler addresses of ``analyze`` and ``track``.

Each case draws, for every option, either a valid value or an invalid one of a random
kind (out of range, non-finite, not a number, a malformed or unsupported address), and
runs the command in this process on an input that does not exist. Whatever the draw,
the command must end within :data:`TIME_LIMIT_S` with exit status 2 and one line on
stderr, leave nothing at ``--out``, and name what it refused: the first invalid option on
the command line (click takes them in that order; ``--size`` is checked after them), or,
when every option is valid, the scheduler it could not reach (a closed loopback port) or
the missing input. A valid option is never refused. The draws are seeded: a failure
names its case, which reruns alone.
"""

from __future__ import annotations

import math
import os
import signal
import socket
import time

import numpy as np
import pytest

from sarmotion.cli.main import EXIT_BAD_INPUT, run

SEED = 20261207
#: Cases per command.
CASES = {"analyze": 350, "track": 250}
#: Longest one case may take (s).
TIME_LIMIT_S = 10.0
#: Bounds the commands state (``--max-speed``: the speed of sound; ``--size``: 4096
#: pixels of 0.25 m).
MAX_SPEED_MPS = 343.0
MAX_SIZE_M = 1024.0


class Hang(Exception):
    """A case ran past :data:`TIME_LIMIT_S`."""


def _alarm(signum, frame):
    raise Hang(f"the command took more than {TIME_LIMIT_S:g} s")


def _worker_limit() -> int:
    return 4 * (os.cpu_count() or 1)


def _closed_port() -> int:
    """A loopback port with no listener (bound, then closed)."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


# --------------------------------------------------------------------- the draws
def _number(rng: np.random.Generator, lo: float, hi: float) -> str:
    """A valid value in ``(lo, hi]``, log-uniform, written in one of Python's float forms."""
    v = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
    return [repr(v), f"{v:.3g}", f"{v:e}"][int(rng.integers(3))]


def _bad_number(rng: np.random.Generator, hi: float) -> str:
    """An invalid value of a positive quantity bounded by ``hi``."""
    kind = int(rng.integers(8))
    if kind == 0:
        return "0"
    if kind == 1:
        return repr(-float(rng.uniform(1e-9, 1e6)))
    if kind == 2:  # beyond the bound by a relative step or by orders of magnitude
        return repr(hi * (1.0 + float(rng.uniform(1e-6, 1e3))))
    if kind == 3:
        return f"1e{int(rng.integers(20, 309))}"
    if kind == 4:
        return ["nan", "NaN", "-nan"][int(rng.integers(3))]
    if kind == 5:
        return ["inf", "-inf", "Infinity", "1e999"][int(rng.integers(4))]
    if kind == 6:
        return ["abc", "", "1,5", "0x10", "--", "1e", "5 m"][int(rng.integers(7))]
    return repr(hi * 2 ** float(rng.integers(1, 60)))


def _workers(rng: np.random.Generator) -> tuple[str, bool]:
    if rng.random() < 0.5:
        return str(int(rng.integers(0, _worker_limit() + 1))), True
    kind = int(rng.integers(4))
    if kind == 0:
        return str(-int(rng.integers(1, 10**6))), False
    if kind == 1:
        return str(_worker_limit() + int(rng.integers(1, 10**4))), False
    if kind == 2:
        return str(10 ** int(rng.integers(6, 40))), False
    return ["1.5", "abc", "", "0x10", "2e3", "nan", "--"][int(rng.integers(7))], False


def _host(rng: np.random.Generator) -> str:
    return ["127.0.0.1", "localhost", "[::1]"][int(rng.integers(3))]


def _bad_address(rng: np.random.Generator, port: int) -> str:
    """A malformed or unsupported scheduler address."""
    host = _host(rng)
    kind = int(rng.integers(12))
    if kind == 0:
        scheme = ["inproc", "ucx", "ws", "wss", "file", "http", "udp", "TCPX"][int(rng.integers(8))]
        return f"{scheme}://{host}:{port}"
    if kind == 1:
        return f"tls://{host}:{port}"  # no certificates in Dask's configuration
    if kind == 2:
        return ""
    if kind == 3:  # printable garbage
        n = int(rng.integers(1, 80))
        return "".join(chr(int(c)) for c in rng.integers(33, 127, n)) + ":x"
    if kind == 4:  # bytes of any kind, control characters and non-ASCII included
        n = int(rng.integers(1, 40))
        return "".join(chr(int(c)) for c in rng.integers(1, 0x2FF, n))
    if kind == 5:
        return f"tcp://{host}:{[0, 65536, 10**6, -1][int(rng.integers(4))]}"
    if kind == 6:
        return f"tcp://{host}"
    if kind == 7:
        bad = ["a..b", "-a.b", "a-.b", "a_b.c", "999.1.1.1", "1.2.3", "[::g]", "[1::2::3]"]
        return f"tcp://{bad[int(rng.integers(len(bad)))]}:{port}"
    if kind == 8:
        return f"tcp://{host}:{port}/{'x' * int(rng.integers(1, 20))}"
    if kind == 9:
        return f"tcp://{'a' * int(rng.integers(254, 5000))}:{port}"
    if kind == 10:
        return f"tcp:// {host}:{port}"
    return f"tcp://{host}:{port}:{port}"


def _scheduler(rng: np.random.Generator, port: int) -> tuple[str, bool]:
    if rng.random() < 0.3:  # well formed: a closed port on this machine
        scheme = ["tcp://", ""][int(rng.integers(2))]
        return f"{scheme}{_host(rng)}:{port}", True
    return _bad_address(rng, port), False


def _case(rng: np.random.Generator, command: str, port: int) -> list[tuple[str, str, bool]]:
    """``[(flag, value, valid)]`` of the options drawn for ``command``, in command-line order."""
    options: list[tuple[str, str, bool]] = []
    if rng.random() < 0.7:
        options.append(("--workers", *_workers(rng)))
    if command == "analyze" and rng.random() < 0.7:
        if rng.random() < 0.5:
            options.append(("--max-speed", _number(rng, 1e-3, MAX_SPEED_MPS), True))
        else:
            options.append(("--max-speed", _bad_number(rng, MAX_SPEED_MPS), False))
    if rng.random() < 0.7:
        if rng.random() < 0.5:
            options.append(("--size", _number(rng, 1e-2, MAX_SIZE_M), True))
        else:
            options.append(("--size", _bad_number(rng, MAX_SIZE_M), False))
    if rng.random() < 0.6:
        options.append(("--scheduler", *_scheduler(rng, port)))
    order = rng.permutation(len(options))
    return [options[k] for k in order]


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _expected(options: list[tuple[str, str, bool]]) -> str:
    """What the refusal names: the first invalid option parsed, else the address or input."""
    invalid = [(flag, value) for flag, value, valid in options if not valid]
    # --size is converted to a float on parsing and checked in the body
    parsed_first = [f for f, v in invalid if f != "--size" or not _is_float(v)]
    if parsed_first:
        return parsed_first[0]
    if invalid:
        return "--size"
    if any(flag == "--scheduler" for flag, _, _ in options):
        return "--scheduler"
    return "missing.cphd"


# --------------------------------------------------------------------- the test
@pytest.fixture(scope="module", autouse=True)
def _loaded():
    """The commands and Dask imported once: their loading is not a case's time."""
    import importlib

    importlib.import_module("sarmotion.cli.analyze")
    importlib.import_module("sarmotion.cli.track")
    importlib.import_module("distributed")


@pytest.mark.parametrize("command", sorted(CASES))
def test_options_fuzz(command, tmp_path, capsys):
    rng = np.random.default_rng([SEED, sorted(CASES).index(command)])
    port = _closed_port()
    missing = tmp_path / "missing.cphd"
    stats: dict[str, int] = {}
    slowest = 0.0
    for k in range(CASES[command]):
        options = _case(rng, command, port)
        out = tmp_path / f"out{k}"
        args = ["-q", command, str(missing), "--out", str(out)]
        for flag, value, _ in options:
            args += [f"{flag}={value}"]  # one token: a value may start with '-'
        expected = _expected(options)
        where = f"{command} case {k}: {args[4:]}"
        previous = signal.signal(signal.SIGALRM, _alarm)
        signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT_S)
        t0 = time.monotonic()
        try:
            code = run(args)
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            signal.signal(signal.SIGALRM, previous)
        slowest = max(slowest, time.monotonic() - t0)
        err = capsys.readouterr().err.strip()
        assert code == EXIT_BAD_INPUT, (where, err)
        assert len(err.splitlines()) == 1 and err.startswith("sarmotion: error:"), (where, err)
        assert "Traceback" not in err and "internal error" not in err, (where, err)
        assert expected in err, (where, expected, err)
        assert sorted(p.name for p in tmp_path.iterdir()) == [], (where, list(tmp_path.iterdir()))
        stats[expected] = stats.get(expected, 0) + 1
    print(command, stats, f"slowest {slowest:.2f} s")  # shown with -s
    flags = {"--workers", "--size", "--scheduler"} | (
        {"--max-speed"} if command == "analyze" else set()
    )
    # every option was refused in some cases, and some cases passed every option
    assert flags <= set(stats), stats
    assert stats.get("missing.cphd", 0) + stats.get("--scheduler", 0) > 0, stats
    assert sum(stats.values()) == CASES[command]
    assert math.isfinite(slowest) and slowest < TIME_LIMIT_S
