"""Collecting a study's rows as the engine hands them back, in any order, into drives.csv.

Each row is keyed by (driver, scenario, controller, trial). :class:`RowJournal` appends every
row to ``drives.csv`` the moment it arrives (flushed, so a killed study keeps what finished)
and, at the end or on Ctrl-C, rewrites the file in plan order through a temporary file and a
rename. :func:`collect` refuses a second row for one key: a rerun task (a worker lost
mid-study) replaces nothing and repeats nothing.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import IO, Any

from pacc.study.report import FIELDS
from sim_bus.errors import SimError

#: a row's identity in drives.csv: (driver, scenario, controller, trial)
RowKey = tuple[str, str, str, int]


def row_key(row: dict[str, Any]) -> RowKey:
    """The (driver, scenario, controller, trial) of a drives.csv row."""
    return (str(row["driver"]), str(row["scenario"]), str(row["controller"]), int(row["trial"]))


class StudyInterrupted(SimError):
    """The study was stopped (Ctrl-C); the rows that had finished are in drives.csv."""

    def __init__(self, kept: int, total: int, path: Path | None) -> None:
        where = f" in {path}" if path is not None else ""
        super().__init__(f"interrupted: {kept} of {total} drives finished and kept{where}")
        self.kept = kept
        self.total = total


class RowJournal:
    """``drives.csv`` written as rows arrive; :meth:`finish` puts them in plan order."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._fh: IO[str] | None = path.open("w", newline="", encoding="utf-8")
        self._writer = csv.DictWriter(self._fh, fieldnames=FIELDS)
        self._writer.writeheader()
        self._fh.flush()

    def append(self, row: dict[str, Any]) -> None:
        """One finished row, on disk before the next one is waited for."""
        assert self._fh is not None, "journal already finished"
        self._writer.writerow(row)
        self._fh.flush()

    def finish(self, rows: Sequence[dict[str, Any]]) -> None:
        """Replace the file by ``rows`` (plan order) atomically; close the journal."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None
        tmp = self.path.with_name(self.path.name + ".part")
        with tmp.open("w", newline="", encoding="utf-8") as fh:
            writer = csv.DictWriter(fh, fieldnames=FIELDS)
            writer.writeheader()
            writer.writerows(rows)
            fh.flush()
            os.fsync(fh.fileno())
        tmp.replace(self.path)


def collect(
    results: Iterator[tuple[int, dict[str, Any]]],
    keys: Sequence[RowKey],
    *,
    journal: RowJournal | None = None,
    on_row: Callable[[int, dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """The rows of ``results`` ((task index, row) in any order) in task order.

    ``keys[i]`` is task i's row key; a row whose key does not match its task, or a second row
    for one key, is a SimError. Each row goes to ``on_row`` (logs, progress) and ``journal``
    as it arrives. Ctrl-C (KeyboardInterrupt) or a task's error closes ``results`` (the engine
    cancels what has not run) and rewrites the journal with the rows that finished, in task
    order; Ctrl-C then raises :class:`StudyInterrupted`, an error itself.
    """
    by_index: dict[int, dict[str, Any]] = {}
    try:
        for index, row in results:
            if row_key(row) != keys[index]:
                raise SimError(
                    f"task {index} returned the row of {row_key(row)}, not {keys[index]}"
                )
            if index in by_index:
                raise SimError(f"a second row for {keys[index]}: a task ran twice")
            by_index[index] = row
            if on_row is not None:
                on_row(index, row)
            if journal is not None:
                journal.append(row)
    except BaseException as exc:
        close = getattr(results, "close", None)
        if close is not None:
            close()
        kept = _in_order(by_index)
        if journal is not None:  # what finished stays, in plan order, whatever stopped us
            journal.finish(kept)
        if isinstance(exc, KeyboardInterrupt):
            path = journal.path if journal is not None else None
            raise StudyInterrupted(len(kept), len(keys), path) from None
        raise
    missing = [keys[i] for i in range(len(keys)) if i not in by_index]
    if missing:
        raise SimError(f"{len(missing)} drive(s) never came back, e.g. {missing[0]}")
    rows = _in_order(by_index)
    if journal is not None:
        journal.finish(rows)
    return rows


def _in_order(by_index: dict[int, dict[str, Any]]) -> list[dict[str, Any]]:
    return [by_index[i] for i in sorted(by_index)]


__all__ = ["RowJournal", "RowKey", "StudyInterrupted", "collect", "row_key"]
