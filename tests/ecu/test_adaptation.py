"""Algorithm 1 on hand-computed cases: every branch, the smoothing width, both clamps."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from dbc.vocab.dgpt import SafetyBounds, predefined
from ecu.adaptation import (
    ADAPTATION_MODES,
    AdaptationError,
    AdaptationParams,
    Reason,
    ShortPresses,
    TakeoverSummary,
    adapt,
    count_short_press,
    spread_weights,
    timegap_weights,
)

P = AdaptationParams(mode="paper")  # P_T 1 s, K_T 1 s, V_D 5 m/s, window 9
#: the one safety band of tables and adaptation: 2 m + 0.8 s·v … 10 m + 5 s·v


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
    new, _ = adapt(t, summary(g=30.0), AdaptationParams(mode="paper", window_size=window))
    changed = np.flatnonzero(np.abs(new.gap_m - t.gap_m) > 1e-12)
    assert changed.size == window
    assert changed.min() == 40 - (window - 1) // 2 and changed.max() == 40 + (window - 1) // 2
    assert new.gap_m[40] == pytest.approx(30.0)


def test_clamp_at_lower_bound() -> None:
    t = predefined(2.0)
    new, d = adapt(t, summary(v=20.0, vf=20.0, g=15.0), P)
    assert d.applied and d.g_desire_m == pytest.approx(15.0)
    assert new.gap_m[40] == pytest.approx(2.0 + 0.8 * 20.0)  # 18 m, the table's own bound
    assert d.delta_m == pytest.approx(18.0 - 44.0)
    # bin 41 (20.5 m/s): 45 - 29 * 0.8 = 21.8 m, above its bound 18.4 m: kept
    assert new.gap_m[41] == pytest.approx(21.8)


def test_clamp_at_upper_bound() -> None:
    t = predefined(4.0)
    new, d = adapt(t, summary(v=20.0, vf=20.0, g=150.0), P)
    assert d.applied
    assert new.gap_m[40] == pytest.approx(10.0 + 5.0 * 20.0)  # 110 m, the table's upper bound


def test_safety_filter_covers_every_bin() -> None:
    t = predefined(1.0, standstill_m=2.0)
    new, _ = adapt(t, summary(v=30.0, vf=30.0, g=20.0), P)
    lo = 2.0 + 0.8 * new.speed_mps
    assert np.all(new.gap_m >= lo - 1e-9) and new.gap_m[60] == pytest.approx(lo[60])
    new.check_bounds(SafetyBounds())


def test_filter_is_the_tables_own_bound() -> None:
    """A custom SafetyBounds is the adaptation's band too: no second, higher floor."""
    bounds = SafetyBounds(standstill_m=3.0, headway_min_s=1.0, standstill_min_m=3.0)
    t = predefined(2.0)
    new, _ = adapt(t, summary(g=1.0), AdaptationParams(), bounds=bounds)
    assert np.all(new.gap_m >= 3.0 + 1.0 * new.speed_mps - 1e-9)
    assert new.gap_m[40] == pytest.approx(23.0)
    new.check_bounds(bounds)


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
        AdaptationParams(short_press_min_s=1.5, min_takeover_s=1.0)
    with pytest.raises(AdaptationError):
        AdaptationParams(coast_down_s=math.nan)
    with pytest.raises(AdaptationError):
        AdaptationParams(short_press_count=0)


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
    one, _ = adapt(
        t, summary(v=20.0, vf=18.0, g=35.0), AdaptationParams(mode="paper", window_size=1)
    )
    assert np.abs(np.diff(one.gap_m) / 0.5).max() == pytest.approx(22.0 + 2.0)


def test_default_p_t_rejects_taps_not_presses() -> None:
    t = predefined(2.0)
    assert not adapt(t, summary(duration=0.5, g=30.0), P)[1].applied
    assert adapt(t, summary(duration=2.0, g=30.0), P)[1].applied


def test_spread_weights_shape() -> None:
    w = spread_weights(11, 0, 5)
    np.testing.assert_allclose(w[:4], [1.0, 2 / 3, 1 / 3, 0.0])
    assert w.shape == (11,)


# -- mode "timegap": direction from the pedal, update in time-gap space over a speed range --

TG = AdaptationParams(mode="timegap", spread_speed_mps=6.0)  # v_min 10 m/s, d0 4 m, K_T 1 s


