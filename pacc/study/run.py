"""Running a study: the control tables, the plan of drives, the engine, the outputs.

Every drive is a :class:`DriveJob`. To the engine (:mod:`cloud_sync.engine.base`: in-process, local
processes or a Dask cluster) the study ships what the drives share once, as
:class:`StudyData` (drivers, tables, lead profiles), and each drive as a small
:class:`DriveTask`; the rows stream back as drives finish and come out in plan order whatever
the engine and its number of workers.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from tqdm import tqdm

from cloud_sync.engine import open_engine
from cloud_sync.engine.base import Engine
from dbc.vocab.dgpt import Dgpt
from dbc.vocab.dgpt_file import save_dgpt
from pacc.study.collect import RowJournal, RowKey, collect
from pacc.study.config import StudyConfig, validate
from pacc.study.drive import predefined_table
from pacc.study.incremental_report import (
    format_incremental,
    plot_incremental,
    write_incremental_csv,
)
from pacc.study.irl_table import irl_table
from pacc.study.loop import StudyCloud, cloud_irl_tables, run_incremental
from pacc.study.report import format_table, plot
from pacc.study.tasks import DriveJob, run_task, split
from sim_bus.drivers import DriverParams
from sim_bus.errors import SimError


def study_cloud(
    cfg: StudyConfig,
    drivers: Mapping[str, DriverParams],
    out: Path,
    engine: Engine | None = None,
) -> StudyCloud:
    """The study's cloud: the one of ``cfg.cloud``, or a fresh embedded one under ``out``
    (training on ``engine`` if it is distributed)."""
    if cfg.cloud is None:
        compute = engine if engine is not None and engine.distributed else None
        return StudyCloud.embedded(out, drivers, cfg.seed, compute)
    assert cfg.token_file is not None and cfg.trust is not None  # validate() checked
    return StudyCloud.remote(cfg.cloud, Path(cfg.token_file), Path(cfg.trust), out)


def tables_for(
    cfg: StudyConfig,
    drivers: Mapping[str, DriverParams],
    cache_dir: Path | None,
    cloud: StudyCloud | None = None,
    engine: Engine | None = None,
) -> dict[tuple[str, str], Dgpt]:
    """(driver id, "predefined" | "irl") -> the control table: predefined, or learned by IRL
    in ``cloud`` (uploaded manual trips, downloaded verified table; the trips made on
    ``engine`` if it is distributed) or in-process (cached)."""
    tables: dict[tuple[str, str], Dgpt] = {}
    needs_irl = any(c.startswith("irl") for c in cfg.controllers)
    learned = cloud_irl_tables(cloud, drivers, cfg.seed, engine) if cloud and needs_irl else {}
    for driver_id, driver in drivers.items():
        if any(c.startswith("predefined") for c in cfg.controllers):
            tables[(driver_id, "predefined")] = predefined_table(driver)
        if needs_irl:
            tables[(driver_id, "irl")] = learned.get(driver_id) or irl_table(
                driver, cfg.seed, cache_dir
            )
    return tables


def log_name(driver_id: str, scenario: str, controller: str, trial: int) -> str:
    """File name of a drive's trip log under ``logs/``."""
    return f"{driver_id}_{scenario}_{controller.replace('+', '_')}_t{trial}.mcap"


def plan(
    cfg: StudyConfig,
    drivers: Mapping[str, DriverParams],
    tables: Mapping[tuple[str, str], Dgpt],
    out: Path,
) -> list[DriveJob]:
    """Every drive of the study, in a fixed order (driver, scenario, controller, trial)."""
    jobs = []
    for driver_id, driver in drivers.items():
        for scenario in cfg.scenarios:
            for controller in cfg.controllers:
                kind = "irl" if controller.startswith("irl") else "predefined"
                for trial in range(cfg.trials):
                    name = log_name(driver_id, scenario, controller, trial)
                    log = out / "logs" / name
                    jobs.append(
                        DriveJob(
                            driver,
                            scenario,
                            controller,
                            trial,
                            cfg.seed,
                            cfg.duration_s,
                            tables[(driver_id, kind)],
                            str(log) if cfg.logs else None,
                            cfg.adaptation,
                            cfg.dbc,
                            cfg.binding,
                            str(out / "can" / name) if cfg.can_logs else None,
                            cfg.bus,
                        )
                    )
    return jobs


