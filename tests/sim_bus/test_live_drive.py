"""A drive shown live (``pacc.study.drive_recording``): the simulated world streamed to the
live view as the drive runs, the drive held to the wall clock; neither changes the drive."""

from __future__ import annotations

import asyncio
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ecu.buslog.format import CanLogError
from ecu.buslog.live import FoxgloveSink
from ecu.buslog.reader import read_canlog
from pacc.commands.drive import main as drive_main
from pacc.study.drive import DriveConfig, DriveResult, predefined_table, run_drive
from pacc.study.drive_recording import RESYNC_S, Pacer
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.errors import DriveError

#: d2 with online adaptation: a takeover at 10.2 s (the world's pedals change mid-drive)
CFG = DriveConfig(scenario="B", driver_id="d2", controller="predefined+oa", seed=1, duration_s=14.0)
UTC0_NS = 1_790_000_000_000_000_000


def _drive(cfg: DriveConfig = CFG, **kwargs: Any) -> DriveResult:
    driver = BUILTIN_DRIVERS["d2"]
    return run_drive(cfg, driver, predefined_table(driver), utc_start_ns=UTC0_NS, **kwargs)


def test_a_live_drive_streams_the_world_and_records_what_a_plain_one_records(
    tmp_path: Path,
) -> None:
    plain = _drive(can_log=tmp_path / "plain.mcap")
    sink = FoxgloveSink("127.0.0.1", 0)
    try:
        live = _drive(can_log=tmp_path / "live.mcap", live=[sink])
    finally:
        sink.close(complete=True)
    assert live.metrics == plain.metrics and live.frames_sent == plain.frames_sent
    a, b = read_canlog(tmp_path / "plain.mcap"), read_canlog(tmp_path / "live.mcap")
    assert a.frames.data == b.frames.data and np.array_equal(a.frames.t_s, b.frames.t_s)
    assert a.series.keys() == b.series.keys()
    for topic, columns in a.series.items():  # /sim/world streamed, the rest as before
        assert columns.keys() == b.series[topic].keys(), topic
        for name, values in columns.items():
            assert np.array_equal(values, b.series[topic][name]), (topic, name)
    assert len(b.series["/sim/world"]["t_s"]) == 14 * 20  # the driver's 20 Hz, once each


def test_a_paced_drive_keeps_to_the_wall_clock_and_gives_the_same_drive() -> None:
    cfg = DriveConfig(scenario="B", driver_id="d2", controller="predefined", seed=1, duration_s=2.0)
    fast = _drive(cfg)
    start = time.perf_counter()
    paced = _drive(cfg, pace=4.0)
    wall = time.perf_counter() - start
    assert wall >= 0.45  # 2 s at 4x: 0.5 s, less the first tick
    assert paced.metrics == fast.metrics and paced.frames_sent == fast.frames_sent
    for bad in (0.0, 1e-300, -1.0, math.nan):
        with pytest.raises(DriveError, match="pace must be within"):
            _drive(cfg, pace=bad)
        with pytest.raises(ValueError, match="pace must be within"):
            Pacer(bad)


def test_the_pacer_waits_for_the_wall_clock_and_goes_on_after_a_stall() -> None:
    """On a clock of its own: it sleeps while the simulation is ahead; after a stall longer
    than RESYNC_S it goes on at the pace from there, with no burst to catch up."""
    now = [100.0]
    slept: list[float] = []

    def sleep(s: float) -> None:
        slept.append(round(s, 9))
        now[0] += s

    pacer = Pacer(2.0, clock=lambda: now[0], sleep=sleep)
    pacer(0.0)  # the origin
    pacer(1.0)  # 1 s of drive at 2x: 0.5 s of wall time
    assert slept == [0.5] and now[0] == 100.5
    now[0] += 0.1  # a loop a little slow: no sleep, and no jump either
    pacer(1.2)
    assert slept == [0.5]
    now[0] += 5.0  # a stall of 5 s: the pacer starts again from here
    pacer(1.4)
    pacer(2.4)
    assert slept == [0.5, 0.5]  # 1 s of drive at 2x again, not a burst
    assert RESYNC_S == 0.25


async def _watch(port: int, done: threading.Event) -> list[tuple[int, bool]]:
    """A Foxglove client subscribed to ``/sim/world`` until the drive is ``done``: each
    message's log time, and whether the drive still ran when it came."""
    websockets = pytest.importorskip("websockets")
    async with websockets.connect(
        f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"], max_size=None
    ) as ws:
        channels: dict[str, int] = {}
        while "/sim/world" not in channels:
            msg = json.loads(await asyncio.wait_for(ws.recv(), 10))
            if msg["op"] == "advertise":
                channels.update({c["topic"]: c["id"] for c in msg["channels"]})
        sub = {"id": 7, "channelId": channels["/sim/world"]}
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [sub]}))
        got: list[tuple[int, bool]] = []  # (log time, the drive still running)
        while not done.is_set():
            try:
                m = await asyncio.wait_for(ws.recv(), 0.5)
            except TimeoutError:
                continue
            except websockets.exceptions.ConnectionClosed:
                break  # the drive ended: its recording closed the server
            if isinstance(m, bytes) and m[0] == 1:
                got.append((int.from_bytes(m[5:13], "little"), not done.is_set()))
        return got


