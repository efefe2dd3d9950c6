"""Where pure work runs: a standard :class:`concurrent.futures.Executor`.

:func:`open_executor` gives the executor of ``--scheduler``/``--workers``:
:class:`InlineExecutor` (this thread), :class:`ProcessPool` or Dask's executor (``local`` or
``tcp://HOST:8786``). :func:`map_unordered` yields ``(index, result)`` as tasks finish, every
index once, each task with one BLAS thread (results independent of the thread count); a broken
:class:`ProcessPool` is restarted up to :data:`MAX_POOL_RESTARTS` times, Dask reschedules itself.
"""

from __future__ import annotations

import logging
import multiprocessing
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

from threadpoolctl import threadpool_limits

from cloud_sync.errors import EngineError

T = TypeVar("T")
R = TypeVar("R")

#: how many times a process pool may break (a worker killed) before a map gives up
MAX_POOL_RESTARTS = 3
#: how long to wait for a Dask scheduler to answer, s
CONNECT_TIMEOUT_S = 10.0


def single_blas_thread() -> threadpool_limits:
    """Limit BLAS (OpenBLAS, MKL, BLIS) to one thread: a context manager that restores the
    previous limit on exit, or, called alone, a limit for the rest of the process."""
    return threadpool_limits(limits=1, user_api="blas")


class InlineExecutor(Executor):
    """Runs each call at once in the caller's thread: deterministic, no processes."""

    def submit(self, fn: Callable[..., R], /, *args: Any, **kwargs: Any) -> Future[R]:
        """Run ``fn(*args, **kwargs)`` now; the returned future is already done."""
        future: Future[R] = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # the future carries it (Ctrl-C too), as a pool's would
            future.set_exception(exc)
        return future