def _job_key(job: DriveJob) -> RowKey:
    return (job.driver.driver_id, job.scenario, job.controller, job.trial)


def run_jobs(
    jobs: Sequence[DriveJob],
    workers: int,
    progress: bool = True,
    *,
    engine: Engine | None = None,
    csv_path: Path | None = None,
) -> list[dict[str, Any]]:
    """Run ``jobs`` on ``engine`` (None: ``workers`` local processes, 1: this process); rows
    in job order. Each drive's worker writes its logs; with ``csv_path``, each finished
    drive's row is appended there (rewritten in job order at the end, or with the finished rows on
    Ctrl-C: :class:`~pacc.study.collect.StudyInterrupted`)."""
    data, tasks = split(jobs)
    keys = [_job_key(job) for job in jobs]
    if len(set(keys)) != len(keys):
        raise SimError("two drives of the plan share a (driver, scenario, controller, trial)")
    bar = tqdm(total=len(jobs), desc="drives", unit="drive", disable=not progress, file=sys.stderr)
    own = engine is None
    running = open_engine(None, workers) if engine is None else engine
    journal = RowJournal(csv_path) if csv_path is not None else None
    try:
        return collect(
            _rows(running.map_unordered(run_task, data, tasks), bar), keys, journal=journal
        )
    finally:
        bar.close()
        if own:
            running.close()


def _rows(
    results: Iterator[tuple[int, dict[str, Any]]], bar: tqdm[Any]
) -> Iterator[tuple[int, dict[str, Any]]]:
    """(index, row) of each finished drive (its worker wrote its logs), counted on ``bar``."""
    try:
        for index, row in results:
            bar.update()
            yield index, row
    finally:
        close = getattr(results, "close", None)
        if close is not None:
            close()


def run_study(
    cfg: StudyConfig,
    out: Path,
    *,
    cache_dir: Path | None = None,
    progress: bool = True,
    engine: Engine | None = None,
) -> list[dict[str, Any]]:
    """Check ``cfg`` and make the output folders, then learn the tables, run every drive and
    write the outputs to ``out``; the rows. Every error of the configuration, the output
    folder or the engine (SimError, OSError, EngineError) comes before anything is learned.
    ``engine``: where the drives run (None: the one ``cfg.scheduler`` and ``cfg.workers``
    name, opened here and closed at the end)."""
    drivers = validate(cfg)
    out.mkdir(parents=True, exist_ok=True)
    (out / "irl").mkdir(exist_ok=True)
    if cfg.logs:
        (out / "logs").mkdir(exist_ok=True)
    if cfg.can_logs:
        (out / "can").mkdir(exist_ok=True)
    if cfg.incremental:  # trips one after another, each on the previous trip's table
        return _run_incremental(cfg, drivers, out)
    if engine is not None:
        return _run_table1(cfg, drivers, out, cache_dir, progress, engine)
    with open_engine(cfg.scheduler, cfg.workers) as own:
        return _run_table1(cfg, drivers, out, cache_dir, progress, own)


def _run_incremental(
    cfg: StudyConfig, drivers: Mapping[str, DriverParams], out: Path
) -> list[dict[str, Any]]:
    cloud = study_cloud(cfg, drivers, out)
    irl = cloud_irl_tables(cloud, drivers, cfg.seed)
    rows = run_incremental(cfg, drivers, cloud, irl)
    write_incremental_csv(out / "incremental.csv", rows)
    (out / "incremental.md").write_text(format_incremental(rows), encoding="utf-8")
    plot_incremental(out / "incremental.png", rows)
    return rows


def _run_table1(
    cfg: StudyConfig,
    drivers: Mapping[str, DriverParams],
    out: Path,
    cache_dir: Path | None,
    progress: bool,
    engine: Engine,
) -> list[dict[str, Any]]:
    cloud = None if cfg.direct else study_cloud(cfg, drivers, out, engine)
    tables = tables_for(cfg, drivers, cache_dir, cloud, engine)
    for (driver_id, kind), table in tables.items():
        if kind == "irl":
            save_dgpt(table, out / "irl" / f"{driver_id}.json")
    jobs = plan(cfg, drivers, tables, out)
    rows = run_jobs(jobs, cfg.workers, progress, engine=engine, csv_path=out / "drives.csv")
    (out / "table1.md").write_text(format_table(cfg, rows), encoding="utf-8")
    plot(out / "study.png", rows)
    return rows
