"""``pacc ecu`` in-process on the virtual bus, with a thread playing the other nodes."""

from __future__ import annotations

import itertools
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import can
import pytest

from dbc import BINDING_PATH, DBC_PATH
from dbc.codec import load_codec
from dbc.vocab.dgpt import predefined
from dbc.vocab.dgpt_file import load_dgpt
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime
from pacc.commands.ecu import main
from pacc.commands.ecu.run import run_until_done
from tests.cli_util import exit_code
from tests.conftest import TakeoverRun
from tests.peers import PeerNodes

_ids = itertools.count()
CODEC = load_codec()


class Peers(threading.Thread):
    """Plays ESC/PEDAL/RADAR/HMI in real time: SET at 1.5 s, accelerator 1.9..3.1 s (its switch,
    and its position at ``accel_pct`` %; 0, the resting position, by default).

    The timeline starts at the ECU's first frame, not at the thread's start: on a loaded
    machine (pytest -n 2 on two cores) the ECU may take a while to open its bus, and SET
    needs a second of valid inputs before it (SET at 1.5 s leaves half a second for the first
    frames of every role to arrive on a loaded machine).
    """

    def __init__(self, channel: str, seconds: float, accel_pct: float = 0.0) -> None:
        super().__init__(daemon=True)
        self.channel, self.seconds, self.accel_pct = channel, seconds, accel_pct
        self.status: list[dict[str, float | int]] = []

    def run(self) -> None:
        with can.Bus(interface="virtual", channel=self.channel) as bus:
            peers = PeerNodes(bus, CODEC)
            peers.set("radar", gap_m=60.0)
            deadline = time.monotonic() + 30.0
            while bus.recv(0.05) is None and time.monotonic() < deadline:
                pass
            t0 = time.monotonic()
            while (t := time.monotonic() - t0) < self.seconds:
                pressed = 1.9 <= t < 3.1
                peers.set("hmi", set=int(1.5 <= t < 1.7))
                peers.set(
                    "pedals", accel_pressed=int(pressed), accel_pedal_pct=self.accel_pct * pressed
                )
                peers.send_due(t)
                while (msg := bus.recv(0)) is not None:
                    mc = CODEC.by_id.get(msg.arbitration_id)
                    if mc is not None and mc.role == "status":
                        self.status.append(mc.decode(msg.data).values)
                time.sleep(0.002)


_SIGTERM_SCRIPT = """
import os, signal, sys, threading, time
import can
from dbc.codec import load_codec
from pacc.commands.ecu import main
from tests.peers import PeerNodes

def peers():
    with can.Bus(interface="virtual", channel="sigterm") as bus:
        p = PeerNodes(bus, load_codec())
        p.set("radar", gap_m=60.0)
        # the script's timeline starts at the ECU's first frame, not at the thread's start:
        # on a loaded machine the ECU may take more than a second to import and open its bus
        deadline = time.monotonic() + 30.0
        while bus.recv(0.05) is None and time.monotonic() < deadline:
            pass
        t0 = time.monotonic()
        while (t := time.monotonic() - t0) < 4.0:
            p.set("hmi", set=int(1.5 <= t < 1.7))
            p.set("pedals", accel_pressed=int(1.9 <= t < 3.1))
            p.send_due(t)
            while bus.recv(0) is not None:
                pass
            time.sleep(0.002)
    os.kill(os.getpid(), signal.SIGTERM)  # as a service manager stops the ECU

threading.Thread(target=peers, daemon=True).start()
sys.exit(main(["-i", "virtual", "-c", "sigterm", "--headway", "3",
               "--takeovers", sys.argv[1], "--save-profile", sys.argv[2]]))
"""


