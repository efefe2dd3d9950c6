"""The Dask distributed backend of :class:`~cloud_sync.engine.base.Engine` (extra ``pacc[dask]``).

A study's shared data is scattered to every worker once (``Client.scatter(broadcast=True)``);
the tasks go in batches (:func:`batch_size`: a Dask task costs milliseconds of scheduling and
transfer, a batch pays it once for several drives, while each worker still gets several
batches to balance the load), each batch one Dask task with a key of its own; results come
back with ``distributed.as_completed`` as each batch finishes, with one BLAS thread per task
(:func:`~cloud_sync.engine.base.single_blas_thread`). A worker that dies mid-task (a killed
process, a lost machine) is Dask's to handle: the scheduler runs the task again on another
worker, up to its ``distributed.scheduler.allowed-failures`` setting, after which the task
fails with ``KilledWorker``, raised here as :class:`~cloud_sync.errors.EngineError`. Each
future is reported once, so a rerun never repeats a result.

The workers import the task functions by name: they need the same pacc installed
(``pip install 'pacc[dask]'`` on every machine of the cluster).
"""

from __future__ import annotations

import logging
import uuid
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar

from distributed import Client, LocalCluster, as_completed
from distributed.scheduler import KilledWorker

from cloud_sync.engine.base import Engine, single_blas_thread
from cloud_sync.errors import EngineError

S = TypeVar("S")
T = TypeVar("T")
R = TypeVar("R")

#: how long to wait for a scheduler to answer, s
CONNECT_TIMEOUT_S = 10.0
#: at most this many tasks in one Dask task
MAX_BATCH = 4
#: at least this many batches per worker (while there are tasks enough), for load balance
BATCHES_PER_WORKER = 4


def batch_size(tasks: int, workers: int) -> int:
    """Tasks per Dask task: at most :data:`MAX_BATCH`, at least :data:`BATCHES_PER_WORKER`
    batches for each of ``workers`` while there are tasks enough, 1 for few tasks."""
    return max(1, min(MAX_BATCH, tasks // (max(1, workers) * BATCHES_PER_WORKER)))


def _apply(
    batch: list[tuple[int, Any]], fn: Callable[[Any, Any], Any], shared: Any
) -> list[tuple[int, Any]]:
    """One batch on a worker: ``(index, fn(shared, task))`` for each of its tasks, with one
    BLAS thread (``shared`` arrives resolved)."""
    with single_blas_thread():
        return [(index, fn(shared, task)) for index, task in batch]


def _call(fn: Callable[..., Any], *args: Any) -> Any:
    """One call on a worker, with one BLAS thread."""
    with single_blas_thread():
        return fn(*args)


class DaskEngine(Engine):
    """Tasks on a Dask cluster through ``client``; closes ``cluster`` too if it owns one."""

    name = "dask"
    distributed = True

    def __init__(self, client: Client, cluster: LocalCluster | None = None) -> None:
        self.client = client
        self.cluster = cluster

    @classmethod
    def local(cls, workers: int) -> DaskEngine:
        """A fresh ``LocalCluster`` of ``workers`` single-threaded worker processes (each under
        a nanny that restarts it if it dies), its HTTP server (and dashboard,
        if bokeh is installed) on a free port."""
        if workers < 1:
            raise EngineError(f"a LocalCluster needs >= 1 worker, got {workers}")
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # any free port: several clusters on one machine
            silence_logs=logging.ERROR,
        )
        try:
            client = Client(cluster)
        except BaseException:
            cluster.close()
            raise
        return cls(client, cluster)

    @classmethod
    def connect(cls, address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> DaskEngine:
        """The cluster whose scheduler listens at ``address`` (``tcp://HOST:8786``)."""
        try:
            client = Client(address, timeout=f"{timeout_s}s")
        except (OSError, ValueError, TypeError) as exc:  # timeouts are OSErrors
            raise EngineError(f"no Dask scheduler answers at {address}: {exc}") from exc
        return cls(client)

    @property
    def workers(self) -> int:
        """Threads across the cluster's workers now (at least 1)."""
        info = self.client.scheduler_info()
        return max(1, sum(int(w.get("nthreads", 1)) for w in info["workers"].values()))

    def map_unordered(
        self, fn: Callable[[S, T], R], shared: S, tasks: Sequence[T]
    ) -> Iterator[tuple[int, R]]:
        """Scatter ``shared`` to every worker, the tasks in batches (:func:`batch_size`),
        each result as its batch finishes."""
        if not tasks:
            return
        handle = self.client.scatter(shared, broadcast=True, hash=False)
        run = uuid.uuid4().hex[:12]
        size = batch_size(len(tasks), self.workers)
        items = list(enumerate(tasks))
        batches = [items[i : i + size] for i in range(0, len(items), size)]
        keys = [f"pacc-{run}-{b}" for b in range(len(batches))]
        futures = self.client.map(_apply, batches, fn=fn, shared=handle, key=keys, pure=False)
        try:
            for future in as_completed(futures):
                try:
                    results = future.result()
                except KilledWorker as exc:
                    raise EngineError(f"a task kept killing its Dask workers: {exc}") from exc
                yield from results
        finally:
            # done, failed or interrupted: release the results and cancel what has not run
            self.client.cancel([*futures, handle])

    def call(self, fn: Callable[..., R], *args: Any) -> R:
        """``fn(*args)`` as one Dask task; its result (a worker lost mid-task: run again)."""
        future = self.client.submit(_call, fn, *args, pure=False)
        try:
            result: R = future.result()
        except KilledWorker as exc:
            raise EngineError(f"a learning job kept killing its Dask workers: {exc}") from exc
        finally:
            future.release()
        return result

    def close(self) -> None:
        """Disconnect; shut the cluster down if this engine started it."""
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()
            self.cluster = None


__all__ = ["BATCHES_PER_WORKER", "CONNECT_TIMEOUT_S", "MAX_BATCH", "DaskEngine", "batch_size"]
