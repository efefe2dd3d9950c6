"""`pacc ecu` and `pacc sim` as two processes on one bus that crosses processes.

No vcan in CI's kernel, so the bus is python-can-remote's: a server process holds a
python-can ``virtual`` bus and serves it over a websocket on 127.0.0.1; each of the two
pacc commands opens it with python-can's ``remote`` interface (``-i remote -c ws://...``),
exactly as a user would. Skipped where python-can-remote is not installed.
"""

from __future__ import annotations

import re
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import can_remote  # noqa: F401 - the bus server the test starts: a dev dependency, so fail if missing
import pytest

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]
RUN_S = 3.0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture
def remote_bus() -> Iterator[str]:
    """A python-can-remote server on 127.0.0.1 for this test; yields its channel URL."""
    port = _free_port()
    server = subprocess.Popen(
        [sys.executable, "-m", "can_remote", "-i", "virtual", "-c", f"pacc-two-{port}"]
        + ["-H", "127.0.0.1", "-p", str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 15.0
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
                break
            except OSError:
                if time.monotonic() > deadline or server.poll() is not None:
                    pytest.fail("the python-can-remote server did not start")
                time.sleep(0.1)
        yield f"ws://127.0.0.1:{port}/"
    finally:
        server.terminate()
        server.wait(timeout=10)


def _count(pattern: str, text: str) -> int:
    match = re.search(pattern, text)
    assert match is not None, text
    return int(match.group(1))


def test_ecu_and_sim_in_two_processes(remote_bus: str) -> None:
    """The simulator's frames reach the ECU's process and the ECU's commands reach the
    simulator's: the ECU engages (SET from the simulated driver), no frame corrupted."""
    bus = ["-i", "remote", "-c", remote_bus]
    pacc = [sys.executable, "-m", "pacc"]
    ecu = subprocess.Popen(
        [*pacc, "ecu", *bus, "--set-speed", "40", "--duration", str(RUN_S + 1.0)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        time.sleep(0.5)
        sim = subprocess.run(
            [*pacc, "sim", *bus, "--duration", str(RUN_S), "--quiet"],
            check=False,
            capture_output=True,
            text=True,
            timeout=60,
            cwd=ROOT,
        )
        ecu_out, ecu_err = ecu.communicate(timeout=60)
    finally:
        if ecu.poll() is None:
            ecu.kill()
    assert sim.returncode == 0, sim.stderr
    assert ecu.returncode == 0, ecu_err
    received = _count(r"(\d+) ACC commands received", sim.stdout)
    frames_in = _count(r"frames in/out:\s+(\d+)", ecu_out)
    assert received > 50 * (RUN_S - 2.0)  # ACC_Command every 20 ms while both run
    assert frames_in > 200 * (RUN_S - 2.0)  # ESC and PEDAL every 10 ms, RADAR, HMI
    # a loaded machine may deliver late (skipped counters), never corrupt
    assert "wrong_crc" not in ecu_out and "wrong_dlc" not in ecu_out
    assert "STANDBY -> ACTIVE" in ecu_out