def test_a_client_that_connects_during_a_paced_drive_sees_the_world_as_it_runs() -> None:
    """What a person gets with ``pacc drive --foxglove``: the drive at real time (here 4x),
    a Foxglove client connected after it started, the world's rows arriving while it runs."""
    pytest.importorskip("websockets")
    cfg = DriveConfig(scenario="B", driver_id="d2", controller="predefined", seed=1, duration_s=8.0)
    sink = FoxgloveSink("127.0.0.1", 0)
    done = threading.Event()
    outcome: dict[str, Any] = {}

    def drive() -> None:
        try:
            outcome["result"] = _drive(cfg, live=[sink], pace=4.0)
        finally:
            done.set()

    seen: dict[str, list[tuple[int, bool]]] = {}

    def client() -> None:  # its own thread: another test may have left a loop in this one
        seen["got"] = asyncio.run(_watch(sink.port, done))

    runner = threading.Thread(target=drive, daemon=True)
    viewer = threading.Thread(target=client, daemon=True)
    try:
        runner.start()
        time.sleep(0.3)  # the person opens the connection after the drive began
        viewer.start()
        viewer.join(20)
    finally:
        runner.join(10)
        sink.close(complete=True)
    assert "got" in seen, "the client thread failed (its error is above)"
    got = seen["got"]
    assert "result" in outcome and outcome["result"].sim_s == pytest.approx(8.0)
    during = [t for t, running in got if running]
    assert len(during) >= 40  # 2 s of the 8-s drive's 20 Hz rows at least, while it ran
    assert during == sorted(during) and len(set(during)) == len(during)


def test_pacc_drive_paces_with_foxglove_and_refuses_a_bad_pace(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    start = time.perf_counter()
    assert drive_main(["--duration", "2", "--pace", "4"]) == 0
    assert time.perf_counter() - start >= 0.45
    assert "paced at 4x real time" in capsys.readouterr().out
    assert drive_main(["--duration", "1", "--foxglove", "127.0.0.1:0", "--pace", "0"]) == 0
    assert "paced" not in capsys.readouterr().out
    start = time.perf_counter()
    assert drive_main(["--duration", "0.5", "--foxglove", "127.0.0.1:0"]) == 0
    assert time.perf_counter() - start >= 0.45  # real time: the default with --foxglove
    assert "paced at 1x real time" in capsys.readouterr().out
    assert drive_main(["--pace", "1e-9"]) == 2
    assert "--pace 1e-09: 0 or at least 0.001" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        drive_main(["--pace", "-1"])
    assert "--pace" in capsys.readouterr().err
    log = tmp_path / "m.mcap"
    assert drive_main(["--manual", "--log", str(log), "--pace", "2"]) == 2
    assert "drop --pace" in capsys.readouterr().err


def test_pacc_sim_with_a_live_view_records_the_whole_world(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``pacc sim --foxglove --can-log``: the world streamed as the simulator runs, every row
    of it in the file too (the last ticks' included), as without the live view."""
    from pacc.commands import sim as sim_cli  # noqa: PLC0415 - an entry point, on top

    counts = []
    for name, extra in (("plain", []), ("live", ["--foxglove", "127.0.0.1:0"])):
        path = tmp_path / f"{name}.mcap"
        argv = ["-i", "virtual", "-c", f"test-live-sim-{name}", "--duration", "1", "--quiet"]
        assert sim_cli.main([*argv, "--can-log", str(path), *extra]) == 0
        world = read_canlog(path).series["/sim/world"]
        assert np.allclose(np.diff(world["t_s"]), 0.05)  # the driver's 20 Hz, no gap
        counts.append(len(world["t_s"]))
    assert "foxglove: live view on ws://127.0.0.1:" in capsys.readouterr().out
    assert counts[0] == counts[1] >= 20


def test_ctrl_c_ends_a_paced_drive_with_its_figures_and_files(tmp_path: Path) -> None:
    """``pacc drive --pace 1`` stopped by Ctrl-C once its recording's first flush (1 s) is
    there: the figures of the drive so far, ``--log`` and ``--can-log`` (the world included)
    written, exit status 130."""
    log, can_log = tmp_path / "run.mcap", tmp_path / "bus.mcap"
    argv = ["--duration", "60", "--pace", "1", "--log", str(log), "--can-log", str(can_log)]

    def sigint_default() -> None:  # an ignored SIGINT would survive exec (a background CI)
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})

    child = subprocess.Popen(
        [sys.executable, "-m", "pacc", "drive", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])},
        preexec_fn=sigint_default,  # noqa: PLW1509 - no threads in the test process here
    )
    assert child.stdout is not None
    first = child.stdout.readline()  # "drive: paced at 1x ..." once the drive starts
    assert "paced at 1x" in first
    part, deadline = can_log.with_name(can_log.name + ".part"), time.monotonic() + 30.0
    while time.monotonic() < deadline and child.poll() is None:  # until the first flush (1 s)
        try:
            if len(read_canlog(part, recover=True).frames):
                break
        except (OSError, CanLogError):  # not there yet, or its header half written
            pass
        time.sleep(0.05)
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=30)
    assert child.returncode == 130, err
    stopped = float(err.split("interrupted at t = ")[1].split(" s")[0])
    assert 0.5 < stopped < 20.0 and "Traceback" not in err
    assert "collisions" in out and f"log            {log}" in out
    world = read_canlog(can_log).series["/sim/world"]
    assert abs(world["t_s"][-1] - stopped) <= 0.1  # the world up to where it stopped
