"""`pacc ecu` and `pacc sim` as two processes on one bus that crosses processes.

No vcan in CI's kernel, so the bus is python-can-remote's: a server process holds a
python-can ``virtual`` bus and serves it over a websocket on 127.0.0.1; each of the two
pacc commands opens it with python-can's ``remote`` interface (``-i remote -c ws://...``),
exactly as a user would. Skipped where python-can-remote is not installed.
"""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO

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


class _Output:
    """Every line a process prints, read on a thread as it comes (a pipe never fills)."""

    def __init__(self, proc: subprocess.Popen[str]) -> None:
        assert proc.stdout is not None
        self.lines: list[str] = []
        self._new = threading.Condition()
        self._thread = threading.Thread(target=self._read, args=(proc.stdout,), daemon=True)
        self._thread.start()

    def _read(self, stream: IO[str]) -> None:
        for line in iter(stream.readline, ""):
            with self._new:
                self.lines.append(line)
                self._new.notify_all()

    def wait_for(self, text: str, timeout_s: float) -> None:
        """Return once a line holds ``text``; fail after ``timeout_s`` s or at the end."""
        with self._new:
            found = self._new.wait_for(
                lambda: any(text in x for x in self.lines) or not self._thread.is_alive(),
                timeout_s,
            )
            if not (found and any(text in x for x in self.lines)):
                pytest.fail(f"never printed {text!r}: {''.join(self.lines)}")

    def text(self) -> str:
        """All it printed (after the process ended)."""
        self._thread.join(timeout=30)
        return "".join(self.lines)


def test_ecu_and_sim_in_two_processes(remote_bus: str) -> None:
    """The simulator's frames reach the ECU's process and the ECU's commands reach the
    simulator's: the ECU engages (SET from the simulated driver), no frame corrupted. The
    simulator starts once the ECU says it runs, and the ECU stops (SIGTERM) once the
    simulator is done, so a slow start on a loaded machine shortens neither."""
    bus = ["-i", "remote", "-c", remote_bus]
    pacc = [sys.executable, "-m", "pacc"]
    ecu = subprocess.Popen(
        [*pacc, "ecu", *bus, "--set-speed", "40", "--duration", "120"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    out = _Output(ecu)
    try:
        out.wait_for("ECU running", 60.0)
        sim = subprocess.run(
            [*pacc, "sim", *bus, "--duration", str(RUN_S), "--quiet"],
            check=False,
            capture_output=True,
            text=True,
            timeout=60,
            cwd=ROOT,
        )
        ecu.send_signal(signal.SIGTERM)
        ecu.wait(timeout=60)
    finally:
        if ecu.poll() is None:
            ecu.kill()
    ecu_out = out.text()
    assert sim.returncode == 0, sim.stderr
    assert ecu.returncode == 0, ecu_out
    received = _count(r"(\d+) ACC commands received", sim.stdout)
    frames_in = _count(r"frames in/out:\s+(\d+)", ecu_out)
    assert received > 50 * (RUN_S - 2.0)  # ACC_Command every 20 ms while both run
    assert frames_in > 200 * (RUN_S - 2.0)  # ESC and PEDAL every 10 ms, RADAR, HMI
    # a loaded machine may deliver late (skipped counters), never corrupt
    assert "wrong_crc" not in ecu_out and "wrong_dlc" not in ecu_out
    assert "STANDBY -> ACTIVE" in ecu_out
