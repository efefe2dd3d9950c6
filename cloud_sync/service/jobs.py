"""Where the cloud's learning jobs run: :class:`DeferredExecutor` queues jobs until asked (the
embedded cloud learns when a table is asked for); :func:`train_table`, a job's training, is a
pure function of trips, seed and settings, run anywhere (:mod:`cloud_sync.engine`).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from concurrent.futures import Executor, Future, ThreadPoolExecutor
from typing import Any

from cloud_sync.engine import single_blas_thread
from cloud_sync.irl.trainer import IrlConfig, fine_tune, learn_dgpt
from dbc.vocab.dgpt import Dgpt
from dbc.vocab.triplog import Trip


class DeferredExecutor(Executor):
    """Queues jobs until :meth:`run_pending` (a sync pass of many batches learns once);
    ``threads`` > 1 runs that many queued jobs at a time (training elsewhere, on Dask)."""

    def __init__(self, threads: int = 1) -> None:
        self._queue: list[tuple[Future[Any], Callable[..., Any], tuple[Any, ...]]] = []
        self._lock = threading.Lock()
        self.threads = max(1, threads)

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Queue ``fn(*args)``; its future completes in :meth:`run_pending`."""
        if kwargs:
            raise TypeError("DeferredExecutor.submit takes positional arguments only")
        future: Future[Any] = Future()
        with self._lock:
            self._queue.append((future, fn, args))
        return future

    def run_pending(self) -> None:
        """Run every queued job, oldest first: in the caller's thread, or ``threads`` at a
        time in a pool of threads."""
        while True:
            with self._lock:
                batch, self._queue = self._queue, []
            if not batch:
                return
            if self.threads == 1 or len(batch) == 1:
                for job in batch:
                    _complete(*job)
            else:
                with ThreadPoolExecutor(min(self.threads, len(batch)), "pacc-deferred") as pool:
                    list(pool.map(lambda job: _complete(*job), batch))


def _complete(future: Future[Any], fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
    try:
        future.set_result(fn(*args))
    except BaseException as exc:  # the future carries it, as a pool's would
        future.set_exception(exc)


def train_table(
    manual: list[Trip],
    corrections: list[Trip],
    previous: Dgpt | None,
    driver_id: str,
    condition: str,
    seed: int,
    irl: IrlConfig | None,
) -> Dgpt:
    """A job's training, pure: ``previous`` (None: learned from the ``manual`` trips)
    fine-tuned with the ``corrections``; DemoError if the data are not enough yet. One BLAS
    thread: the same table on any engine."""
    with single_blas_thread():
        if previous is None:
            previous = learn_dgpt(
                manual, driver_id=driver_id, condition=condition, seed=seed, config=irl
            ).table
        table = previous
        if corrections:
            table = fine_tune(corrections, table, seed=seed, config=irl).table
        return table


__all__ = ["DeferredExecutor", "train_table"]
