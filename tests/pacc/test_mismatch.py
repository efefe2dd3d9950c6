"""The ACC-vs-manual offset, the trip shift and the conditions of a driver."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dbc.vocab.acc_state import AccState
from sim_bus.behaviour import DriverAgent
from sim_bus.drivers import BUILTIN_DRIVERS, CONDITION_FACTORS, DriverParams
from sim_bus.errors import DriverError


def test_the_acc_preference_adds_the_offset_as_a_time_gap() -> None:
    d = dataclasses.replace(BUILTIN_DRIVERS["d2"], acc_offset_s=0.5, acc_preference_factor=1.0)
    v = np.array([10.0, 20.0])
    assert np.allclose(d.acc_preferred_gap_m(v) - d.preferred_gap_m(v), 0.5 * v)
    with pytest.raises(DriverError):
        dataclasses.replace(d, acc_offset_s=-1.5)  # 1.6 s - 1.5 s < 0.3 s
    assert CONDITION_FACTORS["wet"] > 1.0 and CONDITION_FACTORS["night"] > 1.0


def _pref(p: DriverParams, seed: int, engaged: bool) -> float:
    a = DriverAgent(p, np.random.default_rng(seed), dt_s=0.05)
    a.step(20.0, 20.0, p.preferred_gap_m(20.0).item(), AccState.ACTIVE if engaged else AccState.OFF)
    return a.pref_gap_m


def test_a_trip_shift_moves_the_preference_from_trip_to_trip() -> None:
    still = dataclasses.replace(BUILTIN_DRIVERS["d2"], acc_preference_factor=1.0)
    shifting = dataclasses.replace(still, trip_shift_sd_s=0.2)
    assert len({round(_pref(still, s, False), 6) for s in range(5)}) == 1
    prefs = [_pref(shifting, s, False) for s in range(20)]
    assert 0.5 < np.std(prefs) / 20.0 / 0.2 < 1.6  # sd of the shift, in time gap
