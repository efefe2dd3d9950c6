"""The protocol's plan and its counterbalancing, and the person's pedals (pure parts)."""

from __future__ import annotations

import itertools
import math

import pytest

from pacc.hil.human import KEY_RISE_PER_S, KEY_TOUCH, HumanPedals, pedal_accel_mps2, ramp
from pacc.hil.plan import CONDITIONS, acc_order, balanced_latin_square, paper_plan
from sim_bus.errors import SimError


@pytest.mark.parametrize("n", [2, 4, 8, 3, 5])
def test_balanced_latin_square(n: int) -> None:
    rows = [balanced_latin_square(n, r) for r in range(n if n % 2 == 0 else 2 * n)]
    for row in rows:
        assert sorted(row) == list(range(n))  # each condition once per participant
    for pos in range(n):  # each condition equally often in every position
        counts = [sum(1 for row in rows if row[pos] == c) for c in range(n)]
        assert len(set(counts)) == 1
    follows = {pair: 0 for pair in itertools.permutations(range(n), 2)}
    for row in rows:
        for a, b in itertools.pairwise(row):
            follows[(a, b)] += 1
    assert len(set(follows.values())) == 1  # carry-over balanced
    assert balanced_latin_square(n, len(rows)) == rows[0]


def test_paper_plan_is_blind_and_counterbalanced() -> None:
    plan = paper_plan("P01")
    ids = [s.id for s in plan]
    assert ids[:6] == ["consent", "practice", "manual1", "manual2", "manual3", "manual4"]
    assert ids[6] == "learn" and ids[-1] == "done" and len(set(ids)) == len(ids)
    acc = [s for s in plan if s.kind == "drive" and not s.practice and s.controller]
    assert sorted((s.controller, s.scenario) for s in acc) == sorted(CONDITIONS)
    for step in plan:
        assert not any(w in step.label.lower() for w in ("irl", "predefined", "oa"))
    firsts = {acc_order(f"P{k:02d}")[0] for k in range(1, 9)}
    assert len(firsts) == 8  # eight participants: every condition comes first once
    assert acc_order("P09") == acc_order("P01")
    with pytest.raises(SimError):
        acc_order("anon")
    inc = paper_plan("P01", incremental=3)
    assert [s.id for s in inc[-4:]] == ["inc1-B", "inc2-B", "inc3-B", "done"]
    assert inc[-2].label == "Drive 11 of 11" and inc[-2].controller == "irl+oa"


def test_key_ramp_and_pedal_mapping() -> None:
    assert ramp(0.0, True, 0.01) == pytest.approx(KEY_TOUCH + KEY_RISE_PER_S * 0.01)
    assert ramp(0.5, True, 0.01) == pytest.approx(0.5 + KEY_RISE_PER_S * 0.01)
    position = 0.0
    for _ in range(100):  # a 1-s hold is not full throttle: a gentle foot
        position = ramp(position, True, 0.01)
    assert 0.3 < position < 0.6
    assert ramp(1.0, True, 0.01) == 1.0 and ramp(0.01, False, 0.01) == 0.0
    assert pedal_accel_mps2(0.0, 0.0) < 0.0 < pedal_accel_mps2(0.2, 0.0)
    assert pedal_accel_mps2(1.0, 0.5) == pytest.approx(-4.0)  # the brake wins


def test_human_pedals_keys_axes_buttons() -> None:
    h = HumanPedals(gap_setting=2)
    h.keys(True, False)
    h.tick(0.01)
    assert h.accel_pressed and not h.brake_pressed and h.accel_pct > 0.0  # within one tick
    for _ in range(300):
        h.tick(0.01)
    assert h.accel == 1.0
    h.axes(math.nan, 0.5)
    h.tick(0.01)
    assert h.accel == 0.0 and h.brake_pressed and h.brake_bar == pytest.approx(48.0)
    h.press("set")
    h.press("gap")
    h.press("main")
    h.tick(0.01)
    assert h.set_button and h.gap_setting == 3 and h.hmi_buttons["main_switch"] == 0
    for _ in range(40):
        h.tick(0.01)
    assert not h.set_button  # a momentary press, held 0.3 s
    locked = HumanPedals(main_on=True, locked=True)
    locked.press("set")
    locked.tick(0.01)
    assert not locked.set_button and locked.hmi_buttons["main_switch"] == 0
