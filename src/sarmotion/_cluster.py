"""A local Dask cluster that only this process can use and that leaves nothing behind.

Shared by the parts that run their work on Dask (sub-apertures in ``tracking``, patches
in ``collection``); it imports Dask only when a cluster is started.
"""

from __future__ import annotations

import contextlib
import ipaddress
import logging
import os
import re
import shutil
import stat
import tempfile
import threading
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

from .errors import InputError

__all__ = [
    "CONNECT_TIMEOUT_S",
    "INTERRUPTED",
    "MAX_WORKERS_PER_CORE",
    "SCHEDULER_SCHEMES",
    "SCRATCH_PREFIX",
    "WORKER_WAIT_S",
    "SchedulerError",
    "check_address",
    "check_workers",
    "raise_if_interrupted",
    "connect_scheduler",
    "local_client",
    "local_cluster",
    "on_sigint",
    "silence_cluster_loggers",
    "remove_stale_scratch",
]

log = logging.getLogger(__name__)

#: Set by the command line's SIGINT handler as it raises ``KeyboardInterrupt``. Python
#: swallows an exception raised while a garbage-collection callback runs (Dask installs
#: one), so a Ctrl-C can be lost there; the loops that wait on a cluster's tasks look at
#: this event between their waits (:func:`raise_if_interrupted`), so it is not.
INTERRUPTED = threading.Event()


def raise_if_interrupted() -> None:
    """Raise ``KeyboardInterrupt`` if :data:`INTERRUPTED` is set (a Ctrl-C not yet acted on)."""
    if INTERRUPTED.is_set():
        raise KeyboardInterrupt


def on_sigint(signum: int, frame: Any) -> None:
    """SIGINT handler: set :data:`INTERRUPTED`, then raise ``KeyboardInterrupt``.

    Python's own handler only raises; a Ctrl-C raised inside a callback that swallows
    it (Dask's garbage-collection callback) is then lost. With this one the loops that
    wait on tasks still see it (:func:`raise_if_interrupted`).
    """
    INTERRUPTED.set()
    raise KeyboardInterrupt


def _raises_on_sigint(handler: Any) -> bool:
    """Whether ``handler`` is Python's default SIGINT handler or :func:`on_sigint`."""
    import signal

    return handler is signal.default_int_handler or handler is on_sigint


#: Most local workers per core. Each analysis is CPU-bound, so more workers than cores
#: only queue; a few per core still overlap the tracker's and the I/O's waits. Beyond
#: this, workers only add memory (about 24 MB each, and a copy of their sub-aperture).
MAX_WORKERS_PER_CORE = 4


def check_workers(n_workers: int) -> None:
    """ValueError unless ``1 <= n_workers <= MAX_WORKERS_PER_CORE x cores``."""
    cores = os.cpu_count() or 1
    limit = MAX_WORKERS_PER_CORE * cores
    if not 1 <= n_workers <= limit:
        raise ValueError(
            f"n_workers must be within [0, {limit}] ({MAX_WORKERS_PER_CORE} per core on "
            f"{cores} core(s); 0: no Dask), got {n_workers}"
        )


#: Schemes of a scheduler's address: plain TCP, or TLS with the certificates of Dask's
#: configuration. ``inproc://`` exists only inside the process that made it; ``ucx://``
#: and ``ws://`` need transports sarmotion does not install.
SCHEDULER_SCHEMES = ("tcp", "tls")
#: Seconds to reach a scheduler and complete Dask's handshake. On a network that reaches
#: the scheduler at all, a TCP connection and a TLS handshake take milliseconds to a few
#: hundred (a few round trips); a peer silent this long is not a Dask scheduler, or is
#: not answering.
CONNECT_TIMEOUT_S = 5.0
#: Seconds a reached scheduler may take to have its first worker. Workers started with
#: their scheduler register within a second or two of it; a scheduler without workers
#: would hold the command's tasks for ever.
WORKER_WAIT_S = 5.0
#: Prefix of a local cluster's scratch directory in the system's temporary directory; the
#: owner's PID follows it (``sarmotion-dask-<pid>-<random>``).
SCRATCH_PREFIX = "sarmotion-dask-"

#: A host name: dot-separated labels of letters, digits and inner hyphens (RFC 1123).
_LABEL = re.compile(r"(?!-)[A-Za-z0-9-]{1,63}(?<!-)")


class SchedulerError(InputError):
    """A scheduler address that is malformed, unreachable or without workers."""


