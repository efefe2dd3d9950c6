"""Running a study file on the engine, resumable; rows, summary, manifest.

Every driver is one engine task (:func:`driver_task`, pure of its :class:`DriverTask`): its
tables are learned once per table source from its manual trips on manual1..manual4 (study
seed) by the named learner (:mod:`cloud_sync.learners`; ``predefined``: the driver's chosen
constant headway), then every scenario x method x trial drives (:func:`run_drive`) with the
method's controller and adaptation through the plug-in interface. A finished driver's rows
go to ``OUT/rows.jsonl`` at once: a stopped run started again with the same resolved config
skips the drivers already there (another config in the same folder is refused). Outputs:
``manifest.json``, ``drives.csv`` (no wall times: the same config gives the same rows,
in-process or on Dask), ``timings.csv`` (learning and drive wall times), ``summary.md``.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cloud_sync.engine import open_engine
from cloud_sync.engine.base import Engine
from cloud_sync.errors import CloudSyncError
from cloud_sync.learners import learn
from dbc.vocab import FormatError
from dbc.vocab.dgpt import Dgpt
from pacc.study.drive import DriveConfig, predefined_table, resolve_profile, run_drive
from pacc.study.files.manifest import write_manifest
from pacc.study.files.studyfile import Method, StudyFileError, drivers_of, methods_of
from pacc.study.irl_table import manual_trips
from sim_bus.drivers import DriverParams

ROWS = "rows.jsonl"
FIELDS = (
    "driver", "scenario", "method", "table", "adaptation", "controller", "trial", "seed",
    "poi_pct", "nim_per_min", "press_onsets", "min_gap_m", "min_ttc_s", "rms_jerk_mps3",
    "gap_error_rms_m", "takeovers", "adaptations", "collision", "plugin_faults",
)  # fmt: skip


@dataclass(frozen=True)
class DriverTask:
    """Every drive of one driver; picklable."""

    driver: DriverParams
    scenarios: tuple[str, ...]
    methods: tuple[Method, ...]
    seed: int
    trials: int
    duration_s: float | None


def scenario_label(scenario: str) -> str:
    """A scenario's name in the rows: the built-in name or the CSV file's stem."""
    return Path(scenario).stem if scenario.lower().endswith(".csv") else scenario


def driver_tables(task: DriverTask) -> tuple[dict[str, Dgpt], list[dict[str, Any]]]:
    """The driver's table per table source and what learning them took (or why it failed)."""
    tables: dict[str, Dgpt] = {}
    learned: list[dict[str, Any]] = []
    trips = None
    for m in task.methods:
        if m.table_key in tables or any(x["key"] == m.table_key for x in learned):
            continue
        if m.table == "predefined":
            tables[m.table_key] = predefined_table(task.driver)
            continue
        trips = trips if trips is not None else manual_trips(task.driver, task.seed)
        try:
            table = learn(
                m.table,
                trips,
                driver_id=task.driver.driver_id,
                seed=task.seed,
                params=dict(m.learner_args),
            )
        except (FormatError, CloudSyncError, ValueError) as exc:  # data a learner cannot use
            learned.append({"key": m.table_key, "table": m.table, "error": str(exc)})
            continue
        tables[m.table_key] = table
        learned.append({"key": m.table_key, "table": m.table, "learn_s": table.meta["learn_s"]})
    return tables, learned


def drive_row(
    task: DriverTask,
    m: Method,
    table: Dgpt,
    scenario: str,
    trial: int,
) -> tuple[dict[str, Any], float]:
    """One drive of ``m``: its row and its wall time (s)."""
    kind = "predefined" if m.table == "predefined" else "irl"
    seed = task.seed + trial
    cfg = DriveConfig(
        scenario=scenario,
        driver_id=task.driver.driver_id,
        controller=f"{kind}+oa" if m.adaptation else kind,  # type: ignore[arg-type]
        seed=seed,
        duration_s=task.duration_s,
        gap_controller=m.controller,
        controller_args=m.controller_args,
        adaptation_method=m.adaptation,
        adaptation_args=m.adaptation_args,
    )
    result = run_drive(cfg, task.driver, table, resolve_profile(scenario, task.seed))
    mt = result.metrics
    faults = result.summary.plugin_faults
    row = {
        "driver": task.driver.driver_id, "scenario": scenario_label(scenario),
        "method": m.name, "table": m.table, "adaptation": m.adaptation or "none",
        "controller": m.controller or "builtin", "trial": trial, "seed": seed,
        "poi_pct": mt.poi_pct, "nim_per_min": mt.nim_per_min, "press_onsets": mt.press_onsets,
        "min_gap_m": mt.min_gap_m, "min_ttc_s": mt.min_ttc_s, "rms_jerk_mps3": mt.rms_jerk_mps3,
        "gap_error_rms_m": mt.gap_error_rms_m, "takeovers": result.takeovers,
        "adaptations": result.adaptations, "collision": int(result.collision),
        "plugin_faults": "; ".join(f"{k} {n}" for k, n in sorted(faults.items())),
    }  # fmt: skip
    return row, result.wall_s


def driver_task(_shared: None, task: DriverTask) -> dict[str, Any]:
    """Learn the driver's tables and run its drives (on a worker): rows and timings."""
    tables, learned = driver_tables(task)
    rows, walls = [], []
    for scenario in task.scenarios:
        for m in task.methods:
            table = tables.get(m.table_key)
            if table is None:
                continue  # its learner could not learn from this driver's trips (in learned)
            for trial in range(task.trials):
                row, wall = drive_row(task, m, table, scenario, trial)
                rows.append(row)
                walls.append(
                    {"scenario": row["scenario"], "method": m.name, "trial": trial, "wall_s": wall}
                )
    return {"driver": task.driver.driver_id, "rows": rows, "learned": learned, "walls": walls}


