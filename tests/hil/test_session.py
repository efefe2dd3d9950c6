"""A session without a browser: resume after a crash, a lost page, a collision, bad input."""

from __future__ import annotations

import asyncio
import json
import threading
import time
from pathlib import Path

import can
import httpx
import pytest

from dbc.vocab.dgpt import predefined
from ecu.buslog.live import FoxgloveSink
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime
from pacc.commands import hil as hil_cmd
from pacc.commands import study as study_cmd
from pacc.hil.plan import free_plan, paper_plan
from pacc.hil.server import ServerThread, create_app
from pacc.hil.session import Session, SessionConfig
from sim_bus.errors import SimError


def _cfg(tmp_path: Path, short_s: float = 5.0) -> SessionConfig:
    return SessionConfig("P03", "paper", tmp_path, short_s=short_s, lockstep=True)


def test_resume_after_a_crash_mid_drive(tmp_path: Path) -> None:
    s = Session(_cfg(tmp_path), paper_plan("P03"))
    s.handle({"t": "action", "name": "consent"})
    s.handle({"t": "action", "name": "start"})
    view = s.handle({"t": "step", "n": 100})
    assert view is not None and view["phase"] == "driving" and view["state"]["t"] == 1.0
    s.close()  # the process dies mid-drive: nothing of the practice drive is kept as done
    again = Session(_cfg(tmp_path), paper_plan("P03"))
    step = again.current()
    assert step is not None and step.id == "practice" and again.phase == "ready"
    manifest = json.loads((tmp_path / "P03" / "manifest.json").read_text())
    assert "consent" in manifest["done"]
    again._save()
    manifest = json.loads((tmp_path / "P03" / "manifest.json").read_text())
    assert manifest["events"][-1]["event"] == "resumed"
    with pytest.raises(SimError, match="another participant"):
        Session(_cfg(tmp_path), free_plan("B", None))


@pytest.mark.slow
def test_lost_page_pauses_and_marks_the_drive(tmp_path: Path) -> None:
    s = Session(SessionConfig("P04", "free", tmp_path, short_s=2.0), free_plan("B", "predefined"))
    conn = s.connect()
    s.handle({"t": "action", "name": "start"})
    assert s.runner is not None
    s.runner.thread.join(0.5)
    s.disconnect(conn)
    assert s.phase == "paused" and s.runner.paused
    t_paused = s.drive.world.t_s if s.drive else -1.0
    s.runner.thread.join(0.3)
    assert s.drive is not None and s.drive.world.t_s == t_paused  # the world holds still
    s.connect()
    s.handle({"t": "action", "name": "continue"})
    s.runner.thread.join(10.0)
    assert s.phase == "after"
    record = json.loads((tmp_path / "P04" / "drives" / "drive.json").read_text())
    assert record["pauses"] == [
        {"t_s": pytest.approx(t_paused, abs=0.02), "why": "connection lost"}
    ]
    # wall time as in pacc study: the 2-s drive took 2 s and the 0.3-s pause (not the
    # milliseconds its ticks cost)
    assert record["row"]["sim_s"] == 2.0
    assert 2.2 < record["row"]["wall_s"] < 5.0
    assert record["brake_mode"] == "resume" and record["weather"] == "day"
    s.close()


def test_collision_ends_the_drive_and_is_reported(tmp_path: Path) -> None:
    s = Session(_cfg(tmp_path, short_s=60.0), free_plan("B", None))
    s.handle({"t": "action", "name": "start"})
    s.handle({"t": "in", "ka": True, "kb": False})  # full throttle into the lead
    view = s.handle({"t": "step", "n": 6000})
    assert view is not None and view["phase"] == "after" and "collision" in view["message"]
    assert view["state"]["collided"] and view["state"]["t"] < 60.0
    record = json.loads((tmp_path / "P03" / "drives" / "drive.json").read_text())
    assert record["row"]["collision"] == 1 and record["collision_t_s"] > 0


def test_mapping_api_refuses_nonsense(tmp_path: Path) -> None:
    s = Session(_cfg(tmp_path), free_plan("B", None))
    server = ServerThread(create_app(s, tmp_path / "pad.json"))
    port = server.start()
    try:
        base = f"http://127.0.0.1:{port}"
        assert httpx.get(base + "/api/mapping").json() is None
        bad = httpx.put(
            base + "/api/mapping", content=b'{"accel": {"axis": 1, "rest": 0, "full": 0}}'
        )
        assert bad.status_code == 400 and not (tmp_path / "pad.json").exists()
        assert httpx.put(base + "/api/mapping", content=b"[1]").status_code == 400
        ok = httpx.put(base + "/api/mapping", content=b'{"brake": {"button": 6}}')
        assert ok.status_code == 200
        assert httpx.get(base + "/api/mapping").json() == {"brake": {"button": 6}}
        page = httpx.get(base + "/").text
        assert "<canvas" in page and "http" not in page.replace("http-equiv", "")
    finally:
        server.stop()


