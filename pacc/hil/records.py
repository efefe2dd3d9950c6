"""What a finished drive leaves in the session folder: trip log, record, tables, ratings.

``logs/<step>.mcap`` (the trip log), ``drives/<step>.json`` (the Table I row, pauses, the
table versions), ``tables/<step>-final.json`` (the table after online adaptation) and one
line of ``ratings.csv`` per rated drive.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

from dbc.vocab.dgpt_file import save_dgpt
from dbc.vocab.triplog_file import write_trip
from pacc.hil.loop import DriveOutcome, HilDrive
from pacc.hil.plan import Step
from pacc.study.report import METRIC_FIELDS

RATINGS_HEAD = ("participant", "step", "scenario", "controller", "comfort", "trust")


def write_drive(
    folder: Path,
    step: Step,
    drive: HilDrive,
    outcome: DriveOutcome,
    *,
    seed: int,
    pauses: list[dict[str, Any]],
) -> dict[str, Any]:
    """Write the drive's trip log, record and final table; the record."""
    participant = drive.participant.driver_id
    controller = step.controller or "manual"
    meta = {
        "scenario": step.scenario,
        "seed": seed,
        "controller": controller,
        "collision": outcome.collision,
        "source": "pacc.hil",
        "start_utc": outcome.start_utc,
        "step": step.id,
        "pauses": pauses,
    }
    write_trip(folder / "logs" / f"{step.id}.mcap", drive.trip(outcome, meta))
    m = outcome.log.metrics()
    row = {
        "driver": participant,
        "scenario": step.scenario,
        "controller": controller,
        "trial": 1,
        "seed": seed,
        **{k: getattr(m, k) for k in METRIC_FIELDS},
        "takeovers": outcome.takeovers,
        "adaptations": outcome.adaptations,
        "collision": int(outcome.collision),
        "sim_s": round(outcome.sim_s, 3),
        "wall_s": round(outcome.wall_s, 3),
    }
    record: dict[str, Any] = {
        "step": step.id,
        "practice": step.practice,
        "weather": step.weather,
        "brake_mode": drive.cfg.brake_mode,
        "row": row,
        "pauses": pauses,
        "collision_t_s": outcome.collision_t_s,
        "table_version": drive.table.version if step.controller is not None else None,
        "final_table_version": None,
        **outcome.extra,
    }
    if outcome.final_table is not None and step.controller is not None:
        save_dgpt(outcome.final_table, folder / "tables" / f"{step.id}-final.json")
        record["final_table_version"] = outcome.final_table.version
    save_record(folder, step.id, record)
    return record


def save_record(folder: Path, step_id: str, record: dict[str, Any]) -> None:
    """``drives/<step>.json`` (written whole, then renamed into place)."""
    path = folder / "drives" / f"{step_id}.json"
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(json.dumps(record, indent=1, default=str), encoding="utf-8")
    tmp.replace(path)


def append_rating(
    folder: Path, participant: str, step: Step, comfort: int | None, trust: int | None
) -> None:
    """One line of ``ratings.csv`` (a skipped rating is blank)."""
    path = folder / "ratings.csv"
    new = not path.is_file()
    with path.open("a", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        if new:
            w.writerow(RATINGS_HEAD)
        w.writerow([participant, step.id, step.scenario, step.controller, comfort, trust])


def rating(x: Any) -> int | None:
    """A 7-point rating 1..7, or None (skipped or not a rating)."""
    try:
        v = int(x)
    except (TypeError, ValueError):
        return None
    return v if 1 <= v <= 7 else None
