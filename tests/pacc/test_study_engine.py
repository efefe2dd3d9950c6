"""A study on the engines: the same rows in-process and on a Dask LocalCluster, every row
exactly once when a worker is killed mid-run, the finished rows kept on Ctrl-C."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, Future
from pathlib import Path
from typing import Any

import pytest

from cloud_sync.engine import InlineExecutor
from dbc.vocab.triplog_file import read_trip
from pacc.commands.study import main
from pacc.study.pipeline import ROWS, learn_table, run
from pacc.study.spec import StudySpec, table1_method

ROOT = Path(__file__).resolve().parents[2]

#: 4 short drives with predefined tables (no learning): 2 drivers × 2 controllers
TINY = StudySpec(
    drivers=("d1", "d3"),
    scenarios=("B",),
    methods=(table1_method("predefined"), table1_method("predefined+oa")),
    trials=1,
    seed=5,
    duration_s=15.0,
    workers=2,
    learn_in="direct",
)


def row_key(row: dict[str, Any]) -> tuple[str, ...]:
    return (str(row["driver"]), str(row["scenario"]), str(row["controller"]), str(row["trial"]))


def _without_wall(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


def _csv_without_wall(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return [{k: v for k, v in r.items() if k != "wall_s"} for r in csv.DictReader(fh)]


@pytest.fixture(scope="module")
def inline(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[dict[str, Any]]]:
    """The tiny study in this process: the reference rows."""
    out = tmp_path_factory.mktemp("inline")
    return out, run(TINY, out, progress=False, executor=InlineExecutor())


def test_dask_gives_the_rows_of_the_in_process_run(
    inline: tuple[Path, list[dict[str, Any]]], dask_cluster: Executor, tmp_path: Path
) -> None:
    ref_out, ref = inline
    rows = run(TINY, tmp_path, progress=False, executor=dask_cluster)
    assert len(rows) == 4 and len({row_key(r) for r in rows}) == 4
    assert _without_wall(rows) == _without_wall(ref)  # bit-identical figures, plan order
    assert _csv_without_wall(tmp_path / "drives.csv") == _csv_without_wall(ref_out / "drives.csv")
    logs = sorted(p.name for p in (tmp_path / "logs").iterdir())
    assert logs == sorted(p.name for p in (ref_out / "logs").iterdir()) and len(logs) == 4
    ours, theirs = read_trip(tmp_path / "logs" / logs[0]), read_trip(ref_out / "logs" / logs[0])
    assert (ours.gap_m == theirs.gap_m).all()
    # the logs are stamped with each drive's real UTC start (docs/logs.md); the rest is equal
    assert ours.meta.pop("start_utc") != "" and theirs.meta.pop("start_utc") != ""
    assert ours.meta == theirs.meta


class KillOnce(Executor):
    """The Dask executor, but once a task is running it SIGKILLs the worker process that runs
    it (its nanny starts a new one; the scheduler reruns the task)."""

    def __init__(self, inner: Executor) -> None:
        self.inner = inner
        self.client = inner._client  # type: ignore[attr-defined]
        self.killed_pid: int | None = None
        self.killed_keys: list[str] = []
        self._watch: threading.Thread | None = None
        self.stopped = threading.Event()  # set when the run is over: the watcher ends

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        if self._watch is None and fn is not learn_table:  # a drive, not a table task
            # watch from a thread: the plan's later submits must not wait for the kill
            self._watch = threading.Thread(target=self._kill_a_busy_worker, daemon=True)
            self._watch.start()
        return self.inner.submit(fn, *args, **kwargs)

    def _kill_a_busy_worker(self) -> None:
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline and not self.stopped.is_set():
            busy = {addr: keys for addr, keys in self.client.processing().items() if keys}
            if busy:
                addr, keys = next(iter(busy.items()))
                pid = self.client.run(os.getpid, workers=[addr])[addr]
                self.killed_keys = [str(k) for k in keys]
                os.kill(pid, signal.SIGKILL)
                self.killed_pid = pid
                return
            time.sleep(0.002)


def test_a_worker_killed_mid_run_still_gives_every_row_once(
    inline: tuple[Path, list[dict[str, Any]]], dask_cluster: Executor, tmp_path: Path
) -> None:
    _, ref = inline
    engine = KillOnce(dask_cluster)
    cfg = StudySpec(**{**TINY.__dict__, "logs": False})
    rows = run(cfg, tmp_path, progress=False, executor=engine)
    engine.stopped.set()
    if engine._watch is not None:
        engine._watch.join(5.0)
    assert engine.killed_pid is not None and engine.killed_keys  # it was mid-task
    assert _without_wall(rows) == _without_wall(ref)  # none lost, none twice, same figures
    with (tmp_path / "drives.csv").open(newline="") as fh:
        assert [row_key(r) for r in csv.DictReader(fh)] == [row_key(r) for r in ref]
    client = engine.client
    client.wait_for_workers(2, timeout=60)  # the nanny restarted it
    pids = set(client.run(os.getpid).values())
    assert len(pids) == 2 and engine.killed_pid not in pids


def _sigint_default() -> None:
    """In the child before exec: SIGINT handled by default and not blocked, whatever the
    test process's own state (an ignored signal and the signal mask survive exec)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, [signal.SIGINT])


