"""Recovery of the simulator's built-in drivers' preferences from their manual drives."""

from __future__ import annotations

import numpy as np
import pytest

from cloud_sync.irl.trainer import learn_dgpt
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.lead.scenarios import canonical_profiles
from sim_bus.manual import manual_trip


@pytest.mark.slow
@pytest.mark.parametrize("name", ["d1", "d4"])
def test_builtin_driver_preference_recovered_within_2_m(name: str) -> None:
    driver = BUILTIN_DRIVERS[name]
    profiles = canonical_profiles(0)
    trips = [manual_trip(driver, profiles[f"manual{i + 1}"], i) for i in range(4)]
    res = learn_dgpt(trips, driver_id=name, seed=0)
    v, cov = res.table.speed_mps, res.covered
    truth = driver.preferred_gap_m(v)
    assert cov.sum() >= 40
    err = float(np.sqrt(np.mean((res.table.gap_m[cov] - truth[cov]) ** 2)))
    assert err <= 2.0
    # d1 (1.2 s) and d4 (1.2..2.7 s) are told apart: the other one's truth is far
    other = BUILTIN_DRIVERS["d4" if name == "d1" else "d1"].preferred_gap_m(v)
    assert float(np.sqrt(np.mean((res.table.gap_m[cov] - other[cov]) ** 2))) > 4.0
