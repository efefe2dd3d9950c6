"""Benchmark: a study's drives on a Dask LocalCluster against the local process pool.

Run: ``.venv/bin/python bench/scale.py [--workers 2] [--drivers d1,d2,d3,d4,d5] [--trials 2]
[--duration 60]``.

- the plan: every driver × scenario B × (predefined, predefined + OA) × trials, each a
  DURATION-s lockstep drive through the virtual bus with the full ECU, trip logs written
  (predefined tables: nothing to learn, the drives alone are measured);
- local process pool (the named peer, ``pacc study --workers N``): the plan's drives
  (``pacc.study.pipeline.run_one``) on :class:`cloud_sync.engine.ProcessPool`;
- Dask: the same plan on a ``LocalCluster`` of N single-threaded worker processes
  (``pacc study --scheduler local``), after one warm-up drive per worker (the cluster's start
  and the workers' first imports are printed apart: a study pays them once);
- the two alternate, ROUNDS rounds (pool, Dask, pool, Dask ...: a shared machine's load
  falls on both), each round's times printed with the share of the workers' time spent
  inside drives ("busy"), the ratio of the best of each;
- per-task overhead: no-op tasks through each engine, ms per task (wall time × workers /
  tasks), and the drive runs' difference spread over their drives;
- parallel efficiency: the same plan in this process, one drive after another (the serial
  peer, :class:`cloud_sync.engine.InlineExecutor`, one BLAS thread as in the workers),
  ROUNDS times once the cluster is closed (its scheduler runs in this process); the best
  rounds at N workers as serial / (N × parallel); on a shared machine it is lowered by every
  other job.

Both runs must give the same rows (wall time aside), or the script fails. The last line is
``scale: R x the process pool`` (drives per second, Dask over the pool; goal >= 0.95).

``--learn``: instead, per-driver learning: each driver's four manual trips uploaded to a fresh
embedded cloud (``pacc.study.loop.StudyCloud``) and its IRL table learned and downloaded,
in this thread (the named peer, as ``pacc study`` without ``--scheduler``) and on the Dask
LocalCluster (drivers side by side); seconds per driver, the same tables on both, the bytes
the cloud stores per driver. Last line ``learn: R x in-process``.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import tempfile
import time
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

from cloud_sync.engine import (
    InlineExecutor,
    ProcessPool,
    dask_executor,
    map_unordered,
    single_blas_thread,
    workers_of,
)
from pacc.study.irl_table import manual_trips
from pacc.study.loop import StudyCloud
from pacc.study.pipeline import Drive, make_tables, plan, run_one
from pacc.study.spec import StudySpec, table1_method, validate

NOOP_TASKS = 400


def noop(task: bytes) -> int:
    """A task that does nothing but carry 1 kB: the executor's own cost."""
    return len(task)


def per_task_ms(executor: Executor, tasks: int = NOOP_TASKS) -> float:
    """Wall time × workers / tasks of ``tasks`` no-op tasks, ms."""
    start = time.perf_counter()
    done = sum(1 for _ in map_unordered(executor, noop, [b"x" * 1024] * tasks))
    took = time.perf_counter() - start
    assert done == tasks
    return took * workers_of(executor) / tasks * 1e3


def timed_drives(executor: Executor, drives: list[Drive]) -> tuple[float, list[dict[str, Any]]]:
    """Wall seconds of the plan on ``executor`` and its rows, in plan order."""
    start = time.perf_counter()
    rows = dict(map_unordered(executor, run_one, drives))
    return time.perf_counter() - start, [rows[i] for i in range(len(drives))]