@pytest.mark.slow
def test_sigterm_stops_cleanly_keeping_takeovers_and_profile(tmp_path: Path) -> None:
    """SIGTERM (systemd, docker stop) during a takeover's post window: the open segment is
    written, the adapted profile saved and the summary printed, exit code 0."""
    script = tmp_path / "run.py"
    script.write_text(_SIGTERM_SCRIPT)
    proc = subprocess.run(
        [sys.executable, str(script), str(tmp_path / "to"), str(tmp_path / "p.json")],
        env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert "takeover 1 (accel)" in proc.stdout and "takeovers:      1" in proc.stdout
    assert len(list((tmp_path / "to").glob("*-takeover-*.mcap"))) == 1
    saved = load_dgpt(tmp_path / "p.json")
    assert saved.version == 1 and saved.source == "adapted"


def test_closed_stdout_does_not_stop_the_ecu_or_lose_the_profile(tmp_path: Path) -> None:
    """The reader of the ECU's output goes away (``pacc ecu | head``, a dead log pipe): the
    ECU keeps running to the end and still saves the profile; no traceback."""
    target = tmp_path / "p.json"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "pacc",
            "ecu",
            "-i",
            "virtual",
            "-c",
            "closed-stdout",
            "--duration",
            "1.0",
            "--save-profile",
            str(target),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()  # the reader is gone before the first line
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 0, err
    assert "Traceback" not in err
    assert load_dgpt(target).version == 0


def test_invalid_profile_refused_falls_back(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"format": "pacc.dgpt/1", "speed_mps": [0, 1], "gap_m": [1, 2]}))
    channel = f"ecu-cli-{next(_ids)}"
    peers = Peers(channel, 1.0)
    peers.start()
    rc = main(["-i", "virtual", "-c", channel, "--profile", str(bad), "--duration", "0.8"])
    peers.join()
    captured = capsys.readouterr()
    assert rc == 0
    assert "profile refused" in captured.err and str(bad) in captured.err
    assert "missing key(s): version, source" in captured.err
    assert "running on the predefined table (1.5 s headway" in captured.err
    assert peers.status and all(s["fault_code"] == 5 for s in peers.status)
    # DGPT(20 m/s) of the fallback table, once the first ESC frame has arrived
    assert peers.status[-1]["desired_gap_m"] == pytest.approx(34.0, abs=0.05)


def test_usage_and_bus_errors(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["--brake", "sometimes"])
    assert info.value.code == 2
    assert exit_code(main, ["--duration", "-1"]) == 2
    assert main(["--headway", "0.2", "-i", "virtual", "-c", "x"]) == 2
    assert "outside the safety bounds" in capsys.readouterr().err
    assert main(["-i", "no_such_interface", "-c", "x", "--duration", "0"]) == 1
    assert "cannot open the CAN bus" in capsys.readouterr().err
    assert main(["-i", "virtual", "-c", "x", "--dbc", "/nonexistent.dbc"]) == 2
    assert "--dbc /nonexistent.dbc needs --binding" in capsys.readouterr().err


def _network(tmp_path: Path, name: str, text: str) -> list[str]:
    """``--dbc`` and ``--binding`` of an edited pacc DBC with the pacc binding naming it."""
    dbc = tmp_path / name
    dbc.write_text(text)
    binding = tmp_path / f"{name}.binding.toml"
    binding.write_text(BINDING_PATH.read_text().replace('dbc = "pacc.dbc"', f'dbc = "{name}"'))
    return ["--dbc", str(dbc), "--binding", str(binding)]


def test_dbc_needs_the_binding_that_names_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--dbc alone, or with a binding written for another DBC, is a usage error (exit 2)."""
    other = tmp_path / "other.dbc"
    other.write_text(DBC_PATH.read_text())
    argv = ["-i", "virtual", "-c", f"ecu-cli-{next(_ids)}", "--duration", "0"]
    assert main([*argv, "--dbc", str(other)]) == 2
    assert "needs --binding" in capsys.readouterr().err
    assert main([*argv, "--dbc", str(other), "--binding", str(BINDING_PATH)]) == 2
    assert "binds pacc.dbc, not other.dbc" in capsys.readouterr().err
    assert main([*argv, *_network(tmp_path, "other.dbc", DBC_PATH.read_text())]) == 0


def test_dbc_without_periods_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A wrong DBC (no GenMsgCycleTime on an input) exits 1 with a message, no traceback."""
    text = DBC_PATH.read_text().replace('BA_ "GenMsgCycleTime" BO_ 176 10;\n', "")
    network = _network(tmp_path, "nocycle.dbc", text)
    assert main(["-i", "virtual", "-c", f"ecu-cli-{next(_ids)}", *network]) == 1
    err = capsys.readouterr().err
    assert "ESC_Speed" in err and "GenMsgCycleTime" in err