def test_modes_listed_and_validated() -> None:
    assert ADAPTATION_MODES == ("paper", "timegap")
    default = AdaptationParams()
    assert default.mode == "timegap" and default.spread_speed_mps == 15.0
    assert default.coast_down_s == P.coast_down_s and default.min_takeover_s == 1.0
    with pytest.raises(AdaptationError):
        AdaptationParams(mode="magic")  # type: ignore[arg-type]
    with pytest.raises(AdaptationError):
        AdaptationParams(mode="timegap", spread_speed_mps=0.0)
    with pytest.raises(AdaptationError):
        AdaptationParams(mode="timegap", min_speed_mps=0.0)
    with pytest.raises(AdaptationError):
        AdaptationParams(spread_speed_mps=math.inf)


def test_timegap_weights_hand_computed() -> None:
    w = timegap_weights(np.array([20.0, 26.0, 14.0, 32.0]), 20.0, 6.0)
    np.testing.assert_allclose(w, [1.0, math.exp(-0.5), math.exp(-0.5), math.exp(-2.0)])


def test_timegap_closing_case_hand_computed() -> None:
    t = predefined(2.0)  # gap = 4 + 2 v
    new, d = adapt(t, summary(v=20.0, vf=18.0, g=35.0), TG)
    # g_desire = 35 - 1 * 2 = 33; DGPT(20) = 44; dh = -11 / 20 = -0.55 s
    assert d.applied and d.g_desire_m == pytest.approx(33.0) and d.bin_index == 40
    assert new.gap_m[40] == pytest.approx(33.0)
    assert d.delta_m == pytest.approx(-11.0)
    # 26 m/s (bin 52): 56 - exp(-0.5) * 0.55 * 26
    assert new.gap_m[52] == pytest.approx(56.0 - math.exp(-0.5) * 0.55 * 26.0)
    # 14 m/s (bin 28): 32 - exp(-0.5) * 0.55 * 14
    assert new.gap_m[28] == pytest.approx(32.0 - math.exp(-0.5) * 0.55 * 14.0)
    # 5 m/s (bin 10), below v_min: 14 - exp(-0.5 * 2.5^2) * 0.55 * 10, then the 0.8 s floor
    want = 14.0 - math.exp(-0.5 * 2.5**2) * 0.55 * 10.0
    assert new.gap_m[10] == pytest.approx(max(want, 4.0 + 0.8 * 5.0))
    # the time gap changes smoothly everywhere: no bin untouched near v, no step
    assert np.all(np.diff(new.gap_m) > 0.0)


def test_timegap_low_speed_uses_min_speed() -> None:
    t = predefined(2.0)
    new, d = adapt(t, summary(v=4.0, vf=4.0, g=15.0, duration=2.0), TG)
    # not closing: g_desire = 15; DGPT(4) = 12; dh = 3 / max(4, 10) = 0.3 s
    assert d.applied and new.gap_m[8] == pytest.approx(15.0)
    assert new.gap_m[20] == pytest.approx(24.0 + math.exp(-0.5) * 0.3 * 10.0)  # 10 m/s
    assert new.gap_m[32] == pytest.approx(36.0 + math.exp(-2.0) * 0.3 * 16.0)  # 16 m/s


def test_timegap_centre_bin_lands_on_g_desire() -> None:
    t = predefined(3.0)
    new, d = adapt(t, summary(v=17.3, vf=17.3, g=40.0), TG)
    # nearest bin 17.5 m/s (35): DGPT 56.5 -> 40, dh = -16.5 / 17.5 s around 17.5 m/s
    assert d.applied and d.bin_index == 35 and new.gap_m[35] == pytest.approx(40.0)
    assert d.delta_m == pytest.approx(-16.5)
    assert new.gap_m[34] == pytest.approx(
        55.0 - math.exp(-0.5 * (0.5 / 6.0) ** 2) * 16.5 / 17.5 * 17.0
    )
    assert new.lookup(17.3) == pytest.approx(40.0, abs=1.0)


@pytest.mark.parametrize(
    ("pedal", "g", "applied"),
    [
        ("accel", 50.0, False),  # accelerator but a longer gap (44 -> 50): contradiction
        ("accel", 40.0, True),
        ("brake", 40.0, False),  # brake but a shorter gap: contradiction
        ("brake", 50.0, True),
        ("both", 50.0, True),
        ("", 40.0, True),
    ],
)
def test_timegap_direction_from_pedal(pedal: str, g: float, applied: bool) -> None:
    t = predefined(2.0)
    s = TakeoverSummary(duration_s=3.0, v_mps=20.0, v_lead_mps=20.0, gap_m=g, pedal=pedal)
    new, d = adapt(t, s, TG)
    assert d.applied is applied
    if applied:
        assert new.gap_m[40] == pytest.approx(g)
    else:
        assert new is t and d.reason is Reason.AGAINST_PEDAL
        assert d.g_desire_m == pytest.approx(g) and "against_pedal" in str(d)


