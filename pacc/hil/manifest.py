"""A session folder's ``manifest.json``: the plan, the finished steps, the events.

One JSON object: ``participant``, ``protocol``, ``seed``, ``short_s`` (s, or null), ``plan``
(the step ids), ``conditions`` (each drive step's controller, null: by hand), ``done`` (step
id -> what it left: ratings, the learned table's version, ...) and ``events`` (lost
connections, pauses, failures, resumptions, each with its UTC or drive time). It is written
atomically (a ``.part`` file renamed over it) after every change, so a crash leaves the last
complete one; :class:`pacc.hil.session.Session` keeps it and opens it again to resume.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from pacc.hil.plan import Step
from sim_bus.errors import SimError

MANIFEST = "manifest.json"


def open_manifest(
    path: Path,
    participant: str,
    protocol: str,
    seed: int,
    short_s: float | None,
    plan: list[Step],
) -> dict[str, Any]:
    """The manifest at ``path``, a ``resumed`` event appended, or a new one for ``plan``.

    Raises :class:`~sim_bus.errors.SimError` when the file is not a manifest, or is another
    participant's or another plan's.
    """
    plan_ids = [s.id for s in plan]
    if path.is_file():
        try:
            m: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise SimError(f"{path}: not a session manifest ({exc})") from exc
        if m.get("participant") != participant or m.get("plan") != plan_ids:
            raise SimError(f"{path}: another participant's or protocol's session")
        m["events"].append({"event": "resumed", "at": utc_stamp()})
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


def save_manifest(path: Path, manifest: dict[str, Any]) -> None:
    """Write ``manifest`` to ``path`` atomically (``path.part``, then renamed over it)."""
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(json.dumps(manifest, indent=1, default=str), encoding="utf-8")
    tmp.replace(path)


def utc_stamp() -> str:
    """The wall clock's UTC to the second, ``YYYY-MM-DDTHH:MM:SSZ``."""
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
