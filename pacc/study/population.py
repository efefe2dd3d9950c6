"""``pacc study --population N --seed S``: Table I over N drawn drivers, resumable.

The drivers are drawn by :func:`sim_bus.population.draw_population` (seed ``S``), the
scenarios and the IRL tables come from the same seed, and every driver is one job in the
worker pool: its tables (predefined; IRL learned in-process from its manual trips, cached as
in ``pacc study --direct``), then every scenario × controller × trial drive
(:func:`pacc.study.tasks.run_job`, no trip logs). A finished driver's rows are appended to
``OUT/population.jsonl`` at once, so a run that is stopped resumes where it was: a second run
with the same configuration skips the drivers already there, and a larger N extends it (a
different configuration in the same folder is refused). The report
(:mod:`pacc.study.population_report`) comes from the rows of all N drivers.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from cloud_sync.engine import open_engine
from cloud_sync.engine.base import Engine
from ecu.adaptation import AdaptationParams
from pacc.study.config import StudyConfig, validate_drives
from pacc.study.drive import predefined_table
from pacc.study.irl_table import irl_table
from pacc.study.population_report import format_population
from pacc.study.report import write_csv
from pacc.study.tasks import DriveJob, run_job
from sim_bus.drivers import DriverParams
from sim_bus.errors import SimError
from sim_bus.population import draw_population

ROWS_FILE = "population.jsonl"


@dataclass(frozen=True)
class DriverJob:
    """Every drive of one drawn driver; picklable."""

    driver: DriverParams
    scenarios: tuple[str, ...]
    controllers: tuple[str, ...]
    trials: int
    seed: int
    duration_s: float | None
    adaptation: AdaptationParams | None
    cache_dir: str | None
    dbc: str | None = None  # the vehicle network (None: pacc's)
    binding: str | None = None
    bus: str = "lockstep"  # the python-can interface (pacc.study.drive.BUSES)


def run_driver(job: DriverJob) -> list[dict[str, Any]]:
    """Learn or read the driver's tables and run its drives (in a worker); the rows."""
    tables = {}
    if any(c.startswith("predefined") for c in job.controllers):
        tables["predefined"] = predefined_table(job.driver)
    if any(c.startswith("irl") for c in job.controllers):
        cache = Path(job.cache_dir) if job.cache_dir is not None else None
        tables["irl"] = irl_table(job.driver, job.seed, cache)
    rows = []
    for scenario in job.scenarios:
        for controller in job.controllers:
            kind = "irl" if controller.startswith("irl") else "predefined"
            for trial in range(job.trials):
                drive = DriveJob(
                    job.driver,
                    scenario,
                    controller,
                    trial,
                    job.seed,
                    job.duration_s,
                    tables[kind],
                    None,
                    job.adaptation,
                    job.dbc,
                    job.binding,
                    bus=job.bus,
                )
                rows.append(run_job(drive))
    return rows


def fingerprint(cfg: StudyConfig) -> dict[str, Any]:
    """What makes two population runs the same run (JSON-serialisable). Not the number of
    drivers: the first N drivers of a seed are the same whatever N, so a run can be extended."""
    return {
        "seed": cfg.seed,
        "scenarios": list(cfg.scenarios),
        "controllers": list(cfg.controllers),
        "trials": cfg.trials,
        "duration_s": cfg.duration_s,
        "adaptation": None if cfg.adaptation is None else dataclasses.asdict(cfg.adaptation),
        **({"mismatch": cfg.mismatch} if cfg.mismatch else {}),
        **({"trip_shift_s": cfg.trip_shift_s} if cfg.trip_shift_s else {}),
    }


