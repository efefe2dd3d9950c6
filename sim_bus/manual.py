"""ACC-off demonstrations: a synthetic driver follows a lead profile by hand (no bus).

These trips are what the cloud's IRL learns from. Pure physics and the driver's IDM+
(sim_bus.behaviour), at 20 Hz, logged at 10 Hz; a pure function of (driver, profile, seed,
plant configuration). The pedals are the ones the driver presses (``accel_pct``,
``brake_bar`` of :class:`~sim_bus.behaviour.DriverAgent`) as fractions of the network's full
scale, exactly as in an ACC drive's trip (sim_bus.trip) and the ECU's takeover logs.
"""

from __future__ import annotations

import numpy as np

from dbc.codec import load_codec
from dbc.vocab.acc_state import AccState
from dbc.vocab.pedals import PedalScale
from dbc.vocab.triplog import FLOAT_FIELDS, Trip
from dbc.vocab.tripmode import TripMode
from sim_bus.behaviour import DriverAgent
from sim_bus.drivers import DriverParams, random_streams
from sim_bus.errors import DriveError
from sim_bus.lead.profile import LeadProfile
from sim_bus.plant import Plant, PlantConfig, PlantState
from sim_bus.trip import condition_name

MANUAL_DT_S = 0.05
LOG_EVERY = 2  # 20 Hz steps -> 10 Hz samples


def manual_trip(
    driver: DriverParams,
    profile: LeadProfile,
    seed: int,
    plant: PlantConfig | None = None,
    condition: str | None = None,
) -> Trip:
    """Drive ``profile`` by hand with ``driver`` from the lead's speed at the preferred gap:
    a Trip (10 Hz, mode manual), ended by a collision (``meta["collision"]``); ``condition``
    default: named from the driver's condition factor (sim_bus.trip)."""
    if not seed >= 0:
        raise DriveError(f"a seed is an integer >= 0, got {seed}")
    cfg = plant or PlantConfig(dt_s=MANUAL_DT_S)
    if abs(cfg.dt_s - MANUAL_DT_S) > 1e-12:
        raise DriveError(f"manual trips run at dt_s = {MANUAL_DT_S}")
    rng_plant, rng_driver = random_streams(seed, driver.driver_id, 0x6D616E)
    v_lead, a_lead = profile.resample(MANUAL_DT_S)
    v0 = float(v_lead[0])
    gap0 = float(driver.preferred_gap_m(v0))
    car = Plant(cfg, PlantState(v0, 0.0, gap0), rng_plant)
    pedals = PedalScale.from_codec(load_codec())
    agent = DriverAgent(driver, rng_driver, dt_s=MANUAL_DT_S, acc_mode=False, pedals=pedals)
    n = len(v_lead)
    m = (n + LOG_EVERY - 1) // LOG_EVERY
    cols = np.zeros((7, m))
    k = 0
    condition_sum = 0.0  # the drifting condition factor, summed over the logged samples
    for i in range(n):
        vl = float(v_lead[i])
        if i % LOG_EVERY == 0:
            condition_sum += agent.condition
            cols[:, k] = (
                i * MANUAL_DT_S,
                car.v_mps,
                car.gap_m,
                vl,
                car.a_mps2,
                pedals.accel(agent.accel_pct),
                pedals.brake(agent.brake_bar),
            )
            k += 1
        if car.collided:
            break
        agent.step(car.v_mps, vl, car.gap_m, AccState.OFF)
        car.advance(agent.a_cmd_mps2, vl, float(a_lead[i]))
    cols = cols[:, :k]
    meta = {
        "driver_id": driver.driver_id,
        "condition": condition
        if condition is not None
        else condition_name(driver.condition_factor),
        "condition_factor": driver.condition_factor,
        "mode": TripMode.MANUAL.value,
        "scenario": profile.name,
        "seed": int(seed),
        "collision": bool(car.collided),
        "collision_t_s": car.collision_t_s,
        "source": "sim_bus.manual",
        # mean of the driver's drifting condition factor over the trip (1.0 without drift):
        # the preference it actually kept is preferred_gap_m(v, condition_mean), roughly
        "condition_mean": condition_sum / k if k else 1.0,
    }
    floats = dict(zip(FLOAT_FIELDS, cols, strict=True))  # the rows of cols, in the Trip's order
    return Trip(**floats, acc_state=np.full(k, AccState.OFF, dtype=np.int64), meta=meta)
