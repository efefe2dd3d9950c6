"""Test-wide settings: hypothesis without per-example deadlines (CI machines are slow and
shared); the example count can be raised with HYPOTHESIS_PROFILE=thorough; the shared Dask
cluster of the distributed tests; the one scripted takeover run of ``pacc ecu`` that the ECU's
command-line tests and the README's takeover flow read."""

from __future__ import annotations

import io
import os
import time
from collections.abc import Iterator
from concurrent.futures import Executor
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import settings

from cloud_sync.engine import dask_executor

settings.register_profile("default", deadline=None, max_examples=100)
settings.register_profile("thorough", deadline=None, max_examples=1000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


@pytest.fixture(scope="session")
def dask_cluster() -> Iterator[Executor]:
    """One Dask LocalCluster of 2 single-threaded worker processes (each under a nanny),
    shared by the tests that need one within a test process (under pytest-xdist: at most
    one per xdist worker that runs such a test)."""
    executor = dask_executor("local", 2)  # Dask is imported (~1 s) only here
    try:
        yield executor
    finally:
        executor.shutdown()


@dataclass(frozen=True)
class TakeoverRun:
    """What one ``pacc ecu`` run printed and wrote; ``folder`` holds ``spool/`` (the takeover
    segments), ``p.json`` (the adapted profile) and ``bus.mcap`` (the bus recording)."""

    rc: int
    out: str
    err: str
    folder: Path
    started_utc_s: float


@pytest.fixture(scope="session")
def takeover_run(tmp_path_factory: pytest.TempPathFactory) -> TakeoverRun:
    """``pacc ecu --driver d2`` for 4 s against the scripted peers of ``tests.ecu.test_cli``
    (SET, then a 1.2-s accelerator takeover), in real time: run once, read by several tests
    (a test that changes its files works on a copy)."""
    from pacc import cli  # noqa: PLC0415 - the ECU's imports only where a test needs the run
    from tests.ecu.test_cli import Peers  # noqa: PLC0415

    folder = tmp_path_factory.mktemp("takeover-run")
    peers = Peers("takeover-run", 4.2)
    peers.start()
    started = time.time()
    argv = ["ecu", "-i", "virtual", "-c", "takeover-run", "--headway", "3", "--duration", "4.0"]
    argv += ["--driver", "d2", "--takeovers", str(folder / "spool")]
    argv += ["--save-profile", str(folder / "p.json"), "--can-log", str(folder / "bus.mcap")]
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        rc = cli.main(argv)
    peers.join()
    return TakeoverRun(rc, out.getvalue(), err.getvalue(), folder, started)
