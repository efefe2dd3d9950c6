"""The session folder's files: ``manifest.json`` and what each finished drive leaves.

``manifest.json``: the participant, protocol, seed, ``short_s`` (s or null), the plan's step
ids, each drive's controller, ``done`` (step id -> what it left) and ``events`` (lost
connections, pauses, failures, resumptions); rewritten atomically after every change.
Per drive: ``logs/<step>.mcap`` (the trip log), ``drives/<step>.json`` (the Table I row,
pauses, table versions), ``tables/<step>-final.json`` and a line of ``ratings.csv``.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

from dbc.atomic import write_bytes_atomic
from dbc.vocab.dgpt import utc_now_iso
from dbc.vocab.dgpt_file import save_dgpt
from dbc.vocab.triplog_file import write_trip
from pacc.hil.loop import HilDrive
from pacc.hil.plan import Step
from sim_bus.errors import SimError
from sim_bus.metrics import METRIC_FIELDS
from sim_bus.world import WorldLog

RATINGS_HEAD = ("participant", "step", "scenario", "controller", "comfort", "trust")


def write_drive(
    folder: Path,
    step: Step,
    drive: HilDrive,
    log: WorldLog,
    *,
    seed: int,
    pauses: list[dict[str, Any]],
) -> dict[str, Any]:
    """Write the finished drive's trip log, record and final table; the record."""
    participant, car, ecu = drive.participant.driver_id, drive.world.plant, drive.ecu
    controller = step.controller or "manual"
    meta = {
        "scenario": step.scenario,
        "seed": seed,
        "controller": controller,
        "collision": car.collided,
        "source": "pacc.hil",
        "start_utc": drive.base.iso(0.0),
        "step": step.id,
        "pauses": pauses,
    }
    write_trip(folder / "logs" / f"{step.id}.mcap", drive.trip(log, meta))
    m = log.metrics()
    row = {
        "driver": participant,
        "scenario": step.scenario,
        "controller": controller,
        "trial": 1,
        "seed": seed,
        **{k: getattr(m, k) for k in METRIC_FIELDS},
        "takeovers": ecu.takeovers if ecu else 0,
        "adaptations": ecu.adaptations if ecu else 0,
        "collision": int(car.collided),
        "sim_s": round(drive.world.t_s, 3),
        "wall_s": round(drive.wall_s, 3),
    }
    record: dict[str, Any] = {
        "step": step.id,
        "practice": step.practice,
        "weather": step.weather,
        "brake_mode": drive.cfg.brake_mode,
        "row": row,
        "pauses": pauses,
        "collision_t_s": car.collision_t_s,
        "table_version": drive.table.version if step.controller is not None else None,
        "final_table_version": None,
        **drive.extra,
    }
    if ecu is not None and step.controller is not None:
        save_dgpt(ecu.table, folder / "tables" / f"{step.id}-final.json")
        record["final_table_version"] = ecu.table.version
    save_json(folder / "drives" / f"{step.id}.json", record)
    return record


def save_json(path: Path, doc: Any) -> None:
    """Write ``doc`` to ``path`` atomically (:mod:`dbc.atomic`)."""
    write_bytes_atomic(path, json.dumps(doc, indent=1, default=str).encode())


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


MANIFEST = "manifest.json"


def open_manifest(
    path: Path,
    participant: str,
    protocol: str,
    seed: int,
    short_s: float | None,
    plan: list[Step],
) -> dict[str, Any]:
    """The manifest at ``path``, a ``resumed`` event appended, or a new one for ``plan``;
    SimError when it is not a manifest, or another participant's or plan's."""
    plan_ids = [s.id for s in plan]
    if path.is_file():
        try:
            m: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise SimError(f"{path}: not a session manifest ({exc})") from exc
        if m.get("participant") != participant or m.get("plan") != plan_ids:
            raise SimError(f"{path}: another participant's or protocol's session")
        m["events"].append({"event": "resumed", "at": utc_now_iso()})
        return m
    return {
        "participant": participant,
        "protocol": protocol,
        "seed": seed,
        "short_s": short_s,
        "plan": plan_ids,
        "conditions": {s.id: s.controller for s in plan if s.kind == "drive"},
        "done": {},
        "events": [],
    }