def check_address(address: Any, name: str = "scheduler") -> str:
    """A Dask scheduler's address checked and written ``scheme://host:port``.

    ``scheme`` is one of :data:`SCHEDULER_SCHEMES` (``tcp`` when omitted), ``host`` a host
    name (RFC 1123 labels, at most 253 characters), an IPv4 address or an IPv6 address in
    brackets, ``port`` a decimal number within [1, 65535]. A ``tls://`` address needs the
    client certificate and the certificate authority of Dask's configuration
    (``distributed.comm.tls.client.cert`` and ``distributed.comm.tls.ca-file``).
    Nothing is connected to.

    Raises
    ------
    SchedulerError
        Anything else, naming ``name`` and the rule.
    """
    if not isinstance(address, str):
        raise SchedulerError(f"{name} must be an address string, got {type(address).__name__}")
    shown = repr(address) if len(address) <= 80 else repr(address[:77]) + "..."
    rule = f"scheme://host:port, scheme one of {', '.join(s + '://' for s in SCHEDULER_SCHEMES)}"

    def bad(why: str) -> SchedulerError:
        return SchedulerError(f"{name} {shown}: {why} (rule: {rule})")

    if not address or len(address) > 300 or not address.isascii() or not address.isprintable():
        raise bad("not an address" if address else "empty")
    if any(c.isspace() for c in address):
        raise bad("holds a space")
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    scheme = scheme.lower()
    if scheme == "inproc":
        raise bad("inproc:// is an address inside one process, which another cannot reach")
    if scheme not in SCHEDULER_SCHEMES:
        raise bad(f"scheme {scheme!r} is not supported")
    host, colon, port = rest.rpartition(":")
    if not colon or not host:
        raise bad("no host:port")
    if not (port.isdigit() and len(port) <= 5 and 1 <= int(port) <= 65535):
        raise bad("the port must be a number within [1, 65535]")
    if host.startswith("[") and host.endswith("]"):
        try:
            ipaddress.IPv6Address(host[1:-1])
        except ValueError:
            raise bad("not an IPv6 address in brackets") from None
    elif re.fullmatch(r"[0-9.]+", host):
        try:
            ipaddress.IPv4Address(host)
        except ValueError:
            raise bad("not an IPv4 address") from None
    elif len(host) > 253 or not all(_LABEL.fullmatch(label) for label in host.split(".")):
        raise bad("not a host name")
    if scheme == "tls":
        import dask

        missing = [
            key
            for key in ("distributed.comm.tls.client.cert", "distributed.comm.tls.ca-file")
            if not dask.config.get(key, None)
        ]
        if missing:
            raise SchedulerError(
                f"{name} {shown}: tls:// needs the certificates of Dask's configuration; "
                f"{' and '.join(missing)} not set"
            )
    return f"{scheme}://{host}:{int(port)}"


def _identity(address: str, timeout_s: float) -> dict[str, Any]:
    """The scheduler's ``identity`` (its workers included), within ``timeout_s`` in all.

    Every step (the connection, Dask's handshake, the request and the reply) runs under
    one deadline in an event loop of its own thread: a peer that accepts and never
    answers costs ``timeout_s``, not Dask's own retries (a ``distributed.Client`` given a
    timeout still waits on such a peer without end).
    """
    import asyncio
    import queue
    import socket
    import threading

    from distributed import Security
    from distributed.comm import connect

    host, _, port = address.split("://", 1)[1].rpartition(":")

    async def ask() -> dict[str, Any]:
        kwargs = Security().get_connection_args("client")
        comm = await connect(address, timeout=timeout_s, **kwargs)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    answers: queue.Queue[tuple[bool, Any]] = queue.Queue()

    def probe() -> None:
        try:
            # a refused or unroutable connection is said at once (Dask's connect retries
            # it); the name's lookup is under the deadline too
            with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s):
                pass
            answers.put((True, asyncio.run(asyncio.wait_for(ask(), timeout_s))))
        except BaseException as exc:  # handed to the caller
            answers.put((False, exc))

    # a daemon thread: one that never returns (a lookup that hangs) holds nothing up
    threading.Thread(target=probe, name="sarmotion-scheduler-probe", daemon=True).start()
    try:
        ok, reply = answers.get(timeout=timeout_s + 1.0)
    except queue.Empty:
        raise TimeoutError(f"no answer in {timeout_s:g} s") from None
    if not ok:
        raise reply
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        raise OSError("the peer is not a Dask scheduler")
    return reply