def validate_population(cfg: StudyConfig) -> tuple[DriverParams, ...]:
    """The drawn drivers, once ``cfg`` is known to be a runnable population study."""
    validate_drives(cfg)
    if cfg.population < 1:
        raise SimError(f"--population must be >= 1, got {cfg.population}")
    if cfg.cloud is not None or cfg.incremental:
        raise SimError("--population learns in-process: not with --cloud or --incremental")
    if cfg.can_logs:
        raise SimError("--population keeps no logs: not with --can-logs")
    return draw_population(
        cfg.population, cfg.seed, mismatch=cfg.mismatch, trip_shift_sd_s=cfg.trip_shift_s
    )


def read_done(path: Path, fp: dict[str, Any]) -> dict[str, list[dict[str, Any]]]:
    """Driver id -> rows already in ``path`` (written by a run with fingerprint ``fp``).

    A missing file is an empty run; a file of another configuration raises SimError; a last
    line cut short by a kill is ignored (that driver runs again)."""
    if not path.exists():
        return {}
    lines = path.read_text(encoding="utf-8").splitlines()
    try:
        head = json.loads(lines[0]) if lines else {}
    except ValueError:
        head = {}
    if head.get("config") != fp:
        raise SimError(
            f"{path} holds another population run ({head.get('config')}); "
            "give another --out or remove the file"
        )
    done: dict[str, list[dict[str, Any]]] = {}
    for line in lines[1:]:
        try:
            rec = json.loads(line)
        except ValueError:
            continue  # a line cut short by a kill
        done[str(rec["driver"])] = list(rec["rows"])
    return done


def _append(path: Path, record: dict[str, Any]) -> None:
    with path.open("a", encoding="utf-8") as fh:
        fh.write(json.dumps(record) + "\n")
        fh.flush()
        os.fsync(fh.fileno())


def driver_task(_shared: None, job: DriverJob) -> list[dict[str, Any]]:
    """:func:`run_driver` as an engine task (nothing shared: a job carries its driver)."""
    return run_driver(job)


def run_population(
    cfg: StudyConfig,
    out: Path,
    *,
    cache_dir: Path | None = None,
    progress: bool = True,
    engine: Engine | None = None,
) -> list[dict[str, Any]]:
    """Run (or resume) the population study of ``cfg`` into ``out`` on ``engine`` (None: the
    one ``cfg.scheduler`` and ``cfg.workers`` name, opened here); every row, in driver
    order. Writes ``population.jsonl``, ``drives.csv`` and ``population.md``."""
    drivers = validate_population(cfg)
    out.mkdir(parents=True, exist_ok=True)
    path = out / ROWS_FILE
    fp = fingerprint(cfg)
    done = read_done(path, fp)
    if not path.exists():
        path.write_text(json.dumps({"config": fp}) + "\n", encoding="utf-8")
    todo = [
        DriverJob(
            d,
            cfg.scenarios,
            cfg.controllers,
            cfg.trials,
            cfg.seed,
            cfg.duration_s,
            cfg.adaptation,
            str(cache_dir) if cache_dir is not None else None,
            cfg.dbc,
            cfg.binding,
            cfg.bus,
        )
        for d in drivers
        if d.driver_id not in done
    ]
    bar = tqdm(
        total=len(drivers),
        initial=len(drivers) - len(todo),
        desc="drivers",
        unit="driver",
        disable=not progress,
        file=sys.stderr,
    )
    own = engine is None
    running = open_engine(cfg.scheduler, cfg.workers) if engine is None else engine
    try:
        for _, rows in running.map_unordered(driver_task, None, todo):
            done[str(rows[0]["driver"])] = rows
            _append(path, {"driver": rows[0]["driver"], "rows": rows})
            bar.update()
    finally:
        bar.close()
        if own:
            running.close()
    rows_all = [r for d in drivers for r in done[d.driver_id]]
    write_csv(out / "drives.csv", rows_all)
    (out / "population.md").write_text(format_population(cfg, rows_all), encoding="utf-8")
    return rows_all


__all__ = [
    "ROWS_FILE",
    "DriverJob",
    "driver_task",
    "fingerprint",
    "read_done",
    "run_driver",
    "run_population",
]
