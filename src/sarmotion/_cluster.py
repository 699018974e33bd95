"""A local Dask cluster that only this process can use and that leaves nothing behind.

Shared by the parts that run their work on Dask (sub-apertures in ``tracking``, patches
in ``collection``); it imports Dask only when a cluster is started.
"""

from __future__ import annotations

import logging
import os
import tempfile
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from typing import Any

__all__ = ["MAX_WORKERS_PER_CORE", "check_workers", "local_cluster"]


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
    with ExitStack() as stack:
        scratch = stack.enter_context(tempfile.TemporaryDirectory(prefix="sarmotion-dask-"))
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
        cluster = stack.enter_context(
            LocalCluster(
                n_workers=n_workers,
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
        yield cluster