@contextmanager
def connect_scheduler(
    address: str,
    *,
    name: str = "scheduler",
    connect_timeout_s: float | None = None,
    worker_wait_s: float | None = None,
) -> Iterator[Any]:
    """A ``distributed.Client`` of the scheduler at ``address``, with at least one worker.

    The address is checked first (:func:`check_address`). The connection and Dask's
    handshake must complete within ``connect_timeout_s`` (default
    :data:`CONNECT_TIMEOUT_S`) and the scheduler must have a worker within
    ``worker_wait_s`` (default :data:`WORKER_WAIT_S`), so that neither a peer that
    accepts and never answers nor a scheduler without workers can hold the caller.

    Raises
    ------
    SchedulerError
        A bad address, no answer in time (saying why), or no worker in time.
    """
    import time

    from distributed import Client

    address = check_address(address, name)
    connect_s = CONNECT_TIMEOUT_S if connect_timeout_s is None else float(connect_timeout_s)
    wait_s = WORKER_WAIT_S if worker_wait_s is None else float(worker_wait_s)
    deadline = time.monotonic() + wait_s
    while True:
        try:
            identity = _identity(address, connect_s)
        except Exception as exc:  # the network's and Dask's failures alike: the address's
            reason = (
                "no answer"
                if isinstance(exc, TimeoutError)
                else str(exc).splitlines()[0]
                if str(exc)
                else type(exc).__name__
            )
            raise SchedulerError(
                f"{name} {address}: no Dask scheduler answered within {connect_s:g} s ({reason})"
            ) from None
        if identity.get("workers"):
            break
        if time.monotonic() >= deadline:
            raise SchedulerError(
                f"{name} {address}: the scheduler has no worker after {wait_s:g} s (start "
                f"workers first: dask worker {address})"
            )
        time.sleep(min(0.2, max(0.0, deadline - time.monotonic())))
    try:
        client = Client(address, timeout=connect_s, set_as_default=False)
    except Exception as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SchedulerError(f"{name} {address}: cannot connect ({reason})") from None
    try:
        yield client
    finally:
        client.close(timeout=connect_s)


