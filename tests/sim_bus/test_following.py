"""Car-following models against a real trajectory: the closed-loop replay and the fit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sim_bus.dataset import load_human_pairs
from sim_bus.drivers import DriverParams
from sim_bus.following import MODELS, fit_pair, nrmse, simulate
from sim_bus.idm import idm_plus_accel


def _short(n: int = 1200):  # type: ignore[no-untyped-def]
    p = load_human_pairs()[0]
    return dataclasses.replace(
        p, v_leader_mps=p.v_leader_mps[:n], v_follower_mps=p.v_follower_mps[:n], gap_m=p.gap_m[:n]
    )


def test_the_drivers_model_is_the_drivers_idm_plus() -> None:
    """One step of ``driver`` (no delay) is sim_bus.idm's IDM+ for the same parameters, its
    headway over speed included."""
    d = DriverParams(
        "x",
        standstill_m=3.0,
        headway_speeds_mps=(10.0, 30.0),
        headway_s=(1.1, 2.3),
        accel_max_mps2=1.3,
    )
    pair = _short()
    k = int(np.argmax((pair.v_follower_mps > 12.0) & (pair.v_follower_mps < 28.0)))
    x = np.array(
        [[d.accel_max_mps2, d.decel_comfort_mps2, 1.1, 3.0, d.desired_speed_mps, 0.0, 2.3]]
    )
    _, v = simulate("driver", x, pair, k, k + 2)
    v0, vl, g = pair.v_follower_mps[k], pair.v_leader_mps[k], pair.gap_m[k]
    assert 12.0 < v0 < 28.0
    a = idm_plus_accel(v0, vl, g, float(d.preferred_gap_m(v0)), d)
    assert abs(v[1, 0] - (v0 + a * pair.dt_s)) < 1e-9


def test_replay_keeps_the_real_lead_and_sets_apart_parameter_sets() -> None:
    pair = _short()
    good = np.array([[1.5, 2.0, 1.5, 2.0, 33.0], [1.5, 2.0, 3.0, 2.0, 33.0]])
    gap, vel = simulate("idm", good, pair, 100, 1200)
    assert gap.shape == vel.shape == (1100, 2)
    assert np.all(gap[0] == pair.gap_m[100])  # starts from the real state
    err = nrmse(gap, pair.gap_m[100:])
    assert err[1] > err[0]  # twice the real headway is far off the real spacing


def test_fit_beats_a_guess_and_scores_the_held_out_part() -> None:
    pair = _short()
    fit = fit_pair("ctg", pair, maxiter=8)
    assert len(fit.params) == len(MODELS["ctg"])
    guess, _ = simulate("ctg", np.array([[0.1, 0.1, 3.0, 5.0]]), pair, 0, 600)
    assert fit.fit_spacing < float(nrmse(guess, pair.gap_m[:600])[0])
    assert 0.0 < fit.spacing < 1.0 and 0.0 < fit.speed < 1.0


def test_a_reverse_fit_calibrates_on_the_second_half_and_scores_the_first() -> None:
    pair = _short()
    fit = fit_pair("ctg", pair, maxiter=8, reverse=True)
    guess, _ = simulate("ctg", np.array([[0.1, 0.1, 3.0, 5.0]]), pair, 600, 1200)
    assert fit.fit_spacing < float(nrmse(guess, pair.gap_m[600:])[0])
    first, _ = simulate("ctg", np.array(fit.params), pair, 0, 600)
    # the parameters are kept to 4 decimals
    assert fit.spacing == pytest.approx(float(nrmse(first, pair.gap_m[:600])[0]), rel=1e-2)
