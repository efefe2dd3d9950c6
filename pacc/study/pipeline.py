"""One study pipeline: spec → plan → tables → drives on an executor → rows → report.

The plan is every (driver, scenario, method, trial), each a :class:`Drive` holding its
:class:`~pacc.study.drive.DriveConfig`. Tables come first (predefined, learned in the
vehicle-cloud loop or in-process); every drive then runs on the executor as :func:`run_one`.
Rows go to ``OUT/rows.jsonl`` as they finish, so a stopped run resumes; they come out in
plan order whatever the executor, and the report is written last.
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from tqdm import tqdm

from cloud_sync.engine import is_dask, map_unordered, open_executor
from cloud_sync.errors import CloudSyncError
from cloud_sync.learners import learn
from dbc.vocab import FormatError
from dbc.vocab.dgpt import Dgpt
from dbc.vocab.triplog_file import write_trip
from pacc.study.drive import DriveConfig, log_to_trip, predefined_table, resolve_profile, run_drive
from pacc.study.irl_table import irl_table, manual_trips
from pacc.study.loop import StudyCloud, cloud_irl_tables
from pacc.study.spec import ECU_ADAPTATION, Method, StudySpec, road_seed, validate
from sim_bus.drivers import DriverParams
from sim_bus.errors import SimError

T = TypeVar("T")
ROWS = "rows.jsonl"


@dataclass(frozen=True)
class Drive:
    """One drive of a study: everything a worker needs (picklable). ``log``/``can_log``: where
    the worker writes the trip log and the bus recording (None: not written)."""

    config: DriveConfig
    driver: DriverParams
    table: Dgpt
    method: Method
    trial: int
    profile_seed: int  # the lead profile's (pacc.study.spec.road_seed)
    log: str | None = None
    can_log: str | None = None
    bus: str = "lockstep"

    @property
    def key(self) -> str:
        """The drive's identity in ``rows.jsonl``: driver, scenario, method, trial."""
        return row_key({"driver": self.config.driver_id, "scenario": label(self.config.scenario),
                        "method": self.method.name, "trial": self.trial})  # fmt: skip


def label(scenario: str) -> str:
    """A scenario's name in the rows: the built-in name or the CSV file's stem."""
    return Path(scenario).stem if scenario.lower().endswith(".csv") else scenario


def row_key(row: Mapping[str, Any]) -> str:
    """A row's identity: ``driver/scenario/method/trial``."""
    return f"{row['driver']}/{row['scenario']}/{row['method']}/{row['trial']}"


def log_name(driver_id: str, scenario: str, controller: str, trial: int) -> str:
    """File name of a drive's trip log under ``logs/``."""
    return f"{driver_id}_{scenario}_{controller.replace('+', '_')}_t{trial}.mcap"


def run_one(drive: Drive) -> dict[str, Any]:
    """Run one drive (on a worker): its row. The worker writes the drive's trip log and bus
    recording itself, so on a cluster the output folder must be one every worker can write."""
    can_log = Path(drive.can_log) if drive.can_log is not None else None
    profile = resolve_profile(drive.config.scenario, drive.profile_seed)
    result = run_drive(drive.config, drive.driver, drive.table, profile, can_log=can_log,
                       bus=drive.bus)  # fmt: skip
    if drive.log is not None:
        write_trip(Path(drive.log), log_to_trip(result, drive.driver))
    m, method = result.metrics, drive.method
    faults = sorted(result.summary.plugin_faults.items())
    return {
        "driver": drive.driver.driver_id, "scenario": label(drive.config.scenario),
        "controller": method.name, "method": method.name, "table": method.table,
        "adaptation": method.adaptation or "none", "gap_controller": method.controller or "builtin",
        "trial": drive.trial, "seed": drive.config.seed, "poi_pct": m.poi_pct,
        "nim_per_min": m.nim_per_min, "press_onsets": m.press_onsets, "acc_on_s": m.acc_on_s,
        "min_gap_m": m.min_gap_m, "min_ttc_s": m.min_ttc_s, "rms_jerk_mps3": m.rms_jerk_mps3,
        "gap_error_rms_m": m.gap_error_rms_m, "takeovers": result.takeovers,
        "adaptations": result.adaptations, "collision": int(result.collision),
        "plugin_faults": "; ".join(f"{k} {n}" for k, n in faults),
        "sim_s": result.sim_s, "wall_s": result.wall_s,
    }  # fmt: skip


