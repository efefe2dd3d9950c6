"""The trip log of a simulator run: one writer for drive, sim and study; the ECU's pedal scale."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dbc.codec import load_codec
from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import Dgpt, SafetyBounds, clamp_to_bounds, speed_axis
from dbc.vocab.pedals import PedalScale
from dbc.vocab.triplog import Trip
from pacc.study.drive import DriveConfig, log_to_trip, run_drive
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.errors import DriveError
from sim_bus.lead.scenarios import canonical_profiles, shorten
from sim_bus.trip import condition_name, world_trip
from sim_bus.world import WorldLog

PEDALS = PedalScale.from_codec(load_codec())


def _log(n: int, dt_s: float) -> WorldLog:
    t = np.arange(n) * dt_s
    z = np.zeros(n)
    return WorldLog(
        t_s=t,
        v_mps=np.full(n, 20.0),
        gap_m=np.full(n, 30.0),
        v_lead_mps=np.full(n, 20.0),
        a_mps2=z.copy(),
        accel_pressed=np.zeros(n, bool),
        brake_pressed=np.zeros(n, bool),
        acc_state=np.full(n, AccState.ACTIVE, dtype=np.int64),
        pref_gap_m=np.full(n, 30.0),
        a_request_mps2=z.copy(),
        request_active=np.ones(n, bool),
        accel_pct=np.linspace(0.0, 100.0, n),
        brake_bar=np.linspace(0.0, 300.0, n),
    )


def test_world_trip_is_10_hz_with_pedals_on_the_network_scale() -> None:
    log = _log(41, 0.05)  # 2 s at the driver's 20 Hz
    trip = world_trip(log, BUILTIN_DRIVERS["d2"], PEDALS, {"scenario": "B"})
    assert len(trip) == 21 and np.allclose(np.diff(trip.t_s), 0.1)
    assert PEDALS.accel_full_pct == 100.0 and PEDALS.brake_full_bar == 250.0  # the DBC's
    assert np.allclose(trip.accel_pedal, log.accel_pct[::2] / 100.0)
    assert np.allclose(trip.brake_pedal, np.minimum(log.brake_bar[::2] / 250.0, 1.0))
    assert trip.meta == {
        "driver_id": "d2",
        "condition": "default",
        "condition_factor": 1.0,
        "mode": "acc",
        "scenario": "B",
    }
    with pytest.raises(DriveError, match="condition"):
        world_trip(log, BUILTIN_DRIVERS["d2"], PEDALS, {"condition": "dry"})


def test_condition_is_named_from_the_condition_factor() -> None:
    assert condition_name(1.0) == "default"
    assert condition_name(1.2) == "factor-1.2"
    wet = dataclasses.replace(BUILTIN_DRIVERS["d2"], condition_factor=1.25)
    trip = world_trip(_log(3, 0.05), wet, PEDALS, {})
    assert trip.meta["condition"] == "factor-1.25" and trip.meta["condition_factor"] == 1.25


@pytest.mark.slow
def test_the_ecu_and_the_simulator_log_one_brake_value() -> None:
    """The ECU's takeover segments and the simulator's trip of the same drive agree on the
    brake pedal (one scale, from the DBC): before, one divided by 100 and the other by 250."""
    driver = BUILTIN_DRIVERS["d1"]
    segments: list[Trip] = []
    # a table of half the driver's preference: it brakes, again and again
    v = speed_axis()
    table = Dgpt(
        speed_mps=v,
        gap_m=clamp_to_bounds(v, 0.5 * driver.acc_preferred_gap_m(v), SafetyBounds()),
        version=1,
        driver_id="d1",
        condition="dry",
        source="predefined",
        created_utc="2000-01-01T00:00:00Z",
        meta={},
    )
    prof = shorten(canonical_profiles(0)["manual3"], 60.0)
    result = run_drive(
        DriveConfig(scenario="manual3", driver_id="d1", seed=2, duration_s=60.0),
        driver,
        table,
        prof,
        takeover_sink=segments.append,
    )
    trip = log_to_trip(result, driver)
    braked = [s for s in segments if np.nanmax(s.brake_pedal) > 0.05]
    assert len(braked) >= 2
    for seg in braked:
        during = (trip.t_s >= seg.t_s[0]) & (trip.t_s <= seg.t_s[-1])
        ecu_max = float(np.nanmax(seg.brake_pedal))
        sim_max = float(trip.brake_pedal[during].max())
        assert sim_max == pytest.approx(ecu_max, rel=0.05)  # sampled at other instants