def fingerprint(config: Mapping[str, Any]) -> dict[str, Any]:
    """What makes two runs the same run: the config without where it runs."""
    return {k: v for k, v in config.items() if k not in ("workers", "scheduler")}


def read_done(path: Path, fp: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """The finished drivers of an earlier run of the same config in this folder."""
    if not path.is_file():
        return {}
    lines = path.read_text(encoding="utf-8").splitlines()
    try:
        head = json.loads(lines[0]) if lines else {}
    except json.JSONDecodeError:
        head = {}
    if head.get("fingerprint") != json.loads(json.dumps(fp, default=str)):
        raise StudyFileError(f"{path} belongs to another study config: use another --out")
    done: dict[str, dict[str, Any]] = {}
    for line in lines[1:]:
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            continue  # a line cut by a stop: that driver runs again
        done[rec["driver"]] = rec
    return done


def run_tasks(
    tasks: Sequence[Any],
    fn: Callable[[None, Any], dict[str, Any]],
    out: Path,
    fp: Mapping[str, Any],
    engine: Engine,
    *,
    key: Callable[[Any], str],
    progress: Callable[[str], None] | None = None,
) -> dict[str, dict[str, Any]]:
    """Run ``fn`` for the tasks not yet in ``out/rows.jsonl`` on ``engine``, appending each
    record as it finishes; every record by key, finished earlier or now."""
    path = out / ROWS
    done = read_done(path, fp)
    if not path.is_file():
        path.write_text(json.dumps({"fingerprint": fp}, default=str) + "\n", encoding="utf-8")
    todo = [t for t in tasks if key(t) not in done]
    with path.open("a", encoding="utf-8") as fh:
        for _, rec in engine.map_unordered(fn, None, todo):
            fh.write(json.dumps(rec, default=_json_float) + "\n")
            fh.flush()
            done[rec["driver"]] = rec
            if progress is not None:
                progress(f"{len(done)}/{len(tasks)} {rec['driver']}")
    return done


def _json_float(x: Any) -> Any:
    return float(x) if isinstance(x, np.floating) else str(x)


def run_study_file(
    config: Mapping[str, Any],
    out: Path,
    *,
    engine: Engine | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[dict[str, Any]]:
    """Run a resolved study config into ``out`` (see the module docstring); the rows."""
    drivers = drivers_of(config)
    methods = tuple(methods_of(config))
    tasks = [
        DriverTask(d, tuple(config["scenarios"]), methods, int(config["seed"]),
                   int(config["trials"]), config["duration_s"])
        for d in drivers
    ]  # fmt: skip
    write_manifest(out, config, {"drivers_resolved": [d.driver_id for d in drivers]})
    own = engine is None
    eng = engine or open_engine(config["scheduler"] or None, int(config["workers"]))
    try:
        done = run_tasks(
            tasks,
            driver_task,
            out,
            fingerprint(config),
            eng,
            key=lambda t: t.driver.driver_id,
            progress=progress,
        )
    finally:
        if own:
            eng.close()
    rows = [r for d in drivers for r in done[d.driver_id]["rows"]]
    write_rows(out / "drives.csv", rows)
    write_timings(out / "timings.csv", [done[d.driver_id] for d in drivers])
    (out / "summary.md").write_text(
        summary_table(rows, [m.name for m in methods]), encoding="utf-8"
    )
    return rows


def write_rows(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    """The rows as CSV, columns :data:`FIELDS`."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)


def write_timings(path: Path, records: Sequence[Mapping[str, Any]]) -> None:
    """Learning and drive wall times per driver (s), and learning failures."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["driver", "what", "name", "wall_s", "error"])
        for rec in records:
            for x in rec["learned"]:
                w.writerow(
                    [rec["driver"], "learn", x["table"], x.get("learn_s", ""), x.get("error", "")]
                )
            for x in rec["walls"]:
                w.writerow(
                    [
                        rec["driver"],
                        "drive",
                        f"{x['method']} {x['scenario']} {x['trial']}",
                        f"{x['wall_s']:.3f}",
                        "",
                    ]
                )


def summary_table(rows: Sequence[Mapping[str, Any]], methods: Sequence[str]) -> str:
    """Markdown: per method, drives, mean PoI and NIM, lowest TTC, collisions, plug-in faults."""
    lines = [
        "| method | drives | PoI % | NIM /min | min TTC s | collisions | plug-in faults |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in methods:
        mine = [r for r in rows if r["method"] == name]
        if not mine:
            lines.append(f"| {name} | 0 | – | – | – | – | – |")
            continue
        ttc = min(float(r["min_ttc_s"]) for r in mine)
        faults = sum(1 for r in mine if r["plugin_faults"])
        lines.append(
            f"| {name} | {len(mine)} | {np.mean([r['poi_pct'] for r in mine]):.2f} | "
            f"{np.mean([r['nim_per_min'] for r in mine]):.2f} | "
            f"{ttc:.2f}{'' if math.isfinite(ttc) else ''} | "
            f"{sum(int(r['collision']) for r in mine)} | {faults} |"
        )
    return "\n".join(lines) + "\n"


__all__ = ["DriverTask", "driver_task", "run_study_file", "run_tasks", "summary_table"]
