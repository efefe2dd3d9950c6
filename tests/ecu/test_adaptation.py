"""Algorithm 1 on hand-computed cases: every branch, the smoothing width, both clamps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ecu.adaptation import (
    AdaptationError,
    AdaptationParams,
    Reason,
    TakeoverSummary,
    adapt,
    spread_weights,
)
from ecu.dgpt import SafetyBounds, predefined

P = AdaptationParams()  # P_T 1 s, K_T 1 s, V_D 5 m/s, window 9, TG 0.8..5 s, d0 4 m


def summary(
    duration: float = 3.0, v: float = 20.0, vf: float = 20.0, g: float = 40.0, lead: bool = True
) -> TakeoverSummary:
    return TakeoverSummary(duration_s=duration, v_mps=v, v_lead_mps=vf, gap_m=g, lead_valid=lead)


def test_closing_case_hand_computed() -> None:
    t = predefined(2.0)
    new, d = adapt(t, summary(v=20.0, vf=18.0, g=35.0), P)
    # g_desire = 35 - K_T * (20 - 18) = 33; old DGPT(20) = 44 -> delta -11 at bin 40
    assert d.applied and d.reason is Reason.APPLIED
    assert d.bin_index == 40
    assert d.g_desire_m == pytest.approx(33.0)
    assert new.gap_m[40] == pytest.approx(33.0)
    # triangular weights 1 - |j - 40| / 5 over bins 36..44
    assert new.gap_m[41] == pytest.approx(45.0 - 11.0 * 0.8)
    assert new.gap_m[44] == pytest.approx(48.0 - 11.0 * 0.2)
    assert new.gap_m[36] == pytest.approx(40.0 - 11.0 * 0.2)
    assert new.gap_m[45] == t.gap_m[45] and new.gap_m[35] == t.gap_m[35]
    assert new.version == t.version + 1 and new.source == "adapted"
    assert d.delta_m == pytest.approx(-11.0)


def test_not_closing_keeps_gap_at_release() -> None:
    t = predefined(2.0)
    for vf in (20.0, 21.0, 24.9):
        new, d = adapt(t, summary(v=20.0, vf=vf, g=30.0), P)
        assert d.applied
        assert d.g_desire_m == pytest.approx(30.0)
        assert new.gap_m[40] == pytest.approx(30.0)


def test_short_takeover_skipped_at_and_below_p_t() -> None:
    t = predefined(2.0)
    for duration in (0.2, 1.0):
        new, d = adapt(t, summary(duration=duration, g=30.0), P)
        assert not d.applied and d.reason is Reason.SHORT_TAKEOVER
        assert new is t
    _, d = adapt(t, summary(duration=1.01, g=30.0), P)
    assert d.applied


def test_large_speed_difference_skipped() -> None:
    t = predefined(2.0)
    new, d = adapt(t, summary(v=20.0, vf=25.0, g=30.0), P)
    assert not d.applied and d.reason is Reason.SPEED_DIFFERENCE and new is t
    # a large *closing* speed is not filtered: the prediction handles it
    _, d = adapt(t, summary(v=25.0, vf=18.0, g=60.0), P)
    assert d.applied and d.g_desire_m == pytest.approx(53.0)


@pytest.mark.parametrize("window", [1, 3, 5, 9, 15])
def test_smoothing_width(window: int) -> None:
    t = predefined(2.0)
    new, _ = adapt(t, summary(g=30.0), AdaptationParams(window_size=window))
    changed = np.flatnonzero(np.abs(new.gap_m - t.gap_m) > 1e-12)
    assert changed.size == window
    assert changed.min() == 40 - (window - 1) // 2 and changed.max() == 40 + (window - 1) // 2
    assert new.gap_m[40] == pytest.approx(30.0)


def test_clamp_at_lower_bound() -> None:
    t = predefined(2.0)
    new, d = adapt(t, summary(v=20.0, vf=20.0, g=15.0), P)
    assert d.applied and d.g_desire_m == pytest.approx(15.0)
    assert new.gap_m[40] == pytest.approx(4.0 + 0.8 * 20.0)  # 20 m, the 0.8 s time gap
    assert d.delta_m == pytest.approx(20.0 - 44.0)
    # bin 41 (20.5 m/s): 45 - 29 * 0.8 = 21.8 m, above its bound 20.4 m: kept
    assert new.gap_m[41] == pytest.approx(21.8)


def test_clamp_at_upper_bound() -> None:
    t = predefined(4.0)
    new, d = adapt(t, summary(v=20.0, vf=20.0, g=150.0), P)
    assert d.applied
    assert new.gap_m[40] == pytest.approx(4.0 + 5.0 * 20.0)  # 104 m, the 5 s time gap


def test_safety_filter_covers_every_bin() -> None:
    t = predefined(0.8, standstill_m=2.0)  # legal table, below the filter's d0 = 4 m
    new, _ = adapt(t, summary(v=30.0, vf=30.0, g=30.0), P)
    lo = 4.0 + 0.8 * new.speed_mps
    assert np.all(new.gap_m >= lo - 1e-9)
    new.check_bounds(SafetyBounds())


def test_invalid_and_no_lead_skipped() -> None:
    t = predefined(2.0)
    assert adapt(t, summary(lead=False), P)[1].reason is Reason.NO_LEAD
    for s in (summary(g=math.nan), summary(v=math.inf), summary(vf=-1.0), summary(g=-2.0)):
        new, d = adapt(t, s, P)
        assert d.reason is Reason.INVALID_INPUT and new is t


def test_speed_beyond_axis_updates_last_bin() -> None:
    t = predefined(2.0)
    new, d = adapt(t, summary(v=45.0, vf=45.0, g=80.0), P)
    assert d.bin_index == t.speed_mps.size - 1
    assert new.gap_m[-1] == pytest.approx(80.0)


def test_parameters_validated() -> None:
    with pytest.raises(AdaptationError):
        AdaptationParams(window_size=4)
    with pytest.raises(AdaptationError):
        AdaptationParams(safe_tg_min_s=3.0, safe_tg_max_s=2.0)
    with pytest.raises(AdaptationError):
        AdaptationParams(coast_down_s=math.nan)
    with pytest.raises(AdaptationError):
        AdaptationParams(safe_tg_max_s=6.0).check_within(SafetyBounds())


# -- the defaults, justified ---------------------------------------------------------------


def test_default_k_t_matches_coast_down() -> None:
    """K_T = 1 s: released at a closing speed of 1 m/s, a car coasting at 0.5 m/s^2 (drag,
    rolling resistance, engine braking) loses 1 m of gap until the speeds match."""
    dt, dv, gap_lost = 0.001, 1.0, 0.0
    while dv > 0.0:
        gap_lost += dv * dt
        dv -= 0.5 * dt
    assert gap_lost == pytest.approx(P.coast_down_s * 1.0, rel=0.01)


def test_default_window_keeps_table_slope_moderate() -> None:
    """window 9: an 11 m correction changes dDGPT/dv by 11 / 5 bins / 0.5 m/s = 4.4 s; with a
    single bin it would be 22 s, a step the controller's DGPT' term would turn into a kick."""
    t = predefined(2.0)
    new, _ = adapt(t, summary(v=20.0, vf=18.0, g=35.0), P)
    slope = np.abs(np.diff(new.gap_m) / 0.5)
    assert slope.max() == pytest.approx(2.0 + 4.4)
    one, _ = adapt(t, summary(v=20.0, vf=18.0, g=35.0), AdaptationParams(window_size=1))
    assert np.abs(np.diff(one.gap_m) / 0.5).max() == pytest.approx(22.0 + 2.0)


def test_default_p_t_rejects_taps_not_presses() -> None:
    t = predefined(2.0)
    assert not adapt(t, summary(duration=0.5, g=30.0), P)[1].applied
    assert adapt(t, summary(duration=2.0, g=30.0), P)[1].applied


def test_spread_weights_shape() -> None:
    w = spread_weights(11, 0, 5)
    np.testing.assert_allclose(w[:4], [1.0, 2 / 3, 1 / 3, 0.0])
    assert w.shape == (11,)
