"""Where the chunks of a batch or a map run: in this process, or on a Dask cluster.

``dask_client(workers, scheduler)`` opens what the command line asks for: nothing for ``workers == 1``
(every chunk in this process, in order: the debugging path), a ``LocalCluster`` of ``workers`` worker
processes on 127.0.0.1 (default: one per core, no dashboard), or a ``Client`` of the scheduler at
``scheduler`` (``tcp://host:8786``). ``map_chunks`` runs ``function(*chunk)`` for every chunk, one task
each, and returns the results in chunk order, so what comes back never depends on how many workers
there were or which finished first. A worker that dies takes its tasks and the results it held with it;
the scheduler runs them again on the others (up to ``distributed.scheduler.allowed-failures`` deaths
per task), so nothing is lost. Chunk functions are pure (their result depends on their arguments
only) and take everything they need as arguments, so any worker can (re)compute any chunk.
"""

from __future__ import annotations

import logging
import os
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

from ..errors import ClusterError, ScaleInputError
from ..progress import Progress

#: How long to wait for a scheduler named by address to answer [s].
CONNECT_TIMEOUT_S = 10.0


#: Worker processes per core a local cluster may start: more only add memory (each loads the models).
WORKERS_PER_CORE = 4


def max_local_workers() -> int:
    """The most worker processes of a LocalCluster on this machine (WORKERS_PER_CORE per core)."""
    return WORKERS_PER_CORE * (os.cpu_count() or 1)


@contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None) -> Iterator:
    """None (run in this process) for ``workers == 1``; else a ``distributed.Client`` of a new
    LocalCluster of ``workers`` processes (default ``os.cpu_count()``), or of the scheduler at
    ``scheduler``. The cluster it started is shut down on leaving. ScaleInputError for both or for
    ``workers`` outside [1, ``max_local_workers()``]; ClusterError when the scheduler cannot be reached."""
    if workers is not None and scheduler is not None:
        raise ScaleInputError("--workers/--scheduler", "give one of them: workers start a cluster on this machine, "
                              "a scheduler address uses a running one", f"{workers} and {scheduler}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or not 1 <= workers <= max_local_workers()):
        raise ScaleInputError("--workers", f"must be a whole number in [1, {max_local_workers()}] (worker processes "
                              f"on this machine of {os.cpu_count() or 1} cores)", workers)
    if scheduler is not None:
        from distributed import Client

        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            raise ClusterError(f"cannot reach the Dask scheduler at {scheduler!r} within {CONNECT_TIMEOUT_S:g} s: "
                               f"{exc}") from exc
        with client:
            yield client
        return
    count = (os.cpu_count() or 1) if workers is None else workers
    if count == 1:
        yield None
        return
    with local_client(count) as client:
        yield client


@contextmanager
def local_client(workers: int) -> Iterator:
    """A Client of a new LocalCluster of ``workers`` worker processes on 127.0.0.1 (a thread each, no
    dashboard, their own log lines at ERROR), shut down on leaving."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None, silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        yield client


def worker_count(client) -> int:
    """The workers a client has now (1 for None: this process)."""
    return 1 if client is None else len(client.scheduler_info(n_workers=-1)["workers"])


def map_chunks(function: Callable, chunks: Sequence[tuple], client=None, label: str = "chunks") -> list:
    """``[function(*chunk) for chunk in chunks]``, in this process without ``client``, else one Dask task
    per chunk; a progress line on a terminal (``label``: done/total). Interrupted (Ctrl-C) or failed,
    the tasks still queued are cancelled before the exception goes on."""
    results: list = [None] * len(chunks)
    with Progress(len(chunks), label) as tick:
        if client is None:
            for k, chunk in enumerate(chunks):
                results[k] = function(*chunk)
                tick()
            return results
        from distributed import as_completed

        run = f"{function.__name__}-{uuid.uuid4().hex[:12]}"
        futures = [client.submit(function, *chunk, key=f"{run}-{k}", pure=False) for k, chunk in enumerate(chunks)]
        order = {future.key: k for k, future in enumerate(futures)}
        try:
            for future in as_completed(futures):
                results[order[future.key]] = future.result()
                future.release()
                tick()
        finally:
            client.cancel(futures)
    return results
