"""``pacc study``: the Table I runner — outputs, determinism across workers, arithmetic."""

from __future__ import annotations

import csv
import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cloud_sync.engine import InlineExecutor
from dbc.vocab.dgpt import Dgpt, predefined
from dbc.vocab.dgpt_file import load_dgpt
from dbc.vocab.triplog_file import read_trip
from ecu.adaptation import AdaptationParams
from pacc.commands.study import main
from pacc.study import pipeline
from pacc.study.drive import DriveConfig, predefined_table, run_drive
from pacc.study.pipeline import make_tables, plan, run
from pacc.study.report import format_table
from pacc.study.spec import StudySpec, road_seed, table1_method, validate
from pacc.study.stats import reduction_pct
from sim_bus.drivers import BUILTIN_DRIVERS, DriverParams
from sim_bus.lead.profile import LeadProfile
from tests.cli_util import exit_code


def methods(*names: str) -> tuple[Any, ...]:
    """Table I's controllers as methods."""
    return tuple(table1_method(n) for n in names)


SMALL = StudySpec(
    drivers=("d1", "d4"),
    scenarios=("B",),
    methods=methods("predefined", "irl+oa"),
    trials=1,
    seed=3,
    duration_s=25.0,
    workers=1,
    learn_in="direct",  # learned in-process and cached: the cloud loop has tests of its own
)


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("irl-cache")


