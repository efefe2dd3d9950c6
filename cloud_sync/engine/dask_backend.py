"""The Dask distributed backend of :class:`~cloud_sync.engine.base.Engine` (extra ``pacc[dask]``).

A study's shared data is scattered to every worker once (``Client.scatter(broadcast=True)``);
each task is one Dask task with a key of its own, results come back with
``distributed.as_completed`` as they finish. A worker that dies mid-task (a killed process, a
lost machine) is Dask's to handle: the scheduler runs the task again on another worker, up to
its ``distributed.scheduler.allowed-failures`` setting, after which the task fails with
``KilledWorker``, raised here as :class:`~cloud_sync.errors.EngineError`. Each future is
reported once, so a rerun never repeats a result.

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

from cloud_sync.engine.base import Engine
from cloud_sync.errors import EngineError

S = TypeVar("S")
T = TypeVar("T")
R = TypeVar("R")

#: how long to wait for a scheduler to answer, s
CONNECT_TIMEOUT_S = 10.0


def _apply(task: Any, fn: Callable[[Any, Any], Any], shared: Any) -> Any:
    """One task on a worker: ``fn(shared, task)`` (``shared`` arrives resolved)."""
    return fn(shared, task)


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
        """Scatter ``shared`` to every worker, one task per item, results as they finish."""
        if not tasks:
            return
        handle = self.client.scatter(shared, broadcast=True, hash=False)
        run = uuid.uuid4().hex[:12]
        keys = [f"pacc-{run}-{index}" for index in range(len(tasks))]
        futures = self.client.map(_apply, list(tasks), fn=fn, shared=handle, key=keys, pure=False)
        index_of = {future.key: index for index, future in enumerate(futures)}
        try:
            for future in as_completed(futures):
                try:
                    result = future.result()
                except KilledWorker as exc:
                    raise EngineError(f"a task kept killing its Dask workers: {exc}") from exc
                yield index_of[future.key], result
        finally:
            # done, failed or interrupted: release the results and cancel what has not run
            self.client.cancel([*futures, handle])

    def call(self, fn: Callable[..., R], *args: Any) -> R:
        """``fn(*args)`` as one Dask task; its result (a worker lost mid-task: run again)."""
        future = self.client.submit(fn, *args, pure=False)
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


__all__ = ["CONNECT_TIMEOUT_S", "DaskEngine"]