def test_dbc_that_cannot_carry_fault_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = DBC_PATH.read_text().replace(
        "SG_ AccState : 32|3@1+ (1,0) [0|4]", "SG_ AccState : 32|2@1+ (1,0) [0|3]"
    )
    network = _network(tmp_path, "narrow.dbc", text)
    assert main(["-i", "virtual", "-c", f"ecu-cli-{next(_ids)}", *network]) == 1
    err = capsys.readouterr().err
    assert "ACC_Command: acc_state range [0, 3] cannot carry [0, 4]" in err


def test_unwritable_save_profile_refused_before_the_drive(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--save-profile into a directory that does not exist: refused at start (exit 1), not
    after the whole drive when the adapted table would be lost."""
    target = tmp_path / "no-such-dir" / "p.json"
    rc = main(
        [
            "-i",
            "virtual",
            "-c",
            f"ecu-cli-{next(_ids)}",
            "--duration",
            "0.3",
            "--save-profile",
            str(target),
        ]
    )
    captured = capsys.readouterr()
    assert rc == 1
    assert "ECU running" not in captured.out
    assert str(target.parent) in captured.err


def test_help_is_fast_and_lists_flags(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    text = capsys.readouterr().out
    for flag in (
        "--interface",
        "--channel",
        "--bitrate",
        "--profile",
        "--headway",
        "--no-adaptation",
        "--brake",
        "--takeovers",
        "--duration",
    ):
        assert flag in text


@pytest.mark.parametrize(
    ("flags", "line"),
    [
        (
            ["--adaptation-mode", "paper", "--brake", "cancel"],
            "adaptation: paper; brake press: cancel",
        ),
        (["--no-adaptation"], "adaptation: off; brake press: resume"),
    ],
)
def test_cli_adaptation_and_brake_options(
    flags: list[str], line: str, capsys: pytest.CaptureFixture[str]
) -> None:
    rc = main(["-i", "virtual", "-c", f"ecu-cli-{next(_ids)}", "--duration", "0.1", *flags])
    assert rc == 0
    assert line in capsys.readouterr().out


def test_cli_refuses_unknown_adaptation_mode(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--adaptation-mode", "magic"])
    assert exc.value.code == 2
    assert "invalid choice: 'magic'" in capsys.readouterr().err


def test_bus_failure_ends_the_run_cleanly() -> None:
    """A bus that fails under the runtime (here: shut down by another thread, so python-can's
    virtual bus raises CanOperationError on receive) ends the run with the error text
    instead of a traceback, and the open takeover segment is still flushed."""
    bus = can.Bus(interface="virtual", channel=f"ecu-cli-{next(_ids)}")
    flushed: list[bool] = []
    node = EcuNode(EcuConfig(), predefined(1.5))
    node.finish = lambda: flushed.append(True)  # type: ignore[method-assign]
    rt = EcuRuntime(bus, node)
    timer = threading.Timer(0.2, bus.shutdown)
    timer.start()
    t0 = time.monotonic()
    try:
        error = run_until_done(rt, 5.0)
    finally:
        timer.cancel()
        bus.shutdown()
    assert error is not None and "closed" in error.lower()
    assert flushed == [True]
    # it ran, then stopped at the failure, not at 5 s (cycle counts vary under load)
    assert rt.cycles >= 1 and time.monotonic() - t0 < 4.0


@pytest.mark.slow
def test_cli_runs_takeover_prints_summary_and_can_log_records_it(
    takeover_run: TakeoverRun,
) -> None:
    """The scripted run: the summary and the takeover, the adapted profile saved, the bus
    recording (its takeover segment stamped with the wall clock) replayed bit for bit."""
    from dbc.vocab.triplog_file import read_trip  # noqa: PLC0415
    from ecu.buslog.reader import read_canlog  # noqa: PLC0415
    from ecu.buslog.replay import replay_through_ecu  # noqa: PLC0415

    out, folder = takeover_run.out, takeover_run.folder
    assert takeover_run.rc == 0, takeover_run.err
    assert "adaptation: timegap; brake press: resume" in out
    assert "state OFF -> STANDBY" in out
    assert "state STANDBY -> ACTIVE" in out
    assert "state ACTIVE -> OVERRIDE" in out
    assert "takeover 1 (accel)" in out
    assert "adaptation applied" in out
    for line in (
        "cycles:",
        "frames in/out:",
        "E2E errors:",
        "takeovers:      1",
        "adaptations:    1",
        "max cycle time:",
    ):
        assert line in out
    # the open takeover segment is flushed at exit; the adapted profile saved
    assert len(list((folder / "spool").glob("*-takeover-*.mcap"))) == 1
    saved = load_dgpt(folder / "p.json")
    assert saved.version == 1 and saved.source == "adapted"
    rec = folder / "bus.mcap"
    assert f"frames written to {rec}" in out
    log = read_canlog(rec)
    assert log.node == "ecu" and (~log.frames.rx).sum() >= 150  # 50 Hz commands for ~4 s
    assert log.frames.rx.sum() > 500 and "ACC_Command" in log.decoded
    assert any("takeover 1" in text for _, text in log.events), (log.events, out)
    segment = read_trip(next((folder / "spool").glob("*-takeover-*.mcap")))
    start = segment.meta["start_utc"]  # the wall clock, not the boot clock
    assert start[:10] == time.strftime("%Y-%m-%d", time.gmtime(takeover_run.started_utc_s))
    # its cycles at their recorded times: the replayed ECU sends what it sent, bit for bit
    result = replay_through_ecu(log)
    assert result.identical and len(result.sent) >= 150
    assert "OVERRIDE" in [s for _, s in result.states]


def test_help_path_imports_neither_python_can_nor_mcap() -> None:
    code = (
        "import sys, pacc.commands.ecu; "
        "print(sorted({'can', 'mcap', 'cantools'} & set(sys.modules)))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_a_profile_whose_driver_is_not_a_plain_name_is_refused(tmp_path: Path) -> None:
    """A lone surrogate in the profile's driver id: refused with one line (no traceback when
    the id is printed to a UTF-8 stdout), the ECU runs on the predefined table."""
    bad = tmp_path / "bad.json"
    text = json.dumps(predefined(1.5).to_json_dict()).replace('"guest"', '"d1\\ud800"')
    bad.write_text(text)
    proc = subprocess.run(
        [sys.executable, "-m", "pacc", "ecu", "-i", "virtual", "-c", "s", "--duration", "0"]
        + ["--profile", str(bad)],
        env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "profile refused" in proc.stderr and "not a plain name" in proc.stderr


@pytest.mark.parametrize("option", ["--driver", "--condition"])
def test_driver_and_condition_must_be_plain_names(
    option: str, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["-i", "virtual", "-c", "x", "--duration", "0", option, "../../x"]
    assert main(argv) == 2
    assert f"{option} '../../x': not a plain name" in capsys.readouterr().err


def test_missing_socketcan_points_to_the_remote_bus(capsys: pytest.CaptureFixture[str]) -> None:
    try:
        can.Bus(interface="socketcan", channel="vcan0").shutdown()
        pytest.skip("this host has SocketCAN and vcan0")
    except (OSError, can.CanError):
        pass
    assert main(["-i", "socketcan", "-c", "vcan0", "--duration", "0"]) == 1
    err = capsys.readouterr().err
    assert "cannot open the CAN bus" in err and "-i remote" in err and "docs/vehicles.md" in err


def test_an_adaptation_method_with_no_adaptation_is_refused(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["-i", "virtual", "-c", f"ecu-cli-{next(_ids)}", "--duration", "0.1"]
    rc = main([*argv, "--no-adaptation", "--adaptation-method", "bayes"])
    assert rc == 2
    assert "--adaptation-method with --no-adaptation" in capsys.readouterr().err