def test_cli_refuses_bad_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert hil_cmd.main(["--protocol", "paper", "--out", str(tmp_path)]) == 2
    assert "needs --participant" in capsys.readouterr().err
    assert hil_cmd.main(["--protocol", "paper", "--participant", "anon"]) == 2
    assert hil_cmd.main(["--controller", "irl", "--out", str(tmp_path)]) == 2
    assert "needs --table" in capsys.readouterr().err
    (tmp_path / "bad.json").write_text("{}")
    argv = ["--controller", "irl+oa", "--table", str(tmp_path / "bad.json"), "--out", str(tmp_path)]
    assert hil_cmd.main(argv) == 2
    assert study_cmd.main(["--hil", str(tmp_path / "none"), "--out", str(tmp_path / "t")]) == 2
    assert "not a folder of hil sessions" in capsys.readouterr().err


@pytest.mark.slow
def test_a_separate_ecu_on_the_bus_drives_the_car(tmp_path: Path) -> None:
    """``pacc hil -i/-c``: no ECU in the session; one on the bus (its own real-time clock)
    engages when the person presses SET."""
    channel = f"hil-ext-{id(tmp_path):x}"
    ecu_bus = can.Bus(interface="virtual", channel=channel)
    rt = EcuRuntime(ecu_bus, EcuNode(EcuConfig(set_speed_mps=40.0), predefined(1.5)))
    ecu = threading.Thread(target=rt.run_realtime, args=(8.0,), daemon=True)
    ecu.start()
    s = Session(
        SessionConfig(
            "P07",
            "free",
            tmp_path,
            short_s=4.0,
            bus=lambda: can.Bus(interface="virtual", channel=channel),
        ),
        free_plan("B", "predefined"),
    )
    try:
        s.handle({"t": "action", "name": "start"})
        assert s.runner is not None and s.drive is not None and s.drive.ecu is None
        states: set[str] = set()
        last_press = -1.0
        deadline = time.monotonic() + 10.0
        while s.phase == "driving" and time.monotonic() < deadline:
            state = s.runner.latest
            states.add(state["acc_state"])
            # SET, again every 0.5 s until the ECU engages, as a person would: on a loaded
            # machine the ECU's own clock may not yet have held its inputs valid for 1 s
            if state["t"] > 1.8 and "ACTIVE" not in states and state["t"] - last_press > 0.5:
                s.handle({"t": "btn", "name": "set"})
                last_press = state["t"]
            time.sleep(0.02)
        assert s.phase == "after" and "ACTIVE" in states
        assert rt.summary().frames_in > 100
    finally:
        s.close()
        rt.stop()
        ecu.join(5.0)
        ecu_bus.shutdown()


def test_a_live_view_streams_each_drive(tmp_path: Path) -> None:
    """``pacc hil --foxglove``: each drive's recording is also served to Foxglove; a
    WebSocket client sees the decoded channels advertised while the person drives."""
    websockets = pytest.importorskip("websockets")
    cfg = SessionConfig("P08", "free", tmp_path, short_s=3.0, lockstep=True, foxglove="127.0.0.1:0")
    s = Session(cfg, free_plan("B", "predefined"))
    try:
        s.handle({"t": "action", "name": "start"})
        assert s.drive is not None and s.drive.recorder is not None
        ports = [k.port for k in s.drive.recorder.sinks if isinstance(k, FoxgloveSink)]
        assert len(ports) == 1

        async def advertised() -> set[str]:
            async with websockets.connect(
                f"ws://127.0.0.1:{ports[0]}", subprotocols=["foxglove.sdk.v1"]
            ) as ws:
                topics: set[str] = set()
                while "/can/ESC_Speed" not in topics:
                    msg = json.loads(await asyncio.wait_for(ws.recv(), 10))
                    if msg["op"] == "advertise":
                        topics |= {c["topic"] for c in msg["channels"]}
                return topics

        s.handle({"t": "step", "n": 100})  # one second of driving: the recorder flushes
        # in a thread of its own: a browser test of this worker may hold an event loop here
        topics: list[set[str]] = []
        client = threading.Thread(target=lambda: topics.append(asyncio.run(advertised())))
        client.start()
        client.join(20)
        assert topics and "/can/ESC_Speed" in topics[0]
    finally:
        s.close()