@dataclass(frozen=True)
class TableTask:
    """One driver's table from one source (picklable)."""

    driver: DriverParams
    seed: int
    method: Method  # its table source and learner arguments
    cache_dir: str | None = None


def learn_table(task: TableTask) -> Dgpt | str:
    """The driver's table (on a worker), or why its learner could not learn one. ``irl``
    without arguments is the cached IRL table of :func:`~pacc.study.irl_table.irl_table`."""
    table, args = task.method.table, task.method.learner_args
    if table == "predefined":
        return predefined_table(task.driver)
    if table == "irl" and not args:
        cache = Path(task.cache_dir) if task.cache_dir is not None else None
        return irl_table(task.driver, task.seed, cache)
    trips = manual_trips(task.driver, task.seed)
    try:
        return learn(
            table, trips, driver_id=task.driver.driver_id, seed=task.seed, params=dict(args)
        )
    except (FormatError, CloudSyncError, ValueError) as exc:  # data a learner cannot use
        return str(exc)


def make_tables(
    spec: StudySpec,
    drivers: Mapping[str, DriverParams],
    out: Path,
    executor: Executor,
    cache_dir: Path | None,
) -> dict[tuple[str, str], Dgpt | str]:
    """(driver id, method table key) -> the table, or why none was learned."""
    wanted = {(d, m.table_key): m for d in drivers for m in spec.methods}
    tables: dict[tuple[str, str], Dgpt | str] = {}
    cloud_irl = [k for k, m in wanted.items() if m.table == "irl" and not m.learner_args]
    if spec.learn_in == "cloud" and cloud_irl:
        cloud = study_cloud(spec, drivers, out, executor)
        learned = cloud_irl_tables(cloud, drivers, spec.seed, executor)
        tables.update({k: learned[k[0]] for k in cloud_irl})
    todo = [k for k in wanted if k not in tables]
    cache = str(cache_dir) if cache_dir is not None else None
    tasks = [TableTask(drivers[d], spec.seed, wanted[(d, key)], cache) for d, key in todo]
    for index, table in map_unordered(executor, learn_table, tasks):
        tables[todo[index]] = table
    return tables


def study_cloud(
    spec: StudySpec, drivers: Mapping[str, DriverParams], out: Path, executor: Executor | None
) -> StudyCloud:
    """The study's cloud (a fresh embedded one trains on ``executor`` if it is Dask's)."""
    compute = executor if is_dask(executor) else None
    return StudyCloud.open(
        out, drivers, spec.seed, spec.cloud, spec.token_file, spec.trust, compute=compute
    )


def plan(
    spec: StudySpec,
    drivers: Mapping[str, DriverParams],
    tables: Mapping[tuple[str, str], Dgpt | str],
    out: Path,
) -> list[Drive]:
    """Every drive whose table exists, in order (driver, scenario, method, trial)."""
    drives = []
    for driver_id, driver in drivers.items():
        road = road_seed(spec.seed, driver_id, spec.roads)
        for scenario in spec.scenarios:
            for m in spec.methods:
                table = tables[(driver_id, m.table_key)]
                if not isinstance(table, Dgpt):
                    continue  # its learner could not learn from this driver's trips
                for trial in range(spec.trials):
                    name = log_name(driver_id, label(scenario), m.name, trial)
                    cfg = DriveConfig(
                        scenario=scenario, driver_id=driver_id, controller=m.kind,  # type: ignore[arg-type]
                        seed=spec.seed + trial, duration_s=spec.duration_s,
                        adaptation=spec.adaptation, dbc=spec.dbc, binding=spec.binding,
                        gap_controller=m.controller, controller_args=m.controller_args,
                        adaptation_method="" if m.adaptation == ECU_ADAPTATION else m.adaptation,
                        adaptation_args=m.adaptation_args,
                    )  # fmt: skip
                    drives.append(
                        Drive(cfg, driver, table, m, trial, road,
                              str(out / "logs" / name) if spec.logs else None,
                              str(out / "can" / name) if spec.can_logs else None, spec.bus)
                    )  # fmt: skip
    return drives


