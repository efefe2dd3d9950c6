"""Running a study: the control tables, the plan of drives, the worker pool, the outputs.

Every drive is a :class:`DriveJob`, everything a worker process needs (picklable); the rows
come back in plan order whatever the number of workers.
"""

from __future__ import annotations

import multiprocessing
import sys
from collections.abc import Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from ecu.adaptation import AdaptationParams
from ecu.dgpt import Dgpt, save_dgpt
from ecu.triplog import write_trip
from sim_bus.drive import DriveConfig, log_to_trip, predefined_table, run_drive
from sim_bus.drivers import DriverParams
from sim_bus.irl_table import irl_table
from sim_bus.scenarios import canonical_profiles
from sim_bus.study.config import StudyConfig, validate
from sim_bus.study.incremental_report import (
    format_incremental,
    plot_incremental,
    write_incremental_csv,
)
from sim_bus.study.loop import StudyCloud, cloud_irl_tables, run_incremental
from sim_bus.study.report import format_table, plot, write_csv


@dataclass(frozen=True)
class DriveJob:
    """One drive of the study; everything a worker process needs, picklable."""

    driver: DriverParams
    scenario: str
    controller: str
    trial: int
    study_seed: int
    duration_s: float | None
    table: Dgpt
    log_path: str | None
    adaptation: AdaptationParams | None = None
    can_log_path: str | None = None


def run_job(job: DriveJob) -> dict[str, Any]:
    """Run one drive (in a worker process) and return its row of drives.csv."""
    driver = job.driver
    seed = job.study_seed + job.trial
    cfg = DriveConfig(
        scenario=job.scenario,
        driver_id=driver.driver_id,
        controller=job.controller,  # type: ignore[arg-type]
        seed=seed,
        duration_s=job.duration_s,
        adaptation=job.adaptation,
    )
    profile = canonical_profiles(job.study_seed)[job.scenario]
    can_log = Path(job.can_log_path) if job.can_log_path is not None else None
    result = run_drive(cfg, driver, job.table, profile, can_log=can_log)
    if job.log_path is not None:
        write_trip(Path(job.log_path), log_to_trip(result, driver))
    m = result.metrics
    return {
        "driver": driver.driver_id,
        "scenario": job.scenario,
        "controller": job.controller,
        "trial": job.trial,
        "seed": seed,
        "poi_pct": m.poi_pct,
        "nim_per_min": m.nim_per_min,
        "press_onsets": m.press_onsets,
        "acc_on_s": m.acc_on_s,
        "min_gap_m": m.min_gap_m,
        "min_ttc_s": m.min_ttc_s,
        "rms_jerk_mps3": m.rms_jerk_mps3,
        "gap_error_rms_m": m.gap_error_rms_m,
        "takeovers": result.takeovers,
        "adaptations": result.adaptations,
        "collision": int(result.collision),
        "sim_s": result.sim_s,
        "wall_s": result.wall_s,
    }


def study_cloud(cfg: StudyConfig, drivers: Mapping[str, DriverParams], out: Path) -> StudyCloud:
    """The study's cloud: the one of ``cfg.cloud``, or a fresh embedded one under ``out``."""
    if cfg.cloud is None:
        return StudyCloud.embedded(out, drivers, cfg.seed)
    assert cfg.token_file is not None and cfg.trust is not None  # validate() checked
    return StudyCloud.remote(cfg.cloud, Path(cfg.token_file), Path(cfg.trust), out)


def tables_for(
    cfg: StudyConfig,
    drivers: Mapping[str, DriverParams],
    cache_dir: Path | None,
    cloud: StudyCloud | None = None,
) -> dict[tuple[str, str], Dgpt]:
    """(driver id, "predefined" | "irl") -> the control table: predefined, or learned by IRL
    in ``cloud`` (uploaded manual trips, downloaded verified table) or in-process (cached)."""
    tables: dict[tuple[str, str], Dgpt] = {}
    needs_irl = any(c.startswith("irl") for c in cfg.controllers)
    learned = cloud_irl_tables(cloud, drivers, cfg.seed) if cloud and needs_irl else {}
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
                            str(out / "can" / name) if cfg.can_logs else None,
                        )
                    )
    return jobs


def run_jobs(jobs: Sequence[DriveJob], workers: int, progress: bool = True) -> list[dict[str, Any]]:
    """Run ``jobs`` on ``workers`` processes (1: in this process); rows in job order."""
    bar = tqdm(total=len(jobs), desc="drives", unit="drive", disable=not progress, file=sys.stderr)
    rows: list[dict[str, Any]] = []
    try:
        if workers <= 1:
            for job in jobs:
                rows.append(run_job(job))
                bar.update()
            return rows
        ctx = multiprocessing.get_context("spawn" if sys.platform != "linux" else "fork")
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
            for row in pool.map(run_job, jobs, chunksize=1):
                rows.append(row)
                bar.update()
        return rows
    finally:
        bar.close()


def run_study(
    cfg: StudyConfig, out: Path, *, cache_dir: Path | None = None, progress: bool = True
) -> list[dict[str, Any]]:
    """Check ``cfg`` and make the output folders, then learn the tables, run every drive and
    write the outputs to ``out``; the rows. Every error of the configuration or the output
    folder (SimError, OSError) comes before anything is learned."""
    drivers = validate(cfg)
    out.mkdir(parents=True, exist_ok=True)
    (out / "irl").mkdir(exist_ok=True)
    if cfg.logs:
        (out / "logs").mkdir(exist_ok=True)
    if cfg.can_logs:
        (out / "can").mkdir(exist_ok=True)
    cloud = None if cfg.direct else study_cloud(cfg, drivers, out)
    if cfg.incremental:
        assert cloud is not None
        irl = cloud_irl_tables(cloud, drivers, cfg.seed)
        rows = run_incremental(cfg, drivers, cloud, irl)
        write_incremental_csv(out / "incremental.csv", rows)
        (out / "incremental.md").write_text(format_incremental(rows), encoding="utf-8")
        plot_incremental(out / "incremental.png", rows)
        return rows
    tables = tables_for(cfg, drivers, cache_dir, cloud)
    for (driver_id, kind), table in tables.items():
        if kind == "irl":
            save_dgpt(table, out / "irl" / f"{driver_id}.json")
    rows = run_jobs(plan(cfg, drivers, tables, out), cfg.workers, progress)
    write_csv(out / "drives.csv", rows)
    (out / "table1.md").write_text(format_table(cfg, rows), encoding="utf-8")
    plot(out / "study.png", rows)
    return rows