def test_ctrl_c_keeps_the_finished_rows_in_plan_order(tmp_path: Path) -> None:
    out = tmp_path / "out"
    argv = ["--direct", "--drivers", "d1,d3", "--scenarios", "B"]
    argv += ["--controllers", "predefined", "--trials", "4", "--duration", "15", "--seed", "5"]
    argv += ["--workers", "1", "--no-logs", "-q", "--out", str(out)]
    # what this process lets its children inherit of SIGINT (an ignored or blocked SIGINT would
    # be theirs too): said when the study was not interrupted
    inherited = (signal.getsignal(signal.SIGINT), signal.pthread_sigmask(signal.SIG_BLOCK, []))
    proc = subprocess.Popen(
        [sys.executable, "-m", "pacc", "study", *argv],
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_sigint_default,  # noqa: PLW1509 - signal calls only
    )
    csv_path, journal = out / "drives.csv", out / ROWS
    start = time.monotonic()
    lines = 0
    while time.monotonic() < start + 60.0 and proc.poll() is None:
        if journal.is_file() and (lines := len(journal.read_text().splitlines())) >= 3:
            break  # 2 rows
        time.sleep(0.02)
    seen = f"{lines} lines after {time.monotonic() - start:.2f} s, exit {proc.poll()}"
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, f"{err!r}; at SIGINT: {seen}; inherited {inherited}"
    with csv_path.open(newline="") as fh:
        kept = list(csv.DictReader(fh))
    assert 2 <= len(kept) < 8
    assert f"interrupted: {len(kept)} of 8 drives finished and kept in {csv_path}" in err
    order = [("d1", str(t)) for t in range(4)] + [("d3", str(t)) for t in range(4)]
    assert [(r["driver"], r["trial"]) for r in kept] == order[: len(kept)]  # plan order
    assert all(float(r["sim_s"]) == pytest.approx(15.0, abs=0.2) for r in kept)  # whole rows


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--scheduler", " "], "--scheduler needs 'local' or a Dask scheduler address"),
        (["--scheduler", "local", "--incremental", "2"], "not with --scheduler"),
    ],
)
def test_bad_scheduler_options(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([*argv, "--out", str(tmp_path), "-q"]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow
def test_a_population_study_on_dask_gives_the_in_process_rows(
    dask_cluster: Executor, tmp_path: Path
) -> None:
    """``pacc study --population`` is a spec of the same pipeline, on the same executors."""
    cfg = StudySpec(
        drivers=("headway:2:5",),
        seed=5,
        scenarios=("B",),
        methods=(table1_method("predefined"), table1_method("irl+oa")),
        trials=1,
        duration_s=8.0,
        report="population",
        learn_in="direct",
        logs=False,
    )
    cache = tmp_path / "cache"
    ref = run(cfg, tmp_path / "inline", cache_dir=cache, executor=InlineExecutor())
    rows = run(cfg, tmp_path / "dask", cache_dir=cache, executor=dask_cluster)
    assert len(rows) == 4 and _without_wall(rows) == _without_wall(ref)
