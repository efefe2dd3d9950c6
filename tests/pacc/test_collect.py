"""The one journal of a study (``rows.jsonl``): records as tasks finish, plan order out,
a stopped run resumed, another run's folder refused, the finished records kept on Ctrl-C."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from cloud_sync.engine import InlineExecutor, ProcessPool
from pacc.study.pipeline import StudyInterrupted, run_resumable
from sim_bus.errors import SimError

FP = {"seed": 1}
CALLS: list[int] = []


def square(n: int) -> dict[str, Any]:
    CALLS.append(n)
    if n == 99:
        raise KeyboardInterrupt
    return {"n": n, "square": n * n}


def _keys(tasks: list[int]) -> list[str]:
    return [f"t{n}" for n in tasks]


def test_records_in_plan_order_on_any_executor(tmp_path: Path) -> None:
    tasks = list(range(9))
    with ProcessPool(3) as pool:
        got = run_resumable(tasks, square, _keys(tasks), tmp_path / "j.jsonl", FP, pool)
    assert got == [{"n": n, "square": n * n} for n in tasks]
    lines = (tmp_path / "j.jsonl").read_text().splitlines()
    assert json.loads(lines[0]) == {"fingerprint": FP} and len(lines) == 10


def test_a_stopped_run_resumes_and_runs_only_what_is_missing(tmp_path: Path) -> None:
    path, tasks = tmp_path / "j.jsonl", [1, 2, 3, 4]
    run_resumable(tasks, square, _keys(tasks), path, FP, InlineExecutor())
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:3]) + "\n" + lines[3][:9])  # killed mid-line
    CALLS.clear()
    got = run_resumable(tasks, square, _keys(tasks), path, FP, InlineExecutor())
    assert CALLS == [3, 4] and [r["n"] for r in got] == tasks
    with pytest.raises(SimError, match="holds another study"):
        run_resumable(tasks, square, _keys(tasks), path, {"seed": 2}, InlineExecutor())
    with pytest.raises(SimError, match="share a key"):
        run_resumable([1, 1], square, ["a", "a"], tmp_path / "k.jsonl", FP, InlineExecutor())


def test_ctrl_c_keeps_the_finished_records(tmp_path: Path) -> None:
    path, tasks = tmp_path / "j.jsonl", [5, 6, 99, 7]
    with pytest.raises(StudyInterrupted, match="2 of 4 drives finished") as info:
        run_resumable(tasks, square, _keys(tasks), path, FP, InlineExecutor())
    assert [r["n"] for r in info.value.rows] == [5, 6]
    assert len(path.read_text().splitlines()) == 3
