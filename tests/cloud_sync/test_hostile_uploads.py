"""Hostile uploads and clients: a zstd bomb, deeply nested JSON, implausible samples, a client
that hangs up mid-upload, and the /docs page judged in a real browser."""

from __future__ import annotations

import dataclasses
import io
import logging
import shutil
import socket
import time
import tracemalloc
from pathlib import Path

import httpx
import numpy as np
import pytest
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import Chunk, DataEnd, Footer, Header

from cloud_sync.api import MAX_SAMPLES, BadBatchError
from cloud_sync.service.ingest import MAX_DECOMPRESSED_BYTES
from cloud_sync.service.local import LocalCloud
from cloud_sync.service.rules import CloudService, DeferredExecutor
from dbc.vocab.triplog import FLOAT_FIELDS, Trip
from tests.cloud_sync.conftest import follower_trip
from tests.cloud_sync.served import Served
from tests.cloud_sync.test_cloud_api import cloud, token, trip_bytes

__all__ = ["cloud", "token"]  # the fixtures, shared with test_cloud_api

MAGIC = b"\x89MCAP0\r\n"


def zstd_bomb(size: int) -> bytes:
    """An MCAP file of one zstd chunk that decompresses to ``size`` bytes (one message)."""
    out = io.BytesIO()
    writer = zstandard.ZstdCompressor(level=1).stream_writer(out, size=size, closefd=False)
    writer.write(bytes([Opcode.MESSAGE]) + (size - 9).to_bytes(8, "little"))
    left, block = size - 9, bytes(1 << 20)
    while left > 0:
        writer.write(block[: min(left, len(block))])
        left -= len(block)
    writer.flush(zstandard.FLUSH_FRAME)
    records = RecordBuilder()
    Header(profile="", library="bomb").write(records)
    Chunk("zstd", out.getvalue(), 0, 0, 0, size).write(records)
    DataEnd(0).write(records)
    Footer(0, 0, 0).write(records)
    body: bytes = records.end()  # type: ignore[no-untyped-call]
    return MAGIC + body + MAGIC


def test_a_zstd_bomb_is_refused_before_it_is_decompressed(cloud: CloudService, token: str) -> None:
    bomb = zstd_bomb(4 * MAX_DECOMPRESSED_BYTES)
    assert len(bomb) < 64 * 1024
    tracemalloc.start()
    try:
        with pytest.raises(BadBatchError, match="decompresses to more than"):
            LocalCloud(cloud, token).upload(bomb)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 * 1024 * 1024  # the old reader held all 256 MiB
    assert cloud.store.batch_count() == 0


def _with(trip: Trip, **columns: object) -> Trip:
    return dataclasses.replace(trip, **columns)  # type: ignore[arg-type]


def _steady(n: int, meta: dict[str, object]) -> Trip:
    """``n`` samples at 10 Hz of steady following: 20 m/s, 36 m behind a lead as fast."""
    v = np.full(n, 20.0)
    return Trip.manual(np.arange(n) * 0.1, v, np.full(n, 36.0), v, np.zeros(n), meta)


@pytest.mark.parametrize(
    "damage",
    ["v_inf", "gap_minus_inf", "negative_speed", "lead_too_fast", "no_samples", "too_many"],
)
def test_implausible_samples_are_422_and_stored_nowhere(damage: str, tmp_path: Path) -> None:
    cloud = CloudService.open(tmp_path / "cloud")  # the default upload limit: 72,000 samples fit
    token = cloud.register("car-a", ["syn"])
    trip = follower_trip(0, minutes=0.2)
    n = len(trip)
    v = np.array(trip.v_mps)
    bad = {
        "v_inf": lambda: _with(trip, v_mps=np.where(np.arange(n) == 5, np.inf, v)),
        "gap_minus_inf": lambda: _with(trip, gap_m=np.full(n, -np.inf)),
        "negative_speed": lambda: _with(trip, v_mps=v - 100.0),
        "lead_too_fast": lambda: _with(trip, v_lead_mps=np.full(n, 1e6)),
        "no_samples": lambda: Trip(
            **{k: np.zeros(0) for k in FLOAT_FIELDS}, acc_state=np.zeros(0), meta=trip.meta
        ),
        "too_many": lambda: _steady(MAX_SAMPLES + 10, trip.meta),
    }[damage]()
    with pytest.raises(BadBatchError, match="implausible|samples"):
        LocalCloud(cloud, token).upload(trip_bytes(bad, tmp_path))
    assert cloud.store.batch_count() == 0
    cloud.store.close()


def test_the_vehicles_own_trips_stay_plausible(tmp_path: Path) -> None:
    cloud = CloudService.open(tmp_path / "cloud", DeferredExecutor())  # stored, not learned
    token = cloud.register("car-a", ["syn"])
    receipt = LocalCloud(cloud, token).upload(trip_bytes(follower_trip(1, minutes=1), tmp_path))
    assert receipt.kind == "manual" and not receipt.duplicate
    cloud.store.close()


def test_deeply_nested_json_is_a_clean_422(
    cloud: CloudService, token: str, http_server: Served
) -> None:
    http_server.serve(cloud)
    answer = httpx.post(
        f"{http_server.url}/v1/trips",
        content=b"[" * 100_000 + b"]" * 100_000,
        headers={"Authorization": f"Bearer {token}"},
        timeout=30.0,
    )
    assert answer.status_code == 422 and "nested" in answer.json()["detail"]


class _Lines(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


def test_a_client_hanging_up_mid_upload_is_one_log_line(cloud: CloudService, token: str) -> None:
    lines = _Lines()
    loggers = [logging.getLogger(n) for n in ("uvicorn.error", "cloud_sync.service.http")]
    for one in loggers:
        one.addHandler(lines)
    served = Served(cloud)
    try:
        host, port = served.url.removeprefix("http://").split(":")
        with socket.create_connection((host, int(port))) as sock:
            sock.sendall(
                f"POST /v1/batches HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {token}\r\n"
                f"Content-Length: 100000\r\n\r\n".encode()
                + b"\0" * 1000
            )
            time.sleep(0.3)
        deadline = time.monotonic() + 5.0
        while not lines.records and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        served.stop()
        for one in loggers:
            one.removeHandler(lines)
    assert [r.getMessage() for r in lines.records if "disconnected" in r.getMessage()]
    assert not [r for r in lines.records if r.exc_info], "a traceback was logged"
    assert cloud.store.batch_count() == 0


def test_docs_render_the_operations_in_a_browser(
    cloud: CloudService, tmp_path: Path, http_server: Served
) -> None:
    if shutil.which("/usr/bin/chromium") is None:
        pytest.skip("/usr/bin/chromium is missing: `make test` installs it")
    from playwright.sync_api import sync_playwright  # noqa: PLC0415 - only this test

    http_server.serve(cloud)
    shot = tmp_path / "docs.png"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", headless=True)
        page = browser.new_page(viewport={"width": 1200, "height": 1600})
        page.goto(f"{http_server.url}/docs")
        page.wait_for_selector(".opblock", timeout=15_000)
        paths = page.locator(".opblock-summary-path").all_inner_texts()
        text = page.inner_text("body")
        page.screenshot(path=str(shot), full_page=True)
        browser.close()
    assert "Unable to render" not in text
    assert {"/v1/batches", "/v1/trips", "/v1/drivers/{driver_id}/dgpt", "/v1/key"} <= {
        p.replace("\u200b", "") for p in paths
    }
    assert shot.stat().st_size > 20_000  # the page, drawn (looked at: every operation listed)
