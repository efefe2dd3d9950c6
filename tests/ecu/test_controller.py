"""Controller: PID signs, the relative-speed term, anti-windup, cruise, envelope, emergency."""

from __future__ import annotations

import math

import pytest

from ecu.controller import (
    ControlInput,
    ControllerError,
    ControllerParams,
    closing_limit_mps2,
    desired_accel,
    interp,
    limit_command,
    time_to_collision_s,
)

P = ControllerParams()


def obs(
    gap: float = 30.0,
    desired: float = 30.0,
    rel: float = 0.0,
    v: float = 20.0,
    a: float = 0.0,
    lead: bool = True,
    vset: float = 40.0,
    slope: float = 0.0,
    a_lead: float = 0.0,
) -> ControlInput:
    return ControlInput(
        v_mps=v,
        a_mps2=a,
        set_speed_mps=vset,
        lead_valid=lead,
        gap_m=gap,
        rel_speed_mps=rel,
        lead_accel_mps2=a_lead,
        desired_gap_m=desired,
        desired_gap_slope_s=slope,
    )


def test_interp_table() -> None:
    t = ((0.0, 10.0, 20.0), (1.0, 0.5, 0.0))
    assert interp(-5.0, t) == 1.0
    assert interp(5.0, t) == pytest.approx(0.75)
    assert interp(15.0, t) == pytest.approx(0.25)
    assert interp(99.0, t) == 0.0


def test_gap_error_sign() -> None:
    far, _ = desired_accel(P, obs(gap=40.0, desired=30.0), 0.0, 0.02, integrate=False)
    near, _ = desired_accel(P, obs(gap=20.0, desired=30.0), 0.0, 0.02, integrate=False)
    zero, _ = desired_accel(P, obs(gap=30.0, desired=30.0), 0.0, 0.02, integrate=False)
    assert far > 0.0 > near
    assert zero == 0.0
    assert far == pytest.approx(interp(20.0, P.kp) * 10.0)


def test_relative_speed_and_dgpt_slope_terms() -> None:
    closing, _ = desired_accel(P, obs(rel=-2.0), 0.0, 0.02, integrate=False)
    opening, _ = desired_accel(P, obs(rel=2.0), 0.0, 0.02, integrate=False)
    assert closing == pytest.approx(-2.0 * interp(20.0, P.kd))
    assert opening == pytest.approx(-closing)
    # accelerating raises DGPT(v): e_dot = -slope * a, so the law pulls back
    acc, _ = desired_accel(P, obs(a=1.0, slope=1.5), 0.0, 0.02, integrate=False)
    assert acc == pytest.approx(-1.5 * interp(20.0, P.kd))
    lead_brakes, _ = desired_accel(P, obs(a_lead=-2.0), 0.0, 0.02, integrate=False)
    assert lead_brakes == pytest.approx(-2.0 * P.k_lead_accel)


def test_integral_accumulates_and_acts() -> None:
    i = 0.0
    for _ in range(50):
        _, i = desired_accel(P, obs(gap=31.0), i, 0.02, integrate=True)
    assert i == pytest.approx(1.0)  # 1 m error for 1 s
    a, _ = desired_accel(P, obs(gap=30.0), i, 0.02, integrate=False)
    assert a == pytest.approx(interp(20.0, P.ki) * 1.0)


def test_anti_windup_frozen_when_not_integrating() -> None:
    _, i = desired_accel(P, obs(gap=40.0), 3.0, 0.02, integrate=False)
    assert i == 3.0


def test_anti_windup_frozen_at_the_limits() -> None:
    # 60 m too far: kp * e >> accel_max, the integral must not grow
    _, i = desired_accel(P, obs(gap=90.0, desired=30.0), 0.0, 0.02, integrate=True)
    assert i == 0.0
    _, i = desired_accel(P, obs(gap=5.0, desired=40.0, rel=-3.0), 0.0, 0.02, integrate=True)
    assert i == 0.0
    # not frozen when the error unwinds the integral
    _, i = desired_accel(P, obs(gap=29.0, desired=30.0), 5.0, 0.02, integrate=True)
    assert i == pytest.approx(5.0 - 0.02)


def test_integral_clamped() -> None:
    _, i = desired_accel(P, obs(gap=33.0), P.integral_limit_m_s, 0.02, integrate=True)
    assert i == P.integral_limit_m_s


