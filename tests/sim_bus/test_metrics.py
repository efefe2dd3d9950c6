"""PoI, NIM, TTC, jerk on hand-built drives."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sim_bus.metrics import (
    acc_on_mask,
    poi_nim,
    pressed_episodes,
    rms_jerk,
    ttc_s,
)
from sim_bus.world import WorldLog


def test_poi_and_nim_hand_counted() -> None:
    t = np.arange(600) * 0.1  # 60 s
    state = np.full(600, 2)
    acc = np.zeros(600, bool)
    brk = np.zeros(600, bool)
    acc[100:130] = True  # 3 s
    brk[300:310] = True  # 1 s
    acc[310:320] = True  # switch pedals: a second onset, 1 s
    poi, nim, on_s, n = poi_nim(t, state, acc, brk)
    assert on_s == pytest.approx(60.0)
    assert poi == pytest.approx(100.0 * 5.0 / 60.0)
    assert n == 3 and nim == pytest.approx(3.0)


def test_acc_on_excludes_off_and_fault_and_standby_before_engagement() -> None:
    s = np.array([0, 1, 1, 2, 3, 1, 4, 2])
    assert acc_on_mask(s).tolist() == [False, False, False, True, True, True, False, True]
    t = np.arange(8) * 1.0
    pressed = np.array([1, 1, 0, 0, 0, 0, 1, 0], bool)
    poi, nim, on_s, n = poi_nim(t, s, pressed, np.zeros(8, bool))
    assert on_s == 4.0 and poi == 0.0 and n == 0


def test_never_on_gives_nan() -> None:
    poi, nim, on_s, n = poi_nim(np.arange(5.0), np.zeros(5), np.ones(5, bool), np.zeros(5, bool))
    assert math.isnan(poi) and math.isnan(nim) and on_s == 0.0


def test_min_ttc_and_jerk() -> None:
    gap = np.array([30.0, 20.0, 10.0])
    v = np.array([20.0, 20.0, 15.0])
    vl = np.array([25.0, 15.0, 10.0])
    assert ttc_s(gap, v, vl).min() == pytest.approx(2.0)
    assert ttc_s(gap, vl - 10.0, vl).min() == math.inf
    t = np.arange(5) * 0.5
    a = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    assert rms_jerk(t, a) == pytest.approx(2.0)


def _log(
    t: np.ndarray,
    gap: np.ndarray,
    v: np.ndarray,
    vl: np.ndarray,
    accel_pressed: np.ndarray,
    acc_state: np.ndarray | None = None,
    pref_gap_m: float = math.nan,
) -> WorldLog:
    """A drive log of these columns, every other one zero (no brake, no request)."""
    zero = np.zeros(len(t))
    state = np.full(len(t), 2) if acc_state is None else acc_state
    return WorldLog(
        t,
        v,
        gap,
        vl,
        zero,
        accel_pressed,
        zero.astype(bool),
        state,
        np.full(len(t), pref_gap_m),
        zero,
        zero.astype(bool),
        zero,
        zero,
    )


def test_drive_metrics_gap_error_uses_unpressed_acc_on_samples() -> None:
    n = 100
    t = np.arange(n) * 0.1
    state = np.full(n, 2)
    pressed = np.zeros(n, bool)
    pressed[:50] = True
    gap = np.where(np.arange(n) < 50, 100.0, 32.0)
    m = _log(t, gap, np.full(n, 20.0), np.full(n, 20.0), pressed, state, pref_gap_m=30.0).metrics()
    assert m.gap_error_mean_m == pytest.approx(2.0) and m.gap_error_rms_m == pytest.approx(2.0)
    assert m.min_gap_m == 32.0 and m.poi_pct == pytest.approx(50.0)


def test_safety_counts_a_cut_in_that_began_below_the_threshold_apart() -> None:
    """1 s of 10 samples: TTC 1.5 s at samples 2-4 (a cut-in at 0.2 s set it), then 3 s, then
    1.0 s at samples 7-8 (the controller's own doing): only the latter counts as own time;
    an accelerator press at sample 8 is counted as the driver's."""
    t = np.arange(10) * 0.1
    closing = 2.0
    ttc = np.array([9, 9, 1.5, 1.5, 1.5, 3, 3, 1.0, 1.0, 9], dtype=float)
    gap = ttc * closing
    v = np.full(10, 10.0)
    vl = v - closing
    press = np.zeros(10, dtype=bool)
    press[8] = True
    s = _log(t, gap, v, vl, press).safety(2.0, cut_in_t_s=[0.2])
    assert s.below_cut_in_s == pytest.approx(0.3)
    assert s.below_own_s == pytest.approx(0.1)  # sample 7
    assert s.below_override_s == pytest.approx(0.1)  # sample 8
    assert s.min_ttc_own_s == pytest.approx(1.0) and s.min_ttc_s == pytest.approx(1.0)
    # a cut-in that began with more than the threshold plus 1 s exempts nothing
    s = _log(t, gap, v, vl, press).safety(2.0, cut_in_t_s=[0.5])
    assert s.below_cut_in_s == 0.0 and s.below_own_s == pytest.approx(0.4)
    # one that began at 2.9 s (within the 1-s reaction allowance) sets what follows
    ttc2 = np.array([9, 9, 2.9, 2.2, 1.9, 1.8, 2.3, 3.1, 1.0, 9], dtype=float)
    s = _log(t, ttc2 * closing, v, vl, np.zeros(10, dtype=bool)).safety(2.0, [0.2])
    assert s.below_cut_in_s == pytest.approx(0.2) and s.below_own_s == pytest.approx(0.1)


def test_a_time_below_that_began_during_an_accelerator_press_stays_the_drivers() -> None:
    """TTC below 2 s at samples 3-6, the accelerator pressed at 2-4: samples 5-6 (after the
    release, same episode) count with the press; a later episode (8) is the ECU's."""
    t = np.arange(10) * 0.1
    ttc = np.array([9, 9, 3, 1.9, 1.8, 1.7, 1.9, 3, 1.5, 9], dtype=float)
    v = np.full(10, 10.0)
    press = np.zeros(10, dtype=bool)
    press[2:5] = True
    s = _log(t, ttc * 2.0, v, v - 2.0, press).safety(2.0)
    assert s.below_override_s == pytest.approx(0.4)
    assert s.below_own_s == pytest.approx(0.1) and s.min_ttc_own_s == pytest.approx(1.5)


def _episodes_by_hand(below: list[bool], pressed: list[bool]) -> list[bool]:
    """The rule walked sample by sample: a run below the threshold is the driver's from a
    sample pressed at its start, or pressed right after a pressed one, to its end."""
    out = list(pressed)
    for k in range(len(below)):
        run_start = k == 0 or not below[k - 1]
        if below[k] and pressed[k] and (run_start or out[k - 1]):
            j = k
            while j < len(below) and below[j]:
                out[j] = True
                j += 1
    return out


@given(st.lists(st.tuples(st.booleans(), st.booleans()), max_size=40))
def test_pressed_episodes_follow_the_rule_sample_by_sample(
    samples: list[tuple[bool, bool]],
) -> None:
    below = [b for b, _ in samples]
    pressed = [p for _, p in samples]
    got = pressed_episodes(np.array(below, dtype=bool), np.array(pressed, dtype=bool))
    assert got.tolist() == _episodes_by_hand(below, pressed)
