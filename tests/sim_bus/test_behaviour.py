"""The synthetic driver's perception and pedal decisions under ACC (sim_bus.behaviour)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from dbc.vocab.acc_state import AccState
from sim_bus.behaviour import ATTENTIVE_REACTION_S, DriverAgent
from sim_bus.drivers import DriverParams
from sim_bus.idm import interp_float

DT = 0.05


def _agent(**habits: float) -> DriverAgent:
    p = DriverParams(
        "t",
        standstill_m=2.0,
        headway_speeds_mps=(10.0, 30.0),
        headway_s=(1.0, 1.0),
        comfort_band_min_m=1.0,
        accel_noise_mps2=0.0,
        **habits,  # type: ignore[arg-type]
    )
    return DriverAgent(p, np.random.default_rng(0), dt_s=DT)


def _steps(agent: DriverAgent, seconds: float, v: float, v_lead: float, gap: float) -> None:
    for _ in range(int(round(seconds / DT))):
        agent.step(v, v_lead, gap, AccState.ACTIVE)


def test_accelerator_press_lifts_off_at_once_when_the_lead_closes_in() -> None:
    """A press the driver would hold 2 s at least and 1 s past its goal ends as soon as the
    driver sees that the lead closes in (its own model asks to slow down); while pressing it
    watches the lead, so it sees it ATTENTIVE_REACTION_S late, not reaction_s (1 s)."""
    a = _agent(reaction_s=1.0, patience_far_s=0.5, press_min_s=2.0, prolong_s=1.0, press_max_s=5.0)
    _steps(a, 3.0, 15.0, 15.0, 40.0)  # far behind (preference 17 m): it presses
    assert a.accel_pressed
    held = 0.0
    while a.accel_pressed and held < 5.0:
        a.step(15.0, 8.0, 25.0, AccState.OVERRIDE)  # the lead slows: closing at 7 m/s
        held += DT
    assert not a.accel_pressed
    assert held <= ATTENTIVE_REACTION_S + 2 * DT  # not reaction_s, press_min_s or prolong_s


def test_accelerator_press_ends_when_its_own_model_asks_to_slow_down() -> None:
    """The lead slows gently (0.4 m/s², no brake lights by the driver's threshold): the press
    ends when the closing makes the driver's own IDM+ ask for less than zero, long before
    press_max_s and before the gap reaches the preference."""
    a = _agent(reaction_s=0.5, patience_far_s=0.5, press_min_s=0.3, prolong_s=1.0, press_max_s=20.0)
    _steps(a, 3.0, 15.0, 15.0, 30.0)
    assert a.accel_pressed
    v_lead, gap, t = 15.0, 30.0, 0.0
    while a.accel_pressed and t < 20.0:
        v_lead -= 0.4 * DT
        gap += (v_lead - 15.0) * DT
        a.step(15.0, v_lead, gap, AccState.OVERRIDE)
        t += DT
    assert not a.accel_pressed and t < 15.0
    assert a.lead_accel_seen_mps2 > -0.5  # not the brake-light rule
    assert gap > a.pref_gap_m * 1.06  # not the release rule: the gap is still too long


def test_own_speed_is_felt_without_the_reaction_delay() -> None:
    """The ego speeds up toward a steady lead: the time-to-collision reckoned with the speed
    felt now is below ttc_brake_s at once, so the driver brakes before reaction_s is over."""
    a = _agent(reaction_s=1.5, ttc_brake_s=3.5)
    _steps(a, 2.0, 15.0, 15.0, 17.0)  # settled at its preferred gap
    assert not (a.brake_pressed or a.accel_pressed)
    a.step(20.0, 15.0, 17.0, AccState.ACTIVE)  # closing at 5 m/s: TTC 3.4 s
    assert a.brake_pressed


def test_brake_lights_end_a_press_and_keep_one_from_starting() -> None:
    """The lead slows at 1 m/s² (its brake lights), still far away: seen reaction_s late, the
    press ends though the gap is still too large, and no new one starts while it brakes."""
    a = _agent(reaction_s=0.5, patience_far_s=0.5, press_min_s=2.0, prolong_s=1.0, press_max_s=5.0)
    _steps(a, 3.0, 15.0, 15.0, 60.0)
    assert a.accel_pressed
    v_lead, held = 15.0, 0.0
    while a.accel_pressed and held < 5.0:
        v_lead -= 1.0 * DT
        a.step(15.0, v_lead, 60.0, AccState.OVERRIDE)
        held += DT
    assert held <= 0.5 + 0.3 + 2 * DT  # reaction plus the estimate's time constant
    assert a.lead_accel_seen_mps2 < -0.5
    for _ in range(40):  # 2 s more of a braking lead, gap still far too large, not closing
        v_lead -= 1.0 * DT
        a.step(v_lead, v_lead, 60.0, AccState.ACTIVE)
        assert not a.accel_pressed
        assert a._far_t == 0.0  # the "too far" patience does not even start to run


def _press_length(revision: int, pedal: str, seed: int) -> float:
    """How long the first press lasts under constant inputs (s)."""
    p = DriverParams(
        "r",
        standstill_m=2.0,
        headway_speeds_mps=(10.0, 30.0),
        headway_s=(1.0, 1.0),
        comfort_band_min_m=1.0,
        accel_noise_mps2=1.5,
        patience_far_s=0.5,
        press_max_s=2.0,
        ttc_brake_s=3.0,
        revision=revision,
    )
    a = DriverAgent(p, np.random.default_rng(seed), dt_s=DT)
    v, v_lead, gap = (20.0, 20.0, 60.0) if pedal == "accel" else (20.0, 15.0, 12.0)
    t, started = 0.0, -1.0
    while t < 10.0:
        a.step(v, v_lead, gap, AccState.ACTIVE if started < 0 else AccState.OVERRIDE)
        t += DT
        pressed = a.accel_pressed if pedal == "accel" else a.brake_pressed
        if pressed and started < 0:
            started = t
        if started >= 0 and not pressed:
            return t - started
    return t - started


def test_a_brake_press_lasts_while_the_gap_closes_fast_revision_2() -> None:
    """Closing at 5 m/s, 12 m behind (TTC 2.4 s below the driver's 3 s): revision 1 lets go
    at press_max_s (2 s) although nothing changed; revision 2 holds the brake."""
    assert _press_length(1, "brake", 0) <= 2.0 + 2 * DT
    assert _press_length(2, "brake", 0) > 5.0


def test_control_noise_alone_does_not_end_an_accelerator_press_revision_2() -> None:
    """Far behind a steady lead the driver's following model asks for more speed: with
    1.5 m/s^2 of control noise, revision 1 ends some presses early (the noise makes the
    acceleration negative), revision 2 holds each to press_max_s."""
    early = [_press_length(1, "accel", s) < 1.5 for s in range(8)]
    held = [_press_length(2, "accel", s) >= 2.0 - 2 * DT for s in range(8)]
    assert any(early) and all(held)


_FLOATS = st.floats(-1e3, 1e3, allow_nan=False)


@given(
    st.lists(_FLOATS, min_size=1, max_size=6, unique=True).map(sorted),
    st.lists(_FLOATS, min_size=6, max_size=6),
    st.one_of(_FLOATS, st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0])),
)
def test_interp_float_is_np_interp(xp: list[float], fp: list[float], x: float) -> None:
    """The driver's scalar lookup gives np.interp's float, bit for bit: inside a segment, on a
    breakpoint, beyond the ends, NaN, one-point tables."""
    fp = fp[: len(xp)]
    for v in (x, *xp, *(math.nextafter(b, math.inf) for b in xp)):
        ours, numpy = interp_float(v, tuple(xp), tuple(fp)), float(np.interp(v, xp, fp))
        assert ours == numpy or (math.isnan(ours) and math.isnan(numpy))
        assert math.copysign(1.0, ours) == math.copysign(1.0, numpy)


def test_a_press_not_about_the_gap_lasts_tap_s() -> None:
    """At the preferred gap a driver with presses not about the gap makes them, each as long
    as its ``tap_s`` (one step either side)."""
    for tap_s in (0.3, 1.2):
        a = _agent(spurious_press_per_min=30.0, tap_s=tap_s, press_min_s=0.3)
        lengths, held = [], 0.0
        for _ in range(int(60.0 / DT)):
            a.step(15.0, 15.0, 17.0, AccState.ACTIVE)  # exactly at its preference
            if a.accel_pressed:
                held += DT
            elif held:
                lengths.append(held)
                held = 0.0
        assert len(lengths) > 10
        assert all(abs(x - tap_s) <= 2 * DT for x in lengths)
