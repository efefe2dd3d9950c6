"""The simulated world around the ACC: lead profile, ego plant and driver, without the bus.

One :meth:`World.advance` is one plant step (10 ms by default). The driver decides at its
own rate (20 Hz), from what it perceived ``reaction_s`` ago. The applied acceleration is
chosen like a powertrain would: the driver's pedals when one is pressed, else the ACC request
while the ACC command is active and fresh, else coasting. The world logs one sample per driver
step (shape (m,) arrays, see :class:`WorldLog`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from sim_bus.behaviour import COAST_MPS2, DriverAgent
from sim_bus.drivers import DriverParams
from sim_bus.errors import DriveError
from sim_bus.metrics import DriveMetrics, drive_metrics
from sim_bus.plant import Plant, PlantConfig, PlantState
from sim_bus.scenarios import LeadProfile

_COLUMNS = (
    "t_s",
    "v_mps",
    "gap_m",
    "v_lead_mps",
    "a_mps2",
    "accel_pressed",
    "brake_pressed",
    "acc_state",
    "pref_gap_m",
    "a_request_mps2",
    "request_active",
    "accel_pct",
    "brake_bar",
)


#: the logged columns but time (the /sim/world channel of a bus recording)
WORLD_COLUMNS: tuple[str, ...] = _COLUMNS[1:]


@dataclass(frozen=True)
class WorldConfig:
    """Simulation settings: plant (its ``dt_s`` is the tick), driver rate, engagement time."""

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
    """The driver as the world and the bus node see it (a :class:`DriverAgent`, or a person's
    pedals from ``sim_bus.hil``): :meth:`step` once per driver step, then its outputs.

    Outputs: ``a_cmd_mps2`` (m/s², applied while a pedal is pressed), ``accel_pressed``,
    ``brake_pressed``, ``accel_pct`` (%), ``brake_bar`` (bar), ``set_button``,
    ``resume_button``, ``pref_gap_m`` (m, NaN when unknown).
    """

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

    def metrics(self) -> DriveMetrics:
        """The drive's figures (PoI, NIM, safety; sim_bus.metrics) from these samples."""
        return drive_metrics(
            self.t_s,
            self.v_mps,
            self.gap_m,
            self.v_lead_mps,
            self.a_mps2,
            self.acc_state,
            self.accel_pressed,
            self.brake_pressed,
            self.pref_gap_m,
        )


class World:
    """Lead + plant + driver, advanced one tick at a time (pure function of its seed >= 0)."""

    def __init__(
        self,
        driver: DriverParams,
        profile: LeadProfile,
        seed: int,
        cfg: WorldConfig | None = None,
        acc_mode: bool = True,
        pedals: PedalSource | None = None,
    ) -> None:
        """``pedals``: an external driver (a person, ``sim_bus.hil``) instead of the synthetic
        :class:`DriverAgent` of ``driver``; the world then draws no driver noise from it."""
        if not seed >= 0:
            raise DriveError(f"a seed is an integer >= 0, got {seed}")
        self.cfg = cfg = cfg or WorldConfig()
        self.driver = driver
        self.profile = profile
        ss = np.random.SeedSequence([seed, 0x776F726C64])
        rng_plant, rng_driver = (np.random.default_rng(s) for s in ss.spawn(2))
        v_lead, a_lead = profile.resample(cfg.plant.dt_s)
        self._v_lead = v_lead.tolist()
        self._a_lead = a_lead.tolist()
        self.n_ticks = len(self._v_lead) - 1
        v0 = self._v_lead[0]
        gap0 = float(driver.preferred_gap_m(v0)) * cfg.initial_gap_factor
        self.plant = Plant(cfg.plant, PlantState(v0, 0.0, gap0), rng_plant)
        self.agent: PedalSource = pedals or DriverAgent(
            driver, rng_driver, dt_s=cfg.driver_dt_s, acc_mode=acc_mode, engage_s=cfg.engage_s
        )
        self._every = int(round(cfg.driver_dt_s / cfg.plant.dt_s))
        self.tick = 0
        self.t_s = 0.0
        self.v_lead_mps = v0
        self.a_lead_mps2 = self._a_lead[0]
        self.applied_mps2 = 0.0
        m = self.n_ticks // self._every + 1
        self._log = np.zeros((len(_COLUMNS), m))
        self._k = 0

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
            if self._k < self._log.shape[1]:
                self._log[:, self._k] = (
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
                self._k += 1
        if agent.accel_pressed or agent.brake_pressed:
            a = agent.a_cmd_mps2
        elif request_active:
            a = a_request_mps2
        else:
            a = COAST_MPS2
        self.applied_mps2 = a
        car.advance(a, self.v_lead_mps, self.a_lead_mps2)
        self.tick += 1
        self.t_s = self.tick * self.cfg.plant.dt_s
        i = min(self.tick, self.n_ticks)
        self.v_lead_mps = self._v_lead[i]
        self.a_lead_mps2 = self._a_lead[i]

    def log(self) -> WorldLog:
        """The samples logged so far."""
        cols = self._log[:, : self._k]
        d = {name: cols[j].copy() for j, name in enumerate(_COLUMNS)}
        for name in ("accel_pressed", "brake_pressed", "request_active"):
            d[name] = d[name].astype(bool)
        d["acc_state"] = d["acc_state"].astype(np.int64)
        return WorldLog(**d)
