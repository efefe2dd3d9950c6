"""One closed-loop drive: the ECU node and the simulator in one process, lockstep, one bus.

:func:`run_drive` is a pure function of (configuration, seed, shipped data): the ECU and the
simulator each get an end of one python-can bus (``lockstep``, :mod:`dbc.lockstep`, or
``virtual``: the same frames) and time is the simulator's.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, get_args

import can

from dbc.codec import Codec, load_codec, network_paths
from dbc.lockstep import LockstepBus
from dbc.vocab.dgpt import Dgpt, predefined
from dbc.vocab.pedals import PedalScale
from dbc.vocab.triplog import Trip
from ecu import EcuError
from ecu.adaptation import AdaptationParams, Decision
from ecu.buslog.format import TimeBase
from ecu.buslog.recording import open_recording
from ecu.buslog.sinks import Sink
from ecu.buslog.writer import CanLogWriter
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime, RuntimeSummary
from pacc.study.drive_recording import (
    MAX_PACE,
    MIN_PACE,
    WorldFeed,
    after_tick,
    finish_recording,
)
from sim_bus.drivers import GAP_SETTING_CODE, DriverParams
from sim_bus.errors import DriveError, DriverError, ScenarioError
from sim_bus.faults import FaultSpec, fault_rng, parse_faults
from sim_bus.lead.events import ROAD_SCENARIOS, road_profile
from sim_bus.lead.profile import LeadProfile
from sim_bus.lead.profile_csv import load_profile_csv
from sim_bus.lead.scenarios import canonical_profiles, shorten
from sim_bus.metrics import DriveMetrics, SafetyFigures
from sim_bus.node import SimNode
from sim_bus.trip import world_trip
from sim_bus.world import World, WorldConfig, WorldLog

Controller = Literal["predefined", "predefined+oa", "irl", "irl+oa"]
CONTROLLERS: tuple[str, ...] = get_args(Controller)
#: ACC set speed in the car-following study: above every lead speed, so the lead governs
SET_SPEED_MPS = 40.0
#: creation time of every table a drive makes (predefined, adapted): drives stay pure
FIXED_UTC = "2000-01-01T00:00:00Z"
_channel_ids = itertools.count()
#: the python-can interfaces a drive runs on (the first is the default)
BUSES: tuple[str, ...] = ("lockstep", "virtual")


@dataclass(frozen=True)
class DriveConfig:
    """One closed-loop drive (what, with whom, how long, which faults, which brake mode)."""

    scenario: str = "B"
    driver_id: str = "d1"
    controller: Controller = "predefined"
    seed: int = 0
    duration_s: float | None = None  # None: the whole profile
    faults: str = ""
    brake_mode: Literal["resume", "cancel"] = "resume"
    engage_s: float = 1.5
    adaptation: AdaptationParams | None = None  # None: the ECU's default AdaptationParams
    dbc: str | None = None  # the vehicle network's DBC and binding (None: pacc's; docs/vehicles.md)
    binding: str | None = None
    #: plug-in methods (:mod:`ecu.methods`; "": the built-ins called directly) and their
    #: arguments as (name, value) pairs; the adaptation runs only for the +oa controllers
    gap_controller: str = ""
    controller_args: tuple[tuple[str, Any], ...] = ()
    adaptation_method: str = ""
    adaptation_args: tuple[tuple[str, Any], ...] = ()
    #: the driver drives by hand, the ACC never engaged (a manual drive's bus log)
    manual: bool = False


@dataclass(frozen=True)
class AdaptationEvent:
    """One adaptation decision of a drive: when (simulated s), what, and the table after it."""

    t_s: float
    decision: Decision
    table: Dgpt


@dataclass
class DriveResult:
    """What a drive produced: figures, the simulator log, the ECU summary, frame counts."""

    config: DriveConfig
    metrics: DriveMetrics
    collision: bool
    collision_t_s: float | None
    takeovers: int
    adaptations: int
    sim_s: float
    wall_s: float
    log: WorldLog
    summary: RuntimeSummary
    frames_sent: int
    frames_faulted: int
    final_table: Dgpt
    adaptation_events: list[AdaptationEvent] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)
    #: UTC of simulated time 0 (ISO 8601): when the drive ran
    start_utc: str = ""
    #: the road scenario's events as played: (time s, kind, new gap m or None if skipped)
    road_events: list[tuple[float, str, float | None]] = field(default_factory=list)
    #: the ECU's takeover requests at its braking limit (:attr:`ecu.node.EcuNode.limit_requests`)
    limit_requests: int = 0

    def safety(self, threshold_s: float = 2.0) -> SafetyFigures:
        """The drive's time-to-collision exposure (:meth:`WorldLog.safety`), the time after a
        cut-in that began below ``threshold_s`` of TTC counted apart (``below_cut_in_s``)."""
        cuts = [t for t, kind, gap in self.road_events if kind == "cut_in" and gap is not None]
        return self.log.safety(threshold_s, cuts)

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.sim_s / self.wall_s if self.wall_s > 0 else math.inf


def with_condition(driver: DriverParams, factor: float) -> DriverParams:
    """The driver under a driving condition: its condition factor multiplied by ``factor``."""
    if not (math.isfinite(factor) and factor > 0):
        raise DriverError(f"condition factor must be a positive number, got {factor}")
    if factor == 1.0:
        return driver
    return dataclasses.replace(driver, condition_factor=driver.condition_factor * factor)


def predefined_table(driver: DriverParams) -> Dgpt:
    """The Predefined controller's table: the driver's chosen constant headway, d0 = 4 m."""
    return predefined(
        driver.predefined_headway_s, driver_id=driver.driver_id, created_utc=FIXED_UTC
    )


def resolve_profile(scenario: str, seed: int) -> LeadProfile:
    """A canonical profile name (A, B, manual1..4), a road scenario (cutin, cutout, leadloss,
    stopgo, C: :mod:`sim_bus.lead.events`) or a CSV file of ``t_s,v_lead_mps``."""
    if scenario.lower().endswith(".csv"):
        return load_profile_csv(Path(scenario))
    if scenario in ROAD_SCENARIOS:
        return road_profile(scenario, seed)
    profiles = canonical_profiles(seed)
    if scenario not in profiles:
        raise ScenarioError(
            f"unknown scenario {scenario!r}: one of {sorted(profiles) + list(ROAD_SCENARIOS)} "
            "or a .csv file"
        )
    return profiles[scenario]


def run_drive(
    cfg: DriveConfig,
    driver: DriverParams,
    table: Dgpt,
    profile: LeadProfile | None = None,
    *,
    takeover_sink: Any = None,
    manual_sink: Any = None,
    record_channel: str | None = None,
    can_log: Path | None = None,
    utc_start_ns: int | None = None,
    live: Sequence[Sink] = (),
    bus: str = "lockstep",
    pace: float | None = None,
) -> DriveResult:
    """Run one lockstep drive; a collision is reported, never raised. ``can_log``: the MCAP
    recording (time 0 at ``utc_start_ns``), ``live``: more sinks; ``pace``: times real time
    (None: flat out; Ctrl-C ends a paced drive, ``extra["interrupted_at_s"]``)."""
    _check_drive(cfg, bus, pace)
    prof = profile or resolve_profile(cfg.scenario, cfg.seed)
    if cfg.duration_s is not None:
        prof = shorten(prof, cfg.duration_s)
    faults = parse_faults(cfg.faults)
    world = World(driver, prof, cfg.seed, WorldConfig(engage_s=cfg.engage_s), not cfg.manual)
    ecu = ecu_node(cfg, driver, table, prof, takeover_sink, manual_sink)
    base = TimeBase(time.time_ns() if utc_start_ns is None else utc_start_ns, 0.0)
    channel = record_channel or f"pacc-drive-{id(cfg):x}-{next(_channel_ids)}"
    gap = GAP_SETTING_CODE[driver.predefined_setting]
    rig = Rig(
        cfg,
        world,
        ecu,
        table,
        base,
        interface=bus,
        channel=channel,
        can_log=can_log,
        live=live,
        faults=faults,
        gap_setting=gap,
    )
    interrupted_at: float | None = None
    try:
        assert rig.rt is not None
        start = time.perf_counter()
        events: list[AdaptationEvent] = []
        try:
            _lockstep(rig.node, rig.rt, ecu, world, events, after_tick(rig.feed, pace))
        except KeyboardInterrupt:
            if pace is None:
                raise  # a study's drive: its harness handles Ctrl-C
            interrupted_at = world.t_s
        wall = time.perf_counter() - start
        ecu.finish()
        summary = rig.rt.summary()
        log = world.log()
        can_log_error = rig.finish_recording(log)
    finally:
        rig.close()
    # the recording's failure, the simulated time (s) Ctrl-C ended a paced drive at, the ECU's
    # manual trips (with a manual sink: it wrote those it could)
    extra: dict[str, Any] = {"can_log_error": can_log_error} if can_log_error else {}
    if interrupted_at is not None:
        extra["interrupted_at_s"] = interrupted_at
    if ecu.manual is not None:
        extra["manual_trips"] = ecu.manual.trips
    return DriveResult(
        config=cfg,
        metrics=log.metrics(),
        collision=world.plant.collided,
        collision_t_s=world.plant.collision_t_s,
        takeovers=ecu.takeovers,
        adaptations=ecu.adaptations,
        sim_s=world.t_s,
        wall_s=wall,
        log=log,
        summary=summary,
        frames_sent=rig.node.frames_sent,
        frames_faulted=rig.node.frames_faulted,
        final_table=ecu.table,
        adaptation_events=events,
        start_utc=base.iso(0.0),
        road_events=list(world.events_log),
        limit_requests=ecu.limit_requests,
        extra=extra,
    )


class Rig:
    """A drive's wiring: ``world`` on the simulator's node at one end of a private bus
    (``interface``, ``channel``) and ``ecu`` at the other, stepped to the simulator's time and
    recorded to ``can_log`` and ``live`` sinks; ``ecu`` None: ``bus`` is a separate ECU's."""

    def __init__(
        self,
        cfg: DriveConfig,
        world: World,
        ecu: EcuNode | None,
        table: Dgpt,
        base: TimeBase,
        *,
        interface: str = "virtual",
        channel: str = "",
        bus: can.BusABC | None = None,
        can_log: Path | None = None,
        live: Sequence[Sink] = (),
        faults: FaultSpec | None = None,
        gap_setting: int = 2,
    ) -> None:
        self.cfg, self.world, self.ecu, self.base = cfg, world, ecu, base
        self.codec = drive_codec(cfg)
        self.rt: EcuRuntime | None = None
        self.recorder: CanLogWriter | None = None
        self.feed: WorldFeed | None = None  # the world streamed to a live view as it runs
        self.closed = False
        if ecu is None:
            assert bus is not None
            self.buses = [bus]
        else:
            bus, ecu_bus = _open_bus(interface, channel), _open_bus(interface, channel)
            self.buses = [bus, ecu_bus]
        try:
            if ecu is not None:
                self.rt = EcuRuntime(ecu_bus, ecu, codec=self.codec)
                if can_log is not None or live:
                    # the drive's settings in the metadata; one left at None is absent
                    settings = {
                        k: str(v) for k, v in dataclasses.asdict(cfg).items() if v is not None
                    }
                    self.recorder = open_recording(
                        can_log,
                        self.codec,
                        base,
                        node="drive",
                        config=ecu.config,
                        table=table,
                        metadata={"drive": settings},
                        sinks=live,
                    )
                    self.rt.record_to(self.recorder)
                    self.feed = WorldFeed(self.recorder, world) if live else None
            self.node = SimNode(
                bus,
                world,
                codec=self.codec,
                faults=faults,
                rng=fault_rng(cfg.seed),
                gap_setting=gap_setting,
            )
        except BaseException:
            self.close()
            raise

    def finish_recording(self, log: WorldLog) -> str | None:
        """Close the recording with ``log``'s world; why it failed (None: it did not)."""
        if self.recorder is None:
            return None
        return finish_recording(self.recorder, log, streamed=self.feed is not None)

    def close(self) -> None:
        """Shut the buses this drive opened (idempotent); a recording left open is closed."""
        if self.closed:
            return
        self.closed = True
        for bus in self.buses:
            bus.shutdown()
        if self.recorder is not None and not self.recorder.closed:  # a failed drive's: kept
            with contextlib.suppress(EcuError, OSError):
                self.recorder.close()