def _without_wall(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


@pytest.mark.slow
def test_small_study_outputs_and_determinism(tmp_path: Path, cache: Path) -> None:
    one = run(SMALL, tmp_path / "w1", cache_dir=cache, progress=False)
    two = run(
        StudySpec(**{**SMALL.__dict__, "workers": 2, "logs": False}),
        tmp_path / "w2",
        cache_dir=cache,
        progress=False,
    )
    assert len(one) == 4
    assert _without_wall(one) == _without_wall(two)  # workers do not change results
    out = tmp_path / "w1"
    table = (out / "table1.md").read_text()
    assert "| d4 | Unseen (B) |" in table and "paper (average)" in table
    with (out / "drives.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert [r["controller"] for r in rows] == ["predefined", "irl+oa"] * 2
    assert all(r["collision"] == "0" for r in rows)
    assert all(float(r["acc_on_s"]) > 15.0 for r in rows)
    assert (out / "study.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    irl = load_dgpt(out / "irl" / "d4.json")
    assert irl.source == "irl" and irl.driver_id == "d4"
    logs = sorted((out / "logs").glob("*.mcap"))
    assert len(logs) == 4
    trip = read_trip(logs[0])
    assert trip.meta["mode"] == "acc" and trip.meta["driver_id"] == "d1"
    assert trip.t_s[-1] == pytest.approx(25.0, abs=0.2)
    assert not (tmp_path / "w2" / "logs").exists()


def test_table_arithmetic() -> None:
    cfg = StudySpec(drivers=("d1",), scenarios=("A", "B"), methods=methods("predefined", "irl"),
                    trials=2)  # fmt: skip
    rows = []
    for scenario, base in (("A", 20.0), ("B", 10.0)):
        for trial, extra in ((0, 0.0), (1, 2.0)):
            common = {
                "driver": "d1",
                "scenario": scenario,
                "trial": trial,
                "collision": 0,
                "min_gap_m": 9.0,
                "min_ttc_s": 5.0,
            }
            rows.append(
                {**common, "controller": "predefined", "poi_pct": base + extra, "nim_per_min": 4.0}
            )
            rows.append(
                {**common, "controller": "irl", "poi_pct": base / 2 + extra, "nim_per_min": 2.0}
            )
    text = format_table(cfg, rows)
    assert "| d1 | Seen (A) | 21.0 % | 4.0 | 11.0 % | 2.0 |" in text
    assert "| **average** | | **16.0 %** | **4.0** | **8.5 %** | **2.0** |" in text
    assert "IRL: PoI 46.9 % (28.6 %), NIM 50.0 % (40.2 %)" in text
    assert "0 collisions, min gap 9.00 m" in text
    assert math.isnan(reduction_pct(0.0, 1.0))  # nan when the base is zero
    zero = [{**r, "poi_pct": 0.0} for r in rows]  # Predefined never overridden: no reduction
    text = format_table(cfg, zero)
    assert "IRL: PoI n/a (28.6 %)" in text and "nan" not in text
    assert reduction_pct(20.0, 15.0) == pytest.approx(25.0)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--controllers", "pid"], "unknown controllers"),
        (["--scenarios", "Z"], "unknown scenarios"),
        (["--drivers", "nobody.toml"], "nobody.toml"),
        (["--trials", "0"], "--trials"),
    ],
)
def test_bad_options(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert exit_code(main, [*argv, "--out", str(tmp_path), "-q"]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow
def test_adaptation_mode_from_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = StudySpec(
        drivers=("d3",),
        scenarios=("B",),
        methods=methods("predefined+oa"),
        trials=1,
        duration_s=30.0,
        adaptation=AdaptationParams(mode="timegap"),
    )
    drivers = validate(cfg)
    tables = make_tables(cfg, drivers, tmp_path, InlineExecutor(), None)
    drives = plan(cfg, drivers, tables, tmp_path)
    assert [d.config.adaptation for d in drives] == [cfg.adaptation]
    argv = [
        "--drivers",
        "d3",
        "--scenarios",
        "B",
        "--controllers",
        "predefined+oa",
        "--trials",
        "1",
        "--duration",
        "30",
        "--no-logs",
        "-q",
        "--out",
    ]
    rows: dict[str, dict[str, str]] = {}
    for mode in ("paper", "timegap", None):
        # --adaptation-mode is the old spelling of --adaptation
        flag = (
            []
            if mode is None
            else ["--adaptation-mode" if mode == "paper" else "--adaptation", mode]
        )
        assert main([*argv, str(tmp_path / str(mode)), *flag]) == 0
        if mode is not None:
            assert f"{mode} adaptation" in capsys.readouterr().out
        with (tmp_path / str(mode) / "drives.csv").open() as fh:
            (row,) = csv.DictReader(fh)
        rows[str(mode)] = {k: v for k, v in row.items() if k != "wall_s"}
    # the same drive with another adaptation differs; without the flag it is the ECU's default
    assert int(rows["paper"]["adaptations"]) >= 1
    assert rows["paper"] != rows["timegap"]
    assert rows["None"] == rows[AdaptationParams().mode]


# -- drivers given as files: everything named by driver id, under --out -----------------

QUICK = [
    "--direct",  # the fake learner below stands in for the in-process one
    "--scenarios",
    "B",
    "--controllers",
    "predefined,irl",
    "--trials",
    "1",
    "--duration",
    "5",
    "--workers",
    "1",
    "-q",
]


@pytest.fixture
def learned(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The drivers whose IRL table the study asked for (a predefined stand-in, no learning)."""
    calls: list[str] = []

    def fake_irl_table(driver: DriverParams, seed: int, cache_dir: Path | None) -> Dgpt:
        calls.append(driver.driver_id)
        return predefined(2.5, driver_id=driver.driver_id, created_utc="2000-01-01T00:00:00Z")

    monkeypatch.setattr(pipeline, "irl_table", fake_irl_table)
    return calls


def _driver_file(folder: Path, driver_id: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{driver_id}-file.toml"
    path.write_text(f'[driver]\nbase = "d2"\ndriver_id = "{driver_id}"\n')
    return path


def _check_named_by_id(out: Path, driver_id: str) -> None:
    assert load_dgpt(out / "irl" / f"{driver_id}.json").driver_id == driver_id
    with (out / "drives.csv").open() as fh:
        assert {r["driver"] for r in csv.DictReader(fh)} == {driver_id}
    assert f"| {driver_id} | Unseen (B) |" in (out / "table1.md").read_text()
    logs = sorted(p.name for p in (out / "logs").iterdir())
    assert logs == [f"{driver_id}_B_irl_t0.mcap", f"{driver_id}_B_predefined_t0.mcap"]


def test_driver_file_by_absolute_path_writes_only_under_out(
    tmp_path: Path, learned: list[str]
) -> None:
    path = _driver_file(tmp_path / "elsewhere", "alice")
    out = tmp_path / "out"
    assert main(["--drivers", str(path.resolve()), *QUICK, "--out", str(out)]) == 0
    assert learned == ["alice"]
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]  # nothing beside it
    _check_named_by_id(out, "alice")


def test_driver_file_by_relative_path_with_a_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, learned: list[str]
) -> None:
    _driver_file(tmp_path / "drivers", "bob")
    monkeypatch.chdir(tmp_path)
    assert main(["--drivers", "drivers/bob-file.toml", *QUICK, "--out", "out"]) == 0
    assert learned == ["bob"]
    _check_named_by_id(tmp_path / "out", "bob")


@pytest.mark.parametrize("problem", ["same id twice", "out is a file"])
def test_errors_come_before_learning(
    problem: str, tmp_path: Path, learned: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    drivers = "d1"
    out = tmp_path / "out"
    if problem == "same id twice":
        drivers = f"d1,{_driver_file(tmp_path / 'drivers', 'd1')}"
        message = "two drivers have the id 'd1'"
    else:
        out.write_text("not a folder")
        message = str(out)
    assert main(["--drivers", drivers, *QUICK, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert learned == []


def test_roads_shared_or_one_per_driver(tmp_path: Path) -> None:
    spec = StudySpec(drivers=("headway:3:5",), scenarios=("B",), methods=methods("predefined"),
                     trials=2, seed=5, learn_in="direct")  # fmt: skip
    drivers = validate(spec)
    tables = make_tables(spec, drivers, tmp_path, InlineExecutor(), None)
    shared = plan(spec, drivers, tables, tmp_path)
    assert {d.profile_seed for d in shared} == {5}
    own = plan(StudySpec(**{**spec.__dict__, "roads": "per-driver"}), drivers, tables, tmp_path)
    seeds = {d.config.driver_id: d.profile_seed for d in own}
    assert len(set(seeds.values())) == 3 and 5 not in seeds.values()
    # a driver's road is its own, whatever other drivers the study has
    more = validate(StudySpec(**{**spec.__dict__, "drivers": ("headway:4:5",)}))
    assert all(road_seed(5, i) == seeds[i] for i in list(more)[:3])
    assert exit_code(main, ["--roads", "everywhere", "--out", str(tmp_path), "-q"]) == 2


def test_a_driver_who_never_closes_in_engages_the_acc_at_thirty_seconds() -> None:
    # the lead pulls away to 23 m/s and by hand it wants 19 m/s: the gap never comes to feel
    # right (as behind some leads for drawn drivers with a comfortable deceleration of 0.2 m/s^2)
    driver = dataclasses.replace(BUILTIN_DRIVERS["d2"], desired_speed_mps=19.0)
    t = np.arange(0.0, 120.05, 0.1)
    road = LeadProfile("away", t, np.minimum(20.0 + 2.0 * t, 23.0))
    cfg = DriveConfig(scenario="B", driver_id="d2", controller="predefined", seed=3,
                      duration_s=120.0, engage_s=5.0)  # fmt: skip
    result = run_drive(cfg, driver, predefined_table(driver), road)
    assert 85.0 < result.metrics.acc_on_s <= 90.0  # SET at 30 s, not before
    assert not result.collision