class ProcessPool(Executor):
    """A ``ProcessPoolExecutor`` of ``workers`` (fork on Linux, spawn elsewhere) that
    :meth:`restart` replaces when a lost worker broke it."""

    def __init__(self, workers: int) -> None:
        if workers < 1:
            raise EngineError(f"a process pool needs >= 1 worker, got {workers}")
        self.workers = workers
        self._pool = self._new()

    def _new(self) -> ProcessPoolExecutor:
        method = "fork" if sys.platform == "linux" else "spawn"
        return ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context(method))

    def submit(self, fn: Callable[..., R], /, *args: Any, **kwargs: Any) -> Future[R]:
        """``fn(*args, **kwargs)`` on the pool."""
        return self._pool.submit(fn, *args, **kwargs)

    def restart(self) -> None:
        """A fresh pool in place of a broken one."""
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._pool = self._new()

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Shut the pool down."""
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)


def dask_executor(scheduler: str, workers: int, timeout_s: float = CONNECT_TIMEOUT_S) -> Executor:
    """A Dask cluster's executor: ``"local"`` starts a ``LocalCluster`` of ``workers``
    processes, else a scheduler's address (waited for ``timeout_s`` s); its shutdown closes
    client and cluster. EngineError if Dask is missing or no scheduler answers."""
    try:
        # Dask is an optional extra and costs ~1 s of import: only a --scheduler needs it
        from distributed import Client, LocalCluster  # noqa: PLC0415
        from distributed.cfexecutor import ClientExecutor  # noqa: PLC0415
    except ImportError as exc:
        raise EngineError(
            f"--scheduler needs Dask: pip install 'pacc[dask]' ({exc.name} is missing)"
        ) from exc

    class _Owned(ClientExecutor):
        def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
            super().shutdown(wait=wait)  # type: ignore[no-untyped-call]  # distributed
            client.close()
            if cluster is not None:
                cluster.close()

    cluster = None
    if scheduler == "local":
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
        client = Client(cluster or scheduler, timeout=f"{timeout_s}s")
    except (OSError, ValueError, TypeError) as exc:  # timeouts are OSErrors
        if cluster is not None:
            cluster.close()
        raise EngineError(f"no Dask scheduler answers at {scheduler}: {exc}") from exc
    executor: Executor = _Owned(client, pure=False)  # type: ignore[no-untyped-call]
    return executor


def open_executor(scheduler: str | None, workers: int) -> Executor:
    """The executor of a command line: no ``scheduler`` -> :class:`InlineExecutor` for one
    worker, else a :class:`ProcessPool` of ``workers``; a scheduler -> :func:`dask_executor`."""
    if scheduler is None:
        return InlineExecutor() if workers <= 1 else ProcessPool(workers)
    if not scheduler.strip():
        raise EngineError("--scheduler needs 'local' or a Dask scheduler address (tcp://HOST:8786)")
    return dask_executor(scheduler, workers)


def is_dask(executor: Executor | None) -> bool:
    """Whether ``executor`` runs on a Dask cluster (where calls gain from running side by side)."""
    return any(c.__module__.startswith("distributed") for c in type(executor).__mro__)


def workers_of(executor: Executor) -> int:
    """How many calls ``executor`` runs at once (a Dask cluster's threads now)."""
    if isinstance(executor, InlineExecutor):
        return 1
    if isinstance(executor, ProcessPool):
        return executor.workers
    client = getattr(executor, "_client", None)
    if client is not None:
        return max(1, int(sum(client.nthreads().values())))
    return 2


#: set once a worker process has pinned BLAS to one thread for its life
_PINNED: list[bool] = []


def one_blas(fn: Callable[..., R], *args: Any) -> R:
    """``fn(*args)`` with one BLAS thread (what every task of :func:`map_unordered` runs as):
    a worker process is pinned once, for its life (the limit costs milliseconds to set); this
    process only for the call."""
    if multiprocessing.parent_process() is None:
        with single_blas_thread():
            return fn(*args)
    if not _PINNED:
        single_blas_thread()
        _PINNED.append(True)
    return fn(*args)


def map_unordered(
    executor: Executor, fn: Callable[[T], R], tasks: Sequence[T]
) -> Iterator[tuple[int, R]]:
    """``fn(task)`` for every task on ``executor``; ``(index into tasks, result)`` as each one
    finishes. ``fn`` must be a module-level function (workers import it by name). A few tasks
    per worker are in flight at a time (in-process: one, so results stream). A task's error is
    raised here; closing the iterator early (or Ctrl-C) cancels what has not started."""
    pending = dict(enumerate(tasks))
    breaks = 0
    while pending:
        try:
            yield from _one_pass(executor, fn, pending)
        except BrokenProcessPool as exc:
            breaks += 1
            if breaks > MAX_POOL_RESTARTS or not isinstance(executor, ProcessPool):
                raise EngineError(
                    f"the worker pool broke {breaks} times ({len(pending)} task(s) left): {exc}"
                ) from exc
            executor.restart()


def _one_pass(
    executor: Executor, fn: Callable[[T], R], pending: dict[int, T]
) -> Iterator[tuple[int, R]]:
    """The tasks of ``pending`` on ``executor``; each leaves ``pending`` as it is yielded."""
    window = 1 if isinstance(executor, InlineExecutor) else 4 * workers_of(executor)
    queue = iter(list(pending.items()))
    running: dict[Future[R], int] = {}
    try:
        while True:
            for index, task in queue:
                running[executor.submit(one_blas, fn, task)] = index
                if len(running) >= window:
                    break
            if not running:
                return
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in sorted(done, key=running.__getitem__):
                index = running.pop(future)
                result = future.result()
                del pending[index]
                yield index, result
    except BrokenProcessPool:
        # the results that came back before the break are kept; the rest run again
        for future, index in running.items():
            if future.done() and not future.cancelled() and future.exception() is None:
                del pending[index]
                yield index, future.result()
        raise
    except Exception as exc:
        if type(exc).__name__ == "KilledWorker":
            raise EngineError(f"a task kept killing its Dask workers: {exc}") from exc
        raise
    finally:
        for future in running:
            future.cancel()


__all__ = [
    "MAX_POOL_RESTARTS",
    "InlineExecutor",
    "ProcessPool",
    "dask_executor",
    "is_dask",
    "map_unordered",
    "one_blas",
    "open_executor",
    "single_blas_thread",
    "workers_of",
]
