"""One drive with a person at the pedals: world + bus + ECU, stepped in lockstep or real time.

:class:`HilDrive` wires :func:`pacc.study.drive.run_drive`'s parts with
:class:`~pacc.hil.human.HumanPedals` as the driver, the ECU in-process on a private ``lockstep``
channel as in a study (or a separate ``pacc ecu`` on ``bus``). :meth:`HilDrive.step` is one
plant tick (10 ms); :class:`RealtimeRunner` calls it on a thread paced to the wall clock,
lockstep callers (the page's ``step`` messages, tests) call it themselves.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import can

from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import Dgpt
from dbc.vocab.pedals import PedalScale
from dbc.vocab.triplog import Trip
from ecu.buslog.format import TimeBase
from ecu.buslog.sinks import Sink
from pacc.hil.human import HumanPedals
from pacc.study.drive import DriveConfig, Rig, ecu_node
from sim_bus.drivers import GAP_SETTING_CODE, DriverParams
from sim_bus.lead.profile import LeadProfile
from sim_bus.trip import world_trip
from sim_bus.world import World, WorldConfig, WorldLog

_channels = itertools.count()


class HilDrive(Rig):
    """One drive: ``profile`` followed by a person, the ECU driving with ``table``. ``acc``:
    False for a manual drive; ``bus``: a separate ECU's bus, shut on close (None: the ECU
    in-process); ``can_log``: record to this MCAP file; ``set_speed_mps``: what SET sets (None:
    the car's speed at the press).
    """

    def __init__(
        self,
        cfg: DriveConfig,
        participant: DriverParams,
        table: Dgpt,
        profile: LeadProfile,
        *,
        acc: bool = True,
        bus: can.BusABC | None = None,
        can_log: Path | None = None,
        live: Sequence[Sink] = (),
        set_speed_mps: float | None = None,
    ) -> None:
        self.participant = participant
        self.profile = profile
        self.acc = acc
        self.table = table  # what the in-process ECU starts the drive with
        gap = GAP_SETTING_CODE[participant.predefined_setting]
        self.pedals = HumanPedals(main_on=acc, locked=not acc, gap_setting=gap)
        world = World(
            participant, profile, cfg.seed, WorldConfig(engage_s=cfg.engage_s), pedals=self.pedals
        )
        self.segments: list[Trip] = []
        self.extra: dict[str, Any] = {}  # what finish() adds to the drive's record
        ecu = None
        if bus is None:
            ecu = ecu_node(cfg, participant, table, profile, self.segments.append)
            # a person's SET (the study's drives set a speed above every lead's)
            ecu.config = dataclasses.replace(ecu.config, set_speed_mps=set_speed_mps)
        channel = f"pacc-hil-{next(_channels)}-{id(self):x}"
        super().__init__(
            cfg,
            world,
            ecu,
            table,
            TimeBase(time.time_ns(), 0.0),
            interface="lockstep",
            channel=channel,
            bus=bus,
            can_log=can_log,
            live=live,
        )
        self.dt_s = self.world.cfg.plant.dt_s
        #: wall-clock times of the first and the latest tick (perf_counter s)
        self._wall = (math.nan, math.nan)
        self._prev_tor = False
        #: the ECU's takeover requests so far (ACC_Command TakeoverRequest rising); the page
        #: chimes and shows TAKE OVER when it grows (a person's own override is no request)
        self.cues = 0

    @property
    def done(self) -> bool:
        """The profile ended or the car hit the lead."""
        return self.world.done

    def step(self) -> None:
        """One plant tick: the pedals, the simulator node (bus in/out, world), then the ECU."""
        wall = time.perf_counter()
        self._wall = (wall if math.isnan(self._wall[0]) else self._wall[0], wall)
        self.pedals.tick(self.dt_s)
        now = self.node.t_s
        self.node.step()
        if self.rt is not None:
            self.rt.advance_to(now)
        if self.feed is not None:
            self.feed()
        tor = bool(self.node.takeover_request)
        if tor and not self._prev_tor:
            self.cues += 1
        self._prev_tor = tor

    @property
    def wall_s(self) -> float:
        """Wall-clock seconds from the first tick to the latest (pauses included), s."""
        first, last = self._wall
        return 0.0 if math.isnan(first) else last - first

    def snapshot(self) -> dict[str, Any]:
        """What the page shows (never the controller: the drives are blind)."""
        w = self.world
        car = w.plant
        status = self.node.status or {}
        set_speed = status.get("set_speed_mps", 0.0)
        return {
            "t": round(w.t_s, 3),
            "duration": self.profile.duration_s,
            "v": car.v_mps,
            "gap": car.gap_m,
            "v_lead": w.v_lead_mps,
            "a_lead": w.a_lead_mps2,
            "acc_state": AccState(self.node.acc_state).name,
            "set_speed": float(set_speed) if math.isfinite(set_speed) else 0.0,
            "gap_setting": self.pedals.gap_setting,
            "main": self.pedals.main_on,
            "accel": self.pedals.accel,
            "brake": self.pedals.brake,
            "cues": self.cues,
            "collided": car.collided,
            "acc": self.acc,
            "lead": w.lead_present,
            "events": [[round(t, 2), kind] for t, kind, _ in w.events_log],
        }

    def finish(self) -> WorldLog:
        """Close the ECU, the buses and the recording (its failure in :attr:`extra`); the
        drive's log (call once). The figures stay on the world and the ECU."""
        log = self.world.log()
        if self.ecu is not None:
            self.ecu.finish()
        err = self.finish_recording(log)
        self.extra = {"can_log_error": err} if err else {}
        self.close()
        return log

    def trip(self, log: WorldLog, meta: dict[str, Any]) -> Trip:
        """The drive as a trip log (10 Hz); a manual drive's ``mode`` is ``manual``."""
        trip = world_trip(log, self.participant, PedalScale.from_codec(self.codec), meta)
        if not self.acc:
            trip = dataclasses.replace(trip, meta={**trip.meta, "mode": "manual"})
        return trip


class RealtimeRunner:
    """Steps a :class:`HilDrive` on a thread, paced to the wall clock; :attr:`paused` holds
    the world still; ``lateness_s``: the ticks' lateness against the schedule (first 10 000).
    """

    def __init__(self, drive: HilDrive, on_done: Callable[[], None] | None = None) -> None:
        self.drive = drive
        self.paused = False
        self.lateness_s: list[float] = []
        self._stop = threading.Event()
        self._on_done = on_done
        self.latest: dict[str, Any] = drive.snapshot()
        self.thread = threading.Thread(target=self._run, name="pacc-hil-world", daemon=True)

    def start(self) -> None:
        """Start the world's thread."""
        self.thread.start()

    def stop(self) -> None:
        """Stop the thread (the drive is left as it is) and wait for it."""
        self._stop.set()
        if self.thread.is_alive() and threading.current_thread() is not self.thread:
            self.thread.join(5.0)

    def _run(self) -> None:
        drive = self.drive
        dt = drive.dt_s
        due = time.perf_counter()
        while not self._stop.is_set() and not drive.done:
            if self.paused:
                time.sleep(0.01)
                due = time.perf_counter()
                continue
            late = time.perf_counter() - due
            drive.step()
            self.latest = drive.snapshot()
            if len(self.lateness_s) < 10_000:
                self.lateness_s.append(late)
            due += dt
            delay = due - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            elif delay < -0.25:  # far behind (a stall): start a new schedule, do not race
                due = time.perf_counter()
        self.latest = drive.snapshot()
        if not self._stop.is_set() and self._on_done is not None:
            self._on_done()
