"""The trip log of a simulator run: the world's samples as a :class:`dbc.vocab.triplog.Trip`
at 10 Hz, pedals as fractions (:class:`dbc.vocab.pedals.PedalScale`), the condition named from
the driver's condition factor (the cloud never files a rain drive as a dry one).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from dbc.vocab.pedals import PedalScale
from dbc.vocab.triplog import Trip
from dbc.vocab.tripmode import TripMode
from sim_bus.drivers import DriverParams
from sim_bus.errors import DriveError
from sim_bus.world import WorldLog

#: sample period of a trip log, s
TRIP_DT_S = 0.1


def condition_name(condition_factor: float) -> str:
    """The trip's condition: ``"default"`` for the factor 1, else ``"factor-<f>"``."""
    return "default" if condition_factor == 1.0 else f"factor-{condition_factor:g}"


def world_trip(
    log: WorldLog, driver: DriverParams, pedals: PedalScale, meta: Mapping[str, Any]
) -> Trip:
    """The ACC trip of a run (``log``: (m,) arrays), decimated to :data:`TRIP_DT_S`;
    ``meta`` adds scenario, seed … but may not override driver, condition or mode."""
    every = max(1, round(TRIP_DT_S / float(np.median(np.diff(log.t_s))))) if len(log.t_s) > 1 else 1
    sl = slice(None, None, every)
    accel = np.vectorize(pedals.accel, otypes=[np.float64])
    brake = np.vectorize(pedals.brake, otypes=[np.float64])
    own = {
        "driver_id": driver.driver_id,
        "condition": condition_name(driver.condition_factor),
        "condition_factor": driver.condition_factor,
        "mode": TripMode.ACC.value,
    }
    clash = sorted(set(own) & set(meta))
    if clash:
        raise DriveError(f"world_trip: meta may not set {clash}")
    kept = ("t_s", "v_mps", "gap_m", "v_lead_mps", "a_mps2", "acc_state")
    return Trip(
        **{k: getattr(log, k)[sl] for k in kept},
        accel_pedal=accel(log.accel_pct[sl]),
        brake_pedal=brake(log.brake_bar[sl]),
        meta={**own, **meta},
    )
