"""``pacc study``: the Table I runner — outputs, determinism across workers, arithmetic."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from ecu.dgpt import load_dgpt
from ecu.triplog import read_trip
from sim_bus import study
from sim_bus.study import StudyConfig, format_table, reduction_pct, run_study

SMALL = StudyConfig(
    drivers=("d1", "d4"),
    scenarios=("B",),
    controllers=("predefined", "irl+oa"),
    trials=1,
    seed=3,
    duration_s=25.0,
    workers=1,
)


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("irl-cache")


def _without_wall(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


def test_small_study_outputs_and_determinism(tmp_path: Path, cache: Path) -> None:
    one = run_study(SMALL, tmp_path / "w1", cache_dir=cache, progress=False)
    two = run_study(
        StudyConfig(**{**SMALL.__dict__, "workers": 2, "logs": False}),
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
    cfg = StudyConfig(
        drivers=("d1",), scenarios=("A", "B"), controllers=("predefined", "irl"), trials=2
    )
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
    assert reduction_pct(0.0, 1.0) != reduction_pct(0.0, 1.0)  # nan when the base is zero


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
    assert study.main([*argv, "--out", str(tmp_path), "-q"]) == 2
    assert message in capsys.readouterr().err


def test_adaptation_mode_from_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from ecu.adaptation import AdaptationParams

    cfg = StudyConfig(
        drivers=("d3",),
        scenarios=("B",),
        controllers=("predefined+oa",),
        trials=1,
        duration_s=30.0,
        adaptation=AdaptationParams(mode="timegap"),
    )
    jobs = study.plan(cfg, study.tables_for(cfg, None), tmp_path)
    assert [j.adaptation for j in jobs] == [cfg.adaptation]
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
    out: dict[str, list[dict[str, str]]] = {}
    for mode in ("paper", "timegap"):
        assert study.main([*argv, str(tmp_path / mode), "--adaptation-mode", mode]) == 0
        assert f"{mode} adaptation" in capsys.readouterr().out
        with (tmp_path / mode / "drives.csv").open() as fh:
            out[mode] = list(csv.DictReader(fh))
    # same drive, different adaptation: the ECU really used the mode
    assert (
        out["paper"][0]["poi_pct"] != out["timegap"][0]["poi_pct"]
        or out["paper"][0]["gap_error_rms_m"] != out["timegap"][0]["gap_error_rms_m"]
    )