def _check_drive(cfg: DriveConfig, bus: str, pace: float | None) -> None:
    """Raise DriveError for an unknown bus or controller, a negative seed, a bad pace."""
    if bus not in BUSES:
        raise DriveError(f"bus must be one of {', '.join(BUSES)}, got {bus!r}")
    if cfg.controller not in CONTROLLERS:
        raise DriveError(f"controller must be one of {CONTROLLERS}")
    if cfg.seed < 0:
        raise DriveError(f"seed must be >= 0, got {cfg.seed}")
    if pace is not None and not MIN_PACE <= pace <= MAX_PACE:
        raise DriveError(f"pace must be within {MIN_PACE:g}..{MAX_PACE:g}, got {pace}")


def _open_bus(interface: str, channel: str) -> can.BusABC:
    """One end of the drive's bus: frames keep the simulated time they were stamped with."""
    if interface == "virtual":
        return can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
    return LockstepBus(channel=channel)


def drive_codec(cfg: DriveConfig) -> Codec:
    """The codec of the drive's network (``cfg.dbc``/``cfg.binding``); DbcError if unloadable."""
    return load_codec(*network_paths(cfg.dbc, cfg.binding))


def ecu_node(
    cfg: DriveConfig,
    driver: DriverParams,
    table: Dgpt,
    prof: LeadProfile,
    takeover_sink: Any,
    manual_sink: Any = None,
) -> EcuNode:
    """The ECU of a drive: ``cfg``'s controller and adaptation; the road's set speed, else
    the study's (above every lead speed)."""
    scenario = prof.name
    ecu_cfg = EcuConfig(
        adaptation=cfg.controller.endswith("+oa"),
        brake_mode=cfg.brake_mode,
        adaptation_params=cfg.adaptation or AdaptationParams(),
        set_speed_mps=prof.set_speed_mps or SET_SPEED_MPS,
        trip_meta={
            "driver_id": driver.driver_id,
            "seed": cfg.seed,
            "scenario": scenario,
            "controller": cfg.controller,
        },
        gap_controller=cfg.gap_controller,
        controller_args=dict(cfg.controller_args),
        adaptation_method=cfg.adaptation_method,
        adaptation_args=dict(cfg.adaptation_args),
    )
    # adapted tables get a fixed creation time: the drive stays a pure function of its inputs
    return EcuNode(
        ecu_cfg,
        table,
        takeover_sink=takeover_sink,
        utc_now=lambda: FIXED_UTC,
        manual_sink=manual_sink,
    )


