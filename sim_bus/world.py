"""The simulated world around the ACC: lead profile, ego plant and driver, without the bus.

One :meth:`World.advance` is one plant step (10 ms). The lead drives the profile until a road
scenario's event (:mod:`sim_bus.lead.events`) switches the tracked vehicle (free road: the gap
is ``FREE_GAP_M``); then it holds its speed and rejoins the flow. The driver decides at 20 Hz;
the applied acceleration is the pressed pedal's, else the fresh active ACC request, else
coasting. One logged sample per driver step (:class:`WorldLog`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Protocol

import numpy as np

from sim_bus.behaviour import COAST_MPS2, DriverAgent
from sim_bus.drivers import DriverParams, random_streams
from sim_bus.errors import DriveError
from sim_bus.lead.events import cut_in_gap_m, reveal_gap_m
from sim_bus.lead.profile import LeadEvent, LeadProfile
from sim_bus.metrics import (
    NO_LEAD_GAP_M,
    DriveMetrics,
    SafetyFigures,
    acc_on_mask,
    inherited_mask,
    poi_nim,
    pressed_episodes,
    rms_jerk,
    ttc_s,
)
from sim_bus.plant import Plant, PlantConfig, PlantState

#: the gap while no vehicle is in sight (free road), m: beyond any radar's range
FREE_GAP_M = 1000.0
#: how a lead that left its profile rejoins the flow: lag (s), acceleration bounds (m/s²)
REJOIN_TAU_S = 2.0
REJOIN_ACCEL_MPS2 = (-3.0, 1.5)


@dataclass(frozen=True)
class WorldLog:
    """The logged samples of a drive; each attribute an array of shape (m,)."""

    t_s: np.ndarray
    v_mps: np.ndarray
    gap_m: np.ndarray
    v_lead_mps: np.ndarray
    a_mps2: np.ndarray
    accel_pressed: np.ndarray
    brake_pressed: np.ndarray
    acc_state: np.ndarray
    pref_gap_m: np.ndarray
    a_request_mps2: np.ndarray
    request_active: np.ndarray
    accel_pct: np.ndarray
    brake_bar: np.ndarray

    def safety(self, threshold_s: float = 2.0, cut_in_t_s: Sequence[float] = ()) -> SafetyFigures:
        """Min TTC (s), min gap (m) and time (s) below ``threshold_s`` of TTC, whole and
        without the driver's accelerator presses or the cut-ins at ``cut_in_t_s`` (s)."""
        t = np.asarray(self.t_s, dtype=np.float64)
        dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
        gap = np.asarray(self.gap_m, dtype=np.float64)
        ttc = ttc_s(gap, self.v_mps, self.v_lead_mps)
        below = ttc < threshold_s
        press = pressed_episodes(below, np.asarray(self.accel_pressed, dtype=bool))
        cut = inherited_mask(ttc, t, cut_in_t_s, threshold_s) & ~press
        own = ~press & ~cut
        return SafetyFigures(
            min_ttc_s=float(ttc.min()) if len(ttc) else math.inf,
            min_gap_m=float(gap.min()) if len(gap) else math.nan,
            below_s=float(below.sum()) * dt,
            min_ttc_own_s=float(ttc[own].min()) if own.any() else math.inf,
            below_own_s=float((below & own).sum()) * dt,
            below_override_s=float((below & press).sum()) * dt,
            below_cut_in_s=float((below & cut).sum()) * dt,
        )

    def metrics(self) -> DriveMetrics:
        """The drive's figures (:mod:`sim_bus.metrics`); the gap error uses ACC-ON samples
        without a pedal pressed and with a lead ahead."""
        gap_m, acc_state = self.gap_m, self.acc_state
        poi, nim, on_s, n_on = poi_nim(self.t_s, acc_state, self.accel_pressed, self.brake_pressed)
        pressed = np.asarray(self.accel_pressed, bool) | np.asarray(self.brake_pressed, bool)
        on = acc_on_mask(acc_state) & ~pressed & (np.asarray(gap_m) < NO_LEAD_GAP_M)
        err = (np.asarray(gap_m) - np.asarray(self.pref_gap_m))[on]
        ttc = ttc_s(gap_m, self.v_mps, self.v_lead_mps)
        return DriveMetrics(
            poi_pct=poi,
            nim_per_min=nim,
            acc_on_s=on_s,
            press_onsets=n_on,
            min_gap_m=float(np.min(gap_m)) if len(gap_m) else math.nan,
            min_ttc_s=float(ttc.min()) if len(ttc) else math.inf,
            rms_jerk_mps3=rms_jerk(self.t_s, self.a_mps2),
            gap_error_mean_m=float(err.mean()) if err.size else math.nan,
            gap_error_rms_m=float(np.sqrt(np.mean(err * err))) if err.size else math.nan,
        )


