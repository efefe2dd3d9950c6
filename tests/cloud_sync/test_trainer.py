"""The trainer: recovery of a known preference, determinism, fine-tuning, the output table."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cloud_sync.errors import TrainingError
from cloud_sync.irl.config import IrlConfig
from cloud_sync.irl.extract import empirical_baseline
from cloud_sync.irl.features import FeatureConfig
from cloud_sync.irl.sources.synthetic import lead_speed
from cloud_sync.irl.trainer import LearnResult, fine_tune, learn_dgpt
from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import SafetyBounds, predefined
from dbc.vocab.dgpt_file import load_dgpt, save_dgpt
from dbc.vocab.triplog import Trip
from tests.cloud_sync.conftest import takeover_segment

D0, T = 4.0, 1.6


@pytest.fixture(scope="module")
def learned(syn_trips: list[Trip]) -> LearnResult:
    return learn_dgpt(syn_trips, driver_id="syn", condition="dry", seed=0)


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


@pytest.mark.slow
def test_recovers_known_preference(learned: LearnResult) -> None:
    table, cov = learned.table, learned.covered
    truth = D0 + T * table.speed_mps
    assert cov.sum() >= 30  # the drives cover 6..28 m/s or so
    assert rmse(table.gap_m[cov], truth[cov]) <= 2.0
    # a wrong preference is far: the test can fail
    assert rmse(table.gap_m[cov], (D0 + 1.0 * table.speed_mps)[cov]) > 4.0
    assert learned.baseline is not None
    assert rmse(learned.baseline.gap_m[cov], truth[cov]) <= 2.0


@pytest.mark.slow
def test_non_monotonic_preference_recovered_without_a_fitted_line(
    follower: Callable[..., Trip],
) -> None:
    """A driver whose gap peaks at 17 m/s (45 m) and shrinks at both ends (35 m at 8 and
    26 m/s): the time-gap basis is fitted to nothing, and the table rises and falls again."""

    def hump(v: float) -> float:
        return 45.0 - 0.12 * (v - 17.0) ** 2

    trips = [follower(s, preference=hump, v_lo=5.0, v_hi=28.0) for s in range(4)]
    res = learn_dgpt(trips, driver_id="hump")
    feats = res.table.meta["features"]
    assert feats["ref_c0_m"] == 0.0 and feats["ref_c1_s"] == 0.0
    assert feats["time_gap_floor_mps"] > 0.0
    v, g, cov = res.table.speed_mps, res.table.gap_m, res.covered
    assert cov[(v >= 8.0) & (v <= 27.0)].all()
    truth = np.array([hump(float(x)) for x in v])
    assert rmse(g[cov], truth[cov]) <= 5.5
    inner = (v >= 8.0) & (v <= 27.0)
    peak = int(np.argmax(np.where(inner, g, -np.inf)))
    assert 15.0 <= v[peak] <= 23.0
    assert g[peak] - g[v == 8.0][0] >= 8.0 and g[peak] - g[v == 27.0][0] >= 3.0


def lazy_follower(seed: int) -> Trip:
    """5 min at 10 Hz of a driver who keeps 4 m + 1.6 s·v in steady following, closes on a
    slower lead at once (gain 0.6 /s on dv) and lets a faster one pull away (0.15 /s): its gap
    opens further in transients than it closes, so its gaps average above the preference."""
    dt, n = 0.1, 3000
    vl = lead_speed(np.random.default_rng(seed), n, dt, 5.0, 30.0)
    v, g = np.empty(n), np.empty(n)
    v[0], g[0] = vl[0], D0 + T * vl[0]
    for i in range(n - 1):
        dv = vl[i] - v[i]
        a = 0.08 * (g[i] - D0 - T * v[i]) + (0.6 if dv < 0.0 else 0.15) * dv
        v[i + 1] = max(v[i] + float(np.clip(a, -3.5, 2.0)) * dt, 0.0)
        g[i + 1] = g[i] + dv * dt
    t = np.arange(n) * dt
    return Trip.manual(t, v, g, vl, np.gradient(v, t), {"driver_id": "lazy"})


@pytest.mark.slow
def test_gap_preference_is_read_from_steady_following() -> None:
    """The (v, g) reward counts at relative speed ≈ 0 only (κ, FeatureConfig.dv_width_mps):
    the lazy follower's table sits near its preference; weighting every dv alike (width 0)
    puts it where its transients pulled the gaps, 0.8 m above."""
    trips = [lazy_follower(s) for s in range(4)]

    def offset(width: float) -> float:
        config = IrlConfig(features=FeatureConfig(dv_width_mps=width))
        res = learn_dgpt(trips, driver_id="lazy", config=config)
        v, cov = res.table.speed_mps, res.covered
        return float(np.mean(res.table.gap_m[cov] - (D0 + T * v[cov])))

    steady, flat = offset(IrlConfig().features.dv_width_mps), offset(0.0)
    assert abs(steady) <= 0.45 and flat >= 0.6


@pytest.mark.slow
def test_output_table_is_a_valid_irl_dgpt(learned: LearnResult, tmp_path: Path) -> None:
    t = learned.table
    assert t.source == "irl" and t.driver_id == "syn" and t.condition == "dry"
    assert t.version == 1
    t.check_bounds(SafetyBounds())
    meta = t.meta
    assert len(meta["training_digest"]) == 64
    assert len(meta["coverage_s"]) == t.speed_mps.size
    assert len(meta["alpha"]) == learned.mdp.features.n_features
    assert meta["covered_mps"] and meta["covered_mps"][0][0] > 0.0
    path = tmp_path / "d.json"
    save_dgpt(t, path)
    back = load_dgpt(path)
    assert np.allclose(back.gap_m, t.gap_m) and back.meta["alpha"] == meta["alpha"]


@pytest.mark.slow
def test_uncovered_speeds_follow_time_gap_continuation(learned: LearnResult) -> None:
    t, cov = learned.table, learned.covered
    top = int(np.flatnonzero(cov)[-1])
    headway = (t.gap_m[top] - 4.0) / t.speed_mps[top]
    assert t.gap_m[-1] == pytest.approx(
        min(4.0 + headway * 40.0, SafetyBounds().upper_m(40.0)), rel=1e-6
    )
    assert t.gap_m[0] == pytest.approx(4.0)


@pytest.mark.slow
def test_pure_function_of_config_seed_and_data(
    syn_trips: list[Trip], syn_learned_one: LearnResult, learned: LearnResult
) -> None:
    again = syn_learned_one
    same = learn_dgpt(syn_trips[:1], driver_id="syn", seed=0)
    other_seed = learn_dgpt(syn_trips[:1], driver_id="syn", seed=7)
    assert np.array_equal(again.table.gap_m, same.table.gap_m)
    digest = again.table.meta["training_digest"]
    assert digest == same.table.meta["training_digest"] != learned.table.meta["training_digest"]
    # the objective is convex: the seed only moves the start, not the answer
    assert np.max(np.abs(other_seed.table.gap_m - again.table.gap_m)) < 0.5


@pytest.mark.slow
def test_fine_tune_moves_toward_takeovers_and_keeps_uncovered(
    learned: LearnResult, follower: Callable[..., Trip]
) -> None:
    """ACC trips at 15-20 m/s where the driver, in override, keeps 4 m + 1.0 s·v."""
    trips = []
    for seed in (21, 22):
        t = follower(seed, headway_s=1.0, minutes=2.0, v_lo=15.0, v_hi=20.0)
        state = np.full(len(t), AccState.ACTIVE)
        for start in range(0, len(t), 300):
            state[start : start + 150] = AccState.OVERRIDE  # 15 s every 30 s
        trips.append(replace(t, acc_state=state, meta={**t.meta, "mode": "acc"}))
    init = learned.table
    res = fine_tune(trips, init, seed=0)
    new = res.table
    assert new.version == init.version + 1 and new.source == "irl"
    assert new.meta["parent_version"] == init.version
    band = (new.speed_mps >= 16.0) & (new.speed_mps <= 19.0)
    want = 4.0 + 1.0 * new.speed_mps[band]
    before = np.abs(init.gap_m[band] - want).mean()
    after = np.abs(new.gap_m[band] - want).mean()
    assert after < 0.6 * before
    # speeds the takeovers do not cover keep the previous table exactly
    far = ~res.covered
    assert far.sum() > 40
    assert np.array_equal(new.gap_m[far], init.gap_m[far])


@pytest.mark.slow
def test_fine_tune_learns_from_short_takeovers(learned: LearnResult) -> None:
    """Pedal presses of 0.7 s, shorter than a decision, are still corrections: a new version
    (the incremental study's people drivers, whose takeovers all were this short)."""
    presses = [(40, 47, "accel"), (90, 97, "brake"), (140, 147, "accel")]
    segments = [takeover_segment(seed, presses) for seed in range(30, 34)]
    new = fine_tune(segments, learned.table, seed=0).table
    assert new.version == learned.table.version + 1
    assert new.meta["n_segments"] == 12


def test_fine_tune_needs_an_irl_table(syn_trips: list[Trip]) -> None:
    with pytest.raises(TrainingError, match="needs an IRL table"):
        fine_tune(syn_trips[:1], predefined(1.5))


def test_baseline_same_format(syn_trips: list[Trip]) -> None:
    b = empirical_baseline(syn_trips, driver_id="syn")
    assert b.meta["method"] == "empirical" and b.speed_mps.size == 81
    b.check_bounds()


def test_init_of_another_driver_refused(syn_trips: list[Trip]) -> None:
    with pytest.raises(TrainingError, match="belongs to driver 'syn', not 'other'"):
        learn_dgpt(syn_trips[:1], driver_id="other", init=predefined(1.5, driver_id="syn"))


@pytest.mark.parametrize(
    "field_name,value",
    [
        ("takeover_weight", float("nan")),
        ("takeover_weight", -1.0),
        ("takeover_weight", float("inf")),
        ("min_coverage_s", 0.0),
        ("gap_resolution_m", float("nan")),
        ("min_total_demo_s", -5.0),
        ("horizon_steps", 0),
    ],
)
def test_bad_config_refused(field_name: str, value: float) -> None:
    with pytest.raises(TrainingError, match=field_name):
        IrlConfig(**{field_name: value})  # type: ignore[arg-type]
