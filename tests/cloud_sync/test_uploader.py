"""The uploader against the real HTTP service: outages, 5xx, slow answers, refusals, duplicates."""

from __future__ import annotations

import asyncio
import dataclasses
import socket
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import uvicorn

from cloud_sync.service.http import create_app
from cloud_sync.service.local import LocalCloud
from cloud_sync.service.rules import CloudService
from cloud_sync.vehicle.client import HttpCloud
from cloud_sync.vehicle.spool import Spool
from cloud_sync.vehicle.uploader import Uploader, UploaderConfig
from tests.cloud_sync.test_spool import make_trip

FAST = UploaderConfig(backoff_s=0.02, backoff_max_s=0.2, poll_s=0.05)

Scope = dict[str, Any]


class DroppedError(RuntimeError):
    """Raised inside the app after the response started: uvicorn drops the connection."""


class Flaky:
    """ASGI wrapper: answers the first ``fail`` upload requests with 503, drops the
    connection of the next ``drop`` ones in the middle of the answer (after the batch was
    stored: the ack is lost, the vehicle must send it again), stalls the next ``stall`` ones
    past the client's timeout, then passes everything to the real app."""

    def __init__(
        self, app: Any, *, fail: int = 0, drop: int = 0, stall: int = 0, stall_s: float = 2.0
    ) -> None:
        self.app, self.fail, self.drop, self.stall, self.stall_s = app, fail, drop, stall, stall_s
        self.seen = 0

    async def __call__(self, scope: Scope, receive: Any, send: Any) -> None:
        if scope["type"] == "http" and scope["path"] == "/v1/batches":
            self.seen += 1
            if self.seen <= self.fail:
                await send({"type": "http.response.start", "status": 503, "headers": []})
                await send({"type": "http.response.body", "body": b"down for maintenance"})
                return
            if self.seen <= self.fail + self.drop:
                await self.app(scope, receive, self._cut(send))
                return
            if self.seen <= self.fail + self.drop + self.stall:
                await asyncio.sleep(self.stall_s)
        await self.app(scope, receive, send)

    @staticmethod
    def _cut(send: Any) -> Any:
        """A send that starts the answer, then fails before its body: a dropped connection."""

        async def cut(message: dict[str, Any]) -> None:
            if message["type"] == "http.response.body":
                raise DroppedError("connection dropped mid-answer")
            headers = [(k, v) for k, v in message.get("headers", []) if k != b"content-length"]
            await send({**message, "headers": [*headers, (b"content-length", b"1000")]})

        return cut


class Server:
    """uvicorn on a fixed loopback port, in a thread; can start after the client."""

    def __init__(self, app: Any, port: int) -> None:
        self.port, self.app = port, app
        self.server: uvicorn.Server | None = None
        self.thread: threading.Thread | None = None

    def start(self) -> None:
        config = uvicorn.Config(
            self.app, host="127.0.0.1", port=self.port, log_level="warning", lifespan="off"
        )
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(target=self.server.run, daemon=True)
        self.thread.start()
        deadline = time.monotonic() + 10.0
        while not self.server.started and time.monotonic() < deadline:
            time.sleep(0.01)

    def stop(self) -> None:
        if self.server is not None and self.thread is not None:
            self.server.should_exit = True
            self.thread.join(10.0)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture
def cloud(tmp_path: Path) -> Iterator[tuple[CloudService, str]]:
    service = CloudService.open(tmp_path / "cloud")
    token = service.register_vehicle("car-a")
    service.register_driver("car-a", "d1")
    yield service, token
    service.store.close()


def spool_with(tmp_path: Path, n: int) -> Spool:
    spool = Spool(tmp_path / "spool")
    for seed in range(n):
        spool.put_trip(make_trip("takeover", seed=seed))
    return spool


