"""Plant against closed-form kinematics, actuator lag, standstill and collision detection."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sim_bus.errors import DriveError
from sim_bus.plant import Plant, PlantConfig, PlantState, lag_factor
from sim_bus.world import WorldConfig

EXACT = PlantConfig(dt_s=0.01, actuator_tau_s=0.0, sigma_v_mps=0.0, sigma_g_m=0.0)


@given(
    v0=st.floats(5.0, 30.0),
    vf=st.floats(0.0, 35.0),
    a=st.floats(-1.0, 1.5),
    g0=st.floats(20.0, 100.0),
)
def test_constant_acceleration_matches_closed_form(
    v0: float, vf: float, a: float, g0: float
) -> None:
    car = Plant(EXACT, PlantState(v0, 0.0, g0), np.random.default_rng(0))
    n = 300  # 3 s: the speed stays positive for these ranges
    for _ in range(n):
        car.advance(a, vf, 0.0)
    t = n * EXACT.dt_s
    assert car.v_mps == pytest.approx(v0 + a * t, abs=1e-9)
    assert car.gap_m == pytest.approx(g0 + (vf - v0) * t - 0.5 * a * t * t, abs=1e-7)
    assert car.x_m == pytest.approx(v0 * t + 0.5 * a * t * t, abs=1e-7)


def test_gap_sign_ego_acceleration_shrinks_the_gap() -> None:
    # the sign fix of docs/paper-notes.md: ½(a_f − a)Δt², so ego acceleration closes the gap
    def gap_after(a_cmd: float, a_lead: float) -> float:
        car = Plant(EXACT, PlantState(20.0, 0.0, 50.0), np.random.default_rng(0))
        car.advance(a_cmd, 20.0, a_lead)
        return car.gap_m

    assert gap_after(2.0, 0.0) < 50.0 < gap_after(-2.0, 0.0)
    assert gap_after(0.0, 2.0) > 50.0


def test_actuator_lag_is_first_order() -> None:
    cfg = PlantConfig(dt_s=0.01, actuator_tau_s=0.4, sigma_v_mps=0.0, sigma_g_m=0.0)
    car = Plant(cfg, PlantState(20.0, 0.0, 50.0), np.random.default_rng(0))
    for k in range(1, 201):
        car.advance(-2.0, 20.0, 0.0)
        assert car.a_mps2 == pytest.approx(-2.0 * (1.0 - math.exp(-k * 0.01 / 0.4)), rel=1e-9)
    assert lag_factor(0.01, 0.0) == 1.0


def test_speed_never_negative_and_standstill_holds() -> None:
    car = Plant(EXACT, PlantState(1.0, 0.0, 30.0), np.random.default_rng(0))
    for _ in range(500):
        car.advance(-5.0, 0.0, 0.0)
        assert car.v_mps >= 0.0
    assert car.v_mps == 0.0
    # it stopped after v²/(2·5) = 0.1 m, to within one step of travel
    assert car.x_m == pytest.approx(0.1, abs=0.011)


def test_collision_is_detected_and_reported() -> None:
    car = Plant(EXACT, PlantState(20.0, 0.0, 5.0), np.random.default_rng(0))
    while not car.collided and car.t_s < 5.0:
        car.advance(0.0, 10.0, 0.0)
    assert car.collided
    assert car.collision_t_s == pytest.approx(0.5, abs=0.011)
    assert car.gap_m <= 0.0


def test_noise_has_the_configured_std_per_tenth_second() -> None:
    cfg = PlantConfig(dt_s=0.01, actuator_tau_s=0.0, sigma_v_mps=0.05, sigma_g_m=0.0)
    car = Plant(cfg, PlantState(20.0, 0.0, 1e6), np.random.default_rng(3))
    v = [car.v_mps]
    for _ in range(40_000):
        car.advance(0.0, 20.0, 0.0)
        v.append(car.v_mps)
    incr = np.diff(np.asarray(v)[::10])  # increments over 0.1 s
    assert np.std(incr) == pytest.approx(0.05, rel=0.05)


def test_non_finite_command_is_treated_as_zero() -> None:
    car = Plant(EXACT, PlantState(20.0, 0.0, 50.0), np.random.default_rng(0))
    car.advance(math.nan, 20.0, 0.0)
    assert car.v_mps == 20.0 and math.isfinite(car.gap_m)


@pytest.mark.parametrize(
    "field_name,value",
    [
        ("dt_s", 0.0),
        ("dt_s", math.nan),
        ("actuator_tau_s", math.inf),
        ("sigma_v_mps", -1.0),
        ("sigma_g_m", math.nan),
        ("accel_min_mps2", 1.0),
        ("accel_max_mps2", math.nan),
    ],
)
def test_bad_config_rejected(field_name: str, value: float) -> None:
    with pytest.raises(DriveError):
        PlantConfig(**{field_name: value})


@pytest.mark.parametrize(
    "field_name,value",
    [
        ("driver_dt_s", 0.015),
        ("driver_dt_s", math.nan),
        ("engage_s", -1.0),
        ("initial_gap_factor", 0.0),
        ("initial_gap_factor", math.inf),
    ],
)
def test_bad_world_config_rejected(field_name: str, value: float) -> None:
    with pytest.raises(DriveError):
        WorldConfig(**{field_name: value})  # type: ignore[arg-type]
    assert WorldConfig().driver_dt_s == 0.05  # the defaults are valid