def _without_wall(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


def learn_seconds(
    drivers: dict[str, Any], out: Path, compute: Executor | None
) -> tuple[float, float, dict[str, Any]]:
    """Wall seconds to make and upload every driver's manual trips to a fresh embedded cloud,
    then to learn and download every table (as ``cloud_irl_tables``); the tables."""
    cloud = StudyCloud.embedded(out, drivers, 0, compute)
    start = time.perf_counter()
    conditions = {}
    for driver_id, driver in drivers.items():
        trips = manual_trips(driver, 0)
        cloud.upload(trips)
        conditions[driver_id] = str(trips[0].meta.get("condition", "default"))
    uploaded = time.perf_counter()
    tables = {d: cloud.table(d, c) for d, c in conditions.items()}
    return uploaded - start, time.perf_counter() - uploaded, tables


def folder_bytes(folder: Path) -> int:
    """Bytes of the files under ``folder``."""
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


def bench_learning(names: tuple[str, ...], workers: int) -> int:
    """The ``--learn`` benchmark (module docstring); 1 if the tables differ."""
    drivers = validate(StudySpec(drivers=names, learn_in="direct"))
    with tempfile.TemporaryDirectory() as tmp:
        up_s, inline_s, inline = learn_seconds(drivers, Path(tmp) / "inline", None)
        with dask_executor("local", workers) as dask:
            client = dask._client  # type: ignore[attr-defined]  # the Dask executor's client
            client.run(importlib.import_module, "cloud_sync.irl.trainer")  # first imports
            _, dask_s, remote = learn_seconds(drivers, Path(tmp) / "dask", dask)
        blobs = folder_bytes(Path(tmp) / "inline" / "cloud" / "blobs")
        versions = folder_bytes(Path(tmp) / "inline" / "cloud" / "dgpt")
        index = (Path(tmp) / "inline" / "cloud" / "index.sqlite").stat().st_size
    n = len(drivers)
    same = all((inline[d].gap_m == remote[d].gap_m).all() for d in drivers)
    print(f"learning {n} drivers (4 manual trips each, 20 min of 10 Hz demonstrations)")
    print(f"making and uploading the trips (in this process): {up_s / n:.2f} s per driver")
    print(f"in-process: {inline_s:.1f} s, {inline_s / n:.2f} s per driver")
    print(f"dask LocalCluster ({workers} workers): {dask_s:.1f} s, {dask_s / n:.2f} s per driver")
    print(f"tables identical: {same}")
    print(
        f"stored per driver: {blobs / n / 1e6:.2f} MB of trips, {versions / n / 1e3:.1f} kB of "
        f"signed tables (one version), index {index / 1e3:.0f} kB for all {n}"
    )
    print(f"learn: {inline_s / dask_s:.2f}x in-process")
    return 0 if same else 1


def _busy(rows: list[dict[str, Any]], wall_s: float, workers: int) -> float:
    """The share of the workers' time spent inside drives (their own wall_s): what the
    engine leaves to the work, whatever the load of a shared machine."""
    return sum(float(r["wall_s"]) for r in rows) / (wall_s * workers)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; 1 if the two engines' rows differ."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--drivers", default="d1,d2,d3,d4,d5")
    p.add_argument("--trials", type=int, default=2)
    p.add_argument("--duration", type=float, default=60.0, help="simulated s per drive")
    p.add_argument("--rounds", type=int, default=2, help="alternating runs of each engine")
    p.add_argument("--learn", action="store_true", help="benchmark per-driver learning instead")
    args = p.parse_args(argv)
    if args.learn:
        return bench_learning(tuple(args.drivers.split(",")), args.workers)
    cfg = StudySpec(
        drivers=tuple(args.drivers.split(",")),
        scenarios=("B",),
        methods=(table1_method("predefined"), table1_method("predefined+oa")),
        trials=args.trials,
        duration_s=args.duration,
        workers=args.workers,
        learn_in="direct",
    )
    drivers = validate(cfg)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        (out / "logs").mkdir()
        jobs = plan(cfg, drivers, make_tables(cfg, drivers, out, InlineExecutor(), None), out)
        n = len(jobs)
        print(f"plan: {n} drives of {args.duration:.0f} s, {args.workers} workers, logs written")

        pool = ProcessPool(args.workers)
        start = time.perf_counter()
        with dask_executor("local", args.workers) as dask:
            started = time.perf_counter() - start
            warm = time.perf_counter()
            timed_drives(dask, jobs[: args.workers])  # first imports per worker
            warm_s = time.perf_counter() - warm
            print(f"dask LocalCluster: start {started:.2f} s, warm-up {warm_s:.2f} s (once)")
            pool_times, dask_times, serial_times = [], [], []
            for rnd in range(args.rounds):
                pool_s, pool_rows = timed_drives(pool, jobs)
                dask_s, dask_rows = timed_drives(dask, jobs)
                pool_times.append(pool_s)
                dask_times.append(dask_s)
                pool_busy = _busy(pool_rows, pool_s, args.workers)
                dask_busy = _busy(dask_rows, dask_s, args.workers)
                print(
                    f"round {rnd + 1}: process pool {pool_s:.2f} s ({n / pool_s:.2f} drives/s, "
                    f"busy {pool_busy:.0%}), dask {dask_s:.2f} s ({n / dask_s:.2f} drives/s, "
                    f"busy {dask_busy:.0%})"
                )
            pool_task_ms = per_task_ms(pool)
            dask_task_ms = per_task_ms(dask)
        pool.shutdown()
        # the serial peer once the cluster is gone (its scheduler runs in this process)
        for rnd in range(args.rounds):
            with single_blas_thread():
                serial_s, serial_rows = timed_drives(InlineExecutor(), jobs)
            serial_times.append(serial_s)
            print(f"serial round {rnd + 1}: {serial_s:.2f} s ({n / serial_s:.2f} drives/s)")
        pool_s, dask_s, serial_s = min(pool_times), min(dask_times), min(serial_times)

    if _without_wall(serial_rows) != _without_wall(pool_rows):
        print("the serial run and the process pool gave different rows", file=sys.stderr)
        return 1
    if _without_wall(dask_rows) != _without_wall(pool_rows):
        print("the two engines gave different rows", file=sys.stderr)
        return 1
    print(f"rows: {n} identical on both engines and the serial run (wall time aside)")
    _summary(n, args.workers, (serial_s, pool_s, dask_s), (pool_task_ms, dask_task_ms))
    return 0


def _summary(
    n: int, w: int, best_s: tuple[float, float, float], task_ms: tuple[float, float]
) -> None:
    """The closing lines: per-task overhead, parallel efficiency, the headline ratio."""
    serial_s, pool_s, dask_s = best_s
    spread_ms = (dask_s - pool_s) * w / n * 1e3
    print(
        f"per-task overhead (no-op tasks): dask {task_ms[1]:.2f} ms, pool {task_ms[0]:.2f} ms; "
        f"in the drive runs: dask {spread_ms:+.1f} ms per drive against the pool"
    )
    print(
        f"parallel efficiency at {w} workers (best serial {serial_s:.2f} s in this process): "
        f"process pool {serial_s / (w * pool_s):.0%}, dask {serial_s / (w * dask_s):.0%} "
        f"(goal >= 85 %)"
    )
    print(f"scale: {pool_s / dask_s:.2f}x the process pool (drives/s, goal >= 0.95)")


if __name__ == "__main__":
    sys.exit(main())
