"""Manual (ACC-off) demonstrations and their calibration against the real human pairs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ecu.triplog import Trip, read_trip, write_trip
from sim_bus.calibration import headway_by_band
from sim_bus.dataset import load_human_pairs
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.manual import manual_trip
from sim_bus.scenarios import LeadProfile, canonical_profiles, shorten


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
    assert not trip.meta["collision"]
    assert len(trip.t_s) == 3001 and np.allclose(np.diff(trip.t_s), 0.1)
    assert np.all(trip.acc_state == 0)
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


def test_manual_trip_round_trips_through_mcap(
    tmp_path: Path, profiles: dict[str, LeadProfile]
) -> None:
    trip = manual_trip(BUILTIN_DRIVERS["d2"], shorten(profiles["manual1"], 30.0), seed=0)
    path = tmp_path / "m.mcap"
    write_trip(path, trip)
    back = read_trip(path)
    assert np.allclose(back.gap_m, trip.gap_m) and back.meta["mode"] == "manual"


def _headway_by_band(v: np.ndarray, gap: np.ndarray, v_lead: np.ndarray) -> list[float]:
    """The median steady time gaps of the bands with enough data (sim_bus.calibration)."""
    return [x for x in headway_by_band(v, gap, v_lead) if x is not None]


def test_headway_by_band_hand_counted() -> None:
    v = np.concatenate([np.full(100, 12.0), np.full(99, 17.0), np.full(150, 22.0)])
    gap = np.concatenate([np.full(100, 24.0), np.full(99, 34.0), np.full(150, 44.0)])
    v_lead = v.copy()
    v_lead[200:] += 1.0  # not steady: |v_lead - v| >= 0.5
    v_lead[200:260] = v[200:260]  # 60 steady samples: fewer than MIN_SAMPLES
    assert headway_by_band(v, gap, v_lead) == [2.0, None, None, None]  # 99 < 100 samples too
    v_lead[200:300] = v[200:300]
    assert headway_by_band(v, gap, v_lead) == [2.0, None, 2.0, None]


def test_calibration_against_real_human_pairs() -> None:
    """Our drivers, following the real leaders by hand, keep human-like headways.

    Real pairs: median time gaps 1.4-3.4 s per 5 m/s band. Every built-in driver's band
    medians must lie within the range the real followers span (widened by 0.2 s), and the
    drivers together must span most of it.
    """
    pairs = load_human_pairs()
    real: list[float] = []
    for p in pairs:
        real += _headway_by_band(p.v_follower_mps, p.gap_m, p.v_leader_mps)
    lo, hi = min(real), max(real)
    ours: list[float] = []
    for d in BUILTIN_DRIVERS.values():
        for p in pairs[:2] + pairs[4:5]:
            n = len(p.v_leader_mps)
            prof = LeadProfile(p.pair_id, np.arange(n) * 0.1, p.v_leader_mps)
            trip = manual_trip(d, shorten(prof, 600.0), seed=0)
            ours += _headway_by_band(trip.v_mps, trip.gap_m, trip.v_lead_mps)
    assert lo - 0.2 <= min(ours) and max(ours) <= hi + 0.2
    assert max(ours) - min(ours) > 0.6 * (hi - lo)


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