class StudyInterrupted(SimError):
    """The study was stopped (Ctrl-C); ``rows``: those that had finished, in plan order."""

    def __init__(self, rows: list[dict[str, Any]], total: int, path: Path) -> None:
        super().__init__(f"interrupted: {len(rows)} of {total} drives finished and kept in {path}")
        self.rows = rows


def run_resumable(
    tasks: Sequence[T],
    fn: Callable[[T], dict[str, Any]],
    keys: Sequence[str],
    path: Path,
    fp: Mapping[str, Any],
    executor: Executor,
    progress: Callable[[int, int], None] | None = None,
) -> list[dict[str, Any]]:
    """``fn(task)`` on ``executor`` for the tasks whose key is not yet in ``path`` (a JSON
    lines journal: the fingerprint ``fp``, then one record a line, on disk as each task
    finishes); every record in task order. Ctrl-C: :class:`StudyInterrupted`."""
    if len(set(keys)) != len(keys):
        raise SimError("two tasks of the plan share a key")
    done: dict[str, dict[str, Any]] = {}
    if path.is_file():  # an earlier run: its fingerprint must be ``fp``
        lines = path.read_text(encoding="utf-8").splitlines()
        try:
            head = json.loads(lines[0]) if lines else {}
        except ValueError:
            head = {}
        if head.get("fingerprint") != json.loads(json.dumps(fp, default=str)):
            raise SimError(f"{path} holds another study; give another --out or remove the file")
        for line in lines[1:]:
            try:
                rec = json.loads(line)
            except ValueError:
                continue  # a line cut short by a kill: that task runs again
            done[str(rec["key"])] = rec["record"]
    else:
        path.write_text(json.dumps({"fingerprint": fp}, default=str) + "\n", encoding="utf-8")
    todo = [i for i, k in enumerate(keys) if k not in done]
    try:
        with path.open("a", encoding="utf-8") as fh:
            for n, (index, rec) in enumerate(map_unordered(executor, fn, [tasks[i] for i in todo])):
                key = keys[todo[index]]
                done[key] = rec  # kept first: a Ctrl-C during the write loses nothing
                fh.write(json.dumps({"key": key, "record": rec}, default=float) + "\n")
                fh.flush()
                os.fsync(fh.fileno())
                if progress is not None:
                    progress(len(keys) - len(todo) + n + 1, len(keys))
    except KeyboardInterrupt:
        raise StudyInterrupted([done[k] for k in keys if k in done], len(keys), path) from None
    return [done[k] for k in keys]


def run(
    spec: StudySpec,
    out: Path,
    *,
    cache_dir: Path | None = None,
    progress: bool = True,
    executor: Executor | None = None,
) -> list[dict[str, Any]]:
    """Check ``spec``, make the tables, run every drive (or resume), write the report the
    spec names into ``out``; the rows in plan order. ``executor``: where tables and drives
    run (None: the one ``spec.scheduler`` and ``spec.workers`` name, opened here)."""
    from pacc.study import report  # noqa: PLC0415 - scipy's statistics: the main process only

    drivers = validate(spec)
    out.mkdir(parents=True, exist_ok=True)
    if spec.logs:
        (out / "logs").mkdir(exist_ok=True)
    if spec.can_logs:
        (out / "can").mkdir(exist_ok=True)
    if spec.report == "incremental":
        return report.incremental(spec, drivers, out, study_cloud(spec, drivers, out, None))
    own = executor is None
    running = open_executor(spec.scheduler, spec.workers) if executor is None else executor
    try:
        tables = make_tables(spec, drivers, out, running, cache_dir)
        drives = plan(spec, drivers, tables, out)
        bar = tqdm(total=len(drives), desc="drives", unit="drive", disable=not progress,
                   file=sys.stderr)  # fmt: skip
        try:
            rows = run_resumable(drives, run_one, [d.key for d in drives], out / ROWS,
                                 spec.fingerprint(), running,
                                 lambda n, _: bar.update(n - bar.n))  # fmt: skip
        except StudyInterrupted as exc:
            report.write_rows(out / "drives.csv", exc.rows, spec.report)
            raise StudyInterrupted(exc.rows, len(drives), out / "drives.csv") from None
        finally:
            bar.close()
    finally:
        if own:
            running.shutdown(wait=True)
    report.write(spec, drivers, tables, rows, out)
    return rows
