"""Crash safety of the vehicle-to-cloud path: a vehicle process that spools takeover batches and
uploads them to the real HTTP service is SIGKILLed at 100 random instants; after restarts and a
final drain, the cloud holds every batch the spool ever committed, each exactly once."""

from __future__ import annotations

import dataclasses
import os
import random
import signal
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from cloud_sync.service.rules import CloudService
from cloud_sync.vehicle.client import HttpCloud
from cloud_sync.vehicle.spool import Spool
from cloud_sync.vehicle.uploader import Uploader, UploaderConfig
from tests.cloud_sync.served import Served
from tests.cloud_sync.test_spool import make_trip

KILLS = 50


def vehicle(spool_dir: Path, log: Path, url: str, token: str, first_seed: int) -> None:
    """The child: spool a new takeover batch, note it, upload everything pending; forever."""
    spool = Spool(spool_dir)
    client = HttpCloud(url, token, timeout_s=5.0)
    uploader = Uploader(spool, client, UploaderConfig(backoff_s=0.01, backoff_max_s=0.05))
    seed = first_seed
    while True:
        trip = make_trip("takeover", n=120, seed=seed)
        batch = spool.put_trip(dataclasses.replace(trip, meta={**trip.meta, "driver_id": "d1"}))
        with log.open("a") as stream:
            stream.write(batch.digest + "\n")
            stream.flush()
            os.fsync(stream.fileno())
        uploader.drain()
        seed += 1


def _lines(path: Path) -> int:
    return len(path.read_text().split()) if path.exists() else 0


def _wait_for_lines(path: Path, n: int, timeout_s: float) -> None:
    """Until ``path`` holds ``n`` lines (the child committed a batch) or ``timeout_s`` passed."""
    deadline = time.monotonic() + timeout_s
    while _lines(path) < n and time.monotonic() < deadline:
        time.sleep(0.005)


@pytest.fixture
def served(tmp_path: Path) -> Iterator[tuple[CloudService, str, str]]:
    service = CloudService.open(tmp_path / "cloud")
    token = service.register_vehicle("car")
    service.register_driver("car", "d1")
    server = Served(service)
    yield service, server.url, token
    server.stop()
    service.store.close()


@pytest.mark.slow
def test_sigkill_while_spooling_and_uploading_loses_and_duplicates_nothing(
    tmp_path: Path, served: tuple[CloudService, str, str]
) -> None:
    service, url, token = served
    spool_dir, log = tmp_path / "spool", tmp_path / "committed.log"
    rng = random.Random(2026)
    committed: set[str] = set()
    # warm up in the parent (lazy imports of the MCAP writer, the HTTP client), so that every
    # forked child is at work within milliseconds and the kills land mid-work
    Spool(tmp_path / "warm-up").put_trip(make_trip("takeover", n=120))
    with HttpCloud(url, token) as client:
        client.public_key_pem()
    for kill in range(KILLS):
        pid = os.fork()
        if pid == 0:  # pragma: no cover - the child only ever dies by SIGKILL
            try:
                vehicle(spool_dir, log, url, token, first_seed=kill * 1000)
            finally:
                os._exit(1)
        if kill % 5 == 0:  # every fifth kill lands after a commit whatever the machine's load
            _wait_for_lines(log, _lines(log) + 1, timeout_s=20.0)
        time.sleep(rng.uniform(0.0, 0.2))
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        # the restart: whatever is under a final name now is committed
        committed |= {b.digest for b in Spool(spool_dir).pending()}
    committed |= set(log.read_text().split()) if log.exists() else set()
    with HttpCloud(url, token) as client:
        spool = Spool(spool_dir)
        Uploader(spool, client).drain()
    assert spool.pending() == []
    in_cloud = [b.digest for b in service.store.batches("d1", "default")]
    assert len(in_cloud) == len(set(in_cloud))  # exactly once
    assert set(in_cloud) == committed  # nothing lost, nothing invented
    assert len(committed) >= KILLS // 10  # the kills did land mid-work, not only at start