def _pid_alive(pid: int) -> bool:
    """Whether process ``pid`` exists (a process of another user counts as alive)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale_scratch(directory: str | os.PathLike[str] | None = None) -> list[Path]:
    """Remove the scratch directories of local clusters whose owner process is gone.

    A local cluster's scratch directory (:data:`SCRATCH_PREFIX` ``<pid>-...`` in the
    system's temporary directory, or ``directory``) is removed with the cluster; a process
    killed outright (SIGKILL) cannot remove it. Each one whose PID names no running
    process, and that belongs to this user, is removed here. Returns those removed.
    """
    root = Path(tempfile.gettempdir() if directory is None else directory)
    removed = []
    try:
        entries = list(root.glob(SCRATCH_PREFIX + "*"))
    except OSError:
        return removed
    for entry in entries:
        m = re.fullmatch(re.escape(SCRATCH_PREFIX) + r"(\d+)-.*", entry.name)
        if not m:
            continue
        try:
            st = entry.lstat()
        except OSError:
            continue
        if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid():
            continue
        if _pid_alive(int(m.group(1))):
            continue
        shutil.rmtree(entry, ignore_errors=True)
        if not entry.exists():
            removed.append(entry)
            log.debug("removed the scratch directory %s of a process that ended", entry)
    return removed


#: The loggers of Dask's cluster in this process (the scheduler, the nannies, the client
#: and their event loop), silenced once a Ctrl-C stops the command: the cancelled tasks
#: and closed connections of the cluster's shutdown are not the user's news.
_CLUSTER_LOGGERS = ("distributed", "tornado", "asyncio")


def silence_cluster_loggers() -> list[tuple[logging.Logger, bool]]:
    """Disable :data:`_CLUSTER_LOGGERS` and their descendants; return each one's former state.

    Run in worker processes too (:func:`local_client`), where a peer or the client that
    goes away mid-transfer makes Dask log a traceback.
    """
    names = [
        n
        for n in list(logging.root.manager.loggerDict)
        if any(n == p or n.startswith(p + ".") for p in _CLUSTER_LOGGERS)
    ]
    silenced = []
    for name in sorted(set(names) | set(_CLUSTER_LOGGERS)):
        logger = logging.getLogger(name)
        silenced.append((logger, logger.disabled))
        logger.disabled = True
    return silenced


class _SigintGuard:
    """What a Ctrl-C does while a local cluster is up (:func:`local_cluster`).

    - :meth:`installed`: Python's default SIGINT handler (or :func:`on_sigint`) is
      replaced (in the main thread, and only where one of them is in place) by one that
      first disables :data:`_CLUSTER_LOGGERS` and every one of their descendants, then
      sets :data:`INTERRUPTED` and raises ``KeyboardInterrupt``: the cluster then closes
      without a line of its own, and the command says once that it was interrupted. The
      handler and the loggers' state come back when the block ends.
    - :meth:`held`: SIGINT is blocked in this thread while the block runs. A signal mask
      is per thread; the threads this thread starts inherit it, and through ``fork`` and
      ``exec`` the processes they start (Python leaves an inherited mask in place). A
      local cluster's event-loop thread, started in the block, and every worker process
      it spawns, then and later (a restarted worker too), therefore never take the
      terminal's Ctrl-C (sent to the whole foreground process group) as their own; they
      stop when their cluster stops them. A Ctrl-C meanwhile (taken by another thread of
      this process, or pending until the mask is restored) is held, not lost: it is
      raised as ``KeyboardInterrupt`` when the block ends.
    """

    def __init__(self) -> None:
        self.silenced: list[tuple[logging.Logger, bool]] = []
        self.holding = False
        self.pending = False
        self.active = False

    def _silence(self) -> None:
        if not self.silenced:
            self.silenced = silence_cluster_loggers()

    def _handler(self, signum: int, frame: Any) -> None:
        self._silence()
        if self.holding:
            self.pending = True
            return
        INTERRUPTED.set()
        raise KeyboardInterrupt

    @contextmanager
    def installed(self) -> Iterator[None]:
        """The handler in place while the block runs (class notes)."""
        import signal
        import threading

        previous = signal.getsignal(signal.SIGINT)
        self.active = threading.current_thread() is threading.main_thread() and _raises_on_sigint(
            previous
        )
        if self.active:
            signal.signal(signal.SIGINT, self._handler)
        try:
            yield
        finally:
            if self.active:
                signal.signal(signal.SIGINT, previous)
            for logger, disabled in self.silenced:
                logger.disabled = disabled
            self.silenced.clear()

    @contextmanager
    def held(self) -> Iterator[None]:
        """SIGINT blocked in this thread, and a Ctrl-C held, while the block runs."""
        import signal

        blocks = hasattr(signal, "pthread_sigmask")
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT}) if blocks else None
        self.holding = self.active
        try:
            yield
        finally:
            if blocks:
                signal.pthread_sigmask(signal.SIG_SETMASK, previous)
            self.holding = False
        if self.pending:
            self.pending = False
            raise KeyboardInterrupt


async def _started(cluster: Any) -> None:
    """Wait until ``cluster`` has started the workers of its specification.

    The wait is shielded: cancelled (by a Ctrl-C in :func:`distributed.utils.sync`), it
    stops waiting but leaves the start to finish, so that every worker started is one
    the cluster knows and closes (a start cancelled midway would leave its workers out
    of the cluster's list, to be killed at exit instead).
    """
    import asyncio

    await asyncio.shield(cluster._correct_state())


@contextmanager
def local_cluster(
    n_workers: int, *, processes: bool = False, dashboard_address: str | None = None
) -> Iterator[Any]:
    """A ``distributed.LocalCluster`` that only this process can use, and that leaves nothing.

    - *Threads* (``processes=False``): the scheduler and workers talk in memory
      (``inproc://``); no network listener carries tasks.
    - *Processes*: every connection is TLS with mutual authentication, from a key pair
      and self-signed certificate generated for this cluster and held in memory only
      (``distributed.Security.temporary()``, which needs ``cryptography``), bound to
      127.0.0.1. A client without that certificate cannot complete the handshake, so no
      other process, local or remote, can submit code to the workers.
    - The HTTP endpoints Dask starts on every scheduler and worker are bound to
      127.0.0.1 with no routes; the dashboard only with ``dashboard_address``.
    - Worker scratch space is a temporary directory removed with the cluster (not
      ``dask-scratch-space`` in the system's temporary directory).
    - The workers' log level is this process's level of the ``distributed`` logger
      (the command line sets it from ``-v``).
    - Worker processes never take SIGINT (:class:`_SigintGuard`): a Ctrl-C at the
      terminal, at any moment (the workers' start included), interrupts this process
      alone, which closes its client, then its workers, then its scheduler, with Dask's
      loggers silenced, and not each worker with a traceback of its own.
    - The scratch directory's name holds this process's PID; the scratch directories of
      processes that died without removing theirs (SIGKILL) are removed first
      (:func:`remove_stale_scratch`).

    Parameters
    ----------
    n_workers : int
        Workers, one thread each (:func:`check_workers`).
    processes : bool
        Workers as processes (secured as above) or threads of this process.
    dashboard_address : str, optional
        ``"host:port"`` of the scheduler's dashboard; default none.

    Yields
    ------
    distributed.LocalCluster
    """
    import dask
    from distributed import LocalCluster, Security

    check_workers(n_workers)
    security = Security.temporary() if processes else None
    remove_stale_scratch()
    with ExitStack() as stack:
        scratch = stack.enter_context(
            tempfile.TemporaryDirectory(prefix=f"{SCRATCH_PREFIX}{os.getpid()}-")
        )
        stack.enter_context(
            dask.config.set(
                {
                    "temporary-directory": scratch,
                    "distributed.scheduler.http.routes": [],
                    "distributed.worker.http.routes": [],
                }
            )
        )
        level = logging.getLogger("distributed").getEffectiveLevel()
        guard = _SigintGuard()
        stack.enter_context(guard.installed())
        started: list[Any] = []
        stack.callback(_release_work_dirs, started)  # once the cluster is closed
        if processes:
            # multiprocessing starts its resource tracker with the first process it
            # spawns and then unblocks SIGINT in the spawning thread (CPython's
            # resource_tracker, bpo-33613): started here first, it leaves that thread's
            # mask, and so the workers', as _SigintGuard.held sets it
            from multiprocessing import resource_tracker

            resource_tracker.ensure_running()
        with guard.held():
            # the cluster's event-loop thread, started now, and the worker processes it
            # spawns inherit a blocked SIGINT (_SigintGuard); the scheduler alone here
            # (a second or less), so that a Ctrl-C held meanwhile is raised as soon as
            # the cluster is on the stack that closes it
            cluster = stack.enter_context(
                LocalCluster(
                    n_workers=0 if processes else n_workers,
                    threads_per_worker=1,
                    processes=processes,
                    **({"host": "127.0.0.1", "protocol": "tls://"} if processes else {}),
                    security=security,
                    dashboard_address=dashboard_address or "127.0.0.1:0",
                    scheduler_kwargs={"dashboard": dashboard_address is not None},
                    worker_dashboard_address="127.0.0.1:0",
                    local_directory=scratch,
                    silence_logs=level,
                )
            )
            started.append(cluster)
        if processes:  # the workers' start (seconds), which a Ctrl-C interrupts
            cluster.scale(n_workers)
            cluster.sync(_started, cluster)
        yield cluster


def _release_work_dirs(clusters: list[Any]) -> None:
    """Remove the scratch directories the clusters' scheduler and thread workers hold.

    Dask removes a server's directory (its ``_workdir``) when the server closes, or else
    at interpreter exit; an interrupted close leaves it to the exit, when
    :func:`local_cluster` has removed the whole scratch directory, and Dask then logs an
    error for each one missing. Released here, before that removal, they are gone once.
    """
    for cluster in clusters:
        servers = [getattr(cluster, "scheduler", None), *getattr(cluster, "workers", {}).values()]
        for server in servers:
            work_dir = getattr(server, "_workdir", None)
            if work_dir is not None:
                work_dir.release()  # a weakref.finalize: once only, however often called


def _quiet_workers() -> None:
    """Run on each worker as :func:`local_client` ends: its Dask loggers off.

    Returns nothing: ``client.run`` sends a function's result back, and the loggers'
    former states (:func:`silence_cluster_loggers`) are of no use here.
    """
    silence_cluster_loggers()


@contextmanager
def local_client(
    n_workers: int, *, processes: bool = False, dashboard_address: str | None = None
) -> Iterator[Any]:
    """A ``distributed.Client`` of its own :func:`local_cluster` (same parameters).

    Worker processes have their Dask loggers silenced before the client closes, the
    block ended by its end, a Ctrl-C or an error: the client's going away mid-transfer
    (a result or a heartbeat) would otherwise have a worker log a traceback of its own
    on the terminal, after the command's last line.
    """
    from distributed import Client

    with (
        local_cluster(
            n_workers, processes=processes, dashboard_address=dashboard_address
        ) as cluster,
        Client(cluster) as client,
    ):
        try:
            yield client
        finally:
            if processes:
                with contextlib.suppress(Exception):  # a worker gone or stuck: not waited on
                    client.sync(
                        client._run, _quiet_workers, on_error="ignore", callback_timeout=5.0
                    )
