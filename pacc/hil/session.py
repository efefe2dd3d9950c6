"""A participant's session: the plan's steps, the drives, the session folder, resumable.

Folder ``OUT/<participant>/``: ``manifest.json`` and the drives' records
(:mod:`pacc.hil.records`), ``can/<step>.mcap`` (bus recordings), ``tables/``, the cloud's and
spool's folders. Opened again, a session continues at the first step not finished.
:meth:`Session.handle` takes one message of the page (:mod:`pacc.hil.server`) and returns
what it shows next; thread-safe (one lock).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import can

from dbc.vocab.dgpt import Dgpt, utc_now_iso
from dbc.vocab.dgpt_file import load_dgpt, save_dgpt
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import read_trip
from ecu import EcuError
from ecu.buslog.live import live_sinks
from pacc.hil.loop import HilDrive, RealtimeRunner
from pacc.hil.plan import Step, trip_of
from pacc.hil.records import (
    MANIFEST,
    append_rating,
    open_manifest,
    rating,
    save_json,
    write_drive,
)
from pacc.study.drive import DriveConfig, predefined_table, resolve_profile
from pacc.study.irl_table import MANUAL_PROFILES
from pacc.study.loop import StudyCloud
from sim_bus.drivers import DriverParams, PredefinedSetting, load_driver
from sim_bus.errors import SimError
from sim_bus.lead.scenarios import shorten

#: the synthetic driver whose body a participant borrows (start gap, predefined setting)
BODY = "d3"

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SessionConfig:
    """How a session runs. ``short_s``: shorten every drive, s; ``lockstep``: the world advances
    on the page's ``step`` messages; ``cloud``: a URL or folder (None: embedded); ``bus``: opens
    the bus to a separate ECU (None: in-process); ``setting``: the Predefined headway choice.
    """

    participant: str
    protocol: str
    out: Path
    seed: int = 0
    short_s: float | None = None
    lockstep: bool = False
    cloud: str | None = None
    token_file: Path | None = None
    trust: Path | None = None
    bus: Callable[[], can.BusABC] | None = None
    setting: PredefinedSetting = "medium"
    table: Path | None = None  # the IRL table of a free drive (the protocol learns its own)
    #: ``HOST:PORT`` of a Foxglove live view of each drive's recording (in-process ECU only)
    foxglove: str | None = None
    #: brake press: ``resume`` (an override: the paper's study) or ``cancel`` (to STANDBY)
    brake_mode: Literal["resume", "cancel"] = "resume"
    #: the page's horizontal field of view, degrees (the angle the screen subtends at the eye)
    fov_deg: float = 50.0
    #: what SET sets, km/h: None the car's speed at the press (the paper protocol: 130)
    set_speed_kmh: float | None = None


class Session:
    """One participant walking through ``plan`` (see the module docstring)."""

    def __init__(self, cfg: SessionConfig, plan: list[Step]) -> None:
        self.cfg = cfg
        self.plan = plan
        self.folder = cfg.out / cfg.participant
        for sub in ("logs", "can", "drives", "tables"):
            (self.folder / sub).mkdir(parents=True, exist_ok=True)
        self.participant: DriverParams = dataclasses.replace(
            load_driver(BODY), driver_id=cfg.participant, predefined_setting=cfg.setting
        )
        self._lock = threading.RLock()
        self.manifest = open_manifest(
            self.folder / MANIFEST, cfg.participant, cfg.protocol, cfg.seed, cfg.short_s, plan
        )
        self.drive: HilDrive | None = None
        self.runner: RealtimeRunner | None = None
        self.phase = "ready"  # ready | driving | paused | after | syncing | learning | failed
        self.message = ""
        self._conn = 0
        self._pauses: list[dict[str, Any]] = []
        self._cloud_link: StudyCloud | None = None
        self.seq = 0

    def _save(self) -> None:
        save_json(self.folder / MANIFEST, self.manifest)
        self.seq += 1

    def current(self) -> Step | None:
        """The first step not finished (None: the session is complete)."""
        done = self.manifest["done"]
        return next((s for s in self.plan if s.id not in done), None)

    def _mark_done(self, step: Step, info: dict[str, Any]) -> None:
        self.manifest["done"][step.id] = info
        self._save()
        self.phase = "ready"
        self.message = ""

    def connect(self) -> int:
        """A page connected; its connection number. A paused drive waits for ``continue``."""
        with self._lock:
            self._conn += 1
            self.seq += 1
            return self._conn

    def disconnect(self, conn: int) -> None:
        """The page ``conn`` went away: a running drive pauses and is marked."""
        with self._lock:
            if conn != self._conn:
                return
            if self.phase == "driving" and self.drive is not None:
                self._pause("connection lost")

    def _pause(self, why: str) -> None:
        assert self.drive is not None
        if self.runner is not None:
            self.runner.paused = True
        self.phase = "paused"
        self._pauses.append({"t_s": round(self.drive.world.t_s, 3), "why": why})
        step = self.current()
        at = f"{step.id if step else '-'}@{self.drive.world.t_s:.2f}s"
        self.manifest["events"].append({"event": why, "at": at})
        self._save()

    def handle(self, msg: dict[str, Any]) -> dict[str, Any] | None:
        """One message from the page; the view to send back (None: nothing)."""
        kind = msg.get("t")
        with self._lock:
            drive = self.drive
            if kind == "in" and drive is not None:
                if "pa" in msg:
                    drive.pedals.axes(_num(msg.get("pa")), _num(msg.get("pb")))
                else:
                    drive.pedals.keys(bool(msg.get("ka")), bool(msg.get("kb")))
                return None
            if kind == "btn" and drive is not None:
                drive.pedals.press(str(msg.get("name", "")))
                return None
            if kind == "step" and drive is not None and self.cfg.lockstep:
                if self.phase == "driving":
                    for _ in range(max(1, min(int(_num(msg.get("n")) or 10), 1000))):
                        if drive.done:
                            break
                        drive.step()
                    if drive.done:
                        self._end_drive()
            elif kind == "action":
                self._action(str(msg.get("name", "")), msg)
            view = self.view()
            if "id" in msg:
                view["id"] = msg["id"]
            return view

    def view(self) -> dict[str, Any]:
        """What the page shows: the step (never the controller), the phase, the drive."""
        with self._lock:
            step = self.current()
            state = None
            if self.drive is not None:
                state = self.runner.latest if self.runner is not None else self.drive.snapshot()
            return {
                "t": "view",
                "seq": self.seq,
                "step": None if step is None else {"id": step.id, "kind": step.kind},
                "label": "" if step is None else step.label,
                "phase": self.phase,
                "message": self.message,
                "acc": bool(step is not None and step.controller is not None),
                "rate": step is not None
                and step.kind == "drive"
                and not step.practice
                and step.controller is not None,
                "lockstep": self.cfg.lockstep,
                "fov": self.cfg.fov_deg,
                "weather": "day" if step is None else step.weather,
                "brake_mode": self.cfg.brake_mode,
                "set_kmh": self.cfg.set_speed_kmh,
                "state": state,
            }

    def _action(self, name: str, msg: dict[str, Any]) -> None:
        step = self.current()
        if step is None:
            return
        if name == "consent" and step.kind == "consent":
            self._mark_done(step, {"consented": True, "at": utc_now_iso()})
        elif name == "continue" and step.kind in ("break", "done"):
            if step.kind == "break":
                self._mark_done(step, {})
        elif name == "start" and step.kind == "drive" and self.phase == "ready":
            self._start_drive(step)
        elif name == "start" and step.kind == "learn" and self.phase in ("ready", "failed"):
            self.phase = "learning"
            threading.Thread(target=self._learn, args=(step,), daemon=True).start()
        elif name == "continue" and self.phase == "paused":
            self.phase = "driving"
            if self.runner is not None:
                self.runner.paused = False
        elif name == "continue" and self.phase == "after" and step.kind == "drive":
            self._after_drive(step, msg.get("comfort"), msg.get("trust"))
        self.seq += 1

    def _table(self, step: Step) -> Dgpt:
        """The table a drive starts with: Predefined's, the learned one, or for the
        incremental drives the newest fine-tuned version."""
        tables = self.folder / "tables"
        if step.controller not in ("irl", "irl+oa"):
            return predefined_table(self.participant)
        if self.cfg.table is not None:
            return load_dgpt(self.cfg.table)
        if step.id.startswith("inc") and (tables / "irl-latest.json").is_file():
            return load_dgpt(tables / "irl-latest.json")
        return load_dgpt(tables / "irl.json")

    def new_drive(self, step: Step, *, can_log: Path | None = None) -> HilDrive:
        """The drive of ``step`` (its profile, controller, table), not started."""
        profile = resolve_profile(step.scenario, self.cfg.seed)
        if self.cfg.short_s is not None:
            profile = shorten(profile, self.cfg.short_s)
        cfg = DriveConfig(
            scenario=step.scenario,
            driver_id=self.cfg.participant,
            controller=step.controller or "predefined",  # type: ignore[arg-type]
            seed=self.cfg.seed + trip_of(step.id),  # the incremental trips: fresh plant noise
            brake_mode=self.cfg.brake_mode,
        )
        bus = self.cfg.bus() if self.cfg.bus is not None else None
        return HilDrive(
            cfg,
            self.participant,
            self._table(step),
            profile,
            acc=step.controller is not None,
            bus=bus,
            can_log=None if bus is not None else can_log,
            live=live_sinks(self.cfg.foxglove, log.info) if bus is None else [],
            set_speed_mps=None if self.cfg.set_speed_kmh is None else self.cfg.set_speed_kmh / 3.6,
        )

    def _start_drive(self, step: Step) -> None:
        try:
            self.drive = self.new_drive(step, can_log=self.folder / "can" / f"{step.id}.mcap")
        except (EcuError, SimError, OSError) as exc:  # e.g. the live view's port is taken
            self.message = f"cannot start the drive: {exc}"
            log.error("%s", self.message)
            return
        self.message = ""
        self._pauses = []
        self.phase = "driving"
        if not self.cfg.lockstep:
            self.runner = RealtimeRunner(self.drive, on_done=self._runner_done)
            self.runner.start()

    def _runner_done(self) -> None:
        with self._lock:
            if self.drive is not None and self.drive.done:
                self._end_drive()

    def _end_drive(self) -> None:
        step = self.current()
        drive = self.drive
        assert step is not None and drive is not None
        log, car = drive.finish(), drive.world.plant
        self.message = (
            f"The drive ended in a collision at {car.collision_t_s:.1f} s."
            if car.collided and car.collision_t_s is not None
            else ""
        )
        record = write_drive(self.folder, step, drive, log, seed=self.cfg.seed, pauses=self._pauses)
        self.seq += 1
        if step.id.startswith("inc") and drive.ecu is not None:
            self.phase = "syncing"  # the takeovers go up, the fine-tuned table comes down
            args = (step, record, list(drive.segments), drive.table)
            threading.Thread(target=self._sync, args=args, daemon=True).start()
        else:
            self.phase = "after"

    def _after_drive(self, step: Step, comfort: Any, trust: Any) -> None:
        ratings = {"comfort": rating(comfort), "trust": rating(trust)}
        if step.controller is not None and not step.practice:
            append_rating(self.folder, self.cfg.participant, step, **ratings)
        self.drive = None
        self.runner = None
        self._mark_done(step, {"ratings": ratings, "at": utc_now_iso()})

    def _cloud(self) -> StudyCloud:
        cfg = self.cfg
        if self._cloud_link is None:
            self._cloud_link = StudyCloud.open(
                self.folder,
                [cfg.participant],
                cfg.seed,
                cfg.cloud,
                cfg.token_file,
                cfg.trust,
                keep=True,
            )
        return self._cloud_link

    def _learn(self, step: Step) -> None:
        try:
            trips = [read_trip(self.folder / "logs" / f"{name}.mcap") for name in MANUAL_PROFILES]
            table, batches = self._cloud().learn(trips, self.cfg.participant)
        except Exception as exc:  # noqa: BLE001 - any failure is shown; the step can be retried
            self._failed(f"learning failed: {exc}")
            return
        save_dgpt(table, self.folder / "tables" / "irl.json")
        save_dgpt(predefined_table(self.participant), self.folder / "tables" / "predefined.json")
        with self._lock:
            info = {"batches": batches, "version": table.version, "signed": True}
            self._mark_done(step, {**info, "at": utc_now_iso()})

    def _sync(self, step: Step, record: dict[str, Any], segments: list[Trip], table: Dgpt) -> None:
        try:
            newer, batches = self._cloud().fine_tune(segments, table)
        except Exception as exc:  # noqa: BLE001 - shown; the drive's files are kept
            newer, batches = table, 0
            with self._lock:
                event = {"event": f"sync failed: {exc}", "at": utc_now_iso()}
                self.manifest["events"].append(event)
        save_dgpt(newer, self.folder / "tables" / "irl-latest.json")
        record["incremental"] = {"uploaded": batches, "next_version": newer.version}
        save_json(self.folder / "drives" / f"{step.id}.json", record)
        with self._lock:
            self.phase = "after"
            self._save()

    def _failed(self, message: str) -> None:
        with self._lock:
            self.phase = "failed"
            self.message = message
            self.manifest["events"].append({"event": message, "at": utc_now_iso()})
            self._save()

    def close(self) -> None:
        """Stop a running world (the session stays resumable)."""
        with self._lock:
            if self.runner is not None:
                self.runner.stop()
            if self.drive is not None:
                self.drive.close()


def _num(x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return 0.0
    return v if math.isfinite(v) else 0.0
