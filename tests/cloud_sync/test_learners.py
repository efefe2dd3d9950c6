"""Learners behind one interface: irl, empirical, gp, and one by entry point."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from cloud_sync.errors import DemoError
from cloud_sync.learners import LearnerError, learn, make_learner
from dbc.vocab.dgpt import Dgpt, SafetyBounds, predefined
from dbc.vocab.dgpt_file import load_dgpt
from dbc.vocab.plugins import PluginError
from pacc.commands.cloud import main as cloud_main
from pacc.study.irl_table import manual_trips
from sim_bus.dataset import load_human_pairs
from sim_bus.drivers import BUILTIN_DRIVERS


def _rmse_to_truth(table: Dgpt, name: str) -> float:
    driver = BUILTIN_DRIVERS[name]
    covered = np.asarray(table.meta["covered"], dtype=bool)
    truth = driver.preferred_gap_m(table.speed_mps)
    return float(np.sqrt(np.mean((table.gap_m[covered] - truth[covered]) ** 2)))


@pytest.mark.parametrize(
    ("spec", "limit_m"), [("empirical", 1.0), ("gp", 1.0), ("test-timegap", 4.0)]
)
def test_each_learner_recovers_a_drivers_preference(spec: str, limit_m: float) -> None:
    """d2 drives manual1..4 by hand; every learner's table is within ``limit_m`` RMS of the
    true g*(v) at the speeds it covers (test-timegap, one time gap claimed at every speed, is
    the crudest)."""
    trips = manual_trips(BUILTIN_DRIVERS["d2"], 0)
    table = learn(spec, trips, driver_id="d2", seed=0)
    assert table.meta["learner"] == spec and table.meta["learn_s"] >= 0
    assert sum(table.meta["covered"]) >= 20
    assert _rmse_to_truth(table, "d2") < limit_m
    bounds = SafetyBounds()
    assert np.all(table.gap_m >= bounds.lower_m(table.speed_mps) - 1e-9)


def test_the_gp_learner_is_uncertain_away_from_its_data() -> None:
    trips = manual_trips(BUILTIN_DRIVERS["d1"], 0)
    table = learn("gp", trips, driver_id="d1", seed=0)
    covered = np.asarray(table.meta["covered"], dtype=bool)
    assert not covered[-1]  # 40 m/s: never driven
    assert table.meta["gp"]["length_mps"] > 0


def test_learners_refuse_what_they_cannot_learn_from() -> None:
    trip = manual_trips(BUILTIN_DRIVERS["d1"], 0)[0]
    with pytest.raises(DemoError):
        learn(
            "gp",
            [
                trip.__class__.manual(
                    trip.t_s[:5],
                    trip.v_mps[:5],
                    trip.gap_m[:5] * np.nan,
                    trip.v_lead_mps[:5],
                    trip.a_mps2[:5],
                    {},
                )
            ],
            driver_id="x",
            seed=0,
        )
    with pytest.raises(PluginError, match="one of empirical, gp, irl"):
        make_learner("svm")


class NoCoverage:
    def learn(self, trips: object, *, driver_id: str, seed: int) -> Dgpt:
        return predefined(1.5)


def test_a_learner_without_coverage_meta_is_refused() -> None:
    with pytest.raises(LearnerError, match="covered"):
        learn("tests.cloud_sync.test_learners:NoCoverage", [], driver_id="x", seed=0)


def test_pacc_cloud_learn_with_another_learner(tmp_path: Path) -> None:
    pair = load_human_pairs()[0]
    csv = tmp_path / "pair.csv"
    t = np.arange(pair.v_follower_mps.size) * pair.dt_s
    lines = ["t,v_follower,spacing,v_leader"] + [
        f"{a},{b},{c},{d}"
        for a, b, c, d in zip(t, pair.v_follower_mps, pair.gap_m, pair.v_leader_mps, strict=True)
    ]
    csv.write_text("\n".join(lines) + "\n", encoding="utf-8")
    out = tmp_path / "gp.json"
    argv = ["learn", "--learner", "gp", "--demos", str(csv), "--driver", "h1", "-o", str(out)]
    assert cloud_main(argv) == 0
    table = load_dgpt(out)
    assert table.meta["method"] == "gp" and table.driver_id == "h1"
    assert cloud_main([*argv[:2], "nope", *argv[3:]]) == 2


class Tiny:
    """Covers every bin with a 0.5-m gap: far inside the safety bounds' floor at speed."""

    def learn(self, trips: object, *, driver_id: str, seed: int) -> Dgpt:
        table = predefined(1.5)
        gaps = np.full(table.speed_mps.size, 0.5)
        return dataclasses.replace(table, gap_m=gaps, meta={"covered": [True] * gaps.size})


def test_a_learner_table_outside_the_safety_bounds_is_refused() -> None:
    with pytest.raises(LearnerError, match="learner 'tests.cloud_sync.test_learners:Tiny'"):
        learn("tests.cloud_sync.test_learners:Tiny", [], driver_id="x", seed=0)