def test_paper_mode_respects_the_pedal_too() -> None:
    """in both modes an accelerator press never lengthens the table."""
    t = predefined(2.0)
    s = TakeoverSummary(duration_s=3.0, v_mps=20.0, v_lead_mps=20.0, gap_m=50.0, pedal="accel")
    new, d = adapt(t, s, P)
    assert not d.applied and d.reason is Reason.AGAINST_PEDAL and new is t
    new, d = adapt(t, dataclasses.replace(s, pedal=""), P)
    assert d.applied and new.gap_m[40] == pytest.approx(50.0)


def test_timegap_filters_and_safety_bounds() -> None:
    t = predefined(2.0)
    assert adapt(t, summary(duration=0.5), TG)[1].reason is Reason.SHORT_TAKEOVER
    assert adapt(t, summary(vf=26.0), TG)[1].reason is Reason.SPEED_DIFFERENCE
    assert adapt(t, summary(lead=False), TG)[1].reason is Reason.NO_LEAD
    new, d = adapt(t, summary(g=300.0), TG)
    assert d.applied and new.gap_m[40] == pytest.approx(10.0 + 5.0 * 20.0)
    hi = 10.0 + 5.0 * new.speed_mps
    lo = 2.0 + 0.8 * new.speed_mps
    assert np.all(new.gap_m <= hi + 1e-9) and np.all(new.gap_m >= lo - 1e-9)
    new.check_bounds(SafetyBounds())
    low, _ = adapt(t, summary(g=1.0), TG)
    assert np.all(low.gap_m >= lo - 1e-9)


def test_default_timegap_keeps_table_slope_smooth() -> None:
    """The same 11 m correction in timegap mode: dh = -0.55 s spread with sigma 25 m/s
    changes dDGPT/dv by at most |dh| * max|d(w v)/dv| = 0.55 * w(10) * (1 + 10 * 10 / 625)
    ~ 0.59 s (at 10 m/s, where w = exp(-0.08)): far below the paper window's 4.4 s. Below
    10 m/s the safety floor d0 + 0.8 v takes over (the lowered table reaches it)."""
    t = predefined(2.0)
    new, d = adapt(t, summary(v=20.0, vf=18.0, g=35.0), AdaptationParams(spread_speed_mps=25.0))
    assert d.applied and new.gap_m[40] == pytest.approx(33.0)
    change = np.diff(new.gap_m - t.gap_m)[20:] / 0.5  # from 10 m/s up
    assert np.all(new.gap_m[20:] > 4.0 + 0.8 * new.speed_mps[20:])  # no clipping there
    bound = 0.55 * math.exp(-0.08) * (1.0 + 100.0 / 625.0)
    assert np.abs(change).max() == pytest.approx(bound, rel=0.03)
    # every speed learns: the time gap above d0 moves by 0.55 s * w(v)
    assert new.gap_m[80] == pytest.approx(84.0 - 0.55 * math.exp(-0.5 * 0.64) * 40.0)


# -- one safety bound, the pedal's direction, short presses as evidence ------------


@pytest.mark.parametrize("mode", ADAPTATION_MODES)
def test_close_follower_press_for_less_never_lengthens_the_table(mode: str) -> None:
    """The issue's case: a close follower's table at the table's own floor (2 m + 0.8 s·v)
    and one accelerator press asking for 0.5 m less. The earlier 4-m floor of the adaptation
    lifted the whole table by up to 2 m; now no bin grows and the floor is the table's."""
    t = predefined(0.8, standstill_m=2.0)
    g = float(t.lookup(20.0)) - 0.5
    s = TakeoverSummary(duration_s=2.0, v_mps=20.0, v_lead_mps=20.0, gap_m=g, pedal="accel")
    new, d = adapt(t, s, AdaptationParams(mode=mode))  # type: ignore[arg-type]
    assert d.applied
    assert np.all(new.gap_m <= t.gap_m + 1e-12)
    new.check_bounds(SafetyBounds())


