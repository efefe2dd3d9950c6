"""Collecting rows in any order: plan order out, one row per key, the finished rows kept."""

from __future__ import annotations

import csv
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from pacc.study.collect import RowJournal, RowKey, StudyInterrupted, collect, row_key
from pacc.study.report import FIELDS
from sim_bus.errors import SimError

KEYS: list[RowKey] = [("d1", "B", "predefined", t) for t in range(4)]


def _row(index: int) -> dict[str, Any]:
    driver, scenario, controller, trial = KEYS[index]
    row: dict[str, Any] = dict.fromkeys(FIELDS, 0)
    row.update(driver=driver, scenario=scenario, controller=controller, trial=trial)
    row["poi_pct"] = 10.0 + index
    return row


def _read(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


def _results(order: list[int], stop: BaseException | None = None) -> Iterator[tuple[int, Any]]:
    for n, index in enumerate(order):
        if stop is not None and n == 2:
            raise stop
        yield index, _row(index)


def test_rows_come_out_in_plan_order_and_stream_to_disk(tmp_path: Path) -> None:
    seen: list[int] = []
    journal = RowJournal(tmp_path / "drives.csv")

    def on_row(index: int, row: dict[str, Any]) -> None:
        seen.append(len(_read(tmp_path / "drives.csv")))  # on disk before the next arrives

    rows = collect(_results([2, 0, 3, 1]), KEYS, journal=journal, on_row=on_row)
    assert [row_key(r) for r in rows] == KEYS
    assert seen == [0, 1, 2, 3]
    assert [r["trial"] for r in _read(tmp_path / "drives.csv")] == ["0", "1", "2", "3"]
    assert not (tmp_path / "drives.csv.part").exists()


@pytest.mark.parametrize(
    ("order", "message"),
    [([0, 1, 1, 2, 3], "a second row"), ([0, 1, 2], "never came back")],
)
def test_a_row_twice_or_missing_is_an_error(order: list[int], message: str) -> None:
    with pytest.raises(SimError, match=message):
        collect(_results(order), KEYS)


def test_a_row_under_the_wrong_task_is_an_error() -> None:
    def swapped() -> Iterator[tuple[int, dict[str, Any]]]:
        yield 0, _row(1)

    with pytest.raises(SimError, match="returned the row of"):
        collect(swapped(), KEYS)


@pytest.mark.parametrize("stop", [KeyboardInterrupt(), RuntimeError("a drive failed")])
def test_finished_rows_are_kept_in_plan_order_when_stopped(
    stop: BaseException, tmp_path: Path
) -> None:
    journal = RowJournal(tmp_path / "drives.csv")
    expected: type[BaseException] = (
        StudyInterrupted if isinstance(stop, KeyboardInterrupt) else RuntimeError
    )
    with pytest.raises(expected) as info:
        collect(_results([3, 1, 0, 2], stop), KEYS, journal=journal)
    assert [r["trial"] for r in _read(tmp_path / "drives.csv")] == ["1", "3"]
    if isinstance(info.value, StudyInterrupted):
        assert info.value.kept == 2 and info.value.total == 4
        assert "interrupted: 2 of 4 drives finished and kept" in str(info.value)
