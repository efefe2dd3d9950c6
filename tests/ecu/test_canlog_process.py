"""The recorder's writer process (:mod:`ecu.buslog.process.remote`): the same file as the node's
thread writes, crash safety when the node's process is killed, and a clean error (no hang,
no zombie) when the writer dies."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import can
import pytest

from dbc.codec import load_codec
from ecu.buslog import recording
from ecu.buslog.format import CanLogError, TimeBase
from ecu.buslog.process import remote, writers
from ecu.buslog.reader import read_canlog
from ecu.buslog.recording import PROCESS_ENV
from ecu.buslog.writer import CanLogWriter
from pacc.study.drive import DriveConfig, predefined_table, run_drive
from sim_bus.drivers import BUILTIN_DRIVERS

UTC0 = 1_700_000_000_000_000_000


@pytest.fixture(autouse=True)
def _no_failure_remembered(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each test starts as a process where no writer failed to start."""
    monkeypatch.setattr(writers, "_failed", None, raising=False)


def _drive(path: Path) -> None:
    driver = BUILTIN_DRIVERS["d2"]
    cfg = DriveConfig(scenario="B", driver_id="d2", controller="predefined+oa", seed=3)
    cfg = DriveConfig(**{**cfg.__dict__, "duration_s": 25.0})
    run_drive(cfg, driver, predefined_table(driver), can_log=path, utc_start_ns=UTC0)


