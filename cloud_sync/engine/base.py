"""The compute engine: one small seam between pure work and where it runs.

Every drive of a study and every learning job is a pure function of (configuration, seed,
data), so it may run anywhere. An :class:`Engine` runs such functions and hands the results
back; three backends:

- :class:`InlineEngine`: in this process, in order (tests, one worker);
- :class:`ProcessEngine`: a pool of local worker processes (``pacc study --workers N``, the
  single-machine default);
- :class:`~cloud_sync.engine.dask_backend.DaskEngine`: a Dask distributed cluster (``--scheduler
  tcp://HOST:8786``, or ``--scheduler local`` for a ``LocalCluster`` on this machine), in the
  optional extra ``pacc[dask]``.

:meth:`Engine.map_unordered` ships the data every task reads (``shared``) to each worker
once and yields ``(index, result)`` as tasks finish, in any order; the caller puts results
back in order by index. A worker lost mid-run costs a rerun of its task, never a lost or a
repeated result: Dask reschedules on its own, the process pool is rebuilt for the tasks not
yet done. :meth:`Engine.call` runs one function and waits (a learning job of the cloud).

Every worker runs with one BLAS thread (:func:`single_blas_thread`, set when a pool's worker
starts and around each Dask task): results then do not depend on how many threads BLAS would
take on a machine (tables learned with 1 and 16 threads differed by 1e-13 m), and workers do
not oversubscribe the cores they share.
"""

from __future__ import annotations

import multiprocessing
import sys
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from types import TracebackType
from typing import Any, Self, TypeVar

from threadpoolctl import threadpool_limits

from cloud_sync.errors import EngineError

S = TypeVar("S")
T = TypeVar("T")
R = TypeVar("R")

#: how many times a process pool may break (a worker killed) before the run gives up; Dask's
#: own limit is its ``distributed.scheduler.allowed-failures`` setting (3 by default)
MAX_POOL_RESTARTS = 3


class Engine(ABC):
    """Where pure tasks run (see the module docstring). A context manager: ``close`` on exit."""

    #: short name for messages ("inline", "processes", "dask")
    name: str = "engine"
    #: whether :meth:`call` runs elsewhere (a cluster), so that callers gain by calling it
    #: from several threads at once (the cloud's learning jobs); False: it runs in-thread
    distributed: bool = False

    @property
    @abstractmethod
    def workers(self) -> int:
        """How many tasks run at once (>= 1)."""

    @abstractmethod
    def map_unordered(
        self, fn: Callable[[S, T], R], shared: S, tasks: Sequence[T]
    ) -> Iterator[tuple[int, R]]:
        """``fn(shared, task)`` for every task; ``(index into tasks, result)`` as each one
        finishes, every index exactly once. ``fn`` must be a module-level function (workers
        import it by name); ``shared`` goes to each worker once. A task's exception is raised
        here; closing the iterator early (or Ctrl-C) cancels what has not run."""

    def call(self, fn: Callable[..., R], *args: Any) -> R:
        """``fn(*args)`` on the engine, waiting for the result (default: in this thread)."""
        return fn(*args)

    def close(self) -> None:  # noqa: B027 - most engines hold nothing to release
        """Release the engine's workers (idempotent)."""

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


class InlineEngine(Engine):
    """Runs every task in this process, in order: no pickling, no processes."""

    name = "inline"

    @property
    def workers(self) -> int:
        """One task at a time."""
        return 1

    def map_unordered(
        self, fn: Callable[[S, T], R], shared: S, tasks: Sequence[T]
    ) -> Iterator[tuple[int, R]]:
        """``fn(shared, task)`` in task order."""
        for index, task in enumerate(tasks):
            yield index, fn(shared, task)


def single_blas_thread() -> threadpool_limits:
    """Limit BLAS (OpenBLAS, MKL, BLIS) to one thread: a context manager that restores the
    previous limit on exit, or, called alone, a limit for the rest of the process."""
    return threadpool_limits(limits=1, user_api="blas")


#: the shared data of the running map, set once in each worker process by the initializer
_WORKER_SHARED: list[Any] = []


def _install_shared(shared: Any) -> None:
    """A pool worker's initializer: the shared data, and one BLAS thread for its life."""
    single_blas_thread()
    _WORKER_SHARED[:] = [shared]


def _run_with_shared(fn: Callable[[Any, Any], Any], task: Any) -> Any:
    return fn(_WORKER_SHARED[0], task)


class ProcessEngine(Engine):
    """A pool of ``workers`` local processes (fork on Linux, spawn elsewhere); ``shared`` is
    handed to each process once, when it starts. A pool broken by a lost worker is rebuilt
    for the tasks not done, up to :data:`MAX_POOL_RESTARTS` times."""

    name = "processes"

    def __init__(self, workers: int) -> None:
        if workers < 1:
            raise EngineError(f"a process pool needs >= 1 worker, got {workers}")
        self._workers = workers

    @property
    def workers(self) -> int:
        """The pool size."""
        return self._workers

    def map_unordered(
        self, fn: Callable[[S, T], R], shared: S, tasks: Sequence[T]
    ) -> Iterator[tuple[int, R]]:
        """``fn(shared, task)`` on the pool, results as they finish."""
        pending = dict(enumerate(tasks))
        breaks = 0
        while pending:
            try:
                yield from self._one_pool(fn, shared, pending)
            except BrokenProcessPool as exc:
                breaks += 1
                if breaks > MAX_POOL_RESTARTS:
                    raise EngineError(
                        f"the worker pool broke {breaks} times ({len(pending)} task(s) left): {exc}"
                    ) from exc

    def _one_pool(
        self, fn: Callable[[S, T], R], shared: S, pending: dict[int, T]
    ) -> Iterator[tuple[int, R]]:
        """One pool over ``pending``; removes each task from it as its result is yielded."""
        method = "fork" if sys.platform == "linux" else "spawn"
        pool = ProcessPoolExecutor(
            max_workers=min(self._workers, len(pending)),
            mp_context=multiprocessing.get_context(method),
            initializer=_install_shared,
            initargs=(shared,),
        )
        finished = False
        try:
            futures: dict[Future[R], int] = {
                pool.submit(_run_with_shared, fn, task): index for index, task in pending.items()
            }
            try:
                for future in as_completed(futures):
                    index = futures[future]
                    result = future.result()
                    del pending[index]
                    yield index, result
            except BrokenProcessPool:
                # the results that came back before the break are kept; the rest run again
                for future, index in futures.items():
                    if index in pending and future.done() and future.exception() is None:
                        del pending[index]
                        yield index, future.result()
                raise
            finished = True
        finally:
            # on an early close (Ctrl-C, a task's error) do not wait for the queued tasks
            pool.shutdown(wait=finished, cancel_futures=not finished)


__all__ = [
    "MAX_POOL_RESTARTS",
    "Engine",
    "InlineEngine",
    "ProcessEngine",
    "single_blas_thread",
]
