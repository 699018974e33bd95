"""Sub-apertures as independent tasks on Dask: a local cluster or any scheduler.

Each sub-aperture's analysis (:func:`~sarmotion.tracking.sub_apertures.analyze_sub_aperture`)
depends on nothing but its own pulses, so :func:`map_sub_apertures` submits one task per
sub-aperture, data included (a sub-aperture of 117 GOTCHA pulses is 0.8 MB; workers need
no access to the input files), and yields the results *in slow-time order* as they come
back: the tracker consumes sub-aperture ``k`` while later ones still run.

Where the tasks run:

- ``scheduler=None``: a local cluster (:func:`local_cluster`) of ``n_workers`` workers
  (default: one per core, at most :data:`MAX_WORKERS_PER_CORE` per core) with one
  thread each, as *threads* of this process by default, or as processes (each process
  imports the library and loads numba's kernels again, which a pass of a few seconds
  does not repay; ``benchmarks/bench_tracking.py`` measures both). Inside a task,
  numba's and the BLAS thread pools are limited to the worker's share of the cores so
  that the workers do not oversubscribe them. The local cluster accepts no one else's
  code: threads talk in memory, processes over TLS with a certificate generated for the
  cluster (:func:`local_cluster`).
- ``scheduler="tcp://host:8786"`` (or ``"tls://..."``, or a ``distributed.Client``):
  that cluster's workers, which must have sarmotion importable. Its security is the
  cluster's own: a ``tls://`` address is reached with the certificates of Dask's
  configuration (``distributed.comm.tls.*``), as any Dask client does. The scheduler
  must answer and have a worker within the limits of
  :func:`~sarmotion._cluster.connect_scheduler`, else ``SchedulerError``.
- ``n_workers=0``: no Dask, the sub-apertures one after the other in this process.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, nullcontext
from typing import Any

from .._cluster import (
    MAX_WORKERS_PER_CORE,
    check_workers,
    connect_scheduler,
    local_client,
    local_cluster,
)
from ..core import Traces
from ..pipeline import AnalysisOptions
from .sub_apertures import SubApertureDetections, analyze_sub_aperture, sub_aperture_time_s

__all__ = ["MAX_WORKERS_PER_CORE", "check_workers", "local_cluster", "map_sub_apertures"]

log = logging.getLogger(__name__)


def _task(
    traces: Traces,
    options: AnalysisOptions,
    index: int,
    pulses: slice,
    time_s: float,
    threads: int | None,
    numba_threads: int | None = None,
) -> SubApertureDetections:
    """One sub-aperture's analysis with numba's and BLAS's thread pools limited.

    ``numba_threads`` (default ``threads``) for numba's pool, which is per thread;
    ``threads`` for BLAS's, which is per process, so it is set here only when
    ``numba_threads`` is None (a worker process of its own), and otherwise held by the
    caller for every worker thread at once (:func:`map_sub_apertures`): set and reset
    by each task, it would change under the other tasks, and with it the rounding of
    their results. numba's kernels hold the GIL, so the worker *threads* of one process
    never run two of them at once and each may use every core (results do not depend
    on numba's thread count: its parallel loops write disjoint elements).
    """
    if threads is None:
        return analyze_sub_aperture(traces, options, index=index, pulses=pulses, time_s=time_s)
    import numba
    from threadpoolctl import threadpool_limits

    previous = numba.get_num_threads()
    wanted = threads if numba_threads is None else numba_threads
    numba.set_num_threads(max(1, min(wanted, numba.config.NUMBA_NUM_THREADS)))
    try:
        with threadpool_limits(limits=threads) if numba_threads is None else nullcontext():
            return analyze_sub_aperture(traces, options, index=index, pulses=pulses, time_s=time_s)
    finally:
        numba.set_num_threads(previous)


def map_sub_apertures(
    traces: Traces,
    slices: Sequence[slice],
    options: AnalysisOptions,
    *,
    scheduler: str | Any | None = None,
    n_workers: int | None = None,
    processes: bool = False,
    dashboard_address: str | None = None,
) -> Iterator[SubApertureDetections]:
    """Analyse every sub-aperture, on Dask, and yield the results in slow-time order.

    Parameters
    ----------
    traces : Traces
        The whole acquisition.
    slices : sequence of slice
        Pulses of each sub-aperture (:func:`~sarmotion.tracking.sub_apertures.sub_aperture_slices`).
    options : AnalysisOptions
        Options of each analysis.
    scheduler : str or distributed.Client, optional
        Address of a running Dask scheduler (``"tcp://127.0.0.1:8786"``) or a client;
        default a local cluster (module notes).
    n_workers : int, optional
        Workers of the local cluster (default: the number of cores); 0 runs without
        Dask. Ignored with ``scheduler``.
    processes : bool
        Local workers as processes, or threads of this process (default).
    dashboard_address : str, optional
        ``"host:port"`` of the local cluster's dashboard (needs ``bokeh``); default none.

    Yields
    ------
    SubApertureDetections
        One per slice, in the order of ``slices``.
    """
    jobs = [(k, sl, sub_aperture_time_s(traces, sl)) for k, sl in enumerate(slices)]
    if scheduler is None and n_workers == 0:
        for k, sl, t in jobs:
            yield analyze_sub_aperture(
                traces.select_pulses(sl.start, sl.stop), options, index=k, pulses=sl, time_s=t
            )
        return

    cores = os.cpu_count() or 1
    with ExitStack() as stack:
        if scheduler is None:
            workers = cores if n_workers is None else int(n_workers)
            check_workers(workers)
            client = stack.enter_context(
                local_client(workers, processes=processes, dashboard_address=dashboard_address)
            )
            threads: int | None = max(1, cores // workers)
            numba_threads: int | None = None if processes else cores
            if not processes:  # BLAS's pool is per process: one limit for every thread
                from threadpoolctl import threadpool_limits

                stack.enter_context(threadpool_limits(limits=threads))
        elif isinstance(scheduler, str):  # within a timeout, with a worker (or refused)
            client = stack.enter_context(connect_scheduler(scheduler))
            threads = numba_threads = None
        else:
            client = scheduler
            threads = numba_threads = None
        log.info("sub-apertures on %s", client)
        futures = [
            client.submit(
                _task,
                traces.select_pulses(sl.start, sl.stop),
                options,
                k,
                sl,
                t,
                threads,
                numba_threads,
                pure=False,
                key=f"sarmotion-sub-aperture-{k}-{id(jobs)}",
            )
            for k, sl, t in jobs
        ]
        try:
            for future in futures:
                yield future.result()
        finally:
            client.cancel([f for f in futures if not f.done()])
