"""Manual (ACC-off) demonstrations: the synthetic driver by hand, as the cloud sees it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from dbc.codec import load_codec
from dbc.vocab.acc_state import AccState
from dbc.vocab.pedals import PedalScale
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import read_trip, write_trip
from sim_bus.behaviour import BRAKE_BAR_PER_MPS2
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.idm import DECEL_LIMIT_MPS2
from sim_bus.lead.profile import LeadProfile
from sim_bus.lead.scenarios import canonical_profiles, shorten
from sim_bus.manual import manual_trip


@pytest.fixture(scope="module")
def profiles() -> dict[str, LeadProfile]:
    return canonical_profiles(0)


@pytest.mark.parametrize("driver_id", sorted(BUILTIN_DRIVERS))
def test_manual_trip_follows_own_preference(
    driver_id: str, profiles: dict[str, LeadProfile]
) -> None:
    d = BUILTIN_DRIVERS[driver_id]
    trip = manual_trip(d, profiles["manual3"], seed=1)
    assert isinstance(trip, Trip)
    assert trip.meta["mode"] == "manual" and trip.meta["driver_id"] == driver_id
    assert trip.meta["condition"] == "default" and trip.meta["condition_factor"] == 1.0
    assert not trip.meta["collision"]
    assert len(trip.t_s) == 3001 and np.allclose(np.diff(trip.t_s), 0.1)
    assert np.all(trip.acc_state == AccState.OFF)
    assert np.all((trip.accel_pedal >= 0) & (trip.accel_pedal <= 1))
    assert np.all((trip.brake_pedal >= 0) & (trip.brake_pedal <= 1))
    rel = (trip.gap_m - d.preferred_gap_m(trip.v_mps)) / d.preferred_gap_m(trip.v_mps)
    limit = 0.2 if d.condition_drift_per_min > 0 else 0.08
    assert abs(float(np.median(rel))) < limit
    assert trip.gap_m.min() > 2.0


def test_manual_trip_is_deterministic(profiles: dict[str, LeadProfile]) -> None:
    p = shorten(profiles["B"], 60.0)
    a = manual_trip(BUILTIN_DRIVERS["d5"], p, seed=3)
    b = manual_trip(BUILTIN_DRIVERS["d5"], p, seed=3)
    c = manual_trip(BUILTIN_DRIVERS["d5"], p, seed=4)
    assert np.array_equal(a.gap_m, b.gap_m) and np.array_equal(a.v_mps, b.v_mps)
    assert not np.array_equal(a.gap_m, c.gap_m)


def test_two_drivers_of_one_seed_do_not_share_their_noise(
    profiles: dict[str, LeadProfile],
) -> None:
    """The world's random streams follow the driver too: a twin under another id, on the same
    road and seed, drives with other control noise (no factor shared by a seed's drivers)."""
    p = shorten(profiles["B"], 60.0)
    d5 = BUILTIN_DRIVERS["d5"]
    twin = dataclasses.replace(d5, driver_id="d5-twin")
    a, b = manual_trip(d5, p, seed=3), manual_trip(twin, p, seed=3)
    assert not np.array_equal(a.gap_m, b.gap_m)
    assert np.array_equal(manual_trip(twin, p, seed=3).gap_m, b.gap_m)


def test_manual_trip_round_trips_through_mcap(
    tmp_path: Path, profiles: dict[str, LeadProfile]
) -> None:
    trip = manual_trip(BUILTIN_DRIVERS["d2"], shorten(profiles["manual1"], 30.0), seed=0)
    path = tmp_path / "m.mcap"
    write_trip(path, trip)
    back = read_trip(path)
    assert np.allclose(back.gap_m, trip.gap_m) and back.meta["mode"] == "manual"


def test_condition_mean_records_the_drift(profiles: dict[str, LeadProfile]) -> None:
    """A drifting driver's trip records the mean condition factor it kept; others keep 1."""
    p = shorten(profiles["manual2"], 120.0)
    steady = manual_trip(BUILTIN_DRIVERS["d2"], p, seed=2)
    drifting = manual_trip(BUILTIN_DRIVERS["d5"], p, seed=2)
    assert steady.meta["condition_mean"] == 1.0
    c = drifting.meta["condition_mean"]
    assert c != 1.0 and np.exp(-0.3) <= c <= np.exp(0.4)  # the drift's clip in log space
    # the realised preference explains the drifting driver's gaps better than the nominal one
    d5 = BUILTIN_DRIVERS["d5"]
    moving = drifting.v_mps > 5.0
    nominal = np.abs(drifting.gap_m - d5.preferred_gap_m(drifting.v_mps))[moving].mean()
    realised = np.abs(drifting.gap_m - d5.preferred_gap_m(drifting.v_mps, c))[moving].mean()
    assert realised < nominal


def test_manual_pedals_are_the_drivers_on_the_network_scale(
    profiles: dict[str, LeadProfile],
) -> None:
    """By hand the driver presses the same pedals as under ACC (sim_bus.behaviour): the trip
    holds them as fractions of the DBC's full scale, as the ECU's and the drive's logs do."""
    trip = manual_trip(BUILTIN_DRIVERS["d1"], shorten(profiles["manual3"], 120.0), seed=1)
    pedals = PedalScale.from_codec(load_codec())
    accel = trip.accel_pedal[trip.accel_pedal > 0]
    brake = trip.brake_pedal[trip.brake_pedal > 0]
    assert accel.size and brake.size
    assert not np.any((trip.accel_pedal > 0) & (trip.brake_pedal > 0))  # one foot
    # the least press is 1 % / 1 bar; the hardest brake asks DECEL_LIMIT_MPS2
    assert accel.min() >= pedals.accel(1.0) and brake.min() >= pedals.brake(1.0)
    assert brake.max() <= pedals.brake(DECEL_LIMIT_MPS2 * BRAKE_BAR_PER_MPS2)


def test_manual_trip_condition_follows_the_condition_factor(
    profiles: dict[str, LeadProfile],
) -> None:
    wet = dataclasses.replace(BUILTIN_DRIVERS["d2"], condition_factor=1.2)
    trip = manual_trip(wet, shorten(profiles["manual1"], 10.0), seed=0)
    assert trip.meta["condition"] == "factor-1.2" and trip.meta["condition_factor"] == 1.2
    named = manual_trip(wet, shorten(profiles["manual1"], 10.0), seed=0, condition="rain")
    assert named.meta["condition"] == "rain"
