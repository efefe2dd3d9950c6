"""``pacc study --population``: the report, resuming a stopped run, refused options."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pacc.commands.study import main
from pacc.study.pipeline import ROWS, run
from pacc.study.spec import StudySpec, load_drivers, table1_method
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.population import draw_population
from tests.cli_util import exit_code

ARGS = ["--controllers", "predefined,predefined+oa", "--duration", "20", "--workers", "1"]


@pytest.mark.slow  # whole drives, as the other study tests
def test_population_study_reports_and_resumes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "pop"
    code = main(["--population", "2", "--seed", "3", "--out", str(out), "-q", *ARGS])
    assert code == 0
    text = capsys.readouterr().out
    assert "Population study — 2 drawn drivers, population seed 3" in text
    assert "Predefined + OA vs Predefined" in text and "Holm" in text
    assert "no collision: met (0)" in text
    lines = (out / ROWS).read_text(encoding="utf-8").splitlines()
    assert len(lines) == 5 and json.loads(lines[0])["fingerprint"]["seed"] == 3
    first = (out / "drives.csv").read_text(encoding="utf-8")
    assert first.count("\n") == 1 + 2 * 2  # header + 2 drivers x 2 controllers
    # a run killed after its first driver (and half a line of the next drive) resumes
    (out / ROWS).write_text("\n".join(lines[:3]) + "\n" + lines[3][:40], encoding="utf-8")
    cfg = StudySpec(
        drivers=("people:2:3",),
        scenarios=("B",),
        methods=(table1_method("predefined"), table1_method("predefined+oa")),
        trials=1,
        seed=3,
        duration_s=20.0,
        report="population",
        learn_in="direct",
        logs=False,
        workers=1,
        roads="per-driver",  # the population's default
    )
    rows = run(cfg, out, progress=False)
    assert len(rows) == 4
    again = (out / "drives.csv").read_text(encoding="utf-8").splitlines()
    # the re-run driver gives the same row except its wall time
    strip = [",".join(r.split(",")[:-1]) for r in first.splitlines()]
    assert [",".join(r.split(",")[:-1]) for r in again] == strip


@pytest.mark.slow
def test_population_refuses_bad_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = str(tmp_path / "x")
    assert main(["--population", "2", "--drivers", "d1", "--out", out]) == 2
    assert exit_code(main, ["--population", "-1", "--out", out, "-q"]) == 2
    assert "argument --population: '-1': need a whole number >= 1" in capsys.readouterr().err
    assert main(["--population", "1", "--seed", "1", "--out", out, "-q", *ARGS]) == 0
    # another configuration in the same folder is refused, the rows stay
    assert main(["--population", "1", "--seed", "2", "--out", out, "-q", *ARGS]) == 2
    assert "holds another study" in capsys.readouterr().err
    assert len((tmp_path / "x" / ROWS).read_text(encoding="utf-8").splitlines()) == 3


def test_the_people_draw_their_own_mismatch_and_headway_stays_by_name(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``--mismatch``/``--trip-shift`` are gone (the people population draws its own); the
    headway population is still a driver source by name, ``headway:N:SEED``."""
    for flag in ("--mismatch", "--trip-shift"):
        assert exit_code(main, ["--population", "2", flag, "1"]) == 2
        assert f"unrecognized arguments: {flag} 1" in capsys.readouterr().err
    drivers = load_drivers(StudySpec(drivers=("headway:3:4", "d1")))
    drawn = draw_population(3, 4, population="headway")
    assert list(drivers.values()) == [*drawn, BUILTIN_DRIVERS["d1"]]
    assert "mismatch" not in StudySpec().fingerprint()
