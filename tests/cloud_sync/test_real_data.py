"""Learning from real human car following (the OpenACC pairs shipped with sim_bus)."""

from __future__ import annotations

import numpy as np
import pytest

from cloud_sync.irl.trainer import learn_dgpt
from dbc.vocab.triplog import Trip
from sim_bus.dataset import load_human_pairs


def pair_trip(pair_id_part: str) -> Trip:
    """The shipped pair whose id contains ``pair_id_part``, as a manual trip."""
    (p,) = [p for p in load_human_pairs() if pair_id_part in p.pair_id]
    n = p.v_follower_mps.size
    t = np.arange(n) * p.dt_s
    a = np.gradient(p.v_follower_mps, t)
    return Trip.manual(t, p.v_follower_mps, p.gap_m, p.v_leader_mps, a, {"source": p.pair_id})


@pytest.mark.slow
def test_close_human_follower_agrees_with_its_steady_state_gaps() -> None:
    """platoon 3, follower 5: IRL and the empirical steady-state gaps agree (~1.8 m)."""
    trip = pair_trip("platoon3_f5")
    res = learn_dgpt([trip], driver_id="h35", seed=0)
    assert res.baseline is not None
    both = res.covered & np.asarray(res.baseline.meta["covered"], dtype=bool)
    v = res.table.speed_mps
    assert both.sum() >= 15 and v[both].min() < 16.0 and v[both].max() > 24.0
    err = np.sqrt(np.mean((res.table.gap_m[both] - res.baseline.gap_m[both]) ** 2))
    assert err <= 3.0
    headway = (res.table.gap_m[both] / v[both]).mean()
    assert 1.2 <= headway <= 2.0
    assert res.table.meta["usable_demo_s"] > 1000