_COLUMNS = tuple(f.name for f in fields(WorldLog))
#: the logged columns but time (the /sim/world channel of a bus recording)
WORLD_COLUMNS: tuple[str, ...] = _COLUMNS[1:]


@dataclass(frozen=True)
class WorldConfig:
    """Simulation settings: plant (its ``dt_s`` is the tick), driver step s, engagement s."""

    plant: PlantConfig = field(default_factory=PlantConfig)
    driver_dt_s: float = 0.05
    engage_s: float = 1.5
    initial_gap_factor: float = 1.0  # initial gap = factor · driver's preferred gap

    def __post_init__(self) -> None:
        ratio = self.driver_dt_s / self.plant.dt_s
        if not 1 <= ratio < math.inf or abs(ratio - round(ratio)) > 1e-9:
            raise DriveError("driver_dt_s must be a whole multiple of plant.dt_s")
        if not 0 <= self.engage_s < math.inf:
            raise DriveError("engage_s must be finite and >= 0")
        if not 0 < self.initial_gap_factor < math.inf:
            raise DriveError("initial_gap_factor must be finite and > 0")


class PedalSource(Protocol):
    """The driver as the world sees it (a :class:`DriverAgent` or a person, ``pacc.hil``):
    :meth:`step` once per driver step, then its outputs (``a_cmd_mps2`` m/s² while a pedal is
    pressed, ``accel_pct`` %, ``brake_bar`` bar, ``pref_gap_m`` m, NaN when unknown)."""

    a_cmd_mps2: float
    accel_pressed: bool
    brake_pressed: bool
    accel_pct: float
    brake_bar: float
    set_button: bool
    resume_button: bool
    pref_gap_m: float

    def step(self, v_mps: float, v_lead_mps: float, gap_m: float, acc_state: int) -> None:
        """Decide this driver step from the ego speed, lead speed (m/s), gap (m), AccState."""


