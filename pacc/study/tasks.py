"""A study's drives as engine tasks: each drive a pure function of its job and the shared data.

:class:`DriveJob` is one drive of the study with everything it needs; :func:`split` turns the
plan into :class:`StudyData` (drivers, tables and lead profiles, each once: what an engine ships
to every worker once) and light :class:`DriveTask` items; :func:`run_task` is the function the
workers run (and :func:`manual_trips_task`, a driver's manual trips). It lives outside
``pacc.study`` so that a worker imports the drive and nothing of the study harness (its
cloud loop, the trainer, the report): a fresh Dask worker is ready sooner.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dbc.vocab.dgpt import Dgpt
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import write_trip
from ecu.adaptation import AdaptationParams
from pacc.study.drive import DriveConfig, log_to_trip, resolve_profile, run_drive
from pacc.study.irl_table import manual_trips
from sim_bus.drivers import DriverParams
from sim_bus.lead.profile import LeadProfile


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
    dbc: str | None = None  # the vehicle network (None: pacc's)
    binding: str | None = None
    can_log_path: str | None = None  # the drive's bus recording (written by the worker)
    bus: str = "lockstep"  # the python-can interface (pacc.study.drive.BUSES)


def run_job(job: DriveJob, profile: LeadProfile | None = None) -> dict[str, Any]:
    """Run one drive (on a worker): its row of drives.csv. The worker writes the drive's
    trip log at ``job.log_path`` and its bus recording at ``job.can_log_path`` itself (each
    atomically), so the main process only gathers rows: on a cluster of several machines
    the output folder must be a path every worker can write. ``profile``: the lead profile
    of ``job.scenario`` (None: made here from the study seed)."""
    driver = job.driver
    seed = job.study_seed + job.trial
    cfg = DriveConfig(
        scenario=job.scenario,
        driver_id=driver.driver_id,
        controller=job.controller,  # type: ignore[arg-type]
        seed=seed,
        duration_s=job.duration_s,
        adaptation=job.adaptation,
        dbc=job.dbc,
        binding=job.binding,
    )
    if profile is None:
        profile = resolve_profile(job.scenario, job.study_seed)
    can_log = Path(job.can_log_path) if job.can_log_path is not None else None
    result = run_drive(cfg, driver, job.table, profile, can_log=can_log, bus=job.bus)
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


@dataclass(frozen=True)
class StudyData:
    """What the drives share, shipped to each worker once: drivers and tables (indexed by
    :class:`DriveTask`) and the lead profile of each (study seed, scenario)."""

    drivers: tuple[DriverParams, ...]
    tables: tuple[Dgpt, ...]
    profiles: Mapping[tuple[int, str], LeadProfile]


@dataclass(frozen=True)
class DriveTask:
    """One drive as the engine sees it: a :class:`DriveJob` whose driver and table are
    indices into :class:`StudyData` (a few hundred bytes on the wire). The worker writes the
    trip log at ``log_path`` (and the recording at ``can_log_path``) and returns the row."""

    driver: int
    table: int
    scenario: str
    controller: str
    trial: int
    study_seed: int
    duration_s: float | None
    log_path: str | None
    adaptation: AdaptationParams | None
    dbc: str | None = None
    binding: str | None = None
    can_log_path: str | None = None
    bus: str = "lockstep"


def split(jobs: Sequence[DriveJob]) -> tuple[StudyData, list[DriveTask]]:
    """The data ``jobs`` share (each driver, table and profile once) and the light tasks."""
    drivers: dict[int, int] = {}
    tables: dict[int, int] = {}
    driver_list: list[DriverParams] = []
    table_list: list[Dgpt] = []
    profiles: dict[tuple[int, str], LeadProfile] = {}
    tasks = []
    for job in jobs:
        if id(job.driver) not in drivers:
            drivers[id(job.driver)] = len(driver_list)
            driver_list.append(job.driver)
        if id(job.table) not in tables:
            tables[id(job.table)] = len(table_list)
            table_list.append(job.table)
        key = (job.study_seed, job.scenario)
        if key not in profiles:
            profiles[key] = resolve_profile(job.scenario, job.study_seed)
        tasks.append(
            DriveTask(
                drivers[id(job.driver)],
                tables[id(job.table)],
                job.scenario,
                job.controller,
                job.trial,
                job.study_seed,
                job.duration_s,
                job.log_path,
                job.adaptation,
                job.dbc,
                job.binding,
                job.can_log_path,
                job.bus,
            )
        )
    return StudyData(tuple(driver_list), tuple(table_list), profiles), tasks


def run_task(data: StudyData, task: DriveTask) -> dict[str, Any]:
    """:func:`run_job` of ``task`` with the shared data put back (the engine's task)."""
    job = DriveJob(
        data.drivers[task.driver],
        task.scenario,
        task.controller,
        task.trial,
        task.study_seed,
        task.duration_s,
        data.tables[task.table],
        task.log_path,
        task.adaptation,
        task.dbc,
        task.binding,
        task.can_log_path,
        task.bus,
    )
    return run_job(job, data.profiles[(task.study_seed, task.scenario)])


def manual_trips_task(seed: int, driver: DriverParams) -> list[Trip]:
    """The driver's manual (ACC OFF) trips, the IRL demonstrations: an engine task."""
    return manual_trips(driver, seed)


__all__ = [
    "DriveJob",
    "DriveTask",
    "StudyData",
    "manual_trips_task",
    "run_job",
    "run_task",
    "split",
]
