"""The control law's road rules: target switch, brief lead loss, standstill."""

from __future__ import annotations

import math

from dbc.vocab.dgpt import predefined
from ecu.adaptation import AdaptationParams, Reason, TakeoverSummary, adapt
from ecu.controller import RoadParams, stopping_limit_mps2
from ecu.cycle.road import RoadMemory, road_limit, road_update

P = RoadParams()
DT = 0.02


def _run(mem: RoadMemory, n: int, **kw: float | bool) -> tuple[RoadMemory, list[bool]]:
    args = {
        "lead_valid": True,
        "gap_m": 30.0,
        "rel_speed_mps": 0.0,
        "v_mps": 20.0,
        "dt_s": DT,
        "active": True,
        "resume": False,
    }
    args.update(kw)
    out = []
    for _ in range(n):
        mem, switched = road_update(P, mem, **args)  # type: ignore[arg-type]
        out.append(switched)
    return mem, out


def test_a_gap_jump_is_a_target_switch_and_smooth_closing_is_not() -> None:
    mem, sw = _run(RoadMemory(), 50, gap_m=30.0, rel_speed_mps=-2.0)
    assert not any(sw)  # the first lead and a steady gap: no switch
    mem, sw = _run(mem, 1, gap_m=30.0 - 2.0 * DT)  # closing as the speed says
    assert not any(sw)
    mem, sw = _run(mem, 1, gap_m=15.0)  # a cut-in: 15 m closer at once
    assert sw == [True] and mem.since_switch_s == 0.0
    mem, sw = _run(mem, 10, gap_m=15.0)
    assert not any(sw) and math.isclose(mem.since_switch_s, 10 * DT)


def test_a_lead_after_a_free_road_is_a_new_target_and_a_brief_drop_is_not() -> None:
    mem, _ = _run(RoadMemory(), 5)
    mem, _ = _run(mem, 10, lead_valid=False)  # 0.2 s dropout
    mem, sw = _run(mem, 1, gap_m=30.0)
    assert sw == [False]
    mem, _ = _run(mem, 100, lead_valid=False)  # 2 s free road
    mem, sw = _run(mem, 1, gap_m=120.0)
    assert sw == [True]


def test_a_brief_lead_loss_does_not_raise_the_request() -> None:
    mem, _ = _run(RoadMemory(), 5)
    mem, _ = _run(mem, 10, lead_valid=False)
    assert road_limit(P, mem, 1.5, -0.4, False) == -0.4  # cruise would ask for +1.5
    mem, _ = _run(mem, 60, lead_valid=False)  # lost for 1.4 s: a free road
    assert road_limit(P, mem, 1.5, -0.4, False) == 1.5


def test_standstill_holds_until_the_lead_departs_soon_or_the_driver_resumes() -> None:
    stand = {"v_mps": 0.0, "gap_m": 5.0}
    mem, _ = _run(RoadMemory(), 50, **stand)  # 1 s standing behind a stopped lead
    assert road_limit(P, mem, 0.8, -1.0, True) == P.hold_accel_mps2
    early, _ = _run(mem, 1, rel_speed_mps=1.0, **stand)  # departs within 3 s: go on its own
    assert early.go and road_limit(P, early, 0.8, -1.0, True) == 0.8
    mem, _ = _run(mem, 200, **stand)  # 5 s standing
    late, _ = _run(mem, 5, rel_speed_mps=1.0, **stand)  # departs later: still held
    assert not late.go and road_limit(P, late, 0.8, -1.0, True) == P.hold_accel_mps2
    go, _ = _run(late, 1, rel_speed_mps=1.0, resume=True, **stand)  # the driver's RESUME
    assert go.go and road_limit(P, go, 0.8, -1.0, True) == 0.8
    moving, _ = _run(go, 1, v_mps=1.0)
    assert moving.standstill_s < 0 and not moving.go


def test_stopping_limit_stops_behind_where_a_braking_lead_rests() -> None:
    # ego 10 m/s, 10 m behind a lead at 4 m/s braking at 2 m/s^2 (rests 4 m further on):
    # stop 4 m behind it -> 10 m of room -> 5 m/s^2
    assert math.isclose(stopping_limit_mps2(10.0, 10.0, 4.0, -2.0, 4.0), -5.0)
    assert stopping_limit_mps2(10.0, 10.0, 4.0, 0.5, 4.0) == math.inf  # not braking


def test_a_takeover_right_after_a_target_switch_is_not_learned() -> None:
    table = predefined(1.5)
    summary = TakeoverSummary(3.0, 20.0, 20.0, 25.0, pedal="brake", after_switch_s=2.0)
    new, decision = adapt(table, summary, AdaptationParams())
    assert decision.reason is Reason.TARGET_SWITCH and new is table
    later = TakeoverSummary(3.0, 20.0, 20.0, 40.0, pedal="brake", after_switch_s=8.0)
    _, decision = adapt(table, later, AdaptationParams())
    assert decision.reason is Reason.APPLIED