class World:
    """Lead + plant + driver, advanced one tick at a time (pure function of the seed >= 0 and
    the driver)."""

    def __init__(
        self,
        driver: DriverParams,
        profile: LeadProfile,
        seed: int,
        cfg: WorldConfig | None = None,
        acc_mode: bool = True,
        pedals: PedalSource | None = None,
    ) -> None:
        """``pedals``: a person (``pacc.hil``) instead of ``driver``'s :class:`DriverAgent`."""
        if not seed >= 0:
            raise DriveError(f"a seed is an integer >= 0, got {seed}")
        self.cfg = cfg = cfg or WorldConfig()
        self.driver = driver
        self.profile = profile
        rng_plant, rng_driver = random_streams(seed, driver.driver_id, 0x776F726C64)
        self._v_lead, self._a_lead = (x.tolist() for x in profile.resample(cfg.plant.dt_s))
        self.n_ticks = len(self._v_lead) - 1
        v0 = self._v_lead[0]
        gap0 = float(driver.preferred_gap_m(v0)) * cfg.initial_gap_factor
        self.plant = Plant(cfg.plant, PlantState(v0, 0.0, gap0), rng_plant)
        self.agent: PedalSource = pedals or DriverAgent(
            driver, rng_driver, dt_s=cfg.driver_dt_s, acc_mode=acc_mode, engage_s=cfg.engage_s
        )
        self._every = int(round(cfg.driver_dt_s / cfg.plant.dt_s))
        self.tick, self.t_s = 0, 0.0
        self.v_lead_mps, self.a_lead_mps2 = v0, self._a_lead[0]
        self.applied_mps2 = 0.0
        self._events: list[LeadEvent] = sorted(profile.events, key=lambda e: e.t_s)
        self._lead_mode = "profile"  # profile | track (after an event) | none (free road)
        self._hold_v, self._hold_until = 0.0, 0.0  # the held speed m/s, until s
        #: the radar reports no lead until this time (a new track being confirmed), s
        self.radar_blank_until = -1.0
        #: the events played so far: (time s, kind, new gap m or None when skipped)
        self.events_log: list[tuple[float, str, float | None]] = []
        #: one tuple of the _COLUMNS per driver step, at most ``_log_max``
        self._log_max = self.n_ticks // self._every + 1
        self._log: list[tuple[float | bool | int, ...]] = []
        self._dt_s = cfg.plant.dt_s

    @property
    def done(self) -> bool:
        """True at the end of the profile or after a collision."""
        return self.tick >= self.n_ticks or self.plant.collided

    def advance(self, request_active: bool, a_request_mps2: float, acc_state: int) -> None:
        """One tick: the driver decides (every driver step), then the plant moves."""
        agent = self.agent
        car = self.plant
        if self.tick % self._every == 0:
            agent.step(car.v_mps, self.v_lead_mps, car.gap_m, acc_state)
            if len(self._log) < self._log_max:
                self._log.append(
                    (
                        self.t_s,
                        car.v_mps,
                        car.gap_m,
                        self.v_lead_mps,
                        car.a_mps2,
                        agent.accel_pressed,
                        agent.brake_pressed,
                        acc_state,
                        agent.pref_gap_m,
                        a_request_mps2,
                        request_active,
                        agent.accel_pct,
                        agent.brake_bar,
                    )
                )
        # the pressed pedal's acceleration, else the ACC request's, else coasting
        pedal = agent.accel_pressed or agent.brake_pressed
        a = agent.a_cmd_mps2 if pedal else a_request_mps2 if request_active else COAST_MPS2
        self.applied_mps2 = a
        car.advance(a, self.v_lead_mps, self.a_lead_mps2)
        self.tick = tick = self.tick + 1
        self.t_s = tick * self._dt_s
        i = tick if tick < self.n_ticks else self.n_ticks
        if self._lead_mode == "profile":
            self.v_lead_mps, self.a_lead_mps2 = self._v_lead[i], self._a_lead[i]
        elif self._lead_mode == "track":
            self._track(i)
        else:  # free road: nothing in sight
            car.gap_m = FREE_GAP_M
            self.v_lead_mps, self.a_lead_mps2 = car.v_mps, 0.0
        while self._events and self._events[0].t_s <= self.t_s + 1e-9:
            self._play(self._events.pop(0), i)

    @property
    def lead_present(self) -> bool:
        """A vehicle is in sight ahead (False on a free road)."""
        return self._lead_mode != "none"

    def _track(self, i: int) -> None:
        """The lead after an event: holds its speed, then rejoins the flow (tick ``i``)."""
        dt = self.cfg.plant.dt_s
        target = self._hold_v if self.t_s < self._hold_until else self._v_lead[i]
        lo, hi = REJOIN_ACCEL_MPS2
        a = (target - self.v_lead_mps) / REJOIN_TAU_S  # min(max(a, lo), hi), written out
        a = lo if a < lo else a
        a = hi if a > hi else a
        v = self.v_lead_mps + a * dt
        if v <= 0.0:
            v, a = 0.0, 0.0
        self.v_lead_mps, self.a_lead_mps2 = v, a

    def _play(self, ev: LeadEvent, i: int) -> None:
        """Switch the tracked vehicle as ``ev`` says (skipped when a cutter does not fit)."""
        car = self.plant
        v_ego = car.v_mps
        gap: float | None = None
        if ev.kind == "lead_loss":
            self._lead_mode = "none"
            car.gap_m = FREE_GAP_M
            self.v_lead_mps, self.a_lead_mps2 = v_ego, 0.0
        elif ev.kind == "lead_appear":
            gap = ev.gap_m + ev.gap_thw_s * v_ego
        elif self.lead_present:
            reveal = ev.kind == "cut_out"
            gap = (reveal_gap_m if reveal else cut_in_gap_m)(ev, v_ego, car.gap_m)
        if gap is not None:
            v_new = max(v_ego + ev.v_mps, 0.0) if ev.v_relative else ev.v_mps
            car.gap_m = gap
            self._lead_mode = "track"
            self.v_lead_mps, self.a_lead_mps2 = v_new, 0.0
            self._hold_v, self._hold_until = v_new, self.t_s + ev.hold_s
            self.radar_blank_until = self.t_s + ev.dropout_s
        self.events_log.append((self.t_s, ev.kind, gap))

    def logged_since(self, start: int) -> list[tuple[float | bool | int, ...]]:
        """The samples logged from the ``start``-th on (``t_s``, then :data:`WORLD_COLUMNS`):
        what a live view streams."""
        return self._log[start:]

    def log(self) -> WorldLog:
        """The samples logged so far."""
        # float64 columns: what writing each sample into a float array gives (bools 0/1)
        cols = np.array(self._log, dtype=np.float64).reshape(-1, len(_COLUMNS)).T
        d = {name: cols[j].copy() for j, name in enumerate(_COLUMNS)}
        for name in ("accel_pressed", "brake_pressed", "request_active"):
            d[name] = d[name].astype(bool)
        d["acc_state"] = d["acc_state"].astype(np.int64)
        return WorldLog(**d)
