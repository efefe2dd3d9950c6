"""The executors: every task's result exactly once, whatever the backend and lost workers."""

from __future__ import annotations

import os
import signal
import threading
import time
from concurrent.futures import Executor, Future
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cloud_sync.engine import (
    InlineExecutor,
    ProcessPool,
    dask_executor,
    map_unordered,
    open_executor,
    workers_of,
)
from cloud_sync.errors import CloudSyncError, EngineError
from cloud_sync.irl.config import IrlConfig
from cloud_sync.service.rules import CloudService, DeferredExecutor, ServiceConfig
from dbc.vocab.triplog_file import write_trip
from tests.cloud_sync.conftest import follower_trip


def scaled(task: int) -> tuple[int, int]:
    """A pure task: ``task × 3``, with the pid of the process that ran it."""
    time.sleep(0.02)
    return task * 3, os.getpid()


def blas_threads(task: int) -> int:
    """The most threads any BLAS library of the process may use (a pure task)."""
    from threadpoolctl import threadpool_info  # noqa: PLC0415

    return max((i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"), default=1)


def refuse_seven(task: int) -> int:
    if task == 7:
        raise ValueError("seven is refused")
    return task + 1


@pytest.mark.parametrize("executor", [InlineExecutor(), ProcessPool(2)], ids=["inline", "pool"])
def test_every_index_once_with_its_result(executor: Executor) -> None:
    with executor:
        got = dict(map_unordered(executor, scaled, list(range(12))))
    assert {i: r for i, (r, _) in got.items()} == {i: 3 * i for i in range(12)}
    pids = {pid for _, pid in got.values()}
    assert (pids == {os.getpid()}) == (workers_of(executor) == 1)


def test_every_task_runs_with_one_blas_thread(dask_cluster: Executor) -> None:
    for executor in (InlineExecutor(), ProcessPool(2), dask_cluster):
        got = dict(map_unordered(executor, blas_threads, list(range(4))))
        assert got == {i: 1 for i in range(4)}
    scaled_got = dict(map_unordered(dask_cluster, scaled, list(range(20))))
    assert {i: r for i, (r, _) in scaled_got.items()} == {i: 3 * i for i in range(20)}


def test_a_task_error_reaches_the_caller() -> None:
    with ProcessPool(2) as pool, pytest.raises(ValueError, match="seven"):
        list(map_unordered(pool, refuse_seven, list(range(10))))


def test_a_killed_pool_worker_costs_a_rerun_not_a_result() -> None:
    got: dict[int, int] = {}
    with ProcessPool(2) as pool:
        for index, (result, pid) in map_unordered(pool, scaled, list(range(40))):
            assert index not in got
            got[index] = result
            if len(got) == 3:
                os.kill(pid, signal.SIGKILL)  # the pool breaks; the tasks not done run again
    assert got == {i: 3 * i for i in range(40)}


def test_no_scheduler_at_the_address_is_an_engine_error() -> None:
    start = time.monotonic()
    with pytest.raises(EngineError, match="no Dask scheduler answers at tcp://127.0.0.1:9"):
        dask_executor("tcp://127.0.0.1:9", 1, timeout_s=0.5)
    assert time.monotonic() - start < 10.0
    assert issubclass(EngineError, CloudSyncError)


def test_open_executor_without_a_scheduler_changes_nothing() -> None:
    assert isinstance(open_executor(None, 1), InlineExecutor)
    pool = open_executor(None, 3)
    assert isinstance(pool, ProcessPool) and workers_of(pool) == 3
    pool.shutdown()
    with pytest.raises(EngineError, match=">= 1 worker"):
        ProcessPool(0)
    with pytest.raises(EngineError, match="needs 'local' or a Dask scheduler"):
        open_executor(" ", 1)


class Counting(Executor):
    """An executor that counts the calls it hands to another (to see where the work ran)."""

    def __init__(self, inner: Executor) -> None:
        self.inner = inner
        self.calls = 0

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future[Any]:
        self.calls += 1
        return self.inner.submit(fn, *args, **kwargs)


def test_learning_jobs_train_on_dask_as_in_process(dask_cluster: Executor, tmp_path: Path) -> None:
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