def _lockstep(
    node: SimNode,
    rt: EcuRuntime,
    ecu: EcuNode,
    world: World,
    events: list[AdaptationEvent],
    after: Callable[[float], None] | None = None,
) -> None:
    """Step the simulator and then the ECU to the same instant until the world is done; the
    adaptation decisions appended to ``events``, each traced when its takeover ends (what an
    interrupted drive traced is kept). ``after(t_s)`` after each tick (a live view's world
    feed, a pacer)."""
    step = node.step
    advance = rt.advance_to
    last = ecu.last_decision
    while not world.done:
        now = node.t_s
        step()
        advance(now)
        if ecu.last_decision is not last:  # a takeover ended: trace its decision
            last = ecu.last_decision
            if last is not None:
                events.append(AdaptationEvent(now, last, ecu.table))
        if after is not None:
            after(world.t_s)


def log_to_trip(result: DriveResult, driver: DriverParams) -> Trip:
    """The drive's log as an ACC trip at 10 Hz (sim_bus.trip), with the drive's figures."""
    metrics = {k: (v if math.isfinite(v) else None) for k, v in result.metrics.as_dict().items()}
    meta: dict[str, Any] = {
        "scenario": result.config.scenario,
        "seed": result.config.seed,
        "controller": result.config.controller,
        "faults": result.config.faults,
        "collision": result.collision,
        "metrics": metrics,
        "takeovers": result.takeovers,
        "adaptations": result.adaptations,
        "source": "pacc.study.drive",
        "start_utc": result.start_utc,
    }
    pedals = PedalScale.from_codec(drive_codec(result.config))
    return world_trip(result.log, driver, pedals, meta)


def adaptation_params(mode: str | None) -> AdaptationParams | None:
    """The adaptation parameters of ``--adaptation-mode`` (None: the ECU's defaults)."""
    if mode is None:
        return None
    return AdaptationParams(mode=mode)  # type: ignore[arg-type]
