"""``pacc study --scheduler tcp://...`` with no scheduler there: refused at once, before any
IRL table is learned."""

from __future__ import annotations

import socket
import time
from pathlib import Path

import pytest

from pacc import cli


def test_a_scheduler_that_does_not_answer_is_refused_before_learning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    start = time.monotonic()
    argv = ["study", "--scheduler", address, "--drivers", "d1", "--trials", "1"]
    code = cli.main([*argv, "--duration", "5", "--out", str(tmp_path / "s"), "-q"])
    took = time.monotonic() - start
    err = capsys.readouterr().err
    assert code == 2 and f"no Dask scheduler answers at {address}" in err
    assert "learning each driver's IRL table" not in err and took < 10.0
    assert not (tmp_path / "s" / "cloud").exists()
