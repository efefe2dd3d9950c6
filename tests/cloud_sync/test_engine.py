"""The engine seam: every task's result exactly once, whatever the backend and lost workers."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pytest

from cloud_sync.engine import open_engine
from cloud_sync.engine.base import Engine, InlineEngine, ProcessEngine
from cloud_sync.errors import CloudSyncError, EngineError
from cloud_sync.irl.trainer import IrlConfig
from cloud_sync.service.rules import CloudService, DeferredExecutor, ServiceConfig
from dbc.vocab.triplog_file import write_trip
from tests.cloud_sync.conftest import follower_trip

S = TypeVar("S")
T = TypeVar("T")
R = TypeVar("R")


def scaled(shared: dict[str, int], task: int) -> tuple[int, int]:
    """A pure task: ``task × shared["k"]``, with the pid of the process that ran it."""
    time.sleep(0.02)
    return task * shared["k"], os.getpid()


def blas_threads(shared: None, task: int) -> int:
    """The most threads any BLAS library of the process may use (a pure task)."""
    from threadpoolctl import threadpool_info  # noqa: PLC0415

    return max((i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"), default=1)


def refuse_seven(shared: dict[str, int], task: int) -> int:
    if task == 7:
        raise ValueError("seven is refused")
    return task + shared["k"]


@pytest.mark.parametrize("engine", [InlineEngine(), ProcessEngine(2)], ids=lambda e: e.name)
def test_every_index_once_with_its_result(engine: Engine) -> None:
    with engine:
        got = dict(engine.map_unordered(scaled, {"k": 3}, list(range(12))))
    assert {i: r for i, (r, _) in got.items()} == {i: 3 * i for i in range(12)}
    pids = {pid for _, pid in got.values()}
    assert (pids == {os.getpid()}) == (engine.workers == 1)


def test_pool_workers_run_with_one_blas_thread() -> None:
    with ProcessEngine(2) as engine:
        got = dict(engine.map_unordered(blas_threads, None, list(range(4))))
    assert got == {i: 1 for i in range(4)}


def test_dask_batches_its_tasks_and_pins_blas(dask_cluster: Engine) -> None:
    from cloud_sync.engine.dask_backend import MAX_BATCH, batch_size  # noqa: PLC0415

    assert batch_size(5, 2) == 1  # few tasks: one each, for load balance
    assert batch_size(20, 2) == 2
    assert batch_size(1000, 2) == MAX_BATCH
    got = dict(dask_cluster.map_unordered(scaled, {"k": 2}, list(range(40))))
    assert {i: r for i, (r, _) in got.items()} == {i: 2 * i for i in range(40)}
    assert dict(dask_cluster.map_unordered(blas_threads, None, list(range(20)))) == {
        i: 1 for i in range(20)
    }


def test_a_task_error_reaches_the_caller() -> None:
    with ProcessEngine(2) as engine, pytest.raises(ValueError, match="seven"):
        list(engine.map_unordered(refuse_seven, {"k": 1}, list(range(10))))


def test_a_killed_pool_worker_costs_a_rerun_not_a_result() -> None:
    got: dict[int, int] = {}
    with ProcessEngine(2) as engine:
        for index, (result, pid) in engine.map_unordered(scaled, {"k": 5}, list(range(40))):
            assert index not in got
            got[index] = result
            if len(got) == 3:
                os.kill(pid, signal.SIGKILL)  # the pool breaks; the tasks not done run again
    assert got == {i: 5 * i for i in range(40)}


def test_no_scheduler_at_the_address_is_an_engine_error() -> None:
    # the import costs ~1 s: only this test and the distributed ones pay it
    from cloud_sync.engine.dask_backend import DaskEngine  # noqa: PLC0415

    start = time.monotonic()
    with pytest.raises(EngineError, match="no Dask scheduler answers at tcp://127.0.0.1:9"):
        DaskEngine.connect("tcp://127.0.0.1:9", timeout_s=0.5)
    assert time.monotonic() - start < 10.0
    assert issubclass(EngineError, CloudSyncError)


def test_open_engine_without_a_scheduler_changes_nothing() -> None:
    assert isinstance(open_engine(None, 1), InlineEngine)
    pool = open_engine(None, 3)
    assert isinstance(pool, ProcessEngine) and pool.workers == 3
    with pytest.raises(EngineError, match=">= 1 worker"):
        ProcessEngine(0)


class Counting(Engine):
    """An engine that counts the calls it hands to another (to see where the work ran)."""

    name = "counting"

    def __init__(self, inner: Engine) -> None:
        self.inner = inner
        self.calls = 0

    @property
    def workers(self) -> int:
        return self.inner.workers

    def map_unordered(
        self, fn: Callable[[S, T], R], shared: S, tasks: Sequence[T]
    ) -> Iterator[tuple[int, R]]:
        return self.inner.map_unordered(fn, shared, tasks)

    def call(self, fn: Callable[..., R], *args: Any) -> R:
        self.calls += 1
        return self.inner.call(fn, *args)


def test_learning_jobs_train_on_dask_as_in_process(dask_cluster: Engine, tmp_path: Path) -> None:
    config = ServiceConfig(seed=2, irl=IrlConfig(max_iter=3))  # a short fit: same on both
    write_trip(tmp_path / "manual.mcap", follower_trip(0, minutes=1.2))
    blobs = [(tmp_path / "manual.mcap").read_bytes()]
    tables = {}
    counting = Counting(dask_cluster)
    for name, compute in (("inline", None), ("dask", counting)):
        service = CloudService.open(tmp_path / name, config=config, compute=compute)
        service.register_vehicle("car")
        service.register_driver("car", "syn")
        for blob in blobs:
            service.upload("car", blob)  # the inline executor runs the job at once
        service.wait_idle()
        assert service.job_errors == []
        tables[name] = service.latest_table("syn", "default")
        service.store.close()
    assert counting.calls == len(blobs)  # each upload's job trained on the cluster
    inline, dask = tables["inline"], tables["dask"]
    assert inline is not None and dask is not None
    assert dask.version == inline.version == len(blobs)
    assert np.array_equal(dask.gap_m, inline.gap_m)  # bit-identical tables


def test_a_deferred_executor_runs_queued_jobs_side_by_side() -> None:
    barrier = threading.Barrier(2, timeout=10.0)  # broken unless both jobs run at once

    def job(name: str) -> str:
        barrier.wait()
        return name

    deferred = DeferredExecutor(threads=2)
    futures = [deferred.submit(job, "a"), deferred.submit(job, "b")]
    assert not any(f.done() for f in futures)
    deferred.run_pending()
    assert [f.result() for f in futures] == ["a", "b"]
    alone = DeferredExecutor()  # one thread: the caller's, in order
    order: list[int] = []
    for i in range(3):
        alone.submit(order.append, i)
    alone.run_pending()
    assert order == [0, 1, 2]