@pytest.mark.parametrize("mode", ADAPTATION_MODES)
@pytest.mark.parametrize("pedal", ["accel", "brake"])
def test_no_bin_moves_against_the_pedal(mode: str, pedal: str) -> None:
    """Over random tables (inside the bounds) and takeovers: after the accelerator no bin is
    longer, after the brake none shorter, and every bin stays inside the bounds."""
    rng = np.random.default_rng(11)
    bounds = SafetyBounds()
    params = AdaptationParams(mode=mode)  # type: ignore[arg-type]
    for _ in range(200):
        base = predefined(float(rng.uniform(0.8, 4.0)), standstill_m=float(rng.uniform(2, 10)))
        wiggle = base.gap_m + rng.normal(0.0, 3.0, base.gap_m.size)
        t = base.with_gaps(
            np.clip(wiggle, bounds.lower_m(base.speed_mps), bounds.upper_m(base.speed_mps))
        )
        v = float(rng.uniform(0.0, 35.0))
        s = TakeoverSummary(
            duration_s=2.0,
            v_mps=v,
            v_lead_mps=v + float(rng.uniform(-3.0, 3.0)),
            gap_m=float(rng.uniform(1.0, 150.0)),
            pedal=pedal,
        )
        new, d = adapt(t, s, params, bounds=bounds)
        change = new.gap_m - t.gap_m
        if pedal == "accel":
            assert np.all(change <= 1e-12)
        else:
            assert np.all(change >= -1e-12)
        if not d.applied:
            assert new is t
        new.check_bounds(bounds)


def short(pedal: str, duration: float = 0.5, g: float = 30.0) -> TakeoverSummary:
    return TakeoverSummary(duration_s=duration, v_mps=20.0, v_lead_mps=20.0, gap_m=g, pedal=pedal)


def test_short_presses_of_one_pedal_count_as_evidence() -> None:
    params = AdaptationParams()  # two short presses within 30 s
    state = ShortPresses()
    state, run = count_short_press(state, short("accel"), 10.0, params)
    assert not run and state.count == 1 and state.pedal == "accel"
    state, run = count_short_press(state, short("accel"), 25.0, params)
    assert run and state == ShortPresses()  # the run is used up
    t = predefined(2.0)
    assert adapt(t, short("accel"), params)[1].reason is Reason.SHORT_TAKEOVER
    new, d = adapt(t, short("accel"), params, short_run=True)
    assert d.applied and new.gap_m[40] == pytest.approx(30.0)


@pytest.mark.parametrize(
    ("second", "end_s", "count"),
    [
        (short("brake"), 20.0, 1),  # the other pedal: a new run of its own
        (short("accel"), 50.0, 1),  # too late: a new run from this press
        (short("accel", duration=0.2), 20.0, 0),  # a touch: no evidence, the run ends
        (short("accel", duration=2.0), 20.0, 0),  # a long takeover (itself an update) ends it
        (short("both"), 20.0, 0),  # no single direction: the run ends
    ],
)
def test_short_press_runs_break(second: TakeoverSummary, end_s: float, count: int) -> None:
    params = AdaptationParams()
    state, _ = count_short_press(ShortPresses(), short("accel"), 10.0, params)
    state, run = count_short_press(state, second, end_s, params)
    assert not run and state.count == count


def test_short_run_does_not_admit_touches() -> None:
    t = predefined(2.0)
    _, d = adapt(t, short("accel", duration=0.2), AdaptationParams(), short_run=True)
    assert d.reason is Reason.SHORT_TAKEOVER


@pytest.mark.parametrize("mode", ADAPTATION_MODES)
def test_step_fraction_moves_part_of_the_way(mode: str) -> None:
    t = predefined(2.0)  # 44 m at 20 m/s
    full, _ = adapt(t, summary(g=30.0), AdaptationParams(mode=mode))  # type: ignore[arg-type]
    half, d = adapt(t, summary(g=30.0), AdaptationParams(mode=mode, step_fraction=0.5))  # type: ignore[arg-type]
    assert full.gap_m[40] == pytest.approx(30.0)
    assert half.gap_m[40] == pytest.approx(37.0) and d.delta_m == pytest.approx(-7.0)
    above = slice(20, None)  # from 10 m/s up, where neither reaches the safety floor
    assert np.allclose((half.gap_m - t.gap_m)[above], 0.5 * (full.gap_m - t.gap_m)[above])
    with pytest.raises(AdaptationError):
        AdaptationParams(step_fraction=0.0)
