"""``pacc replay LOG --frames rx`` into a ``pacc ecu`` of another process, as docs/logs.md
prints it: over python-can-remote on 127.0.0.1 (no vcan in CI); ``-i virtual``, which no
other process can reach, is refused with a hint."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import can
import pytest

from ecu.buslog.reader import read_canlog
from pacc import cli
from tests.sim_bus.test_two_processes import remote_bus

__all__ = ["remote_bus"]  # the fixture: a python-can-remote server on a free port

ROOT = Path(__file__).resolve().parents[2]


def _drive(folder: Path, duration_s: float) -> Path:
    rec = folder / "drive.mcap"
    argv = ["drive", "--scenario", "B", "--driver", "d2", "--controller", "predefined+oa"]
    assert (
        cli.main([*argv, "--seed", "1", "--duration", str(duration_s), "--can-log", str(rec)]) == 0
    )
    return rec


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 6-s drive: an ECU of another process has time to start and answer."""
    return _drive(tmp_path_factory.mktemp("replay"), 6.0)


@pytest.fixture(scope="module")
def short_drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 1-s drive: a real-time replay that needs no answer."""
    return _drive(tmp_path_factory.mktemp("short"), 1.0)


def test_replay_on_a_virtual_bus_is_refused_with_a_hint(
    short_drive: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert (
        cli.main(["replay", str(short_drive), "-i", "virtual", "-c", "bus0", "--frames", "rx"]) == 2
    )
    err = capsys.readouterr().err
    assert "no other ECU can listen" in err and "-i remote" in err


def test_replay_onto_a_missing_socketcan_points_to_the_remote_bus(
    short_drive: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    try:
        can.Bus(interface="socketcan", channel="vcan0").shutdown()
        pytest.skip("this host has SocketCAN and vcan0")
    except (OSError, can.CanError):
        pass
    assert cli.main(["replay", str(short_drive), "-i", "socketcan", "-c", "vcan0"]) == 2
    err = capsys.readouterr().err
    assert "cannot open the CAN bus" in err and "-i remote" in err


def test_replay_sends_every_received_frame_onto_a_shared_bus(
    short_drive: Path, remote_bus: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """In this process (the next test runs the command as a user does)."""
    n_rx = int(read_canlog(short_drive).frames.rx.sum())
    argv = ["replay", str(short_drive), "-i", "remote", "-c", remote_bus, "--frames", "rx"]
    assert cli.main(argv) == 0
    assert f"replay: {n_rx} frames of {short_drive} sent" in capsys.readouterr().out


@pytest.mark.slow
def test_replayed_inputs_drive_an_ecu_in_another_process(drive: Path, remote_bus: str) -> None:
    bus = ["-i", "remote", "-c", remote_bus]
    pacc = [sys.executable, "-m", "pacc"]
    ecu = subprocess.Popen(
        [*pacc, "ecu", *bus, "--duration", "12"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        replay = subprocess.run(
            [*pacc, "replay", str(drive), *bus, "--frames", "rx"],
            check=False,
            capture_output=True,
            text=True,
            timeout=60,
            cwd=ROOT,
        )
    finally:
        ecu.kill()
        ecu.communicate(timeout=30)
    assert replay.returncode == 0, replay.stderr
    n_rx = int(read_canlog(drive).frames.rx.sum())
    assert f"replay: {n_rx} frames of {drive} sent" in replay.stdout
    match = re.search(r"ACC commands received: (\d+)", replay.stdout)
    assert match is not None and int(match.group(1)) > 100, replay.stdout