def test_the_writer_process_writes_the_threads_file_byte_for_byte(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 25-s drive (3 row flushes, 25 chunks of raw frames, events, the world) recorded by
    the writer process and on the drive's thread: the same bytes."""
    monkeypatch.setenv(PROCESS_ENV, "0")
    _drive(tmp_path / "thread.mcap")
    monkeypatch.setenv(PROCESS_ENV, "1")
    assert writers.start_writer()
    _drive(tmp_path / "process.mcap")
    _drive(tmp_path / "again.mcap")  # a second recording by the same (pooled) writer
    thread = (tmp_path / "thread.mcap").read_bytes()
    assert len(read_canlog(tmp_path / "thread.mcap").frames) > 5000
    assert (tmp_path / "process.mcap").read_bytes() == thread
    assert (tmp_path / "again.mcap").read_bytes() == thread


def _frame(i: int) -> can.Message:
    return can.Message(arbitration_id=0x123, data=i.to_bytes(4, "little") + bytes(4))


def test_a_dead_writer_is_a_clean_error_at_close(tmp_path: Path) -> None:
    """The writer process killed mid-recording: the node's taps and ticks never raise,
    close raises CanLogError naming the writer, and the process is reaped (no zombie)."""
    path = tmp_path / "dead.mcap"
    assert writers.start_writer()
    w = CanLogWriter(path, load_codec().db, TimeBase(UTC0, 0.0), node="t", process=True)
    out = w._out
    assert isinstance(out, remote.RemoteOutput)
    proc = out._proc
    for i in range(200):
        w.frame(i * 0.01, _frame(i), True)
        w.tick(i * 0.01)
    part = Path(f"{path}.part")
    deadline = time.monotonic() + 20
    while _frames_in(part) < 100 and time.monotonic() < deadline:  # the writer caught up
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(10)
    for i in range(200, 2000):  # the pipe breaks: the recording stops, the node does not
        w.frame(i * 0.01, _frame(i), True)
        w.tick(i * 0.01)
    with pytest.raises(CanLogError, match="writer process|recording stopped"):
        w.close()
    assert proc.returncode == -signal.SIGKILL
    assert proc not in writers._idle
    assert _frames_in(part) >= 100  # what the writer wrote before it died stays readable


def _frames_in(part: Path) -> int:
    """Frames in a recording being written (0 while it cannot be read yet)."""
    try:
        return len(read_canlog(part, recover=True).frames)
    except CanLogError:
        return 0


_KILLED = r"""
import json, sys, time
import can
from dbc.codec import load_codec
from ecu.buslog.process import writers
from ecu.buslog.format import TimeBase
from ecu.buslog.writer import CanLogWriter

path = sys.argv[1]
assert writers.start_writer()
w = CanLogWriter(path, load_codec().db, TimeBase(0, 0.0), node="kill", process=True, flush_s=0.1)
print(json.dumps({"writer": w._out._proc.pid}), flush=True)
i = 0
while True:
    msg = can.Message(arbitration_id=0x123, data=i.to_bytes(4, "little") + bytes(4))
    w.frame(i * 0.001, msg, True)
    w.tick(i * 0.001)
    if i == 3000:
        print(json.dumps({"sent": i}), flush=True)
    i += 1
    if i > 3000:
        time.sleep(0.001)
"""


def _running(pid: int) -> bool:
    """The process runs (not gone, not a zombie left for an init that does not reap)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.slow
def test_a_killed_node_leaves_what_its_writer_got(tmp_path: Path) -> None:
    """The node's process SIGKILLed: its writer process writes every frame it was sent
    (each 0.1-s flush), leaves ``.part`` readable, and exits."""
    path = tmp_path / "killed.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-c", _KILLED, str(path)], stdout=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None
    writer = json.loads(proc.stdout.readline())["writer"]
    sent = json.loads(proc.stdout.readline())["sent"]
    proc.kill()
    proc.wait(10)
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:  # the writer ends on its own (its stdin closed)
        if not _running(writer):
            break
        time.sleep(0.05)
    else:
        os.kill(writer, signal.SIGKILL)
        pytest.fail("the writer process did not end after its node was killed")
    frames = read_canlog(Path(f"{path}.part"), recover=True).frames
    counters = [int.from_bytes(d[:4], "little") for d in frames.data]
    assert counters == list(range(len(counters)))  # an unbroken prefix
    assert len(counters) >= sent - 100  # every flush before the kill (0.1 s = 100 frames)


def test_a_recording_with_no_writer_ready_is_written_on_the_thread(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """No writer started yet: the recording does not wait for one (it is written on the
    node's thread); a process's first recording starts none (it may be its only one), its
    second starts one for the next."""
    writers._end_idle()
    monkeypatch.setattr(writers, "_asked", 0)
    w = CanLogWriter(tmp_path / "first.mcap", None, TimeBase(UTC0, 0.0), node="t", process=True)
    assert not isinstance(w._out, remote.RemoteOutput)
    w.close()
    assert not writers._idle
    w = CanLogWriter(tmp_path / "a.mcap", None, TimeBase(UTC0, 0.0), node="t", process=True)
    assert not isinstance(w._out, remote.RemoteOutput)
    w.close()
    assert len(writers._idle) == 1  # starting
    assert writers.start_writer()
    w = CanLogWriter(tmp_path / "b.mcap", None, TimeBase(UTC0, 0.0), node="t", process=True)
    assert isinstance(w._out, remote.RemoteOutput)
    w.close()
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()


class _OwnDatabase:
    """A database of its own making, which cannot be pickled (a lambda in it)."""

    messages: list[object] = []

    def __init__(self) -> None:
        self.hook = lambda: None


def test_a_database_that_cannot_be_sent_keeps_the_recording_on_the_thread(
    tmp_path: Path,
) -> None:
    assert writers.start_writer()
    idle = len(writers._idle)
    w = CanLogWriter(
        tmp_path / "own.mcap", _OwnDatabase(), TimeBase(UTC0, 0.0), node="t", process=True
    )
    assert not isinstance(w._out, remote.RemoteOutput)
    w.frame(0.0, _frame(0), True)
    w.close()
    assert len(read_canlog(tmp_path / "own.mcap").frames) == 1
    assert len(writers._idle) == idle  # the writer went back to the pool


def test_a_writer_only_when_asked_or_auto_while_a_core_is_free(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    monkeypatch.delenv(PROCESS_ENV, raising=False)
    assert not recording.use_writer()  # by default: the node's thread
    monkeypatch.setenv(PROCESS_ENV, "auto")
    monkeypatch.setattr(os, "getloadavg", lambda: (1.2, 1.0, 1.0))
    assert recording.use_writer()
    monkeypatch.setattr(os, "getloadavg", lambda: (1.6, 1.0, 1.0))
    assert not recording.use_writer()  # a study on every core: the node's thread
    monkeypatch.setenv(PROCESS_ENV, "1")
    assert recording.use_writer()
    monkeypatch.setenv(PROCESS_ENV, "0")
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert not recording.use_writer()


def test_asked_for_a_writer_the_first_recording_starts_one_and_uses_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``PACC_RECORDER_PROCESS=1``: a process's first file recording (``pacc drive
    --can-log``) starts a writer, waits for it, and is written by it; a live view (sinks) or no
    file keeps the node's thread."""
    writers._end_idle()
    monkeypatch.setattr(writers, "_asked", 0)
    monkeypatch.setenv(PROCESS_ENV, "1")
    codec = load_codec()
    w = recording.open_recording(tmp_path / "first.mcap", codec, TimeBase(UTC0, 0.0), node="t")
    assert isinstance(w._out, remote.RemoteOutput)
    w.frame(0.0, _frame(0), True)
    w.close()
    assert len(read_canlog(tmp_path / "first.mcap").frames) == 1
    monkeypatch.setenv(PROCESS_ENV, "0")
    w = recording.open_recording(tmp_path / "own.mcap", codec, TimeBase(UTC0, 0.0), node="t")
    assert not isinstance(w._out, remote.RemoteOutput)
    w.close()


def test_a_writer_that_dies_at_start_costs_no_wait(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """A writer that exits at once (here ``/bin/false``): the recording goes to the node's
    thread at once, one warning, and the next recording does not try again."""
    writers._end_idle()
    monkeypatch.setenv(PROCESS_ENV, "1")
    monkeypatch.setattr(sys, "executable", "/bin/false")
    codec = load_codec()
    t0 = time.monotonic()
    w = recording.open_recording(tmp_path / "a.mcap", codec, TimeBase(UTC0, 0.0), node="t")
    assert not isinstance(w._out, remote.RemoteOutput)
    w.close()
    w = recording.open_recording(tmp_path / "b.mcap", codec, TimeBase(UTC0, 0.0), node="t")
    assert not isinstance(w._out, remote.RemoteOutput)
    w.close()
    assert time.monotonic() - t0 < 2.0
    assert not writers._idle
    warnings = [r for r in caplog.records if "writer process" in r.getMessage()]
    assert len(warnings) == 1
    assert "exit code 1" in warnings[0].getMessage()


def test_an_idle_writer_that_died_is_replaced_at_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The pool's idle writer killed (a stray kill): the next recording starts a new one
    without waiting for the dead one."""
    assert writers.start_writer()
    dead = writers._idle[0]
    os.kill(dead.pid, signal.SIGKILL)
    dead.wait(10)
    monkeypatch.setenv(PROCESS_ENV, "1")
    t0 = time.monotonic()
    w = recording.open_recording(tmp_path / "a.mcap", load_codec(), TimeBase(UTC0, 0.0), node="t")
    assert time.monotonic() - t0 < writers.START_TIMEOUT_S
    assert isinstance(w._out, remote.RemoteOutput)
    assert w._out._proc is not dead
    w.close()


def test_the_writer_runs_the_nodes_code_not_the_current_directorys(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Spawned from a folder holding another ``ecu`` package (another checkout), the writer
    still imports the node's: it starts and writes the recording."""
    fake = tmp_path / "checkout" / "ecu" / "buslog"
    fake.mkdir(parents=True)
    (fake.parent / "__init__.py").write_text("raise SystemExit(3)\n")
    (fake / "__init__.py").write_text("")
    (fake / "serve.py").write_text("raise SystemExit(3)\n")
    writers._end_idle()
    monkeypatch.chdir(fake.parent.parent)
    assert writers.start_writer()
    w = CanLogWriter(tmp_path / "a.mcap", None, TimeBase(UTC0, 0.0), node="t", process=True)
    assert isinstance(w._out, remote.RemoteOutput)
    w.frame(0.0, _frame(0), True)
    w.close()
    assert len(read_canlog(tmp_path / "a.mcap").frames) == 1


def test_a_service_stop_sigterm_to_the_writer_does_not_lose_the_recording(
    tmp_path: Path,
) -> None:
    """SIGTERM to the writer mid-recording (systemd stops a service by signalling every
    process of it): the writer goes on, the node finishes the file."""
    path = tmp_path / "term.mcap"
    assert writers.start_writer()
    w = CanLogWriter(path, load_codec().db, TimeBase(UTC0, 0.0), node="t", process=True)
    out = w._out
    assert isinstance(out, remote.RemoteOutput)
    for i in range(300):
        w.frame(i * 0.01, _frame(i), True)
        w.tick(i * 0.01)
    os.kill(out._proc.pid, signal.SIGTERM)
    os.kill(out._proc.pid, signal.SIGHUP)
    time.sleep(0.2)
    for i in range(300, 600):
        w.frame(i * 0.01, _frame(i), True)
        w.tick(i * 0.01)
    w.close()
    assert len(read_canlog(path).frames) == 600


def test_the_recorder_imports_where_os_has_no_register_at_fork(tmp_path: Path) -> None:
    """``os.register_at_fork`` is POSIX only: without it (Windows) the recorder still
    imports and records on the node's thread."""
    code = (
        "import os, random, sys\n"
        "import can, ecu.buslog.output, ecu.buslog.process.serve, ecu.buslog.sinks, ecu.signals\n"
        "assert 'ecu.buslog.process.remote' not in sys.modules\n"
        "del os.register_at_fork  # as on Windows, for the recorder's own modules\n"
        "from ecu.buslog.writer import CanLogWriter\n"
        "from ecu.buslog.format import TimeBase\n"
        "w = CanLogWriter(sys.argv[1], None, TimeBase(0, 0.0), node='t')\n"
        "w.close()\n"
    )
    subprocess.run([sys.executable, "-c", code, str(tmp_path / "a.mcap")], check=True)
    assert read_canlog(tmp_path / "a.mcap").frames is not None


def _record_in_a_worker(path: str, pids: Any) -> None:
    """A pool worker's task: one recording by a writer process; the writer's pid sent."""
    assert writers.start_writer()
    w = CanLogWriter(path, None, TimeBase(UTC0, 0.0), node="t", process=True)
    assert isinstance(w._out, remote.RemoteOutput)
    pids.send(w._out._proc.pid)
    w.close()


def test_a_pool_workers_idle_writer_is_waited_for_at_its_exit(tmp_path: Path) -> None:
    """A multiprocessing worker ends with ``os._exit`` (no ``atexit``): its idle writer is
    still ended and reaped by it (no zombie left to init)."""
    ctx = multiprocessing.get_context("fork")
    ours, theirs = ctx.Pipe()
    worker = ctx.Process(target=_record_in_a_worker, args=(str(tmp_path / "a.mcap"), theirs))
    worker.start()
    pid = ours.recv()
    worker.join(30)
    assert worker.exitcode == 0
    assert not Path(f"/proc/{pid}").exists()  # reaped by the worker before it exited
    assert read_canlog(tmp_path / "a.mcap").frames is not None


def test_start_up_errors_put_the_recording_on_the_thread(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A writer that cannot be spawned (no such interpreter), or that died between READY
    and the recording's first message: the recording is written on the node's thread,
    no exception out of opening it, the dead writer reaped."""
    assert writers.start_writer()
    proc = writers.ready_writer()
    assert proc is not None
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(10)
    with pytest.raises(remote.NotSendable, match="ended"):
        remote.RemoteOutput(proc, tmp_path / "a.mcap", None, TimeBase(UTC0, 0.0), "t")
    assert proc.stdin is not None and proc.stdin.closed
    assert proc not in writers._idle
    writers._end_idle()
    monkeypatch.setenv(PROCESS_ENV, "1")
    monkeypatch.setattr(sys, "executable", str(tmp_path / "no-such-python"))
    w = recording.open_recording(tmp_path / "b.mcap", load_codec(), TimeBase(UTC0, 0.0), node="t")
    assert not isinstance(w._out, remote.RemoteOutput)
    w.frame(0.0, _frame(0), True)
    w.close()
    assert len(read_canlog(tmp_path / "b.mcap").frames) == 1


def _start_a_writer(ok: Any) -> None:
    ok.send(writers.start_writer())


def test_a_fork_while_the_pool_is_locked_does_not_deadlock_the_child() -> None:
    """Forked while another thread holds the pool's lock (spawning a writer): the child
    has a lock of its own and starts its writer."""
    ctx = multiprocessing.get_context("fork")
    ours, theirs = ctx.Pipe()
    with writers._lock:
        child = ctx.Process(target=_start_a_writer, args=(theirs,))
        child.start()
    if not ours.poll(10):
        child.kill()
        child.join(10)
        pytest.fail("the child deadlocked on the parent's lock")
    assert ours.recv() is True
    child.join(20)
    assert child.exitcode == 0


def test_a_stopped_writer_bounds_the_backlog_and_the_close(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The writer alive but taking nothing (SIGSTOP, as on a hung disk): past the backlog's
    cap the recording stops; the close does not hang: the writer is killed and reaped,
    CanLogError names it, and what it wrote before stays readable in ``.part``."""
    monkeypatch.setattr(remote, "MAX_BACKLOG_BYTES", 1 << 16)
    monkeypatch.setattr(remote, "CLOSE_TIMEOUT_S", 1.0)
    path = tmp_path / "stuck.mcap"
    assert writers.start_writer()
    w = CanLogWriter(path, None, TimeBase(UTC0, 0.0), node="t", process=True, flush_s=0.01)
    out = w._out
    assert isinstance(out, remote.RemoteOutput)
    proc = out._proc
    for i in range(50):
        w.frame(i * 0.001, _frame(i), True)
        w.tick(i * 0.001)
    deadline = time.monotonic() + 20
    while _frames_in(Path(f"{path}.part")) < 40 and time.monotonic() < deadline:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGSTOP)
    i = 50
    while w.error is None and i < 1_000_000:
        w.frame(i * 0.001, _frame(i), True)
        w.tick(i * 0.001)
        i += 1
    assert w.error is not None and "behind by" in w.error
    t0 = time.monotonic()
    with pytest.raises(CanLogError, match=f"pid {proc.pid}"):
        w.close()
    assert time.monotonic() - t0 < 5
    assert proc.returncode == -signal.SIGKILL
    assert _frames_in(Path(f"{path}.part")) >= 40


def test_a_writer_that_never_answers_the_close_is_killed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(remote, "CLOSE_TIMEOUT_S", 1.0)
    assert writers.start_writer()
    w = CanLogWriter(tmp_path / "a.mcap", None, TimeBase(UTC0, 0.0), node="t", process=True)
    out = w._out
    assert isinstance(out, remote.RemoteOutput)
    w.frame(0.0, _frame(0), True)
    os.kill(out._proc.pid, signal.SIGSTOP)
    t0 = time.monotonic()
    with pytest.raises(CanLogError, match=f"writer process \\(pid {out._proc.pid}\\)"):
        w.close()
    assert time.monotonic() - t0 < 5
    assert out._proc.returncode == -signal.SIGKILL
    assert out._proc not in writers._idle


_FULL_DISK = r"""
import resource, sys
import can
import numpy as np
from ecu.buslog.process import writers
from ecu.buslog.format import CanLogError, TimeBase
from ecu.buslog.writer import CanLogWriter

path, process = sys.argv[1], sys.argv[2] == "1"
resource.setrlimit(resource.RLIMIT_FSIZE, (40_000, 40_000))  # a full disk at 40 kB
assert not process or writers.start_writer()  # the writer inherits the limit
w = CanLogWriter(path, None, TimeBase(0, 0.0), node="t", process=process, flush_s=0.1)
w.series("/sim/world", ("v",))
for i in range(20_000):
    msg = can.Message(arbitration_id=0x123, data=i.to_bytes(4, "little") + bytes(4))
    w.frame(i * 0.001, msg, True)
    w.tick(i * 0.001)
w.event(20.0, "end")
w.write_series("/sim/world", {"v": np.zeros(10_000)}, np.arange(10_000) * 0.05)
try:
    w.close()
except CanLogError as exc:
    print(exc)
"""


@pytest.mark.slow
def test_a_full_disk_gives_the_same_first_error_on_both_paths(tmp_path: Path) -> None:
    """A write that fails (a file-size limit): what is fed after it (the world's series,
    an event) is not written, and closing reports the first failure, the same text on the
    node's thread and with a writer process."""
    said = {}
    for process in ("0", "1"):
        path = tmp_path / "full.mcap"
        run = subprocess.run(
            [sys.executable, "-c", _FULL_DISK, str(path), process],
            capture_output=True,
            text=True,
            check=True,
        )
        said[process] = run.stdout.strip()
        assert Path(f"{path}.part").exists()
        Path(f"{path}.part").unlink()
    assert "recording stopped at t = " in said["0"]
    assert "File too large" in said["0"]
    assert said["0"] == said["1"]


def test_an_unknown_setting_warns_once_and_uses_the_thread(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr(recording, "_warned", False)
    monkeypatch.setenv(PROCESS_ENV, "yes")
    assert not recording.use_writer()
    assert not recording.use_writer()
    warned = [r.getMessage() for r in caplog.records if PROCESS_ENV in r.getMessage()]
    assert warned == [f"{PROCESS_ENV}='yes' is not 0, 1 or auto: recording on the node's thread"]
    monkeypatch.setenv(PROCESS_ENV, "")
    assert not recording.use_writer()


def test_a_relative_path_is_the_nodes_after_it_changed_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A pooled writer started in one directory, the node then in another: a relative
    path is written where the node means it."""
    (tmp_path / "later").mkdir()
    monkeypatch.chdir(tmp_path)
    assert writers.start_writer()
    monkeypatch.chdir(tmp_path / "later")
    w = CanLogWriter("rel.mcap", None, TimeBase(UTC0, 0.0), node="t", process=True)
    assert isinstance(w._out, remote.RemoteOutput)
    w.frame(0.0, _frame(0), True)
    w.close()
    assert len(read_canlog(tmp_path / "later" / "rel.mcap").frames) == 1


def test_a_silent_writer_is_given_up_after_the_timeout(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A writer that never says READY (stuck at start): start_writer gives up after its
    timeout, kills and reaps it, and later recordings do not wait again."""
    silent = tmp_path / "silent"
    silent.write_text("#!/bin/sh\nexec sleep 60\n")
    silent.chmod(0o755)
    writers._end_idle()
    monkeypatch.setattr(writers, "START_TIMEOUT_S", 0.5)
    monkeypatch.setattr(sys, "executable", str(silent))
    t0 = time.monotonic()
    assert not writers.start_writer()
    assert time.monotonic() - t0 < 2.0
    assert not writers._idle
    t0 = time.monotonic()
    assert not writers.start_writer()
    assert time.monotonic() - t0 < 0.1