def test_integral_frozen_while_cruise_caps() -> None:
    # gap 5 m too large but already at the set speed: cruise law in control
    a, i = desired_accel(P, obs(gap=35.0, v=20.0, vset=20.0), 0.0, 0.02, integrate=True)
    assert a == 0.0 and i == 0.0


def test_cruise_without_lead() -> None:
    a, _ = desired_accel(P, obs(lead=False, v=20.0, vset=25.0, gap=0.0), 0.0, 0.02, integrate=True)
    assert a == pytest.approx(P.k_cruise_per_s * 5.0)
    a, _ = desired_accel(P, obs(lead=False, v=30.0, vset=25.0), 0.0, 0.02, integrate=True)
    assert a < 0.0


def test_envelope_and_rate_limit() -> None:
    dt = 0.02
    assert limit_command(P, 0.0, 10.0, dt, emergency=False) == pytest.approx(2.5 * dt)
    assert limit_command(P, 0.0, -10.0, dt, emergency=False) == pytest.approx(-2.5 * dt)
    assert limit_command(P, 1.99, 10.0, dt, emergency=False) == 2.0
    assert limit_command(P, -3.45, -10.0, dt, emergency=True) == -3.5
    assert limit_command(P, 0.5, 0.51, dt, emergency=False) == pytest.approx(0.51)
    assert limit_command(P, 0.5, math.nan, dt, emergency=False) == pytest.approx(0.45)
    assert limit_command(P, 0.5, 0.0, -1.0, emergency=False) == 0.5


def test_emergency_relaxes_only_braking_jerk() -> None:
    dt = 0.02
    assert limit_command(P, 0.0, -3.0, dt, emergency=True) == pytest.approx(-10.0 * dt)
    assert limit_command(P, -3.0, 1.0, dt, emergency=True) == pytest.approx(-3.0 + 2.5 * dt)


def test_closing_limit_matches_the_lead_speed_at_the_floor() -> None:
    """Closing at 4 m/s with 8 m to the floor: -1 m/s^2 stops the closing exactly there
    (16 / (2 * 8)); the lead's own deceleration adds; not closing or at the floor: bounded."""
    assert closing_limit_mps2(14.0, -4.0, 0.0, 6.0) == pytest.approx(-1.0)
    assert closing_limit_mps2(14.0, -4.0, -2.0, 6.0) == pytest.approx(-3.0)
    assert closing_limit_mps2(14.0, 0.5, 0.0, 6.0) == math.inf
    assert closing_limit_mps2(5.0, -4.0, 0.0, 6.0) == pytest.approx(-16.0)  # 0.5 m margin
    v, gap, dv, a = 0.0, 14.0, 4.0, closing_limit_mps2(14.0, -4.0, 0.0, 6.0)
    for _ in range(4000):  # integrate the closing under that deceleration
        gap -= dv * 0.001
        dv += a * 0.001
        v += 0.001
        if dv <= 0.0:
            break
    assert gap == pytest.approx(6.0, abs=0.01)


def test_time_to_collision() -> None:
    assert time_to_collision_s(True, 20.0, -5.0) == pytest.approx(4.0)
    assert time_to_collision_s(True, 20.0, 1.0) == math.inf
    assert time_to_collision_s(False, 20.0, -5.0) == math.inf


def test_parameters_validated() -> None:
    with pytest.raises(ControllerError):
        ControllerParams(kp=((0.0, 0.0), (1.0, 1.0)))
    with pytest.raises(ControllerError):
        ControllerParams(accel_min_mps2=0.5)
    with pytest.raises(ControllerError):
        ControllerParams(emergency_jerk_mps3=1.0)
    with pytest.raises(ControllerError):
        ControllerParams(ki=((0.0,), (-1.0,)))


@pytest.mark.parametrize(
    "bad",
    [
        {"accel_min_mps2": -math.inf},
        {"accel_max_mps2": math.inf},
        {"accel_min_mps2": -1e300},
        {"accel_max_mps2": 50.0},
    ],
)
def test_envelope_outside_the_production_limits_refused(bad: dict[str, float]) -> None:
    """The envelope may be narrowed, never widened beyond -3.5 ... +2.0 m/s^2 (ISO 15622):
    an infinite or wider limit would let limit_command emit anything the jerk allows."""
    with pytest.raises(ControllerError, match="envelope"):
        ControllerParams(**bad)  # type: ignore[arg-type]
    assert ControllerParams(accel_min_mps2=-3.0, accel_max_mps2=1.5).accel_max_mps2 == 1.5