def wait_for(done: Callable[[], object], timeout_s: float = 30.0) -> None:
    """Poll ``done`` every 20 ms until it holds; fail the test after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not done():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


def test_every_batch_arrives_and_leaves_the_spool(
    tmp_path: Path, cloud: tuple[CloudService, str]
) -> None:
    service, token = cloud
    spool = spool_with(tmp_path, 3)
    digests = {b.digest for b in spool.pending()}
    uploader = Uploader(spool, LocalCloud(service, token), FAST)
    assert uploader.drain() == 3
    assert spool.pending() == [] and service.store.batch_count() == 3
    assert {b.digest for b in service.store.batches("d1", "default")} == digests


def test_a_batch_the_cloud_already_holds_is_acknowledged_as_duplicate(
    tmp_path: Path, cloud: tuple[CloudService, str]
) -> None:
    """Crash after the upload, before the ack: the next pass uploads again, once stored."""
    service, token = cloud
    spool = spool_with(tmp_path, 1)
    api = LocalCloud(service, token)
    api.upload(spool.pending()[0].path.read_bytes())  # delivered, ack lost
    uploader = Uploader(spool, api, FAST)
    assert uploader.drain() == 1
    assert uploader.stats.duplicates == 1 and service.store.batch_count() == 1


@pytest.mark.slow
def test_outage_5xx_dropped_and_slow_answers_lose_nothing(
    tmp_path: Path, cloud: tuple[CloudService, str]
) -> None:
    service, token = cloud
    spool = spool_with(tmp_path, 4)
    port = free_port()
    flaky = Flaky(create_app(service), fail=3, drop=2, stall=2, stall_s=1.5)
    server = Server(flaky, port)
    client = HttpCloud(f"http://127.0.0.1:{port}", token, timeout_s=0.5)
    uploader = Uploader(spool, client, FAST)
    uploader.start()
    try:
        wait_for(lambda: uploader.stats.retries >= 3)  # the server is down: retries
        assert len(spool.pending()) == 4  # nothing deleted
        server.start()
        wait_for(lambda: not spool.pending())
    finally:
        uploader.stop()
        client.close()
        server.stop()
    assert spool.pending() == []
    assert service.store.batch_count() == 4  # each once, though some were sent twice
    assert flaky.seen >= 4 + 3 + 2 + 2
    assert uploader.stats.duplicates >= 1  # a dropped ack: stored once, acknowledged later


def test_a_bad_batch_is_set_aside_and_a_not_yet_registered_driver_is_kept(
    tmp_path: Path, cloud: tuple[CloudService, str]
) -> None:
    """422 (no driver_id: the batch itself is bad) -> rejected/ with the reason; 403 (driver
    not registered yet: the set-up) -> kept and uploaded once the driver is registered."""
    service, token = cloud
    spool = Spool(tmp_path / "spool")
    later = spool.put_trip(
        dataclasses.replace(
            make_trip("takeover", seed=1), meta={"driver_id": "x", "mode": "takeover"}
        )
    )
    bad = spool.put_trip(
        dataclasses.replace(make_trip("takeover", seed=2), meta={"mode": "takeover"})
    )
    spool.put_trip(make_trip("takeover", seed=3))
    uploader = Uploader(spool, LocalCloud(service, token), FAST)
    assert uploader.drain() == 1  # the good one; the queue went on past the other two
    assert uploader.stats.rejected == 1 and uploader.stats.held == 1
    assert spool.pending() == [later]
    reason = (tmp_path / "spool" / "rejected" / f"{bad.path.name}.reason").read_text()
    assert "HTTP 422" in reason
    service.register_driver("car-a", "x")
    assert uploader.drain() == 1 and spool.pending() == []


def test_a_wrong_token_keeps_every_batch(tmp_path: Path, cloud: tuple[CloudService, str]) -> None:
    service, token = cloud
    spool = spool_with(tmp_path, 3)
    typo = Uploader(spool, LocalCloud(service, "x" + token), FAST)
    assert typo.drain() == 0 and typo.stats.held == 1  # the pass stopped at the first 401
    assert len(spool.pending()) == 3 and typo.stats.rejected == 0
    assert Uploader(spool, LocalCloud(service, token), FAST).drain() == 3


def test_stop_cuts_a_backoff_short(tmp_path: Path) -> None:
    spool = spool_with(tmp_path, 1)
    slow = UploaderConfig(backoff_s=30.0, backoff_max_s=60.0, poll_s=60.0)
    client = HttpCloud(f"http://127.0.0.1:{free_port()}", "t", timeout_s=0.5)
    uploader = Uploader(spool, client, slow)
    uploader.start()
    wait_for(lambda: uploader.stats.retries >= 1)  # the first attempt failed: in its backoff
    started = time.monotonic()
    uploader.stop()
    client.close()
    assert time.monotonic() - started < 2.0
    assert len(spool.pending()) == 1  # nothing deleted unacknowledged
